//! Copies from the GPU back to the CPU: rendered images, per-pixel visit counts, buffers.

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

use super::{GpuContext, RenderError, RenderTarget};

/// Where a buffer read back without waiting stands (the frame's requests, a probe, a frame's
/// report, upload timestamps), kept in an `AtomicU8` that the map callback sets.
pub(crate) mod map_state {
    /// Free: nothing recorded into it.
    pub const IDLE: u8 = 0;
    /// A copy into it is recorded; mapping starts once the encoder is submitted.
    pub const RECORDED: u8 = 1;
    pub const MAPPING: u8 = 2;
    /// Mapped: its bytes can be read, then it is unmapped and idle again.
    pub const MAPPED: u8 = 3;
    pub const FAILED: u8 = 4;
}

/// Starts mapping `buffer` for reading without waiting: `state` is [`map_state::MAPPING`]
/// until the device is polled past the copy, then [`map_state::MAPPED`] or
/// [`map_state::FAILED`].
pub(crate) fn start_map_read(buffer: &wgpu::Buffer, state: &Arc<AtomicU8>) {
    state.store(map_state::MAPPING, Ordering::Release);
    let state = Arc::clone(state);
    buffer
        .slice(..)
        .map_async(wgpu::MapMode::Read, move |result| {
            let next = if result.is_ok() {
                map_state::MAPPED
            } else {
                map_state::FAILED
            };
            state.store(next, Ordering::Release);
        });
}

/// `read` of the bytes of `buffer`, which [`start_map_read`] mapped (`state` is
/// [`map_state::MAPPED`]); then the buffer is unmapped and idle again. Where its range cannot be
/// had, `None`, and the buffer is left as it is: unmapping a buffer that is not mapped is a
/// validation error (which panics), and one left mapped must not be copied into again.
pub(crate) fn read_mapped<T>(
    buffer: &wgpu::Buffer,
    state: &AtomicU8,
    read: impl FnOnce(&[u8]) -> T,
) -> Option<T> {
    let result = {
        let bytes = buffer.slice(..).get_mapped_range().ok()?;
        read(&bytes)
    };
    buffer.unmap();
    state.store(map_state::IDLE, Ordering::Release);
    Some(result)
}

/// Waits for `buffer` (MAP_READ) to map and returns its bytes.
fn map_and_read(context: &GpuContext, buffer: &wgpu::Buffer) -> Result<Vec<u8>, RenderError> {
    let slice = buffer.slice(..);
    let (sender, receiver) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |result| {
        let _ = sender.send(result);
    });
    context.wait_idle()?;
    receiver
        .recv()
        .map_err(|_| RenderError::DeviceLost("GPU readback was dropped".into()))?
        .map_err(|e| RenderError::DeviceLost(format!("GPU readback failed: {e}")))?;
    let bytes = slice
        .get_mapped_range()
        .map_err(|e| RenderError::DeviceLost(format!("GPU readback failed: {e}")))?
        .to_vec();
    buffer.unmap();
    Ok(bytes)
}

/// Copies `size` bytes of `source` (COPY_SRC) to the CPU.
pub fn read_buffer(
    context: &GpuContext,
    source: &wgpu::Buffer,
    size: u64,
) -> Result<Vec<u8>, RenderError> {
    let staging = context.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("voxscope::readback_staging"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = context
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("voxscope::readback_buffer"),
        });
    encoder.copy_buffer_to_buffer(source, 0, &staging, 0, size);
    context.queue.submit([encoder.finish()]);
    map_and_read(context, &staging)
}

/// The rendered image of `target` as RGBA8.
pub fn read_image(
    context: &GpuContext,
    target: &RenderTarget,
) -> Result<image::RgbaImage, RenderError> {
    let unpadded = target.width * 4;
    let padded =
        unpadded.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let staging = context.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("voxscope::readback_image"),
        size: padded as u64 * target.height as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = context
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("voxscope::readback_image"),
        });
    encoder.copy_texture_to_buffer(
        target.texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(target.height),
            },
        },
        wgpu::Extent3d {
            width: target.width,
            height: target.height,
            depth_or_array_layers: 1,
        },
    );
    context.queue.submit([encoder.finish()]);
    let bytes = map_and_read(context, &staging)?;
    let mut pixels = Vec::with_capacity((unpadded * target.height) as usize);
    for row in bytes.chunks_exact(padded as usize) {
        pixels.extend_from_slice(&row[..unpadded as usize]);
    }
    image::RgbaImage::from_raw(target.width, target.height, pixels)
        .ok_or_else(|| RenderError::Invalid("GPU image has the wrong size".into()))
}

/// Nodes visited by each pixel's ray in the last frame of `target`.
pub fn read_visits(context: &GpuContext, target: &RenderTarget) -> Result<Vec<u32>, RenderError> {
    let bytes = read_buffer(
        context,
        &target.visits,
        target.width as u64 * target.height as u64 * 4,
    )?;
    Ok(bytemuck::cast_slice(&bytes).to_vec())
}
