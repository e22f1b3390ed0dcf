//! Showing images in a window (`host view`): a swapchain on the surface of the window the
//! [`Gpu`] was opened for ([`Gpu::with_display`]), each frame's 8-bit RGBA pixels copied from
//! a staging buffer into a swapchain image and presented. No graphics pipeline: a clear and a
//! buffer-to-image copy on the renderer's own queue.

use crate::device::DeviceOwner;
use crate::error::GpuError;
use crate::resources::Staging;
use crate::Gpu;
use ash::vk;
use std::sync::Arc;

/// What became of one frame given to [`Presenter::present`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shown {
    /// On screen.
    Presented,
    /// The window changed size (or is minimised): [`Presenter::resize`] to its new size, then
    /// present again.
    Stale,
}

/// The swapchain of one window and what a frame's copy needs.
pub struct Presenter {
    owner: Arc<DeviceOwner>,
    loader: ash::khr::swapchain::Device,
    swapchain: vk::SwapchainKHR,
    images: Vec<vk::Image>,
    extent: vk::Extent2D,
    /// Whether the swapchain's format stores blue first (B8G8R8A8): the RGBA bytes are swapped.
    bgra: bool,
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    /// Signalled when an acquired image may be written.
    acquired: vk::Semaphore,
    /// Per swapchain image: signalled when its copy is done, waited for by the presentation.
    copied: Vec<vk::Semaphore>,
    staging: Option<Staging>,
}

impl Gpu {
    /// Opens the preferred Vulkan device that can present to `display`'s window, as
    /// [`Gpu::new`] opens one for rendering only. The window must outlive the returned `Gpu`.
    pub fn with_display(display: &crate::Display) -> Result<Self, GpuError> {
        Self::from_owner(Arc::new(DeviceOwner::open(Some(display))?))
    }

    /// A swapchain of `width` x `height` pixels (the window's inner size; the surface's own
    /// extent where it fixes one) on the window this device was opened for.
    pub fn presenter(&self, width: u32, height: u32) -> Result<Presenter, GpuError> {
        let owner = self.owner.clone();
        if owner.surface.is_none() {
            return Err(GpuError::Internal(
                "a presenter needs a device opened with Gpu::with_display".into(),
            ));
        }
        let device = &owner.device;
        let (pool, cmd) = crate::resources::command_pool(&owner)?;
        // SAFETY: valid create infos; every object is destroyed in Drop (a failure here leaks
        // them until the device is destroyed, which frees them).
        let (fence, acquired) = unsafe {
            let fence = device
                .create_fence(&vk::FenceCreateInfo::default(), None)
                .map_err(|e| GpuError::Vulkan("vkCreateFence", e))?;
            let acquired = device
                .create_semaphore(&vk::SemaphoreCreateInfo::default(), None)
                .map_err(|e| GpuError::Vulkan("vkCreateSemaphore", e))?;
            (fence, acquired)
        };
        let mut p = Presenter {
            loader: ash::khr::swapchain::Device::new(&owner.instance, device),
            owner: owner.clone(),
            swapchain: vk::SwapchainKHR::null(),
            images: Vec::new(),
            extent: vk::Extent2D::default(),
            bgra: true,
            pool,
            cmd,
            fence,
            acquired,
            copied: Vec::new(),
            staging: None,
        };
        p.resize(width, height)?;
        Ok(p)
    }
}

impl Presenter {
    /// The swapchain's size in pixels ([0, 0] while the window is minimised).
    pub fn extent(&self) -> [u32; 2] {
        [self.extent.width, self.extent.height]
    }

    /// Makes the swapchain anew for a window of `width` x `height` pixels (after a resize, or
    /// when [`Presenter::present`] said [`Shown::Stale`]). A zero size (minimised) keeps no
    /// swapchain until the next resize.
    pub fn resize(&mut self, width: u32, height: u32) -> Result<(), GpuError> {
        let owner = self.owner.clone();
        let (surfaces, surface) = owner.surface.as_ref().expect("checked in Gpu::presenter");
        // SAFETY: queries on the live surface; the old swapchain is idle (every frame waits for
        // its fence) and retired by the new one, then destroyed.
        unsafe {
            let _ = owner.device.device_wait_idle();
            let caps = surfaces
                .get_physical_device_surface_capabilities(owner.physical, *surface)
                .map_err(|e| GpuError::Vulkan("vkGetPhysicalDeviceSurfaceCapabilitiesKHR", e))?;
            let extent = if caps.current_extent.width != u32::MAX {
                caps.current_extent
            } else {
                vk::Extent2D {
                    width: width.clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                    height: height
                        .clamp(caps.min_image_extent.height, caps.max_image_extent.height),
                }
            };
            let old = std::mem::replace(&mut self.swapchain, vk::SwapchainKHR::null());
            self.destroy_semaphores();
            self.images.clear();
            self.extent = vk::Extent2D::default();
            if extent.width == 0 || extent.height == 0 {
                if old != vk::SwapchainKHR::null() {
                    self.loader.destroy_swapchain(old, None);
                }
                return Ok(());
            }
            if !caps
                .supported_usage_flags
                .contains(vk::ImageUsageFlags::TRANSFER_DST)
            {
                return Err(GpuError::NoPresentation(
                    "the window's swapchain images cannot be copied to (no TRANSFER_DST usage)"
                        .into(),
                ));
            }
            let formats = surfaces
                .get_physical_device_surface_formats(owner.physical, *surface)
                .map_err(|e| GpuError::Vulkan("vkGetPhysicalDeviceSurfaceFormatsKHR", e))?;
            // 8-bit formats only: the frame's bytes are copied as they are (sRGB-encoded, as
            // a PNG holds them; a copy converts nothing, whether the format says UNORM or SRGB).
            let pick = [
                vk::Format::B8G8R8A8_UNORM,
                vk::Format::R8G8B8A8_UNORM,
                vk::Format::B8G8R8A8_SRGB,
                vk::Format::R8G8B8A8_SRGB,
            ]
            .into_iter()
            .find_map(|f| formats.iter().find(|s| s.format == f).copied())
            .ok_or_else(|| {
                GpuError::NoPresentation(format!(
                    "the window offers no 8-bit RGBA or BGRA swapchain format (only {:?})",
                    formats.iter().map(|f| f.format).collect::<Vec<_>>()
                ))
            })?;
            self.bgra = matches!(
                pick.format,
                vk::Format::B8G8R8A8_UNORM | vk::Format::B8G8R8A8_SRGB
            );
            let count = if caps.max_image_count == 0 {
                caps.min_image_count + 1
            } else {
                (caps.min_image_count + 1).min(caps.max_image_count)
            };
            let alpha = [
                vk::CompositeAlphaFlagsKHR::OPAQUE,
                vk::CompositeAlphaFlagsKHR::INHERIT,
                vk::CompositeAlphaFlagsKHR::PRE_MULTIPLIED,
                vk::CompositeAlphaFlagsKHR::POST_MULTIPLIED,
            ]
            .into_iter()
            .find(|a| caps.supported_composite_alpha.contains(*a))
            .unwrap_or(vk::CompositeAlphaFlagsKHR::OPAQUE);
            let info = vk::SwapchainCreateInfoKHR::default()
                .surface(*surface)
                .min_image_count(count)
                .image_format(pick.format)
                .image_color_space(pick.color_space)
                .image_extent(extent)
                .image_array_layers(1)
                .image_usage(vk::ImageUsageFlags::TRANSFER_DST)
                .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
                .pre_transform(caps.current_transform)
                .composite_alpha(alpha)
                .present_mode(vk::PresentModeKHR::FIFO)
                .clipped(true)
                .old_swapchain(old);
            let created = self.loader.create_swapchain(&info, None);
            if old != vk::SwapchainKHR::null() {
                self.loader.destroy_swapchain(old, None);
            }
            self.swapchain = created.map_err(|e| GpuError::Vulkan("vkCreateSwapchainKHR", e))?;
            self.images = self
                .loader
                .get_swapchain_images(self.swapchain)
                .map_err(|e| GpuError::Vulkan("vkGetSwapchainImagesKHR", e))?;
            for _ in &self.images {
                let s = owner
                    .device
                    .create_semaphore(&vk::SemaphoreCreateInfo::default(), None)
                    .map_err(|e| GpuError::Vulkan("vkCreateSemaphore", e))?;
                self.copied.push(s);
            }
            self.extent = extent;
        }
        Ok(())
    }

    /// Shows `rgba` (`width` x `height` pixels, 4 bytes each, rows top to bottom) in the
    /// window's top-left corner, the rest dark grey; waits until the copy is done. `gpu` is the
    /// device this presenter was made on (its queue is shared: the render's submissions and
    /// this one never overlap).
    pub fn present(
        &mut self,
        gpu: &Gpu,
        rgba: &[u8],
        width: u32,
        height: u32,
    ) -> Result<Shown, GpuError> {
        if self.swapchain == vk::SwapchainKHR::null() {
            return Ok(Shown::Stale);
        }
        let bytes = u64::from(width) * u64::from(height) * 4;
        if rgba.len() as u64 != bytes {
            return Err(GpuError::Internal(format!(
                "{} bytes for a {width}x{height} RGBA frame",
                rgba.len()
            )));
        }
        if self.staging.as_ref().is_none_or(|s| s.size() < bytes) {
            self.staging = Some(Staging::new(&self.owner, bytes)?);
        }
        let staging = self.staging.as_mut().expect("made above");
        if self.bgra {
            let swapped: Vec<u8> = rgba
                .as_chunks::<4>()
                .0
                .iter()
                .flat_map(|p| [p[2], p[1], p[0], p[3]])
                .collect();
            staging.write(0, &swapped);
        } else {
            staging.write(0, rgba);
        }
        let device = &self.owner.device;
        // The queue is the renderer's: hold its submitter while this frame uses it.
        let _queue = gpu
            .submitter
            .lock()
            .map_err(|_| GpuError::Internal("poisoned".into()))?;
        // SAFETY: the swapchain, its images and every object below are alive; the command
        // buffer is re-recorded only after the last frame's fence was waited for.
        unsafe {
            let (index, _) = match self.loader.acquire_next_image(
                self.swapchain,
                u64::MAX,
                self.acquired,
                vk::Fence::null(),
            ) {
                Ok(r) => r,
                Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => return Ok(Shown::Stale),
                Err(e) => return Err(GpuError::Vulkan("vkAcquireNextImageKHR", e)),
            };
            let image = self.images[index as usize];
            let cmd = self.cmd;
            device
                .reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty())
                .map_err(|e| GpuError::Vulkan("vkResetCommandBuffer", e))?;
            device
                .begin_command_buffer(
                    cmd,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .map_err(|e| GpuError::Vulkan("vkBeginCommandBuffer", e))?;
            let range = vk::ImageSubresourceRange::default()
                .aspect_mask(vk::ImageAspectFlags::COLOR)
                .level_count(1)
                .layer_count(1);
            let layout = |old, new, src, dst, stage| {
                let barrier = vk::ImageMemoryBarrier::default()
                    .src_access_mask(src)
                    .dst_access_mask(dst)
                    .old_layout(old)
                    .new_layout(new)
                    .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .image(image)
                    .subresource_range(range);
                device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    stage,
                    vk::DependencyFlags::empty(),
                    &[],
                    &[],
                    &[barrier],
                );
            };
            layout(
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                vk::AccessFlags::empty(),
                vk::AccessFlags::TRANSFER_WRITE,
                vk::PipelineStageFlags::TRANSFER,
            );
            let grey = vk::ClearColorValue {
                float32: [0.08, 0.08, 0.08, 1.0],
            };
            device.cmd_clear_color_image(
                cmd,
                image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &grey,
                &[range],
            );
            let w = width.min(self.extent.width);
            let h = height.min(self.extent.height);
            if w > 0 && h > 0 {
                let after_clear = vk::MemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                    .dst_access_mask(vk::AccessFlags::TRANSFER_WRITE);
                device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::DependencyFlags::empty(),
                    &[after_clear],
                    &[],
                    &[],
                );
                let region = vk::BufferImageCopy::default()
                    .buffer_row_length(width)
                    .buffer_image_height(height)
                    .image_subresource(
                        vk::ImageSubresourceLayers::default()
                            .aspect_mask(vk::ImageAspectFlags::COLOR)
                            .layer_count(1),
                    )
                    .image_extent(vk::Extent3D {
                        width: w,
                        height: h,
                        depth: 1,
                    });
                device.cmd_copy_buffer_to_image(
                    cmd,
                    staging.buffer(),
                    image,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &[region],
                );
            }
            layout(
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                vk::ImageLayout::PRESENT_SRC_KHR,
                vk::AccessFlags::TRANSFER_WRITE,
                vk::AccessFlags::empty(),
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
            );
            device
                .end_command_buffer(cmd)
                .map_err(|e| GpuError::Vulkan("vkEndCommandBuffer", e))?;
            let waits = [self.acquired];
            let stages = [vk::PipelineStageFlags::TRANSFER];
            let cmds = [cmd];
            let signals = [self.copied[index as usize]];
            let submit = vk::SubmitInfo::default()
                .wait_semaphores(&waits)
                .wait_dst_stage_mask(&stages)
                .command_buffers(&cmds)
                .signal_semaphores(&signals);
            device
                .queue_submit(self.owner.queue, &[submit], self.fence)
                .map_err(|e| match e {
                    vk::Result::ERROR_DEVICE_LOST => GpuError::DeviceLost("presenting".into()),
                    e => GpuError::Vulkan("vkQueueSubmit", e),
                })?;
            device
                .wait_for_fences(&[self.fence], true, u64::MAX)
                .map_err(|e| GpuError::Vulkan("vkWaitForFences", e))?;
            device
                .reset_fences(&[self.fence])
                .map_err(|e| GpuError::Vulkan("vkResetFences", e))?;
            let swapchains = [self.swapchain];
            let indices = [index];
            let info = vk::PresentInfoKHR::default()
                .wait_semaphores(&signals)
                .swapchains(&swapchains)
                .image_indices(&indices);
            match self.loader.queue_present(self.owner.queue, &info) {
                Ok(false) => Ok(Shown::Presented),
                Ok(true) | Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(Shown::Stale),
                Err(vk::Result::ERROR_DEVICE_LOST) => {
                    Err(GpuError::DeviceLost("presenting".into()))
                }
                Err(e) => Err(GpuError::Vulkan("vkQueuePresentKHR", e)),
            }
        }
    }

    fn destroy_semaphores(&mut self) {
        for s in self.copied.drain(..) {
            // SAFETY: the device is idle (callers wait first).
            unsafe { self.owner.device.destroy_semaphore(s, None) };
        }
    }
}

impl Drop for Presenter {
    fn drop(&mut self) {
        // SAFETY: waits for the device, then destroys what this presenter made.
        unsafe {
            let _ = self.owner.device.device_wait_idle();
            self.destroy_semaphores();
            if self.swapchain != vk::SwapchainKHR::null() {
                self.loader.destroy_swapchain(self.swapchain, None);
            }
            let d = &self.owner.device;
            d.destroy_semaphore(self.acquired, None);
            d.destroy_fence(self.fence, None);
            d.destroy_command_pool(self.pool, None);
        }
    }
}
