//! What a renderer reads back to the host outside its frames, for tests, `dvsgi info` and the
//! benchmark's reports: images (any mip level), the voxel volumes whatever their layout, the
//! work list of occupied voxels, the resident bricks and what the volumes take. Each read-back
//! is a batch of its own, recorded and waited for between frames, never inside one.

use super::voxel::{self, bricks};
use super::{budget, passes, Renderer};
use crate::gpu::{GpuResult, Image};
use crate::render::graph::Pass;
use std::sync::Arc;

impl Renderer {
    /// Copy an image of this renderer to the host, every layer (waits; for tests and debugging).
    pub fn download(&mut self, image: &Arc<Image>) -> GpuResult<Vec<u8>> {
        self.download_level(image, 0)
    }

    /// Copy one mip level of an image to the host (waits; for tests and debugging).
    pub fn download_level(&mut self, image: &Arc<Image>, level: u32) -> GpuResult<Vec<u8>> {
        let ctx = self.ctx.clone();
        let copy = passes::readback::ImageDownload::level(&ctx, image, level)?;
        let host = passes::readback::HostReadPass { buffers: vec![copy.buffer.clone()], tail: false };
        self.scheduler.begin(None)?;
        self.scheduler.record(&[&copy, &host])?;
        self.scheduler.end(true)?;
        Ok(copy.bytes().to_vec())
    }

    /// Read the work list of occupied voxels back (waits; after a frame, never inside one).
    pub fn voxel_list(&mut self) -> GpuResult<Option<voxel::ListSnapshot>> {
        let Some(v) = self.passes().voxels.as_ref().map(|v| v.volumes.clone()) else { return Ok(None) };
        let ctx = self.ctx.clone();
        let list = &v.list;
        let header = passes::voxel_list::BufferDownload::new(&ctx, &list.buffer, 0, voxel::work_list_header::SIZE)?;
        self.scheduler.begin(None)?;
        self.scheduler.record(&[
            &header,
            &passes::readback::HostReadPass { buffers: vec![header.buffer.clone()], tail: false },
        ])?;
        self.scheduler.end(true)?;
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(header.bytes());
        let count = u64::from(words[3]).min(list.capacity);
        let stale_count = u64::from(words[11]).min(list.capacity);
        // The entries in use (and the stale ones), then decode all together.
        let entries =
            passes::voxel_list::BufferDownload::new(&ctx, &list.buffer, 0, voxel::work_list_header::SIZE + count * 4)?;
        let mut downloads = vec![&entries];
        let stale = match &list.stale {
            Some(s) => Some(passes::voxel_list::BufferDownload::new(&ctx, s, 0, stale_count * 4)?),
            None => None,
        };
        downloads.extend(stale.as_ref());
        let host = passes::readback::HostReadPass {
            buffers: downloads.iter().map(|d| d.buffer.clone()).collect(),
            tail: false,
        };
        let mut passes: Vec<&dyn Pass> = downloads.iter().map(|d| *d as &dyn Pass).collect();
        passes.push(&host);
        self.scheduler.begin(None)?;
        self.scheduler.record(&passes)?;
        self.scheduler.end(true)?;
        let stale_bytes = stale.as_ref().map(|s| s.bytes().to_vec()).unwrap_or_default();
        Ok(Some(voxel::ListSnapshot::decode(v.grid.resolution, entries.bytes(), &stale_bytes)))
    }

    /// A full-resolution voxel volume as N^3 texels (x fastest), whatever its layout: a
    /// bricked volume is put together from its pool through the map, empty where no brick is
    /// resident (waits; for tests and debugging).
    pub fn download_voxels(&mut self, image: &Arc<Image>) -> GpuResult<Vec<u8>> {
        self.download_pooled(image, 0)
    }

    /// Level `level` of a directional volume (`face` 0..6: +x, -x, +y, -y, +z, -z) as texels,
    /// whatever its layout (waits; for tests and debugging).
    pub fn download_directional(&mut self, face: usize, level: u32) -> GpuResult<Vec<u8>> {
        let v = self.passes().voxels.as_ref().map(|v| v.volumes.clone()).expect("voxel volumes");
        let pooled = v.bricks.as_ref().map_or(0, |b| b.directional.len() as u32);
        if level < pooled {
            let image = v.bricks.as_ref().expect("bricks").directional[level as usize][face].clone();
            return self.download_pooled(&image, level as usize + 1);
        }
        self.download_level(&v.directional[face], level - pooled)
    }

    /// An image of pool `pool` as the dense texels of its level (an image of a dense volume
    /// as it is).
    fn download_pooled(&mut self, image: &Arc<Image>, pool: usize) -> GpuResult<Vec<u8>> {
        let v = self.passes().voxels.as_ref().map(|v| v.volumes.clone()).expect("voxel volumes");
        let Some(b) = &v.bricks else { return self.download(image) };
        let pooled = self.download(image)?;
        let map: Vec<u32> = bytemuck::pod_collect_to_vec(&self.download(&b.maps[pool])?);
        let texel = pooled.len() / image.desc.texel_count() as usize;
        // Pool 0's integer volumes store 8^3 texels per slot, its radiance volumes 9^3.
        let p = &b.layout.pools[pool];
        let stride = image.desc.extent.width / p.slots[0];
        Ok(bricks::unpool(p, stride, &pooled, &map, texel))
    }

    /// Read the resident bricks of every pool back (waits; after a frame, never inside one).
    /// None with dense volumes.
    pub fn resident_bricks(&mut self) -> GpuResult<Option<bricks::BrickSnapshot>> {
        let Some(v) = self.passes().voxels.as_ref().map(|v| v.volumes.clone()) else { return Ok(None) };
        let Some(b) = &v.bricks else { return Ok(None) };
        let ctx = self.ctx.clone();
        let all = passes::voxel_list::BufferDownload::new(&ctx, &b.lists, 0, b.lists.size)?;
        self.scheduler.begin(None)?;
        self.scheduler
            .record(&[&all, &passes::readback::HostReadPass { buffers: vec![all.buffer.clone()], tail: false }])?;
        self.scheduler.end(true)?;
        Ok(Some(bricks::BrickSnapshot::decode(&b.layout, all.bytes())))
    }

    /// What the voxel volumes take: the layout, the bytes allocated against the dense layout's
    /// estimate, and the resident bricks of every pool (reads the lists back: after a frame,
    /// never inside one). None without voxels.
    pub fn voxel_memory(&mut self) -> GpuResult<Option<bricks::VoxelMemory>> {
        let Some(v) = self.passes().voxels.as_ref().map(|v| v.volumes.clone()) else { return Ok(None) };
        let images: u64 = v.all().iter().map(|i| i.bytes).sum();
        let tail = v.bounce_tail.as_ref().map_or(0, |t| t.buffer.size);
        let lists = v.list.bytes() + v.bricks.as_ref().map_or(0, |b| b.lists.size) + tail;
        let dense_bytes = budget::Estimate::on_layout(&self.ctx, &self.scene, crate::scene::VoxelLayout::Dense).volumes;
        let full: u64 = v.full_resolution().iter().map(|i| i.bytes).sum();
        let pool_bytes: Vec<u64> = std::iter::once(full)
            .chain(v.bricks.iter().flat_map(|b| b.directional.iter().map(|l| l.iter().map(|i| i.bytes).sum())))
            .collect();
        let (layout, pools) = match self.resident_bricks()? {
            Some(snapshot) => ("bricks", snapshot.pool_memory(&pool_bytes)),
            None => ("dense", Vec::new()),
        };
        Ok(Some(bricks::VoxelMemory { layout: layout.to_string(), bytes: images + lists, dense_bytes, pools }))
    }
}
