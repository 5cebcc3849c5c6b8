//! Buffers and images, all memory through gpu-allocator, every object named.

use super::context::Context;
use super::error::{GpuError, GpuResult, VkContext};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

pub struct Buffer {
    ctx: Arc<Context>,
    pub raw: vk::Buffer,
    allocation: Option<Allocation>,
    pub size: u64,
    pub name: String,
}

impl Buffer {
    pub fn new(
        ctx: &Arc<Context>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> GpuResult<Buffer> {
        let size = size.max(4);
        let d = &ctx.device;
        // Buffers are CONCURRENT between distinct graphics and compute families: they are small
        // (uniforms, lights, geometry) and CONCURRENT costs nothing for them; images stay
        // EXCLUSIVE and move between families by ownership transfers (render::graph).
        let families = ctx.distinct_families();
        let mut info = vk::BufferCreateInfo::default().size(size).usage(usage);
        info = match &families {
            Some(f) => info.sharing_mode(vk::SharingMode::CONCURRENT).queue_family_indices(f),
            None => info.sharing_mode(vk::SharingMode::EXCLUSIVE),
        };
        check_allocation(ctx, name, size)?;
        let raw = unsafe { d.create_buffer(&info, None) }.vk("vkCreateBuffer")?;
        let req = unsafe { d.get_buffer_memory_requirements(raw) };
        let allocation =
            allocate(ctx, name, req, location, true).inspect_err(|_| unsafe { d.destroy_buffer(raw, None) })?;
        if let Err(e) = unsafe { d.bind_buffer_memory(raw, allocation.memory(), allocation.offset()) } {
            unsafe { d.destroy_buffer(raw, None) };
            let _ = ctx.allocator().free(allocation);
            return Err(GpuError::Vk { call: "vkBindBufferMemory", result: e });
        }
        ctx.name_object(raw, name);
        Ok(Buffer { ctx: ctx.clone(), raw, allocation: Some(allocation), size, name: name.to_string() })
    }

    /// A host-visible uniform buffer holding `value`.
    pub fn uniform<T: bytemuck::Pod>(ctx: &Arc<Context>, name: &str, value: &T) -> GpuResult<Buffer> {
        let b = Buffer::new(
            ctx,
            name,
            std::mem::size_of::<T>() as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            MemoryLocation::CpuToGpu,
        )?;
        b.write_pod(std::slice::from_ref(value));
        Ok(b)
    }

    /// Host-visible bytes (CpuToGpu / GpuToCpu buffers only).
    pub fn mapped(&self) -> Option<&[u8]> {
        self.allocation.as_ref()?.mapped_slice()
    }

    /// Copy `data` into a host-visible buffer at `offset`. The caller guarantees the GPU is
    /// not reading the written range (the frame that used it has completed).
    pub fn write(&self, offset: usize, data: &[u8]) {
        let alloc = self.allocation.as_ref().expect("live buffer");
        let ptr = alloc.mapped_ptr().expect("Buffer::write on a buffer that is not host-visible");
        assert!(offset + data.len() <= alloc.size() as usize, "write past the end of {}", self.name);
        // SAFETY: in bounds (checked above), host-visible persistently mapped memory, and no
        // GPU access to the range is in flight (caller's contract).
        unsafe {
            std::ptr::copy_nonoverlapping(data.as_ptr(), (ptr.as_ptr() as *mut u8).add(offset), data.len());
        }
    }

    pub fn write_pod<T: bytemuck::Pod>(&self, data: &[T]) {
        self.write(0, bytemuck::cast_slice(data));
    }
}

/// Refuse, naming the limit, an allocation larger than the device's largest allocation or heap
/// (the driver would fail it with a bare out-of-memory, or the validation layer flag it).
fn check_allocation(ctx: &Context, name: &str, bytes: u64) -> GpuResult<()> {
    let i = &ctx.info;
    let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
    for (limit, what) in [(i.max_allocation, "maxMemoryAllocationSize"), (i.device_local_heap, "largest memory heap")] {
        if limit > 0 && bytes > limit {
            return Err(GpuError::Limit(format!(
                "{name:?} needs {:.1} MiB, more than {}'s {what} ({:.1} MiB)",
                mib(bytes),
                i.name,
                mib(limit)
            )));
        }
    }
    Ok(())
}

impl Drop for Buffer {
    fn drop(&mut self) {
        if self.ctx.has_failed() {
            return; // the GPU may still use it (Context::has_failed)
        }
        unsafe { self.ctx.device.destroy_buffer(self.raw, None) };
        if let Some(a) = self.allocation.take() {
            let _ = self.ctx.allocator().free(a);
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageKind {
    D2,
    D2Array,
    D3,
}

#[derive(Debug, Clone, Copy)]
pub struct ImageDesc {
    pub kind: ImageKind,
    pub format: vk::Format,
    pub extent: vk::Extent3D,
    pub mip_levels: u32,
    /// Array layers (D2Array).
    pub layers: u32,
    pub usage: vk::ImageUsageFlags,
    /// Shared by the graphics and compute families at once (CONCURRENT) where they differ,
    /// instead of moving between them by ownership transfers: for images both queues use in
    /// every frame whose contents carry from frame to frame (the voxel volumes), so that a
    /// queue's next use waits only for the other queue's last use, not for a release recorded
    /// after all of its later work (`render::graph`).
    pub concurrent: bool,
}

impl ImageDesc {
    pub fn d2(format: vk::Format, width: u32, height: u32, usage: vk::ImageUsageFlags) -> Self {
        ImageDesc {
            kind: ImageKind::D2,
            format,
            extent: vk::Extent3D { width, height, depth: 1 },
            mip_levels: 1,
            layers: 1,
            usage,
            concurrent: false,
        }
    }
    pub fn d2_array(format: vk::Format, width: u32, height: u32, layers: u32, usage: vk::ImageUsageFlags) -> Self {
        ImageDesc { kind: ImageKind::D2Array, layers, ..Self::d2(format, width, height, usage) }
    }
    pub fn d3(format: vk::Format, size: u32, mip_levels: u32, usage: vk::ImageUsageFlags) -> Self {
        ImageDesc {
            kind: ImageKind::D3,
            format,
            extent: vk::Extent3D { width: size, height: size, depth: size },
            mip_levels,
            layers: 1,
            usage,
            concurrent: false,
        }
    }
    /// Texels of level 0.
    pub fn texel_count(&self) -> u64 {
        u64::from(self.extent.width)
            * u64::from(self.extent.height)
            * u64::from(self.extent.depth)
            * u64::from(self.layers)
    }

    /// A 3D image of `extent` texels (a brick pool), one mip level.
    pub fn d3_extent(format: vk::Format, extent: [u32; 3], usage: vk::ImageUsageFlags) -> Self {
        let [width, height, depth] = extent;
        ImageDesc { extent: vk::Extent3D { width, height, depth }, ..Self::d3(format, 1, 1, usage) }
    }
    pub fn aspect(&self) -> vk::ImageAspectFlags {
        match self.format {
            vk::Format::D32_SFLOAT | vk::Format::D16_UNORM | vk::Format::X8_D24_UNORM_PACK32 => {
                vk::ImageAspectFlags::DEPTH
            }
            vk::Format::D24_UNORM_S8_UINT | vk::Format::D32_SFLOAT_S8_UINT => {
                vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL
            }
            _ => vk::ImageAspectFlags::COLOR,
        }
    }
    pub fn full_range(&self) -> vk::ImageSubresourceRange {
        vk::ImageSubresourceRange {
            aspect_mask: self.aspect(),
            base_mip_level: 0,
            level_count: self.mip_levels,
            base_array_layer: 0,
            layer_count: self.layers,
        }
    }
}

pub struct Image {
    ctx: Arc<Context>,
    pub raw: vk::Image,
    /// View of the whole image (all mips, all layers).
    pub view: vk::ImageView,
    /// One 2D view per array layer (D2Array only), for rendering into a layer.
    pub layer_views: Vec<vk::ImageView>,
    /// One view per mip level (D3 with more than one level), for storage writes to a level.
    pub level_views: Vec<vk::ImageView>,
    allocation: Option<Allocation>,
    pub desc: ImageDesc,
    pub name: String,
    pub bytes: u64,
    /// Created CONCURRENT by both families (`ImageDesc::concurrent` on a device whose families
    /// differ): the tracker plans no ownership transfers for it.
    pub concurrent: bool,
    /// Whether dropping it destroys the `VkImage` (not a swapchain's image, see [`Image::external`]).
    owned: bool,
}

/// Refuse, naming the limit, an image larger than the device's maxImageDimension2D/3D or with
/// more layers than maxImageArrayLayers.
fn check_image_limits(ctx: &Context, name: &str, desc: &ImageDesc) -> GpuResult<()> {
    let lim = &ctx.info.limits;
    let (max, what) = match desc.kind {
        ImageKind::D3 => (lim.max_image_dimension3_d, "maxImageDimension3D"),
        _ => (lim.max_image_dimension2_d, "maxImageDimension2D"),
    };
    if desc.extent.width.max(desc.extent.height).max(desc.extent.depth) > max {
        return Err(GpuError::Limit(format!(
            "image {name:?} is {}x{}x{}, beyond this device's {what} = {max}",
            desc.extent.width, desc.extent.height, desc.extent.depth
        )));
    }
    if desc.kind == ImageKind::D2Array && desc.layers > lim.max_image_array_layers {
        return Err(GpuError::Limit(format!(
            "image {name:?} needs {} layers, beyond this device's maxImageArrayLayers = {}",
            desc.layers, lim.max_image_array_layers
        )));
    }
    Ok(())
}

/// The image object of `desc` (optimal tiling, one sample, exclusive, UNDEFINED), no memory yet.
fn create_image(ctx: &Context, desc: &ImageDesc) -> GpuResult<vk::Image> {
    let families = concurrent_families(ctx, desc);
    let info = shared_by(image_info(desc), &families);
    unsafe { ctx.device.create_image(&info, None) }.vk("vkCreateImage")
}

/// The families that share an image of `desc` at once: both, where it asks for CONCURRENT
/// sharing and the device's graphics and compute families differ; else none (EXCLUSIVE).
fn concurrent_families(ctx: &Context, desc: &ImageDesc) -> Vec<u32> {
    ctx.distinct_families().filter(|_| desc.concurrent).map(Vec::from).unwrap_or_default()
}

/// `info` shared CONCURRENT by `families` (when there are any).
fn shared_by<'a>(info: vk::ImageCreateInfo<'a>, families: &'a [u32]) -> vk::ImageCreateInfo<'a> {
    match families {
        [] => info,
        f => info.sharing_mode(vk::SharingMode::CONCURRENT).queue_family_indices(f),
    }
}

/// The bytes `ctx`'s device asks for an image of `desc`, its padding and alignment included
/// (vkGetDeviceImageMemoryRequirements, maintenance4: no image is created).
pub fn device_image_bytes(ctx: &Context, desc: &ImageDesc) -> u64 {
    let families = concurrent_families(ctx, desc);
    let info = shared_by(image_info(desc), &families);
    let query = vk::DeviceImageMemoryRequirements::default().create_info(&info);
    let mut req = vk::MemoryRequirements2::default();
    unsafe { ctx.device.get_device_image_memory_requirements(&query, &mut req) };
    req.memory_requirements.size
}

fn image_info(desc: &ImageDesc) -> vk::ImageCreateInfo<'static> {
    let image_type = match desc.kind {
        ImageKind::D3 => vk::ImageType::TYPE_3D,
        _ => vk::ImageType::TYPE_2D,
    };
    vk::ImageCreateInfo::default()
        .image_type(image_type)
        .format(desc.format)
        .extent(desc.extent)
        .mip_levels(desc.mip_levels)
        .array_layers(desc.layers)
        .samples(vk::SampleCountFlags::TYPE_1)
        .tiling(vk::ImageTiling::OPTIMAL)
        .usage(desc.usage)
        .sharing_mode(vk::SharingMode::EXCLUSIVE)
        .initial_layout(vk::ImageLayout::UNDEFINED)
}

/// Device-local memory for image `raw` (checked against the device's limits first); on failure
/// the image is destroyed.
fn allocate_image_memory(
    ctx: &Context,
    name: &str,
    raw: vk::Image,
    req: vk::MemoryRequirements,
) -> GpuResult<Allocation> {
    check_allocation(ctx, name, req.size)
        .and_then(|()| allocate(ctx, name, req, MemoryLocation::GpuOnly, false))
        .inspect_err(|_| unsafe { ctx.device.destroy_image(raw, None) })
}

/// Memory from gpu-allocator for an object with requirements `req` (`linear`: a buffer or
/// linearly tiled image); the error names the object and the bytes asked for.
fn allocate(
    ctx: &Context,
    name: &str,
    req: vk::MemoryRequirements,
    location: MemoryLocation,
    linear: bool,
) -> GpuResult<Allocation> {
    ctx.allocator()
        .allocate(&AllocationCreateDesc {
            name,
            requirements: req,
            location,
            linear,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        })
        .map_err(|source| GpuError::Alloc { name: name.to_string(), bytes: req.size, source })
}

impl Image {
    pub fn new(ctx: &Arc<Context>, name: &str, desc: ImageDesc) -> GpuResult<Image> {
        let d = &ctx.device;
        check_image_limits(ctx, name, &desc)?;
        let raw = create_image(ctx, &desc)?;
        let req = unsafe { d.get_image_memory_requirements(raw) };
        let allocation = allocate_image_memory(ctx, name, raw, req)?;
        let mut img = Image::without_views(ctx, name, raw, desc, (req.size, true));
        unsafe { d.bind_image_memory(raw, allocation.memory(), allocation.offset()) }.vk("vkBindImageMemory")?;
        img.allocation = Some(allocation);
        ctx.name_object(raw, name);
        img.create_whole_view()?;
        img.create_layer_views()?;
        img.create_level_views()?;
        Ok(img)
    }

    /// `raw` as an image with no views or memory yet; `(bytes, owned)`: its memory's size and
    /// whether dropping it destroys `raw`.
    fn without_views(
        ctx: &Arc<Context>,
        name: &str,
        raw: vk::Image,
        desc: ImageDesc,
        (bytes, owned): (u64, bool),
    ) -> Image {
        Image {
            ctx: ctx.clone(),
            raw,
            view: vk::ImageView::null(),
            layer_views: Vec::new(),
            level_views: Vec::new(),
            allocation: None,
            desc,
            name: name.to_string(),
            bytes,
            owned,
            concurrent: desc.concurrent && ctx.distinct_families().is_some(),
        }
    }

    /// An image someone else owns (a swapchain's), with a view of its own: tracked by the
    /// frame's barriers like any other; dropping it destroys only the view.
    pub fn external(ctx: &Arc<Context>, name: &str, raw: vk::Image, desc: ImageDesc) -> GpuResult<Image> {
        let mut img = Image::without_views(ctx, name, raw, desc, (0, false));
        ctx.name_object(raw, name);
        img.create_whole_view()?;
        Ok(img)
    }

    /// The view of the whole image (all mips, all layers), named "`name` view".
    fn create_whole_view(&mut self) -> GpuResult<()> {
        let view_type = match self.desc.kind {
            ImageKind::D2 => vk::ImageViewType::TYPE_2D,
            ImageKind::D2Array => vk::ImageViewType::TYPE_2D_ARRAY,
            ImageKind::D3 => vk::ImageViewType::TYPE_3D,
        };
        self.view = self.create_view(view_type, self.desc.full_range())?;
        self.ctx.name_object(self.view, &format!("{} view", self.name));
        Ok(())
    }

    /// One 2D view per array layer of a D2Array image (none for the other kinds).
    fn create_layer_views(&mut self) -> GpuResult<()> {
        if self.desc.kind != ImageKind::D2Array {
            return Ok(());
        }
        for layer in 0..self.desc.layers {
            let range = vk::ImageSubresourceRange {
                base_array_layer: layer,
                layer_count: 1,
                level_count: 1,
                ..self.desc.full_range()
            };
            let v = self.create_view(vk::ImageViewType::TYPE_2D, range)?;
            self.ctx.name_object(v, &format!("{} layer {layer}", self.name));
            self.layer_views.push(v);
        }
        Ok(())
    }

    /// One 3D view per mip level of a D3 image with more than one level (none otherwise).
    fn create_level_views(&mut self) -> GpuResult<()> {
        if self.desc.kind != ImageKind::D3 || self.desc.mip_levels <= 1 {
            return Ok(());
        }
        for level in 0..self.desc.mip_levels {
            let range = vk::ImageSubresourceRange { base_mip_level: level, level_count: 1, ..self.desc.full_range() };
            let v = self.create_view(vk::ImageViewType::TYPE_3D, range)?;
            self.ctx.name_object(v, &format!("{} level {level}", self.name));
            self.level_views.push(v);
        }
        Ok(())
    }

    /// Edge length of mip `level` (3D images).
    pub fn level_size(&self, level: u32) -> u32 {
        (self.desc.extent.width >> level).max(1)
    }

    fn create_view(&self, ty: vk::ImageViewType, range: vk::ImageSubresourceRange) -> GpuResult<vk::ImageView> {
        unsafe {
            self.ctx.device.create_image_view(
                &vk::ImageViewCreateInfo::default()
                    .image(self.raw)
                    .view_type(ty)
                    .format(self.desc.format)
                    .subresource_range(range),
                None,
            )
        }
        .vk("vkCreateImageView")
    }

    /// Buffer copy region covering mip 0, layer 0 (all depth slices), tightly packed.
    pub fn copy_region(&self) -> vk::BufferImageCopy {
        vk::BufferImageCopy {
            buffer_offset: 0,
            buffer_row_length: 0,
            buffer_image_height: 0,
            image_subresource: vk::ImageSubresourceLayers {
                aspect_mask: self.desc.aspect(),
                mip_level: 0,
                base_array_layer: 0,
                layer_count: 1,
            },
            image_offset: vk::Offset3D::default(),
            image_extent: self.desc.extent,
        }
    }

    pub fn extent2d(&self) -> vk::Extent2D {
        vk::Extent2D { width: self.desc.extent.width, height: self.desc.extent.height }
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        if self.ctx.has_failed() {
            return; // the GPU may still use it (Context::has_failed)
        }
        unsafe {
            for v in self.layer_views.drain(..).chain(self.level_views.drain(..)) {
                self.ctx.device.destroy_image_view(v, None);
            }
            if self.view != vk::ImageView::null() {
                self.ctx.device.destroy_image_view(self.view, None);
            }
            if self.owned {
                self.ctx.device.destroy_image(self.raw, None);
            }
        }
        if let Some(a) = self.allocation.take() {
            let _ = self.ctx.allocator().free(a);
        }
    }
}

/// A sampler with RAII.
pub struct Sampler {
    ctx: Arc<Context>,
    pub raw: vk::Sampler,
}

impl Sampler {
    pub fn new(ctx: &Arc<Context>, name: &str, info: &vk::SamplerCreateInfo) -> GpuResult<Sampler> {
        let raw = unsafe { ctx.device.create_sampler(info, None) }.vk("vkCreateSampler")?;
        ctx.name_object(raw, name);
        Ok(Sampler { ctx: ctx.clone(), raw })
    }
}

impl Drop for Sampler {
    fn drop(&mut self) {
        if self.ctx.has_failed() {
            return; // the GPU may still use it (Context::has_failed)
        }
        unsafe { self.ctx.device.destroy_sampler(self.raw, None) };
    }
}
