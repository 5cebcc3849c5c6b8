//! The voxel grid and its volumes. The grid is a cube: the scene file's `[scene] bounds` when
//! given, otherwise the world bounds at the scene time grown by 5% (so surfaces on the scene's
//! boundary are not on the grid's faces). Volumes are created only when the scene needs them.

use crate::gpu::{Access, Bind, Buffer, Context, GpuError, GpuResult, Image, ImageDesc, Sampler};
use crate::render::cones::GpuGiParams;
use crate::render::graph::Use;
use crate::scene::{Aabb, GiMode, Scene, View};
use ash::vk;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::sync::Arc;

pub const RADIANCE_VOLUME_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;

/// Mirrors `VoxelGrid` in glsl/include/voxel.glsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug)]
pub struct GpuVoxelGrid {
    pub origin: [f32; 4],
    pub dims: [u32; 4],
    pub params: [f32; 4],
}

/// Placement of the cubic grid in world space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VoxelGrid {
    /// World position of the grid's min corner.
    pub origin: Vec3,
    /// Edge length of one voxel (world units).
    pub voxel_size: f32,
    pub resolution: u32,
}

impl VoxelGrid {
    /// The cube around `bounds` (padded by `pad` of its size on every side).
    pub fn around(bounds: Aabb, resolution: u32, pad: f32) -> VoxelGrid {
        let (center, extent) =
            if bounds.is_empty() { (Vec3::ZERO, 1.0) } else { (bounds.center(), bounds.extent().max_element()) };
        // A flat or empty scene still gets a grid of non-zero size.
        let extent = if extent > 0.0 && extent.is_finite() { extent } else { 1.0 } * (1.0 + 2.0 * pad);
        VoxelGrid { origin: center - Vec3::splat(extent * 0.5), voxel_size: extent / resolution as f32, resolution }
    }

    pub fn for_scene(scene: &Scene) -> VoxelGrid {
        let res = scene.settings.gi.voxel_resolution;
        match scene.bounds {
            Some(b) => VoxelGrid::around(b, res, 0.0),
            None => VoxelGrid::around(scene.world_bounds(scene.settings.time), res, 0.05),
        }
    }
}

/// What the scene needs voxelized.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VoxelNeeds {
    /// Some material emits: an emission volume.
    pub emission: bool,
    /// Some object is dynamic: a static-flag volume, a dynamic clear and a dynamic pass.
    pub dynamic: bool,
    /// Cones are traced (final image with `vct`, GI views, the mip view): the six directional
    /// volumes.
    pub cones: bool,
    /// Light bounces in the voxels (0 without cones).
    pub bounces: u32,
}

impl VoxelNeeds {
    pub fn of(scene: &Scene) -> VoxelNeeds {
        let s = &scene.settings;
        let cones = match s.view {
            View::Final | View::Indirect | View::Ao => s.gi.mode == GiMode::Vct,
            View::VoxelMip => true,
            View::VoxelAlbedo | View::VoxelNormal | View::VoxelEmission | View::VoxelRadiance => false,
        };
        VoxelNeeds {
            emission: scene.materials.iter().any(|m| m.is_emissive()),
            dynamic: scene.objects.iter().any(|o| o.dynamic),
            cones,
            bounces: if cones { s.gi.bounces } else { 0 },
        }
    }
}

/// The voxel volumes (R32_UINT: RGB8 + 8-bit count, see voxel.glsl) and the grid uniform.
pub struct VoxelVolumes {
    pub grid: VoxelGrid,
    pub needs: VoxelNeeds,
    pub grid_buffer: Buffer,
    pub albedo: Arc<Image>,
    pub normal: Arc<Image>,
    /// Only with emissive materials.
    pub emission: Option<Arc<Image>>,
    /// Only with dynamic objects: 1 where static geometry was voxelized (R8_UINT).
    pub flags: Option<Arc<Image>>,
    /// Outgoing radiance of the lit voxels, direct light and emission (RGBA16F, alpha = occupancy).
    pub radiance: Arc<Image>,
    /// With bounces: the radiance with bounced light (the final radiance), and the scratch
    /// volume each bounce writes before it is copied into the first (a bounce samples the
    /// previous result while it runs). Empty without bounces.
    pub bounced: Vec<Arc<Image>>,
    /// The six directional volumes (+x, -x, +y, -y, +z, -z) at half resolution with full mip
    /// chains, built from the final radiance; only when cones are traced.
    pub directional: Vec<Arc<Image>>,
    /// Cone-tracing parameters (`GiParams` in cone_params.glsl).
    pub gi_params: Buffer,
    /// Trilinear, mipmapped, transparent black outside the grid.
    pub sampler: Sampler,
    /// Bound in place of `flags` when there is none (a 1-voxel volume).
    pub flags_placeholder: Option<Arc<Image>>,
    /// Emitted radiance that maps to 255 in the emission volume.
    pub emission_scale: f32,
    /// The radiance, bounce and directional volumes hold radiance times this
    /// (`lights::radiance_scale`).
    pub radiance_scale: f32,
    /// `gi.diffuse_rays`: the per-pixel tracer gathers with rays instead of cones (> 0).
    pub diffuse_rays: u32,
}

impl VoxelVolumes {
    pub fn new(ctx: &Arc<Context>, scene: &Scene) -> GpuResult<VoxelVolumes> {
        if !ctx.info.optional.geometry_shader || !ctx.info.optional.fragment_stores_and_atomics {
            return Err(GpuError::Limit(format!(
                "voxel GI needs geometryShader and fragmentStoresAndAtomics, which {} lacks; use --set gi.mode=\"none\"",
                ctx.info.name
            )));
        }
        let grid = VoxelGrid::for_scene(scene);
        let needs = VoxelNeeds::of(scene);
        let res = grid.resolution;
        let usage =
            vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::TRANSFER_SRC;
        let volume = |name: &str, format| Image::new(ctx, name, ImageDesc::d3(format, res, 1, usage)).map(Arc::new);
        let sampled = usage | vk::ImageUsageFlags::SAMPLED;
        let mip_levels = res.trailing_zeros(); // half resolution down to 1 voxel
        let directional = if needs.cones {
            ["+x", "-x", "+y", "-y", "+z", "-z"]
                .iter()
                .map(|d| {
                    Image::new(
                        ctx,
                        &format!("voxel radiance {d}"),
                        ImageDesc::d3(RADIANCE_VOLUME_FORMAT, res / 2, mip_levels, sampled),
                    )
                    .map(Arc::new)
                })
                .collect::<GpuResult<Vec<_>>>()?
        } else {
            Vec::new()
        };
        // The bounced radiance and the scratch volume each bounce writes before it is copied in.
        let bounced = if needs.bounces > 0 {
            ["voxel radiance bounced", "voxel bounce scratch"]
                .iter()
                .map(|name| Image::new(ctx, name, ImageDesc::d3(RADIANCE_VOLUME_FORMAT, res, 1, sampled)).map(Arc::new))
                .collect::<GpuResult<Vec<_>>>()?
        } else {
            Vec::new()
        };
        // `--view ao` shows the occlusion whether or not it darkens the final image.
        let mut gi = scene.settings.gi.clone();
        gi.ao |= scene.settings.view == View::Ao;
        let gi_params = Buffer::uniform(ctx, "gi params", &GpuGiParams::new(&gi, res, grid.voxel_size, mip_levels))?;
        let addr = vk::SamplerAddressMode::CLAMP_TO_BORDER;
        let sampler = Sampler::new(
            ctx,
            "voxel volume sampler",
            &vk::SamplerCreateInfo::default()
                .mag_filter(vk::Filter::LINEAR)
                .min_filter(vk::Filter::LINEAR)
                .mipmap_mode(vk::SamplerMipmapMode::LINEAR)
                .address_mode_u(addr)
                .address_mode_v(addr)
                .address_mode_w(addr)
                .border_color(vk::BorderColor::FLOAT_TRANSPARENT_BLACK)
                .max_lod(mip_levels as f32),
        )?;
        let emission_scale = scene.materials.iter().map(|m| m.emission.max_element()).fold(0.0f32, f32::max).max(1e-6);
        let radiance_scale = crate::render::lights::radiance_scale(scene);
        let grid_buffer = Buffer::uniform(
            ctx,
            "voxel grid",
            &GpuVoxelGrid {
                origin: [grid.origin.x, grid.origin.y, grid.origin.z, grid.voxel_size],
                dims: [res, 0, 0, 0],
                params: [emission_scale, radiance_scale, 1.0 / radiance_scale, 0.0],
            },
        )?;
        Ok(VoxelVolumes {
            grid,
            needs,
            grid_buffer,
            albedo: volume("voxel albedo", vk::Format::R32_UINT)?,
            radiance: Image::new(ctx, "voxel radiance", ImageDesc::d3(RADIANCE_VOLUME_FORMAT, res, 1, sampled))
                .map(Arc::new)?,
            bounced,
            directional,
            gi_params,
            sampler,
            normal: volume("voxel normal", vk::Format::R32_UINT)?,
            emission: needs.emission.then(|| volume("voxel emission", vk::Format::R32_UINT)).transpose()?,
            flags: needs.dynamic.then(|| volume("voxel static flags", vk::Format::R8_UINT)).transpose()?,
            flags_placeholder: (!needs.dynamic)
                .then(|| {
                    Image::new(ctx, "voxel flags placeholder", ImageDesc::d3(vk::Format::R8_UINT, 1, 1, usage))
                        .map(Arc::new)
                })
                .transpose()?,
            emission_scale,
            radiance_scale,
            diffuse_rays: scene.settings.gi.diffuse_rays,
        })
    }

    /// Every volume that exists, for clears and memory reports.
    pub fn all(&self) -> Vec<&Arc<Image>> {
        let mut v = vec![&self.albedo, &self.normal];
        v.extend(self.emission.as_ref());
        v.extend(self.flags.as_ref());
        v.push(&self.radiance);
        v.extend(self.bounced.iter());
        v.extend(self.directional.iter());
        v
    }

    /// The radiance volume the cones sample: with bounces the bounced radiance, else the
    /// direct radiance. The directional volumes are built from it.
    pub fn final_radiance(&self) -> &Arc<Image> {
        self.bounced.first().unwrap_or(&self.radiance)
    }

    /// Uses of the averaged volumes (albedo, normal, emission) by a pass that writes them with
    /// `access`, keeping their contents, plus the flag volume (or its placeholder) with `flags`.
    pub fn uses(&self, access: Access, flags: Access) -> Vec<Use<'_>> {
        let mut uses = vec![
            Use::image(&self.albedo, access),
            Use::image(&self.normal, access),
            Use::image(self.flags_or_placeholder(), flags),
        ];
        uses.extend(self.emission.as_ref().map(|e| Use::image(e, access)));
        uses
    }

    /// Grid uniform, albedo, normal, emission (or albedo), flags (or placeholder): the
    /// bindings, in this order, of every pass that writes the averaged volumes.
    pub fn binds(&self) -> [Bind<'_>; 5] {
        [
            Bind::Uniform(&self.grid_buffer),
            Bind::StorageImage(self.albedo.view),
            Bind::StorageImage(self.normal.view),
            Bind::StorageImage(self.emission_or_albedo().view),
            Bind::StorageImage(self.flags_or_placeholder().view),
        ]
    }

    /// The volume bound where the emission volume goes (albedo stands in, never written).
    pub fn emission_or_albedo(&self) -> &Arc<Image> {
        self.emission.as_ref().unwrap_or(&self.albedo)
    }

    pub fn flags_or_placeholder(&self) -> &Arc<Image> {
        self.flags.as_ref().or(self.flags_placeholder.as_ref()).expect("flags or placeholder")
    }
}
