//! The frame: which passes exist for this scene and the order they run in.
//! This is the one place to read to know what a frame does.

use super::graph::Pass;
use super::passes::gbuffer::{GBuffer, GBufferPass};
use super::passes::lighting::LightingPass;
use super::passes::readback::{HostReadPass, ReadbackPass};
use super::passes::shadow::ShadowPass;
use super::passes::tonemap::{TonemapPass, DISPLAY_FORMAT};
use super::scene_gpu::SceneGpu;
use super::FrameBuffers;
use crate::gpu::{Context, GpuResult, Image, ImageDesc};
use ash::vk;
use std::sync::Arc;

/// Every pass the scene needs, created once.
pub struct FramePasses {
    /// Only when at least one light casts shadows.
    pub shadow: Option<ShadowPass>,
    pub gbuffer: GBufferPass,
    pub lighting: LightingPass,
    pub tonemap: TonemapPass,
    /// Created on the first frame whose output is read back (not for benchmarks).
    pub readback: Option<(ReadbackPass, HostReadPass)>,
}

pub const RADIANCE_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
pub const SHADOW_FORMAT: vk::Format = vk::Format::D32_SFLOAT;

impl FramePasses {
    pub fn new(
        ctx: &Arc<Context>,
        scene: &Arc<SceneGpu>,
        frame: &FrameBuffers,
        width: u32,
        height: u32,
        shadow_views: u32,
        shadow_map_size: u32,
    ) -> GpuResult<FramePasses> {
        let gbuffer = Arc::new(GBuffer::new(ctx, width, height)?);
        // Without shadowed lights the lighting pass still binds a 1x1 placeholder map.
        let (atlas_size, atlas_layers) = if shadow_views > 0 { (shadow_map_size, shadow_views) } else { (1, 1) };
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
        let radiance = Arc::new(Image::new(
            ctx,
            "radiance",
            ImageDesc::d2(
                RADIANCE_FORMAT,
                width,
                height,
                vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC,
            ),
        )?);
        let display = Arc::new(Image::new(
            ctx,
            "display",
            ImageDesc::d2(
                DISPLAY_FORMAT,
                width,
                height,
                vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC,
            ),
        )?);
        let shadow =
            if shadow_views > 0 { Some(ShadowPass::new(ctx, scene, frame, &atlas, shadow_views)?) } else { None };
        Ok(FramePasses {
            shadow,
            gbuffer: GBufferPass::new(ctx, scene, frame, &gbuffer)?,
            lighting: LightingPass::new(ctx, frame, &gbuffer, &atlas, &radiance)?,
            tonemap: TonemapPass::new(ctx, frame, &radiance, &display)?,
            readback: None,
        })
    }

    /// Create the readback passes if they do not exist yet.
    pub fn ensure_readback(&mut self, ctx: &Arc<Context>) -> GpuResult<()> {
        if self.readback.is_none() {
            let rb = ReadbackPass::new(ctx, &self.lighting.radiance, &self.tonemap.display)?;
            let host = HostReadPass::new(&rb);
            self.readback = Some((rb, host));
        }
        Ok(())
    }

    /// The frame, in dependency order. `readback`: copy the results for the host (after
    /// `ensure_readback`).
    pub fn list(&self, readback: bool) -> Vec<&dyn Pass> {
        let mut passes: Vec<&dyn Pass> = Vec::new();
        if let Some(shadow) = &self.shadow {
            passes.push(shadow);
        }
        passes.push(&self.gbuffer);
        passes.push(&self.lighting);
        passes.push(&self.tonemap);
        if let (true, Some((copy, host))) = (readback, &self.readback) {
            passes.push(copy);
            passes.push(host);
        }
        passes
    }
}
