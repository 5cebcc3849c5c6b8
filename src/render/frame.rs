//! The frame: which passes exist for this scene and the order they run in.
//! This is the one place to read to know what a frame does.

use super::graph::Pass;
use super::passes::gbuffer::{GBuffer, GBufferPass};
use super::passes::lighting::LightingPass;
use super::passes::readback::ReadbackPasses;
use super::passes::shadow::ShadowPass;
use super::passes::tonemap::{TonemapPass, DISPLAY_FORMAT};
use super::passes::voxel_clear::{DynamicClearPass, VoxelClearPass};
use super::passes::voxel_light::VoxelLightPass;
use super::passes::voxel_view::VoxelViewPass;
use super::passes::voxelize::{VoxelizePass, Voxelizer};
use super::scene_gpu::SceneGpu;
use super::voxel::VoxelVolumes;
use super::FrameBuffers;
use crate::gpu::{Context, GpuResult, Image, ImageDesc};
use crate::scene::{GiMode, Scene, View};
use ash::vk;
use std::sync::Arc;

/// The voxel passes; they exist only with `gi.mode = "vct"` or a voxel view.
pub struct VoxelPasses {
    pub volumes: Arc<VoxelVolumes>,
    pub clear: VoxelClearPass,
    pub voxelize_static: VoxelizePass,
    /// Only with dynamic objects.
    pub dynamic: Option<(DynamicClearPass, VoxelizePass)>,
    pub light: VoxelLightPass,
}

/// How the frame shades pixels.
pub enum Shading {
    Lighting(LightingPass),
    VoxelView(VoxelViewPass),
}

/// Every pass the scene needs, created once.
pub struct FramePasses {
    pub voxels: Option<VoxelPasses>,
    /// Only when at least one light casts shadows.
    pub shadow: Option<ShadowPass>,
    pub gbuffer: GBufferPass,
    pub shading: Shading,
    pub tonemap: TonemapPass,
    /// Created on the first frame whose output is read back (not for benchmarks).
    pub readback: Option<ReadbackPasses>,
}

/// What differs from frame to frame.
#[derive(Debug, Clone, Copy)]
pub struct FrameState {
    /// Static geometry is already voxelized.
    pub static_voxelized: bool,
    /// Copy the outputs for the host.
    pub readback: bool,
}

pub const RADIANCE_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
pub const SHADOW_FORMAT: vk::Format = vk::Format::D32_SFLOAT;

impl FramePasses {
    pub fn new(
        ctx: &Arc<Context>,
        scene: &Scene,
        scene_gpu: &Arc<SceneGpu>,
        frame: &FrameBuffers,
        shadow_views: u32,
    ) -> GpuResult<FramePasses> {
        let s = &scene.settings;
        let (width, height) = (s.width, s.height);
        let gbuffer = Arc::new(GBuffer::new(ctx, width, height)?);
        // Without shadowed lights the lighting pass still binds a 1x1 placeholder map.
        let (atlas_size, atlas_layers) = if shadow_views > 0 { (s.shadow_map_size, shadow_views) } else { (1, 1) };
        let atlas = Arc::new(Image::new(
            ctx,
            if shadow_views > 0 { "shadow maps" } else { "shadow map placeholder" },
            ImageDesc::d2_array(
                SHADOW_FORMAT,
                atlas_size,
                atlas_size,
                atlas_layers,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::SAMPLED,
            ),
        )?);
        let image2d = |name: &str, format| {
            Image::new(
                ctx,
                name,
                ImageDesc::d2(format, width, height, vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC),
            )
            .map(Arc::new)
        };
        let radiance = image2d("radiance", RADIANCE_FORMAT)?;
        let display = image2d("display", DISPLAY_FORMAT)?;
        let voxel_view = s.view != View::Final;
        let voxels = if s.gi.mode == GiMode::Vct || voxel_view {
            let volumes = Arc::new(VoxelVolumes::new(ctx, scene)?);
            let voxelizer = Voxelizer::new(ctx, scene_gpu, frame, &volumes)?;
            let dynamic = if volumes.needs.dynamic {
                Some((DynamicClearPass::new(ctx, &volumes)?, VoxelizePass::new(&voxelizer, true)))
            } else {
                None
            };
            Some(VoxelPasses {
                light: VoxelLightPass::new(ctx, frame, &volumes, &atlas, &s.gi)?,
                clear: VoxelClearPass::new(&volumes),
                voxelize_static: VoxelizePass::new(&voxelizer, false),
                dynamic,
                volumes,
            })
        } else {
            None
        };
        let shading = match (&voxels, voxel_view) {
            (Some(v), true) => Shading::VoxelView(VoxelViewPass::new(ctx, frame, &v.volumes, s.view, &radiance)?),
            _ => Shading::Lighting(LightingPass::new(ctx, frame, &gbuffer, &atlas, &radiance)?),
        };
        let shadow =
            if shadow_views > 0 { Some(ShadowPass::new(ctx, scene_gpu, frame, &atlas, shadow_views)?) } else { None };
        Ok(FramePasses {
            voxels,
            shadow,
            gbuffer: GBufferPass::new(ctx, scene_gpu, frame, &gbuffer)?,
            shading,
            tonemap: TonemapPass::new(ctx, frame, &radiance, &display)?,
            readback: None,
        })
    }

    /// Create the readback passes if they do not exist yet.
    pub fn ensure_readback(&mut self, ctx: &Arc<Context>) -> GpuResult<()> {
        if self.readback.is_none() {
            let radiance = match &self.shading {
                Shading::Lighting(l) => l.radiance.clone(),
                Shading::VoxelView(v) => v.radiance.clone(),
            };
            self.readback = Some(ReadbackPasses::new(ctx, &radiance, &self.tonemap.display)?);
        }
        Ok(())
    }

    /// The frame, in dependency order.
    pub fn list(&self, state: FrameState) -> Vec<&dyn Pass> {
        let mut passes: Vec<&dyn Pass> = Vec::new();
        if let Some(v) = &self.voxels {
            if !state.static_voxelized {
                passes.push(&v.clear);
                passes.push(&v.voxelize_static);
            }
            if let Some((clear, voxelize)) = &v.dynamic {
                passes.push(clear);
                passes.push(voxelize);
            }
        }
        let lit_voxels = match &self.shading {
            Shading::Lighting(_) => true,
            Shading::VoxelView(view) => view.shows_radiance(),
        };
        if lit_voxels {
            if let Some(shadow) = &self.shadow {
                passes.push(shadow);
            }
            if let Some(v) = &self.voxels {
                passes.push(&v.light);
            }
        }
        match &self.shading {
            Shading::Lighting(lighting) => {
                passes.push(&self.gbuffer);
                passes.push(lighting);
            }
            // A voxel view needs no G-buffer.
            Shading::VoxelView(view) => passes.push(view),
        }
        passes.push(&self.tonemap);
        if let (true, Some(r)) = (state.readback, &self.readback) {
            passes.push(&r.radiance);
            passes.push(&r.display);
            passes.push(&r.host);
        }
        passes
    }
}
