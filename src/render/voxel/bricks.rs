//! The bricked (sparse) layout of the voxel volumes: each volume stores only the bricks of
//! 8^3 texels that hold something, in a pool (a 3D image of bricks side by side), found
//! through a map of the grid's bricks (R32_UINT: 0 = not resident, else where the brick's slot
//! lies in the pool image: [`Pool::entry_slot`]).
//! docs/SPARSE.md says why this layout and not sparse residency, with the measurements.
//!
//! Pool 0 holds the full-resolution volumes (albedo, normal, emission, flags, sums, radiance,
//! bounces); pools 1.. the directional volumes' levels that are larger than [`DENSE_SIDE`]^3.
//! Every volume sampled with hardware trilinear filtering (pool 0's radiance volumes, whose
//! first samples every cone takes, and every pooled directional level) stores each brick with
//! a one-texel apron on its low side (9^3 texels: the texels 8b-1 .. 8b+7 of brick b on each
//! axis), so a filter stays inside one brick and costs one map lookup and one fetch; a brick is
//! resident when any of its 9^3 texels can be non-empty. Pool 0's integer volumes, read texel
//! by texel, share its slots at 8^3 per slot. Coarser directional levels stay dense.
//!
//! The GPU marks bricks while voxelizing and allocates pool slots in a compute pass; the pools
//! are sized up front by an upper bound from the triangles (`voxel::capacity`: a
//! separating-axis test of each triangle against the bricks its box touches), so no
//! allocation can overflow and the memory estimate is what is allocated.

use super::grid::RADIANCE_VOLUME_FORMAT;
use crate::gpu::{Buffer, Image};
use ash::vk;
use std::sync::Arc;

/// Texels along each side of a brick.
pub const BRICK: u32 = 8;
/// Directional levels of at most this many texels per side are dense.
pub const DENSE_SIDE: u32 = 64;
/// Pools: full resolution and up to three directional levels (grids up to 1024^3).
pub const MAX_POOLS: usize = 4;
/// Set in the map entry of a resident brick (bricks.glsl), above its slot's 10-bit axes.
pub const BRICK_RESIDENT: u32 = 1 << 30;
/// Slots per axis a map entry can address.
pub const MAX_SLOTS_PER_AXIS: u32 = 1 << 10;

/// One pool: the bricks of one level of the grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pool {
    /// Texels per side of the level (N for pool 0, N/2 >> L for directional level L).
    pub level_side: u32,
    /// Bricks per side of the map: level_side / 8, plus one with the apron (the bricks past
    /// the last texel hold it in their apron).
    pub map_side: u32,
    /// Texels per side of a stored brick in the pool's sampled volumes: 9, with the apron
    /// (pool 0's integer volumes store 8: [`Pool::extent_at`]).
    pub stride: u32,
    /// Slots the pool holds: an upper bound of the resident bricks.
    pub capacity: u32,
    /// Slots per axis of the pool image (x * y * z >= capacity).
    pub slots: [u32; 3],
}

impl Pool {
    fn new(level_side: u32, apron: bool, capacity: u64) -> Pool {
        let map_side = level_side / BRICK + u32::from(apron);
        let capacity = capacity.min(u64::from(map_side).pow(3)).max(1) as u32;
        // As cubic as the count allows: x = y = ceil(cbrt), z what remains.
        let x = (f64::from(capacity).cbrt().ceil() as u32).max(1);
        let z = capacity.div_ceil(x * x);
        Pool { level_side, map_side, stride: BRICK + u32::from(apron), capacity, slots: [x, x, z] }
    }

    /// Texels per axis of the pool's sampled images (radiance, directional levels).
    pub fn extent(&self) -> [u32; 3] {
        self.extent_at(self.stride)
    }

    /// Texels per axis of an image of the pool that stores `stride`^3 texels per slot.
    pub fn extent_at(&self, stride: u32) -> [u32; 3] {
        self.slots.map(|s| s * stride)
    }

    /// Bricks of the grid at this level (the map's entries).
    pub fn map_entries(&self) -> u64 {
        u64::from(self.map_side).pow(3)
    }

    /// The slot, per axis of the pool image, of map entry `entry` (bricks.glsl's `slot_entry`:
    /// the position with [`BRICK_RESIDENT`] set, 10 bits per axis); `None` for a brick that is
    /// not resident (0) or marked but not allocated.
    pub fn entry_slot(entry: u32) -> Option<[u32; 3]> {
        (entry & !0x3fff_ffff == BRICK_RESIDENT).then_some([
            entry & 0x3ff,
            (entry >> 10) & 0x3ff,
            (entry >> 20) & 0x3ff,
        ])
    }
}

/// The pools of a grid: full resolution first, then the pooled directional levels.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BrickLayout {
    pub pools: Vec<Pool>,
}

/// The images of pool 0 besides its two sampled radiance volumes (RGBA16F, 9^3 per slot):
/// R32_UINT and R8_UINT volumes and the bounce's scratch volume (RGBA16F), 8^3 per slot.
/// Pools 1.. hold six sampled RGBA16F volumes each. What [`BrickLayout::fit`] weighs.
#[derive(Debug, Clone, Copy)]
pub struct FullImages {
    pub words: u32,
    pub bytes: u32,
    pub scratch: bool,
}

impl BrickLayout {
    /// Directional levels with more than [`DENSE_SIDE`] texels per side (at most 3).
    pub fn pooled_levels(resolution: u32) -> u32 {
        (0..3).take_while(|&l| (resolution / 2) >> l > DENSE_SIDE).count() as u32
    }

    /// Each pool's slots arranged (x, y, z near the cube root of its capacity) so that its
    /// images take the least memory by `image_bytes(format, extent, sampled)`: a device pads
    /// 3D images to its tiles (an H100 took 23% over the texels for a pool 99 texels a side),
    /// and the arrangement decides by how much. Deterministic: the first least candidate, the
    /// near-cubic one first.
    pub fn fit(mut self, full: FullImages, image_bytes: &dyn Fn(vk::Format, [u32; 3], bool) -> u64) -> BrickLayout {
        use vk::Format as F;
        for (i, pool) in self.pools.iter_mut().enumerate() {
            let cost = |p: &Pool| -> u64 {
                let sampled = image_bytes(RADIANCE_VOLUME_FORMAT, p.extent(), true);
                if i > 0 {
                    return 6 * sampled;
                }
                let plain = |f| image_bytes(f, p.extent_at(BRICK), false);
                let scratch = if full.scratch { plain(RADIANCE_VOLUME_FORMAT) } else { 0 };
                2 * sampled
                    + u64::from(full.words) * plain(F::R32_UINT)
                    + u64::from(full.bytes) * plain(F::R8_UINT)
                    + scratch
            };
            let c = pool.slots[0];
            let mut best = (cost(pool), *pool);
            for x in c.saturating_sub(3).max(1)..=c + 3 {
                for y in x.saturating_sub(3).max(1)..=x {
                    let z = pool.capacity.div_ceil(x * y);
                    if z > x {
                        continue; // y <= x and z <= x: none long and thin
                    }
                    let candidate = Pool { slots: [x, y, z], ..*pool };
                    let bytes = cost(&candidate);
                    if bytes < best.0 {
                        best = (bytes, candidate);
                    }
                }
            }
            *pool = best.1;
            // A grid of at most 1024^3 has at most 129^3 bricks a level: about 130 slots a side.
            debug_assert!(pool.slots.iter().all(|&s| s < MAX_SLOTS_PER_AXIS), "{pool:?}");
        }
        self
    }

    /// The pools of a grid of `resolution`, sized by `capacity`: pool 0's bricks, then each
    /// pooled directional level's (`voxel::capacity::Capacity::bricks`).
    pub fn sized(resolution: u32, capacity: &[u64]) -> BrickLayout {
        let mut pools = vec![Pool::new(resolution, true, capacity[0])];
        for (l, &c) in capacity[1..].iter().enumerate() {
            pools.push(Pool::new((resolution / 2) >> l, true, c));
        }
        BrickLayout { pools }
    }
}

/// Byte offsets of the brick lists' header (`BrickListBlock` in glsl/include/brick_list.glsl).
pub mod brick_list_header {
    /// Per pool: a `VkDispatchIndirectCommand` over its resident bricks and their count.
    pub fn range(pool: usize) -> u64 {
        16 * pool as u64
    }
    /// Word indices of the per-pool arrays after the ranges: first entry, capacity, dropped,
    /// static bricks.
    pub const FIRST: usize = 16;
    pub const CAPACITY: usize = 20;
    pub const DROPPED: usize = 24;
    pub const STATIC: usize = 28;
    /// Per pool: a `VkDispatchIndirectCommand` over its dynamic bricks and their count.
    pub fn dynamic_range(pool: usize) -> u64 {
        128 + 16 * pool as u64
    }
    /// Header size in bytes; the entries follow.
    pub const SIZE: u64 = 192;
}

/// The GPU side of a bricked layout: one map per pool, the pooled directional levels and the
/// lists of resident bricks.
pub struct Bricks {
    pub layout: BrickLayout,
    /// One R32_UINT map per pool.
    pub maps: Vec<Arc<Image>>,
    /// Pools 1..: the six directional volumes of each pooled level (RGBA16F, 9^3 per brick).
    pub directional: Vec<Vec<Arc<Image>>>,
    /// The resident bricks of every pool, after a header of indirect dispatches.
    pub lists: Arc<Buffer>,
}

impl Bricks {
    /// The lists' header with nothing resident: where each pool's entries start and how many
    /// it may hold (`BrickListBlock`).
    pub fn empty_header(&self) -> [u32; brick_list_header::SIZE as usize / 4] {
        let mut h = [0u32; brick_list_header::SIZE as usize / 4];
        let mut first = 0;
        for (i, p) in self.layout.pools.iter().enumerate() {
            h[brick_list_header::FIRST + i] = first;
            h[brick_list_header::CAPACITY + i] = p.capacity;
            first += p.capacity;
        }
        h
    }

    /// The maps and the pooled directional images.
    pub fn images(&self) -> impl Iterator<Item = &Arc<Image>> {
        self.maps.iter().chain(self.directional.iter().flatten())
    }
}

/// The resident bricks as read back after a frame (`Renderer::resident_bricks`): for tests,
/// `info` and the benchmark.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BrickSnapshot {
    pub pools: Vec<PoolSnapshot>,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PoolSnapshot {
    pub pool: Pool,
    /// Brick coordinates in allocation order.
    pub resident: Vec<[u32; 3]>,
    /// Bricks that found no slot: always 0, since the capacity bounds what can be marked.
    pub dropped: u32,
}

impl BrickSnapshot {
    /// Decode the lists buffer (`BrickListBlock`).
    pub fn decode(layout: &BrickLayout, bytes: &[u8]) -> BrickSnapshot {
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(bytes);
        let pools = layout
            .pools
            .iter()
            .enumerate()
            .map(|(i, &pool)| {
                let count = words[4 * i + 3].min(pool.capacity) as usize;
                let first = (brick_list_header::SIZE / 4) as usize + words[brick_list_header::FIRST + i] as usize;
                let unpack = |w: &u32| [w & 0x3ff, (w >> 10) & 0x3ff, w >> 20];
                let resident = words[first..first + count].iter().map(unpack).collect();
                PoolSnapshot { pool, resident, dropped: words[brick_list_header::DROPPED + i] }
            })
            .collect();
        BrickSnapshot { pools }
    }
}

/// What the voxel volumes take on the device, as `info` prints it and `bench --json` records
/// it (`Renderer::voxel_memory`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VoxelMemory {
    /// "bricks" or "dense".
    pub layout: String,
    /// Bytes allocated for the voxel volumes, the brick maps and pools, and the voxel and
    /// brick lists (what the budget's estimate counts as volumes).
    pub bytes: u64,
    /// The budget's estimate of the same volumes in the dense layout at this resolution, on
    /// this device (`Estimate::on`).
    pub dense_bytes: u64,
    /// One entry per pool: full resolution first, then the pooled directional levels (none
    /// in the dense layout).
    pub pools: Vec<PoolMemory>,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoolMemory {
    /// Texels per side of the level the pool holds.
    pub level_side: u32,
    /// Texels per side of a brick in the pool's sampled volumes (9, with the filtering apron;
    /// pool 0's integer volumes store 8).
    pub brick_stride: u32,
    /// Bricks resident after the last frame.
    pub resident: u32,
    /// Slots allocated.
    pub capacity: u32,
    /// Bricks in the level's grid (what a dense volume stores).
    pub grid_bricks: u64,
    /// Bytes of the pool's images.
    pub bytes: u64,
}

impl VoxelMemory {
    /// Allocated over the dense estimate.
    pub fn ratio(&self) -> f64 {
        self.bytes as f64 / self.dense_bytes.max(1) as f64
    }

    /// The lines `info` prints.
    pub fn summary(&self) -> Vec<String> {
        let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
        if self.layout == "dense" {
            return vec![format!("voxel layout: dense, {:.2} MiB of volumes and lists", mib(self.bytes))];
        }
        let mut lines = vec![format!(
            "voxel layout: bricks of {BRICK}³, {:.2} MiB of volumes, maps and lists ({:.3} of the dense layout's {:.2} MiB)",
            mib(self.bytes),
            self.ratio(),
            mib(self.dense_bytes)
        )];
        lines.extend(self.pools.iter().enumerate().map(|(i, p)| {
            let (what, per_brick) = if i == 0 {
                ("full resolution".to_string(), format!("{BRICK}³ per brick, {}³ with the radiance apron", p.brick_stride))
            } else {
                (format!("directional level {}", i - 1), format!("{}³ per brick", p.brick_stride))
            };
            format!(
                "bricks, {what} ({}³ texels, {per_brick}): {} resident of {} slots, {} bricks in the grid ({:.2}%); pool {:.2} MiB",
                p.level_side,
                p.resident,
                p.capacity,
                p.grid_bricks,
                100.0 * p.resident as f64 / p.grid_bricks.max(1) as f64,
                mib(p.bytes),
            )
        }));
        lines
    }
}

impl BrickSnapshot {
    /// Per pool, with the bytes of each pool's images (`pool_bytes`).
    pub fn pool_memory(&self, pool_bytes: &[u64]) -> Vec<PoolMemory> {
        self.pools
            .iter()
            .zip(pool_bytes)
            .map(|(p, &bytes)| PoolMemory {
                level_side: p.pool.level_side,
                brick_stride: p.pool.stride,
                resident: p.resident.len() as u32,
                capacity: p.pool.capacity,
                grid_bricks: p.pool.map_entries(),
                bytes,
            })
            .collect()
    }
}

/// The dense texels (`texel` bytes each, x fastest) of a pool's level, from the bytes of a pool
/// image that stores `stride`^3 texels per slot (8, or 9 with the apron) and the pool's map:
/// each resident brick's interior copied out, the rest zero.
pub fn unpool(pool: &Pool, stride: u32, pooled: &[u8], map: &[u32], texel: usize) -> Vec<u8> {
    let side = pool.level_side as usize;
    let ext = pool.extent_at(stride).map(|e| e as usize);
    let apron = (stride - BRICK) as usize;
    let stride = stride as usize;
    let mut out = vec![0u8; side * side * side * texel];
    let m = pool.map_side as usize;
    for (i, slot) in map.iter().enumerate().filter_map(|(i, &e)| Some((i, Pool::entry_slot(e)?))) {
        let b = [i % m, (i / m) % m, i / (m * m)];
        let slot = slot.map(|s| s as usize);
        for z in 0..BRICK as usize {
            for y in 0..BRICK as usize {
                for x in 0..BRICK as usize {
                    let t = [b[0] * 8 + x, b[1] * 8 + y, b[2] * 8 + z];
                    if t.iter().any(|&c| c >= side) {
                        continue;
                    }
                    let p = [x, y, z].map(|c| c + apron);
                    let src = ((slot[2] * stride + p[2]) * ext[1] + slot[1] * stride + p[1]) * ext[0]
                        + slot[0] * stride
                        + p[0];
                    let dst = (t[2] * side + t[1]) * side + t[0];
                    out[dst * texel..(dst + 1) * texel].copy_from_slice(&pooled[src * texel..(src + 1) * texel]);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pools_hold_their_capacity_in_near_cubic_images() {
        let p = Pool::new(256, false, 5418);
        assert_eq!((p.map_side, p.stride, p.capacity), (32, 8, 5418));
        assert!(p.slots.iter().product::<u32>() >= 5418 && p.slots[0] == 18);
        let d = Pool::new(128, true, 10_000); // more than the map's 17^3 = 4913 bricks
        assert_eq!((d.map_side, d.stride, d.capacity), (17, 9, 4913));
        assert_eq!(d.extent()[0], d.slots[0] * 9);
    }

    #[test]
    fn grids_pool_the_directional_levels_above_64_texels() {
        assert_eq!(BrickLayout::pooled_levels(64), 0);
        assert_eq!(BrickLayout::pooled_levels(128), 0);
        assert_eq!(BrickLayout::pooled_levels(256), 1);
        assert_eq!(BrickLayout::pooled_levels(512), 2);
        assert_eq!(BrickLayout::pooled_levels(1024), 3);
    }

    /// Map entries as bricks.glsl writes them: the slot's position with bit 30 set.
    #[test]
    fn map_entries_decode_to_slot_positions() {
        assert_eq!(Pool::entry_slot(0), None, "not resident");
        assert_eq!(Pool::entry_slot(u32::MAX), None, "marked, not allocated (BRICK_PENDING)");
        assert_eq!(Pool::entry_slot(BRICK_RESIDENT), Some([0, 0, 0]));
        assert_eq!(Pool::entry_slot(BRICK_RESIDENT | 3 | (5 << 10) | (1023 << 20)), Some([3, 5, 1023]));
        // Every arrangement a grid of 1024^3 can need fits the entry's 10 bits per axis.
        let full = FullImages { words: 10, bytes: 1, scratch: true };
        let layout = BrickLayout::sized(1024, &[129u64.pow(3), 65u64.pow(3), 33u64.pow(3), 17u64.pow(3)])
            .fit(full, &|_, e, _| u64::from(e[0]) * u64::from(e[1]) * u64::from(e[2]));
        assert!(layout.pools.iter().all(|p| p.slots.iter().all(|&s| s < MAX_SLOTS_PER_AXIS)), "{layout:?}");
    }

    #[test]
    fn pools_fit_their_slots_to_what_the_device_pads() {
        // A device that pads every side of a 3D image to a multiple of 16 texels.
        let padded =
            |_: vk::Format, e: [u32; 3], _: bool| e.iter().map(|&x| u64::from(x.div_ceil(16) * 16)).product::<u64>();
        let layout = BrickLayout { pools: vec![Pool::new(256, true, 5422), Pool::new(128, true, 1304)] };
        let full = FullImages { words: 9, bytes: 1, scratch: true };
        let fitted = layout.clone().fit(full, &padded);
        for (before, after) in layout.pools.iter().zip(&fitted.pools) {
            let slots = after.slots.iter().product::<u32>();
            assert!(slots >= after.capacity && after.slots[2] <= after.slots[0] && after.slots[1] <= after.slots[0]);
            assert_eq!(
                (after.capacity, after.map_side, after.stride),
                (before.capacity, before.map_side, before.stride)
            );
            let cost = |p: &Pool| padded(vk::Format::UNDEFINED, p.extent(), true);
            assert!(cost(after) <= cost(before), "{before:?} -> {after:?}");
        }
        // The directional pool (11^3 slots, 99 texels a side, padded to 112^3) fits better.
        let cost = |p: &Pool| padded(vk::Format::UNDEFINED, p.extent(), true);
        assert!(cost(&fitted.pools[1]) < cost(&layout.pools[1]), "{:?}", fitted.pools[1]);
        // By the texels alone, the fewest slots win and the near-cubic default stays on a tie.
        let texels = |_: vk::Format, e: [u32; 3], _: bool| e.iter().map(|&x| u64::from(x)).product::<u64>();
        let exact = BrickLayout { pools: vec![Pool::new(64, true, 27)] }.fit(full, &texels);
        assert_eq!(exact.pools[0].slots, [3, 3, 3]);
    }
}
