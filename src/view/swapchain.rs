//! The window's surface and swapchain: made for the window's size, remade when the window
//! resizes or the swapchain goes out of date, and never made while the window is minimised.

use super::ViewError;
use crate::gpu::{Context, GpuError, GpuResult, Image, ImageDesc, VkContext};
use ash::vk;
use raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use std::sync::Arc;

/// A Vulkan surface of a window.
pub struct Surface {
    ctx: Arc<Context>,
    pub loader: ash::khr::surface::Instance,
    pub raw: vk::SurfaceKHR,
}

impl Surface {
    /// The surface of `window`; an error unless the graphics queue can present to it.
    pub fn new(ctx: &Arc<Context>, window: &winit::window::Window) -> Result<Surface, ViewError> {
        let display = window.display_handle().map_err(|e| ViewError::Window(e.to_string()))?;
        let handle = window.window_handle().map_err(|e| ViewError::Window(e.to_string()))?;
        let raw =
            unsafe { ash_window::create_surface(&ctx.entry, &ctx.instance, display.as_raw(), handle.as_raw(), None) }
                .vk("vkCreateSurfaceKHR")?;
        let surface =
            Surface { ctx: ctx.clone(), loader: ash::khr::surface::Instance::new(&ctx.entry, &ctx.instance), raw };
        let family = ctx.graphics_queue.family;
        let ok = unsafe { surface.loader.get_physical_device_surface_support(ctx.physical_device, family, raw) }
            .vk("vkGetPhysicalDeviceSurfaceSupportKHR")?;
        if !ok {
            return Err(ViewError::Window(format!(
                "{}'s graphics queue (family {family}) cannot present to this window; choose another device \
                 with --device",
                ctx.info.name
            )));
        }
        Ok(surface)
    }
}

impl Drop for Surface {
    fn drop(&mut self) {
        if !self.ctx.has_failed() {
            unsafe { self.loader.destroy_surface(self.raw, None) };
        }
    }
}

/// How the swapchain presents: as fast as frames come (`mailbox` or `immediate`, so the
/// viewer's frame time is the renderer's) unless `vsync` asks for `fifo`.
fn present_mode(available: &[vk::PresentModeKHR], vsync: bool) -> vk::PresentModeKHR {
    let order: &[vk::PresentModeKHR] =
        if vsync { &[] } else { &[vk::PresentModeKHR::MAILBOX, vk::PresentModeKHR::IMMEDIATE] };
    order.iter().copied().find(|m| available.contains(m)).unwrap_or(vk::PresentModeKHR::FIFO)
}

/// An sRGB format (the UI's blending and the frame's decoding are then exact), else the first.
fn surface_format(available: &[vk::SurfaceFormatKHR]) -> vk::SurfaceFormatKHR {
    let srgb = [vk::Format::B8G8R8A8_SRGB, vk::Format::R8G8B8A8_SRGB];
    available
        .iter()
        .copied()
        .find(|f| srgb.contains(&f.format) && f.color_space == vk::ColorSpaceKHR::SRGB_NONLINEAR)
        .or(available.first().copied())
        .unwrap_or(vk::SurfaceFormatKHR {
            format: vk::Format::B8G8R8A8_SRGB,
            color_space: vk::ColorSpaceKHR::SRGB_NONLINEAR,
        })
}

/// A swapchain and the semaphores of its presentations.
pub struct Swapchain {
    ctx: Arc<Context>,
    loader: ash::khr::swapchain::Device,
    pub raw: vk::SwapchainKHR,
    pub format: vk::Format,
    pub extent: vk::Extent2D,
    pub present_mode: vk::PresentModeKHR,
    /// Whether its images can be copied from (window captures; most surfaces allow it).
    pub readable: bool,
    /// The images, tracked by the frame's barriers like any other.
    pub images: Vec<Arc<Image>>,
    /// Per image: signalled when its frame is drawn, waited for by its presentation.
    rendered: Vec<vk::Semaphore>,
    /// Signalled by acquisitions, used in turn. One more than the images: a semaphore comes
    /// round again only after the renderer has waited for the frame that waited on it (the
    /// renderer's frame slots keep at most two frames in flight).
    acquired: Vec<vk::Semaphore>,
    next_acquired: usize,
    /// The surface was lost (VK_ERROR_SURFACE_LOST_KHR): make a new one with the next swapchain.
    pub surface_lost: std::cell::Cell<bool>,
}

/// An acquired swapchain image.
pub struct Acquired {
    pub index: u32,
    pub acquired: vk::Semaphore,
    pub rendered: vk::Semaphore,
}

impl Swapchain {
    /// A swapchain of `size` (the window's inner size) on `surface`, replacing `old` if given.
    /// `None` when the surface has no area (a minimised window).
    pub fn new(
        ctx: &Arc<Context>,
        surface: &Surface,
        size: (u32, u32),
        vsync: bool,
        old: Option<&Swapchain>,
    ) -> GpuResult<Option<Swapchain>> {
        let (pd, s) = (ctx.physical_device, surface.raw);
        let caps = unsafe { surface.loader.get_physical_device_surface_capabilities(pd, s) }
            .vk("vkGetPhysicalDeviceSurfaceCapabilitiesKHR")?;
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: size.0.clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: size.1.clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        if extent.width == 0 || extent.height == 0 {
            return Ok(None);
        }
        let formats = unsafe { surface.loader.get_physical_device_surface_formats(pd, s) }
            .vk("vkGetPhysicalDeviceSurfaceFormatsKHR")?;
        let modes = unsafe { surface.loader.get_physical_device_surface_present_modes(pd, s) }
            .vk("vkGetPhysicalDeviceSurfacePresentModesKHR")?;
        let format = surface_format(&formats);
        let mode = present_mode(&modes, vsync);
        let count = if caps.max_image_count == 0 {
            caps.min_image_count + 1
        } else {
            (caps.min_image_count + 1).min(caps.max_image_count)
        };
        let mut usage = vk::ImageUsageFlags::COLOR_ATTACHMENT;
        if caps.supported_usage_flags.contains(vk::ImageUsageFlags::TRANSFER_SRC) {
            usage |= vk::ImageUsageFlags::TRANSFER_SRC; // window captures
        }
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(s)
            .min_image_count(count)
            .image_format(format.format)
            .image_color_space(format.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(usage)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(composite_alpha(caps.supported_composite_alpha))
            .present_mode(mode)
            .clipped(true)
            .old_swapchain(old.map(|o| o.raw).unwrap_or_default());
        let loader = ash::khr::swapchain::Device::new(&ctx.instance, &ctx.device);
        let raw = unsafe { loader.create_swapchain(&info, None) }.vk("vkCreateSwapchainKHR")?;
        let mut me = Swapchain {
            ctx: ctx.clone(),
            loader,
            raw,
            format: format.format,
            extent,
            present_mode: mode,
            readable: usage.contains(vk::ImageUsageFlags::TRANSFER_SRC),
            images: Vec::new(),
            rendered: Vec::new(),
            acquired: Vec::new(),
            next_acquired: 0,
            surface_lost: std::cell::Cell::new(false),
        };
        me.wrap_images(usage)?;
        Ok(Some(me))
    }

    /// The swapchain's images as tracked [`Image`]s, and a semaphore pair per image.
    fn wrap_images(&mut self, usage: vk::ImageUsageFlags) -> GpuResult<()> {
        let raws = unsafe { self.loader.get_swapchain_images(self.raw) }.vk("vkGetSwapchainImagesKHR")?;
        let desc = ImageDesc::d2(self.format, self.extent.width, self.extent.height, usage);
        for (i, raw) in raws.iter().enumerate() {
            self.images.push(Arc::new(Image::external(&self.ctx, &format!("swapchain image {i}"), *raw, desc)?));
        }
        for _ in 0..raws.len() {
            self.rendered.push(self.semaphore("rendered")?);
        }
        for _ in 0..=raws.len() {
            self.acquired.push(self.semaphore("acquired")?);
        }
        Ok(())
    }

    fn semaphore(&self, name: &str) -> GpuResult<vk::Semaphore> {
        let s = unsafe { self.ctx.device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
            .vk("vkCreateSemaphore")?;
        self.ctx.name_object(s, &format!("swapchain {name}"));
        Ok(s)
    }

    /// The next image; `None` when the swapchain is out of date or its surface lost (remake
    /// them and try again).
    pub fn acquire(&mut self) -> GpuResult<Option<Acquired>> {
        let acquired = self.acquired[self.next_acquired];
        let timeout = self.ctx.gpu_timeout().as_nanos() as u64;
        let r = unsafe { self.loader.acquire_next_image(self.raw, timeout, acquired, vk::Fence::null()) };
        match r {
            Ok((index, _suboptimal)) => {
                self.next_acquired = (self.next_acquired + 1) % self.acquired.len();
                Ok(Some(Acquired { index, acquired, rendered: self.rendered[index as usize] }))
            }
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(None),
            Err(vk::Result::ERROR_SURFACE_LOST_KHR) => {
                self.surface_lost.set(true);
                Ok(None)
            }
            Err(vk::Result::TIMEOUT | vk::Result::NOT_READY) => Err(GpuError::Timeout {
                what: "a swapchain image".into(),
                seconds: self.ctx.gpu_timeout().as_secs_f64(),
            }),
            Err(result) => Err(GpuError::Vk { call: "vkAcquireNextImageKHR", result }),
        }
    }

    /// Present image `a` once its frame is drawn. `Ok(false)`: out of date, suboptimal or its
    /// surface lost (remake).
    pub fn present(&self, a: &Acquired) -> GpuResult<bool> {
        let (waits, chains, indices) = ([a.rendered], [self.raw], [a.index]);
        let info = vk::PresentInfoKHR::default().wait_semaphores(&waits).swapchains(&chains).image_indices(&indices);
        let r = {
            let _g = self.ctx.submit_lock.lock().unwrap_or_else(|p| p.into_inner());
            unsafe { self.loader.queue_present(self.ctx.graphics_queue.raw, &info) }
        };
        match r {
            Ok(suboptimal) => Ok(!suboptimal),
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(false),
            Err(vk::Result::ERROR_SURFACE_LOST_KHR) => {
                self.surface_lost.set(true);
                Ok(false)
            }
            Err(result) => Err(GpuError::Vk { call: "vkQueuePresentKHR", result }),
        }
    }
}

/// Opaque where the surface allows it (the window shows the frame, not what is behind it).
fn composite_alpha(supported: vk::CompositeAlphaFlagsKHR) -> vk::CompositeAlphaFlagsKHR {
    [
        vk::CompositeAlphaFlagsKHR::OPAQUE,
        vk::CompositeAlphaFlagsKHR::INHERIT,
        vk::CompositeAlphaFlagsKHR::PRE_MULTIPLIED,
    ]
    .into_iter()
    .find(|f| supported.contains(*f))
    .unwrap_or(vk::CompositeAlphaFlagsKHR::POST_MULTIPLIED)
}

impl Drop for Swapchain {
    fn drop(&mut self) {
        if self.ctx.has_failed() {
            return;
        }
        // The owner waits for the device to be idle before dropping a swapchain.
        self.images.clear();
        unsafe {
            for s in self.rendered.drain(..).chain(self.acquired.drain(..)) {
                self.ctx.device.destroy_semaphore(s, None);
            }
            self.loader.destroy_swapchain(self.raw, None);
        }
    }
}
