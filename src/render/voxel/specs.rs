//! Every allocation of the voxel volumes, decided in one place: `VoxelVolumes::new` creates
//! exactly these (named as it holds them), and the memory estimate (`budget`) sums their bytes
//! without creating anything. A volume added here is allocated and counted; one added
//! elsewhere is neither (and `tests/limits.rs` checks the estimate against the allocation to
//! the byte).

use super::bricks::{brick_list_header, BrickLayout, BRICK};
use super::grid::RADIANCE_VOLUME_FORMAT;
use super::{sum_word_indices, work_list_header, ScanLayout, VoxelNeeds};
use crate::gpu::{Context, ImageDesc};
use ash::vk;

/// One allocation: a buffer of so many bytes, or a 3D image (format, extent, mip levels,
/// whether it is sampled besides being a storage image).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Alloc {
    Buffer(u64),
    Volume { format: vk::Format, extent: [u32; 3], mips: u32, sampled: bool },
}

impl Alloc {
    fn volume(format: vk::Format, extent: [u32; 3], mips: u32, sampled: bool) -> Alloc {
        Alloc::Volume { format, extent, mips, sampled }
    }

    /// Bytes: by the texel count (`ctx` None: what any device needs at least), or on `ctx`'s
    /// device as its memory requirements state them (its padding and alignment included).
    pub fn bytes(&self, ctx: Option<&Context>) -> u64 {
        match *self {
            Alloc::Buffer(bytes) => bytes,
            Alloc::Volume { format, extent, mips, sampled } => super::volume_bytes(ctx, format, extent, mips, sampled),
        }
    }

    /// The image to create (storage, cleared and copied; sampled where it says so).
    pub fn desc(&self) -> ImageDesc {
        let Alloc::Volume { format, extent, mips, sampled } = *self else { panic!("a buffer has no image") };
        let mut usage =
            vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::TRANSFER_SRC;
        if sampled {
            usage |= vk::ImageUsageFlags::SAMPLED;
        }
        // The voxelization (graphics) writes them and the voxel light (compute) reads them
        // every update: shared by both families at once (`ImageDesc::concurrent`).
        ImageDesc { mip_levels: mips, concurrent: true, ..ImageDesc::d3_extent(format, extent, usage) }
    }

    /// A buffer's bytes.
    pub fn size(&self) -> u64 {
        let Alloc::Buffer(bytes) = *self else { panic!("an image is not a buffer") };
        bytes
    }
}

/// The voxel volumes of a grid of `resolution` with `needs`, dense or in `layout`'s pools.
#[derive(Debug, Clone)]
pub struct VolumeSpecs {
    /// Integer volumes at full resolution (R32_UINT; N^3 or pool 0 at 8^3 per slot).
    pub albedo: Alloc,
    pub normal: Alloc,
    pub emission: Option<Alloc>,
    /// The static flags (R8_UINT), with dynamic objects; else their 1^3 placeholder.
    pub flags: Option<Alloc>,
    pub flags_placeholder: Option<Alloc>,
    pub sides: Option<Alloc>,
    pub sides_placeholder: Option<Alloc>,
    pub side_normals: Option<Alloc>,
    pub side_normals_placeholder: Option<Alloc>,
    /// With `gi.plane_backs = "closed"`: the backs that close a solid (R8_UINT); else a 1^3
    /// placeholder.
    pub backs: Option<Alloc>,
    pub backs_placeholder: Option<Alloc>,
    /// The voxelization's sums (R32_UINT).
    pub sums: Vec<Alloc>,
    /// The direct radiance (RGBA16F, sampled; pool 0 at 9^3 per slot, with the apron).
    pub radiance: Alloc,
    /// With bounces: the bounced radiance (as the radiance) and the bounce's scratch volume
    /// (read texel by texel: 8^3 per slot).
    pub bounced: Vec<Alloc>,
    /// With cones: each of the six directional volumes' dense levels (half resolution, below
    /// the pooled levels), with their mip chains.
    pub directional: Option<Alloc>,
    /// With bricks: each pool's map (R32_UINT per brick) and each pooled level's six volumes.
    pub maps: Vec<Alloc>,
    pub pooled: Vec<Alloc>,
    /// With bricks: the lists of resident bricks, after their header.
    pub brick_lists: Option<Alloc>,
    /// The scan buffer ([`ScanLayout`]).
    pub scan: Alloc,
    /// The work list (header and an entry per voxel the triangles can occupy) and, with
    /// dynamic objects, the stale list.
    pub list: Alloc,
    pub stale: Option<Alloc>,
    /// With bounces: the first update's bounce tail (its records only with the tail).
    pub tail: Option<Alloc>,
    /// The 1^3 stand-ins bound where a map or a pooled level does not exist.
    pub map_placeholder: Alloc,
    pub pool_placeholder: Alloc,
}

/// Workgroups per record of the first update's bounce tail (glsl/include/bounce_tail.glsl): with
/// the tail, as many as a dispatch over a full work list of `list_capacity` entries has
/// (`list_range` in glsl/include/voxel_list.glsl: 64 invocations a group, at most 32768 groups
/// along x); without it, one, for the compose steps that bind the buffer and leave it alone.
pub fn tail_groups(needs: &VoxelNeeds, list_capacity: u64) -> u32 {
    const GROUP: u64 = 64;
    const GROUPS_X: u64 = 32768;
    if !needs.bounce_tail {
        return 1;
    }
    let groups = list_capacity.div_ceil(GROUP).max(1);
    u32::try_from(groups.min(GROUPS_X) * groups.div_ceil(GROUPS_X)).unwrap_or(u32::MAX)
}

impl VolumeSpecs {
    /// `list_capacity`: the work list's entries (`Capacity::list`); `layout`: the pools, fitted.
    pub fn new(resolution: u32, needs: &VoxelNeeds, list_capacity: u64, layout: Option<&BrickLayout>) -> VolumeSpecs {
        use vk::Format as F;
        let res = resolution;
        let full = layout.map_or([res; 3], |l| l.pools[0].extent_at(BRICK));
        let volume = |format| Alloc::volume(format, full, 1, false);
        let radiance_extent = layout.map_or([res; 3], |l| l.pools[0].extent());
        let radiance = Alloc::volume(RADIANCE_VOLUME_FORMAT, radiance_extent, 1, true);
        let pooled_levels = layout.map_or(0, |l| l.pools.len() as u32 - 1);
        let side = (res / 2) >> pooled_levels;
        let mips = res.trailing_zeros() - pooled_levels;
        let placeholder = |format, sampled| Alloc::volume(format, [1; 3], 1, sampled);
        VolumeSpecs {
            albedo: volume(F::R32_UINT),
            normal: volume(F::R32_UINT),
            emission: needs.emission.then(|| volume(F::R32_UINT)),
            flags: needs.dynamic.then(|| volume(F::R8_UINT)),
            flags_placeholder: (!needs.dynamic).then(|| placeholder(F::R8_UINT, false)),
            sides: needs.sides.then(|| volume(F::R32_UINT)),
            sides_placeholder: (!needs.sides).then(|| placeholder(F::R32_UINT, false)),
            side_normals: needs.sides.then(|| volume(F::R32G32B32A32_UINT)),
            side_normals_placeholder: (!needs.sides).then(|| placeholder(F::R32G32B32A32_UINT, false)),
            backs: needs.closed_backs.then(|| volume(F::R8_UINT)),
            backs_placeholder: (!needs.closed_backs).then(|| placeholder(F::R8_UINT, false)),
            sums: sum_word_indices(needs).iter().map(|_| volume(F::R32_UINT)).collect(),
            radiance,
            bounced: if needs.bounces > 0 { vec![radiance, volume(RADIANCE_VOLUME_FORMAT)] } else { Vec::new() },
            directional: needs.cones.then(|| Alloc::volume(RADIANCE_VOLUME_FORMAT, [side; 3], mips, true)),
            maps: layout.map_or(Vec::new(), |l| {
                l.pools.iter().map(|p| Alloc::volume(F::R32_UINT, [p.map_side; 3], 1, false)).collect()
            }),
            pooled: layout.map_or(Vec::new(), |l| {
                l.pools[1..].iter().map(|p| Alloc::volume(RADIANCE_VOLUME_FORMAT, p.extent(), 1, true)).collect()
            }),
            brick_lists: layout.map(|l| {
                let entries: u64 = l.pools.iter().map(|p| u64::from(p.capacity)).sum();
                Alloc::Buffer(brick_list_header::SIZE + 4 * entries)
            }),
            scan: Alloc::Buffer(4 * ScanLayout::new(res, layout).words),
            list: Alloc::Buffer(work_list_header::SIZE + 4 * list_capacity),
            stale: needs.dynamic.then(|| Alloc::Buffer(4 * list_capacity.max(1))),
            tail: (needs.bounces > 0).then(|| Alloc::Buffer(32 + 32 * u64::from(tail_groups(needs, list_capacity)))),
            map_placeholder: placeholder(F::R32_UINT, false),
            pool_placeholder: placeholder(RADIANCE_VOLUME_FORMAT, true),
        }
    }

    /// Every allocation, each directional and pooled volume six times.
    pub fn all(&self) -> Vec<Alloc> {
        let mut out = vec![self.albedo, self.normal];
        out.extend(self.emission);
        out.extend(self.flags);
        out.extend(self.flags_placeholder);
        out.extend(self.sides);
        out.extend(self.sides_placeholder);
        out.extend(self.side_normals);
        out.extend(self.side_normals_placeholder);
        out.extend(self.backs);
        out.extend(self.backs_placeholder);
        out.extend(&self.sums);
        out.push(self.radiance);
        out.extend(&self.bounced);
        out.extend(self.directional.iter().flat_map(|d| [*d; 6]));
        out.extend(&self.maps);
        out.extend(self.pooled.iter().flat_map(|p| [*p; 6]));
        out.extend(self.brick_lists);
        out.extend([self.scan, self.list]);
        out.extend(self.stale);
        out.extend(self.tail);
        // The map placeholder twice: one for the passes that write, one for those that read.
        out.extend([self.map_placeholder, self.map_placeholder, self.pool_placeholder]);
        out
    }
}
