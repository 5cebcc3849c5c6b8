//! The voxel grid and its volumes. The grid is a cube: the scene file's `[scene] bounds` when
//! given, otherwise the world bounds at the scene time grown by 5% (so surfaces on the scene's
//! boundary are not on the grid's faces). Volumes are created only when the scene needs them.

pub mod bricks;
pub mod capacity;
mod grid;
pub mod specs;

pub use grid::{VoxelGrid, RADIANCE_VOLUME_FORMAT};

use crate::gpu::{Access, Buffer, Context, GpuError, GpuResult, Image, ImageDesc, Sampler};
use crate::render::binding::Binds;
use crate::render::cones::GpuGiParams;
use crate::scene::{
    ConeFilter, GiSettings, Opacity, PlaneBacks, Scene, View, VoxelAttenuation, VoxelCover, VoxelLayout,
};
use ash::vk;
use bricks::{BrickLayout, Bricks, FullImages, MAX_POOLS};
use bytemuck::{Pod, Zeroable};
use capacity::Capacity;
use specs::{Alloc, VolumeSpecs};
use std::sync::Arc;

/// Mirrors `VoxelGrid` in glsl/include/voxel.glsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug)]
pub struct GpuVoxelGrid {
    pub origin: [f32; 4],
    pub dims: [u32; 4],
    pub params: [f32; 4],
    pub pools: [[u32; 4]; MAX_POOLS],
}

impl GpuVoxelGrid {
    /// The uniform for `grid` in its layout (`bricks`: its pools), with the voxelization's
    /// fixed-point one and the emission and radiance scales.
    /// `cover`: gi.voxel_cover (`AREA_COVER`, `DIRECTIONAL_COVER`).
    fn new(
        grid: &VoxelGrid,
        bricks: Option<&Bricks>,
        sum_scale: u32,
        [emission, radiance]: [f32; 2],
        cover: VoxelCover,
    ) -> Self {
        let pooled = bricks.map_or(0, |b| b.layout.pools.len() as u32 - 1);
        GpuVoxelGrid {
            origin: [grid.origin.x, grid.origin.y, grid.origin.z, grid.voxel_size],
            dims: [grid.resolution, pooled, u32::from(bricks.is_some()), sum_scale],
            params: [emission, radiance, 1.0 / radiance, cover_param(cover)],
            pools: pool_uniforms(bricks),
        }
    }
}

/// `grid.params.w` for a voxel cover (glsl/include/voxel.glsl: `AREA_COVER` from 1,
/// `DIRECTIONAL_COVER` from 2).
fn cover_param(cover: VoxelCover) -> f32 {
    match cover {
        VoxelCover::Touch => 0.0,
        VoxelCover::Area => 1.0,
        VoxelCover::Directional => 2.0,
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
    /// The directional volumes hold opacity for two-tap cone samples (`gi.cone_filter`), not
    /// optical depth.
    pub two_tap: bool,
    /// `gi.opacity = "layers"`: a texel's optical depth may reach ln 65536, not ln 256.
    pub layers: bool,
    /// `gi.voxel_cover = "area"` or `"directional"`: the voxelization sums each voxel's cover
    /// (one more word).
    pub area_cover: bool,
    /// The first update adds the bounce tail (`GiSettings::first_update_tail`): its records.
    pub bounce_tail: bool,
    /// `gi.attenuation = "per-side"` with cones: the voxel light's factors per side (one more
    /// full-resolution word, read by the directional volumes' first level), from the normals
    /// seen from each side (twenty-four more words of sums, four of resolved normals).
    pub sides: bool,
    /// `gi.plane_backs = "dark"` or `"closed"` with cones: the directional volumes' first level
    /// shows a one-plane voxel's back its emission only (reading the normal and emission
    /// volumes).
    pub dark_backs: bool,
    /// `gi.plane_backs = "closed"` with cones: each voxelization marks the backs that close a
    /// solid (one more full-resolution byte, glsl/voxel_backs.comp), which the first level
    /// leaves out.
    pub closed_backs: bool,
}

impl VoxelNeeds {
    /// Pool 0's images besides the sampled radiance (what its slot arrangement weighs):
    /// albedo, normal, emission and the sums (R32_UINT), the static flags and the closed backs
    /// (R8_UINT), the bounce's scratch volume.
    pub fn full_images(&self) -> FullImages {
        let sides = if self.sides { 1 + 4 } else { 0 };
        let words = 2 + u32::from(self.emission) + sides + sum_word_indices(self).len() as u32;
        let bytes = u32::from(self.dynamic) + u32::from(self.closed_backs);
        FullImages { words, bytes, scratch: self.bounces > 0 }
    }

    /// In the bricked `layout`: the directional levels of a grid of `resolution` kept in pools
    /// of bricks (none without cones); None with dense volumes.
    pub fn pooled_levels(&self, layout: VoxelLayout, resolution: u32) -> Option<u32> {
        let levels = if self.cones { BrickLayout::pooled_levels(resolution) } else { 0 };
        (layout == VoxelLayout::Bricks).then_some(levels)
    }

    /// The scene's voxels; `cones`: cones are traced through them (per pixel, or by the mip
    /// view), so they have directional volumes and bounce light.
    pub fn of(scene: &Scene, cones: bool) -> VoxelNeeds {
        VoxelNeeds {
            emission: scene.materials.iter().any(|m| m.is_emissive()),
            dynamic: scene.objects.iter().any(|o| o.dynamic),
            cones,
            bounces: if cones { scene.settings.gi.bounces } else { 0 },
            two_tap: cones && scene.settings.gi.cone_filter == ConeFilter::TwoTap,
            layers: cones && scene.settings.gi.opacity == Opacity::Layers,
            area_cover: scene.settings.gi.voxel_cover != VoxelCover::Touch,
            bounce_tail: cones && scene.settings.gi.first_update_tail(),
            sides: cones && scene.settings.gi.attenuation == VoxelAttenuation::PerSide,
            dark_backs: cones && scene.settings.gi.plane_backs != PlaneBacks::Lit,
            closed_backs: cones && scene.settings.gi.plane_backs == PlaneBacks::Closed,
        }
    }
}

/// The first update's bounce tail (`BounceTailBlock` in glsl/include/bounce_tail.glsl): the
/// gain and the ratio (two vec4), then two records of one vec4 per workgroup of a list dispatch.
pub struct TailBuffer {
    pub buffer: Arc<Buffer>,
    /// Workgroups per record ([`specs::tail_groups`]; 1 where the tail is not used).
    pub groups: u32,
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
    /// With bounces: the first update's bounce tail (records only with `needs.bounce_tail`).
    pub bounce_tail: Option<TailBuffer>,
    /// The six directional volumes (+x, -x, +y, -y, +z, -z) at half resolution with full mip
    /// chains, built from the final radiance; only when cones are traced.
    pub directional: Vec<Arc<Image>>,
    /// Cone-tracing parameters (`GiParams` in cone_params.glsl).
    pub gi_params: Buffer,
    /// The same for the bounce's cones (`gi.bounce_cones`).
    pub bounce_params: Buffer,
    /// Trilinear, mipmapped, transparent black outside the grid.
    pub sampler: Sampler,
    /// Bound in place of `flags` when there is none (a 1-voxel volume).
    pub flags_placeholder: Option<Arc<Image>>,
    /// With `needs.sides`: each occupied voxel's six factors, the light of its faces along each
    /// side's axis over its mean normal's (R32_UINT, 5 bits a side: voxel.glsl, `pack_sides`),
    /// written by the voxel light, read by the directional volumes' first level.
    pub sides: Option<Arc<Image>>,
    /// Bound in place of `sides` when there is none (a 1-voxel volume, never touched).
    pub sides_placeholder: Option<Arc<Image>>,
    /// With `needs.sides`: each occupied voxel's normals as seen from its six sides
    /// (R32G32B32A32_UINT, 21 bits a side: voxel.glsl, `pack_side_normal`), written by the
    /// resolve, read by the voxel light.
    pub side_normals: Option<Arc<Image>>,
    /// Bound in place of `side_normals` when there are none.
    pub side_normals_placeholder: Option<Arc<Image>>,
    /// With `needs.closed_backs`: each one-plane voxel's backs that close a solid, a bit per
    /// directional volume (R8_UINT: glsl/voxel_backs.comp), written after each voxelization,
    /// read by the directional volumes' first level.
    pub backs: Option<Arc<Image>>,
    /// Bound in place of `backs` when there are none (a 1-voxel volume, never touched).
    pub backs_placeholder: Option<Arc<Image>>,
    /// Emitted radiance that maps to 255 in the emission volume.
    pub emission_scale: f32,
    /// The radiance, bounce and directional volumes hold radiance times this
    /// (`lights::radiance_scale`).
    pub radiance_scale: f32,
    /// `gi.diffuse_rays`: the per-pixel tracer gathers with rays instead of cones (> 0).
    pub diffuse_rays: u32,
    /// The work list of occupied voxels the voxel passes dispatch over.
    pub list: VoxelList,
    /// The voxelization's sums (voxel.glsl): R32_UINT volumes of the full-resolution extent,
    /// each with its word in `vox_sums[]` ([`sum_word_indices`]): a count, three channels each
    /// of albedo, normal and (with emission) emission, the surface's offset and (with
    /// `gi.voxel_cover = "area"` or `"directional"`) the cover; zero between voxelizations
    /// (the resolve zeroes what it reads).
    pub sums: Vec<(usize, Arc<Image>)>,
    /// The fixed-point one of the sums ([`sum_scale`]).
    pub sum_scale: u32,
    /// Counts made offsets by glsl/scan.comp ([`ScanLayout`]): per 8^3 brick of the grid its
    /// occupied voxels, then their offsets in the work list (glsl/voxel_resolve.comp); with
    /// bricks, per block of each pool's map its pending bricks, then their first slot.
    pub scan: Arc<Buffer>,
    /// With `gi.voxel_layout = "bricks"`: the maps, pools and lists of resident bricks. The
    /// full-resolution volumes above are then pools of bricks, and `directional` holds only
    /// the dense levels (those of at most 64^3 texels).
    pub bricks: Option<Bricks>,
    /// Bound in place of the brick maps and pooled levels that do not exist.
    pub map_placeholder: Arc<Image>,
    /// Bound in place of the brick maps that do not exist by the passes that only read them.
    pub read_placeholder: Arc<Image>,
    pub pool_placeholder: Arc<Image>,
}

/// Byte offsets of the list header (`VoxelListBlock` in glsl/include/voxel_list.glsl): each
/// range is a `VkDispatchIndirectCommand` followed by its entry count.
pub mod work_list_header {
    /// Every occupied voxel: the voxel light and bounce.
    pub const OCCUPIED: u64 = 0;
    /// The dynamic voxels of the last revoxelization: the dynamic clear.
    pub const DYNAMIC: u64 = 16;
    /// The voxels the last dynamic clear emptied: zeroed in the radiance volumes on relight.
    pub const STALE: u64 = 32;
    pub const STATIC_COUNT: u64 = 48;
    pub const DROPPED: u64 = 52;
    /// Header size; the entries (one packed voxel per u32) follow.
    pub const SIZE: u64 = 64;
}

/// The work list: every occupied voxel once (static voxels first), appended by voxelization,
/// with the indirect dispatch arguments of its ranges; and, with dynamic objects, the stale
/// list of voxels the last dynamic clear emptied.
pub struct VoxelList {
    pub buffer: Arc<Buffer>,
    /// Only with dynamic objects.
    pub stale: Option<Arc<Buffer>>,
    /// Entries the list holds ([`list_capacity`]), so no voxelization can overflow it.
    pub capacity: u64,
}

/// The fixed-point one of the voxelization's sums (`grid.dims.w`, glsl/include/voxel.glsl):
/// as fine as 16 bits, but no finer than lets a voxel add one sample of 1.0 per triangle the
/// scene draws without its 32-bit sum overflowing (a voxel receives at most one sample per
/// triangle and pass: one fragment per pixel column). At least 255 (8 bits, what the averages
/// keep), which could overflow only past 16.8 million triangles meeting in one voxel.
pub fn sum_scale(scene: &Scene) -> u32 {
    let triangles: u64 = scene
        .objects
        .iter()
        .flat_map(|o| o.meshes.iter().filter_map(|&i| scene.meshes.get(i as usize)))
        .map(|m| m.indices.len() as u64 / 3)
        .sum();
    (u64::from(u32::MAX) / triangles.max(1)).clamp(255, 65535) as u32
}

/// What each volume of sums holds (`SUM_COUNT`, `SUM_ALBEDO`... in glsl/include/voxel.glsl).
/// The six directions of the directional volumes, as their names say them.
pub const DIRECTIONS: [&str; 6] = ["+x", "-x", "+y", "-y", "+z", "-z"];

const SUM_NAMES: [&str; 36] = [
    "count",
    "albedo r",
    "albedo g",
    "albedo b",
    "normal x",
    "normal y",
    "normal z",
    "surface offset",
    "emission r",
    "emission g",
    "emission b",
    "cover",
    "side +x w n x",
    "side +x w n y",
    "side +x w n z",
    "side +x w",
    "side -x w n x",
    "side -x w n y",
    "side -x w n z",
    "side -x w",
    "side +y w n x",
    "side +y w n y",
    "side +y w n z",
    "side +y w",
    "side -y w n x",
    "side -y w n y",
    "side -y w n z",
    "side -y w",
    "side +z w n x",
    "side +z w n y",
    "side +z w n z",
    "side +z w",
    "side -z w n x",
    "side -z w n y",
    "side -z w n z",
    "side -z w",
];

/// The volumes of sums the voxelization adds to, as their words in `vox_sums[]`
/// (glsl/include/voxel.glsl): a count, albedo and normal (three channels each) and where the
/// surface lies in the voxel (one); with emission three more; with `gi.voxel_cover = "area"`
/// or `"directional"` how much of the voxel its surfaces cover (one); with `gi.attenuation =
/// "per-side"` the normals seen from each side (twenty-four: four for each of six sides).
pub fn sum_word_indices(needs: &VoxelNeeds) -> Vec<usize> {
    let mut words: Vec<usize> = (0..8).collect();
    if needs.emission {
        words.extend(8..11);
    }
    if needs.area_cover {
        words.push(11);
    }
    if needs.sides {
        words.extend(12..36);
    }
    words
}

/// Bricks of 8^3 in a grid of `resolution` (the voxel scan's granularity).
pub fn scan_bricks(resolution: u32) -> u64 {
    u64::from(resolution.div_ceil(8)).pow(3)
}

/// The scan buffer's layout (glsl/include/scan_buffer.glsl), in words: a 16-word header of
/// totals, one word per 8^3 brick of the grid, then for each pool of bricks (`bricks`) one word
/// per block of 512 map entries.
pub struct ScanLayout {
    /// Per pool: its first word and its blocks.
    pub pools: Vec<(u32, u32)>,
    pub words: u64,
}

/// Words before the voxel counts, and the header word of pool p's total.
pub const SCAN_VOXELS: u32 = 16;
pub const SCAN_POOL_TOTAL: u32 = 4;

impl ScanLayout {
    pub fn new(resolution: u32, bricks: Option<&BrickLayout>) -> ScanLayout {
        let mut next = u64::from(SCAN_VOXELS) + scan_bricks(resolution);
        let pools = bricks
            .map_or(&[][..], |b| &b.pools[..])
            .iter()
            .map(|p| {
                let blocks = u64::from(p.map_side).pow(3).div_ceil(512);
                let pool = (next as u32, blocks as u32);
                next += blocks;
                pool
            })
            .collect();
        ScanLayout { pools, words: next }
    }
}

impl VoxelList {
    /// The lists `specs` sizes, for `capacity` entries.
    fn new(ctx: &Arc<Context>, specs: &VolumeSpecs, capacity: u64) -> GpuResult<VoxelList> {
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::INDIRECT_BUFFER
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::TRANSFER_SRC;
        let gpu = gpu_allocator::MemoryLocation::GpuOnly;
        let buffer = Arc::new(Buffer::new(ctx, "voxel list", specs.list.size(), usage, gpu)?);
        let stale = (specs.stale)
            .map(|s| Buffer::new(ctx, "voxel stale list", s.size(), usage, gpu).map(Arc::new))
            .transpose()?;
        Ok(VoxelList { buffer, stale, capacity })
    }

    /// Bytes of GPU memory the lists take.
    pub fn bytes(&self) -> u64 {
        self.buffer.size + self.stale.as_ref().map_or(0, |s| s.size)
    }
}

/// The bounce tail's buffer as `alloc` sizes it.
fn tail_buffer(ctx: &Arc<Context>, alloc: Alloc, needs: &VoxelNeeds, list_capacity: u64) -> GpuResult<TailBuffer> {
    let groups = specs::tail_groups(needs, list_capacity);
    let gpu = gpu_allocator::MemoryLocation::GpuOnly;
    let buffer = Buffer::new(ctx, "voxel bounce tail", alloc.size(), vk::BufferUsageFlags::STORAGE_BUFFER, gpu)?;
    Ok(TailBuffer { buffer: Arc::new(buffer), groups })
}

impl VoxelVolumes {
    pub fn new(ctx: &Arc<Context>, scene: &Scene, needs: VoxelNeeds) -> GpuResult<VoxelVolumes> {
        check_voxel_features(ctx)?;
        let grid = VoxelGrid::for_scene(scene);
        let res = grid.resolution;
        let capacity = Capacity::of(scene, &grid, needs.pooled_levels(scene.settings.gi.voxel_layout, res));
        let image_bytes = |f, e, sampled| volume_bytes(Some(ctx), f, e, 1, sampled);
        let layout = fitted_layout(res, &needs, &capacity, &image_bytes);
        let specs = VolumeSpecs::new(res, &needs, capacity.list, layout.as_ref());
        let image = |name: &str, a: &Alloc| Image::new(ctx, name, a.desc()).map(Arc::new);
        let bricks = layout.map(|l| bricks_of(ctx, l, &specs)).transpose()?;
        let mip_levels = res.trailing_zeros(); // half resolution down to 1 voxel
        let directional = match &specs.directional {
            Some(d) => {
                DIRECTIONS.iter().map(|dir| image(&format!("voxel radiance {dir}"), d)).collect::<GpuResult<_>>()?
            }
            None => Vec::new(),
        };
        // The bounced radiance and the scratch volume each bounce writes before it is copied in.
        let bounced = match &specs.bounced[..] {
            [b, scratch] => vec![image("voxel radiance bounced", b)?, image("voxel bounce scratch", scratch)?],
            _ => Vec::new(),
        };
        let bounce_tail = specs.tail.map(|a| tail_buffer(ctx, a, &needs, capacity.list)).transpose()?;
        let (gi_params, bounce_params) = gi_uniforms(ctx, scene, &grid, mip_levels)?;
        let sum_scale = sum_scale(scene);
        let emission_scale = scene.materials.iter().map(|m| m.emission.max_element()).fold(0.0f32, f32::max).max(1e-6);
        let radiance_scale = crate::render::lights::radiance_scale(scene);
        let grid_buffer = Buffer::uniform(
            ctx,
            "voxel grid",
            &GpuVoxelGrid::new(
                &grid,
                bricks.as_ref(),
                sum_scale,
                [emission_scale, radiance_scale],
                scene.settings.gi.voxel_cover,
            ),
        )?;
        let sums = (sum_word_indices(&needs).into_iter().zip(&specs.sums))
            .map(|(w, a)| Ok((w, image(&format!("voxel sum {}", SUM_NAMES[w]), a)?)))
            .collect::<GpuResult<Vec<_>>>()?;
        let optional = |name: &str, a: &Option<Alloc>| a.as_ref().map(|a| image(name, a)).transpose();
        Ok(VoxelVolumes {
            grid,
            needs,
            grid_buffer,
            albedo: image("voxel albedo", &specs.albedo)?,
            radiance: image("voxel radiance", &specs.radiance)?,
            bounced,
            bounce_tail,
            directional,
            gi_params,
            bounce_params,
            sampler: volume_sampler(ctx, mip_levels)?,
            normal: image("voxel normal", &specs.normal)?,
            emission: optional("voxel emission", &specs.emission)?,
            flags: optional("voxel static flags", &specs.flags)?,
            flags_placeholder: optional("voxel flags placeholder", &specs.flags_placeholder)?,
            sides: optional("voxel side factors", &specs.sides)?,
            sides_placeholder: optional("voxel side factors placeholder", &specs.sides_placeholder)?,
            side_normals: optional("voxel side normals", &specs.side_normals)?,
            side_normals_placeholder: optional("voxel side normals placeholder", &specs.side_normals_placeholder)?,
            backs: optional("voxel closed backs", &specs.backs)?,
            backs_placeholder: optional("voxel closed backs placeholder", &specs.backs_placeholder)?,
            emission_scale,
            radiance_scale,
            diffuse_rays: scene.settings.gi.diffuse_rays,
            list: VoxelList::new(ctx, &specs, capacity.list)?,
            sums,
            sum_scale,
            scan: scan_buffer(ctx, &specs)?,
            bricks,
            map_placeholder: image("voxel brick map placeholder", &specs.map_placeholder)?,
            read_placeholder: image("voxel brick map placeholder (read)", &specs.map_placeholder)?,
            pool_placeholder: image("voxel brick pool placeholder", &specs.pool_placeholder)?,
        })
    }

    /// The brick maps (`brick_maps[4]` in bricks.glsl), placeholders where there are none,
    /// touched with `access`. (Every pass that finds voxels in the bricked volumes binds them.)
    /// A pass that only reads them binds a placeholder of its own (`read_placeholder`), so it
    /// is not tied to the passes that write theirs (in another frame, on the other queue).
    pub fn brick_maps(&self, access: Access) -> Binds<'_> {
        let maps = self.bricks.as_ref().map_or(&[][..], |b| &b.maps[..]);
        let writes = access.info().writes;
        let placeholder = if writes { &self.map_placeholder } else { &self.read_placeholder };
        let bound = (0..MAX_POOLS).map(|i| maps.get(i).unwrap_or(placeholder));
        Binds::new().storage_images(bound, access)
    }

    /// The pooled directional levels (`aniso_pool[18]` and `pool_sampler` in cone.glsl),
    /// placeholders where there are none, sampled in compute shaders.
    pub fn pools(&self) -> Binds<'_> {
        let pooled = self.bricks.as_ref().map_or(&[][..], |b| &b.directional[..]);
        let bound = (0..3 * 6).map(|i| pooled.get(i / 6).map_or(&self.pool_placeholder, |level| &level[i % 6]));
        Binds::new().images(bound, Access::ComputeShaderReadSampled).sampler(self.sampler.raw)
    }

    /// The volumes cone.glsl samples in a compute shader beside its pools and brick maps: the
    /// full-resolution radiance `lod0` and the directional volumes.
    pub fn cone_volumes<'a>(&'a self, lod0: &'a Arc<Image>) -> Binds<'a> {
        let read = Access::ComputeShaderReadSampled;
        Binds::new().sampled(lod0, self.sampler.raw, read).sampled_array(&self.directional, self.sampler.raw, read)
    }

    /// Every volume that exists, for clears and memory reports: with bricks their maps and
    /// pooled levels too, and the placeholders (cleared once like the rest).
    pub fn all(&self) -> Vec<&Arc<Image>> {
        let mut v = self.full_resolution();
        v.extend(self.directional.iter());
        v.extend(self.bricks.iter().flat_map(|b| b.images()));
        v.extend([&self.map_placeholder, &self.read_placeholder, &self.pool_placeholder]);
        v.extend(self.sides_placeholder.as_ref());
        v.extend(self.side_normals_placeholder.as_ref());
        v.extend(self.backs_placeholder.as_ref());
        v
    }

    /// The volumes at full resolution (one texel per voxel; pool 0 of the bricked layout).
    pub fn full_resolution(&self) -> Vec<&Arc<Image>> {
        let mut v = vec![&self.albedo, &self.normal];
        v.extend(self.emission.as_ref());
        v.extend(self.flags.as_ref());
        v.extend(self.sides.as_ref());
        v.extend(self.side_normals.as_ref());
        v.extend(self.backs.as_ref());
        v.push(&self.radiance);
        v.extend(self.bounced.iter());
        v.extend(self.sums.iter().map(|(_, image)| image));
        v
    }

    /// The radiance volume the cones sample: with bounces the bounced radiance, else the
    /// direct radiance. The directional volumes are built from it.
    pub fn final_radiance(&self) -> &Arc<Image> {
        self.bounced.first().unwrap_or(&self.radiance)
    }

    /// The sums (`vox_sums[SUM_WORDS]` in voxel.glsl), touched with `access`: the words the
    /// scene does not need (emission, cover) are the map placeholder (never touched).
    pub fn sums_bound(&self, access: Access) -> Binds<'_> {
        let word = |w| self.sums.iter().find(|(i, _)| *i == w).map_or(&self.map_placeholder, |(_, image)| image);
        let bound = (0..SUM_NAMES.len()).map(word);
        Binds::new().storage_images(bound, access)
    }

    /// The volume bound where the emission volume goes (albedo stands in, never written).
    pub fn emission_or_albedo(&self) -> &Arc<Image> {
        self.emission.as_ref().unwrap_or(&self.albedo)
    }

    pub fn flags_or_placeholder(&self) -> &Arc<Image> {
        self.flags.as_ref().or(self.flags_placeholder.as_ref()).expect("flags or placeholder")
    }

    /// The side factors, or their placeholder where `gi.attenuation` is not `"per-side"`.
    pub fn sides_or_placeholder(&self) -> &Arc<Image> {
        self.sides.as_ref().or(self.sides_placeholder.as_ref()).expect("sides or placeholder")
    }

    /// The closed backs, or their placeholder where `gi.plane_backs` is not `"closed"`.
    pub fn backs_or_placeholder(&self) -> &Arc<Image> {
        self.backs.as_ref().or(self.backs_placeholder.as_ref()).expect("backs or placeholder")
    }

    /// The normals seen from each side, or their placeholder.
    pub fn side_normals_or_placeholder(&self) -> &Arc<Image> {
        self.side_normals.as_ref().or(self.side_normals_placeholder.as_ref()).expect("side normals or placeholder")
    }
}

/// The work list as read back after a frame (`Renderer::voxel_list`): for tests, `info` and
/// the benchmark's occupancy report. Never read inside a frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ListSnapshot {
    pub resolution: u32,
    /// Group counts of the indirect dispatch over every occupied voxel.
    pub occupied_groups: [u32; 3],
    /// Occupied voxels, static ones first: `entries[..static_count]`.
    pub entries: Vec<[u32; 3]>,
    pub static_count: u32,
    /// Group counts of the dynamic clear's dispatch (over `entries[static_count..]`).
    pub dynamic_groups: [u32; 3],
    /// Voxels the last dynamic clear emptied.
    pub stale: Vec<[u32; 3]>,
    pub stale_groups: [u32; 3],
    /// Appends that did not fit: always 0, since the capacity bounds what voxelization can
    /// append ([`list_capacity`]); a test checks it.
    pub dropped: u32,
}

impl ListSnapshot {
    /// Decode the list buffer's bytes (the header and the entries in use) and the stale list's.
    pub fn decode(resolution: u32, bytes: &[u8], stale_bytes: &[u8]) -> ListSnapshot {
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(bytes);
        let range = |offset: u64| {
            let i = offset as usize / 4;
            ([words[i], words[i + 1], words[i + 2]], words[i + 3])
        };
        let (occupied_groups, count) = range(work_list_header::OCCUPIED);
        let (dynamic_groups, _) = range(work_list_header::DYNAMIC);
        let (stale_groups, stale_count) = range(work_list_header::STALE);
        let unpack = |w: &u32| [w & 0x3ff, (w >> 10) & 0x3ff, (w >> 20) & 0x3ff];
        let first = work_list_header::SIZE as usize / 4;
        let entries = words[first..].iter().take(count as usize).map(unpack).collect();
        let stale_words: Vec<u32> = bytemuck::pod_collect_to_vec(stale_bytes);
        ListSnapshot {
            resolution,
            occupied_groups,
            entries,
            static_count: words[work_list_header::STATIC_COUNT as usize / 4],
            dynamic_groups,
            stale: stale_words.iter().take(stale_count as usize).map(unpack).collect(),
            stale_groups,
            dropped: words[work_list_header::DROPPED as usize / 4],
        }
    }

    /// How much of the grid is occupied, and what a bricked layout would hold.
    pub fn occupancy(&self) -> Occupancy {
        let n = u64::from(self.resolution);
        let bricks = |side: u32| {
            let mut set: Vec<u64> = self
                .entries
                .iter()
                .map(|c| {
                    let b = c.map(|v| u64::from(v / side));
                    b[0] + n * (b[1] + n * b[2])
                })
                .collect();
            set.sort_unstable();
            set.dedup();
            set.len() as u64
        };
        Occupancy {
            resolution: self.resolution,
            voxels: n.pow(3),
            occupied: self.entries.len() as u64,
            static_occupied: u64::from(self.static_count),
            bricks4: bricks(4),
            bricks8: bricks(8),
        }
    }
}

/// Occupied voxels of the grid (after voxelization) and the bricks of 4^3 and 8^3 voxels that
/// hold any: what a sparse layout would have to store.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Occupancy {
    pub resolution: u32,
    /// N^3.
    pub voxels: u64,
    pub occupied: u64,
    /// Of which static.
    pub static_occupied: u64,
    pub bricks4: u64,
    pub bricks8: u64,
}

impl Occupancy {
    pub fn fraction(&self) -> f64 {
        self.occupied as f64 / self.voxels.max(1) as f64
    }

    /// Bricks of `side`^3 voxels in the grid.
    pub fn brick_slots(&self, side: u32) -> u64 {
        u64::from(self.resolution.div_ceil(side)).pow(3)
    }

    /// Occupied bricks of `side`^3 (4 or 8).
    pub fn bricks(&self, side: u32) -> u64 {
        if side == 4 {
            self.bricks4
        } else {
            self.bricks8
        }
    }

    /// One line: occupied voxels and bricks, with their shares of the grid.
    pub fn summary(&self) -> String {
        let pct = |a: u64, b: u64| 100.0 * a as f64 / b.max(1) as f64;
        let bricks = |side: u32| {
            let (b, slots) = (self.bricks(side), self.brick_slots(side));
            format!("{b} of {side}³ ({:.2}%)", pct(b, slots))
        };
        format!(
            "{} of {}³ ({:.3}%), {} static; bricks {}, {}",
            self.occupied,
            self.resolution,
            100.0 * self.fraction(),
            self.static_occupied,
            bricks(4),
            bricks(8)
        )
    }
}

fn check_voxel_features(ctx: &Context) -> GpuResult<()> {
    if !ctx.info.optional.geometry_shader || !ctx.info.optional.fragment_stores_and_atomics {
        return Err(GpuError::Limit(format!(
            "voxel GI needs geometryShader and fragmentStoresAndAtomics, which {} lacks; use --set gi.mode=\"none\"",
            ctx.info.name
        )));
    }
    Ok(())
}

/// The six directional volumes (+x, -x, +y, -y, +z, -z) at half resolution, with the mip
/// Bytes of a voxel volume (`mips` levels of `extent` texels; `sampled`: also sampled, not only
/// a storage image): by its texels, or on `ctx`'s device as the device states them
/// (vkGetDeviceImageMemoryRequirements: its padding and alignment), never less than the texels.
pub fn volume_bytes(ctx: Option<&Context>, format: vk::Format, extent: [u32; 3], mips: u32, sampled: bool) -> u64 {
    let level = |l: u32| extent.iter().map(|&e| u64::from((e >> l).max(1))).product::<u64>();
    let texels = (0..mips).map(level).sum::<u64>() * crate::render::passes::readback::bytes_per_texel(format);
    let Some(ctx) = ctx else { return texels };
    let mut usage =
        vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::TRANSFER_SRC;
    if sampled {
        usage |= vk::ImageUsageFlags::SAMPLED;
    }
    let desc = ImageDesc { mip_levels: mips, concurrent: true, ..ImageDesc::d3_extent(format, extent, usage) };
    crate::gpu::memory::device_image_bytes(ctx, &desc).max(texels)
}

/// With bricks (`capacity` counts them): the pools, each one's slots arranged to take the least
/// memory by `image_bytes(format, extent, sampled)` (a device's, or the texels'). None dense.
pub fn fitted_layout(
    resolution: u32,
    needs: &VoxelNeeds,
    capacity: &Capacity,
    image_bytes: &dyn Fn(vk::Format, [u32; 3], bool) -> u64,
) -> Option<BrickLayout> {
    (!capacity.bricks.is_empty())
        .then(|| BrickLayout::sized(resolution, &capacity.bricks).fit(needs.full_images(), image_bytes))
}

/// The maps, pooled levels and lists of `layout`, as `specs` sizes them.
fn bricks_of(ctx: &Arc<Context>, layout: BrickLayout, specs: &VolumeSpecs) -> GpuResult<Bricks> {
    let image = |name: String, a: &Alloc| Image::new(ctx, &name, a.desc()).map(Arc::new);
    let maps = (specs.maps.iter().enumerate())
        .map(|(i, a)| image(format!("voxel brick map {i}"), a))
        .collect::<GpuResult<Vec<_>>>()?;
    let directional = (specs.pooled.iter().enumerate())
        .map(|(l, a)| DIRECTIONS.iter().map(|d| image(format!("voxel radiance {d} level {l} bricks"), a)).collect())
        .collect::<GpuResult<Vec<_>>>()?;
    let usage = vk::BufferUsageFlags::STORAGE_BUFFER
        | vk::BufferUsageFlags::INDIRECT_BUFFER
        | vk::BufferUsageFlags::TRANSFER_DST
        | vk::BufferUsageFlags::TRANSFER_SRC;
    let size = specs.brick_lists.expect("bricked specs have lists").size();
    let lists = Buffer::new(ctx, "voxel brick lists", size, usage, gpu_allocator::MemoryLocation::GpuOnly)?;
    Ok(Bricks { layout, maps, directional, lists: Arc::new(lists) })
}

/// The scan buffer `specs` sizes ([`ScanLayout`]).
fn scan_buffer(ctx: &Arc<Context>, specs: &VolumeSpecs) -> GpuResult<Arc<Buffer>> {
    let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST;
    Buffer::new(ctx, "voxel scan", specs.scan.size(), usage, gpu_allocator::MemoryLocation::GpuOnly).map(Arc::new)
}

/// The cone-tracing parameters of the per-pixel tracer and of the bounce (`gi.bounce_cones`,
/// 0: the per-pixel cone set; `gi.bounce_footprint`).
fn gi_uniforms(ctx: &Arc<Context>, scene: &Scene, grid: &VoxelGrid, mip_levels: u32) -> GpuResult<(Buffer, Buffer)> {
    // `--view ao` shows the occlusion whether or not it darkens the final image.
    let mut gi = scene.settings.gi.clone();
    gi.ao |= scene.settings.view == View::Ao;
    let (res, vs) = (grid.resolution, grid.voxel_size);
    let gi_params = Buffer::uniform(ctx, "gi params", &GpuGiParams::new(&gi, res, vs, mip_levels))?;
    let bounce_cones = if gi.bounce_cones == 0 { gi.diffuse_cones } else { gi.bounce_cones };
    let bounce_gi = GiSettings { diffuse_cones: bounce_cones, footprint: gi.bounce_footprint, ..gi };
    let bounce_params = Buffer::uniform(ctx, "bounce gi params", &GpuGiParams::new(&bounce_gi, res, vs, mip_levels))?;
    Ok((gi_params, bounce_params))
}

/// Trilinear, mipmapped, transparent black outside the grid.
fn volume_sampler(ctx: &Arc<Context>, mip_levels: u32) -> GpuResult<Sampler> {
    let addr = vk::SamplerAddressMode::CLAMP_TO_BORDER;
    Sampler::new(
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
    )
}

/// The pools' uniform (`VoxelGrid.pools`): slots per axis and map side of each pool.
fn pool_uniforms(bricks: Option<&Bricks>) -> [[u32; 4]; MAX_POOLS] {
    let mut u = [[1, 1, 1, 0]; MAX_POOLS];
    for (i, p) in bricks.map_or(&[][..], |b| &b.layout.pools[..]).iter().enumerate() {
        u[i] = [p.slots[0], p.slots[1], p.slots[2], p.map_side];
    }
    u
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_list_snapshot_decodes_the_header_and_packed_entries() {
        let mut words = vec![0u32; work_list_header::SIZE as usize / 4];
        words[..4].copy_from_slice(&[1, 1, 1, 2]); // occupied: groups, count
        words[4..8].copy_from_slice(&[1, 1, 1, 1]); // dynamic
        words[8..12].copy_from_slice(&[1, 1, 1, 1]); // stale
        words[12] = 1; // static count
        let pack = |c: [u32; 3]| c[0] | (c[1] << 10) | (c[2] << 20);
        words.extend([pack([1, 2, 3]), pack([511, 0, 7]), pack([9, 9, 9])]); // a third, unused
        let stale = [pack([4, 5, 6])];
        let l = ListSnapshot::decode(512, bytemuck::cast_slice(&words), bytemuck::cast_slice(&stale));
        assert_eq!(l.entries, vec![[1, 2, 3], [511, 0, 7]]);
        assert_eq!((l.static_count, l.occupied_groups, l.stale.clone()), (1, [1, 1, 1], vec![[4, 5, 6]]));
        let o = l.occupancy();
        assert_eq!((o.occupied, o.static_occupied, o.bricks4, o.bricks8, o.voxels), (2, 1, 2, 2, 512u64.pow(3)));
    }
}
