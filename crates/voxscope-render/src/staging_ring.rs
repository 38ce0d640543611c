//! The streaming renderer's uploads into its atlas: a ring of host-visible buffers made once,
//! each written while mapped with every brick of a frame (a brick's rows at the copy's row
//! alignment), copied into the atlas's slots by one encoder, and mapped again once the GPU has
//! read it. No buffer, staging allocation or queue write per brick; a frame never waits for a
//! buffer (while none is mapped, its bricks go through `Queue::write_texture` instead).

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

use voxscope_stream::PADDED_BRICK;

use super::GpuContext;

const MAPPED: u8 = 0;
const IN_FLIGHT: u8 = 1;
const FAILED: u8 = 2;

/// Buffers in the ring: one being written, one or two the GPU is still reading.
const BUFFERS: usize = 3;

/// Bytes of one brick in a ring buffer: its 34 × 34 rows, each at the copy's row alignment.
pub(crate) fn staged_brick_bytes() -> u64 {
    (PADDED_BRICK * PADDED_BRICK) as u64 * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as u64
}

/// One buffer of the ring and whether it is mapped for writing.
struct StagingBuffer {
    buffer: wgpu::Buffer,
    state: Arc<AtomicU8>,
}

/// Where one staged brick goes: its texels, and the atlas cell it fills.
pub(crate) struct StagedBrick<'a> {
    pub texels: &'a [u8],
    pub origin: wgpu::Origin3d,
}

/// The ring. Bricks per buffer bound a frame's uploads through it; more go through the queue.
pub(crate) struct StagingRing {
    buffers: Vec<StagingBuffer>,
    next: usize,
    bricks_per_buffer: usize,
    bytes_per_texel: u32,
    /// One brick at the row alignment, reused.
    scratch: Vec<u8>,
}

impl StagingRing {
    /// A ring whose buffers hold `bricks_per_buffer` bricks of `bytes_per_texel` each, mapped
    /// from the start (none for 0: every brick goes through the queue).
    pub(crate) fn new(
        context: &GpuContext,
        bricks_per_buffer: usize,
        bytes_per_texel: u32,
    ) -> Self {
        let size = staged_brick_bytes() * bricks_per_buffer as u64;
        let buffers = (0..if bricks_per_buffer > 0 { BUFFERS } else { 0 })
            .map(|_| StagingBuffer {
                buffer: context.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("voxscope::stream_staging"),
                    size,
                    usage: wgpu::BufferUsages::MAP_WRITE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: true,
                }),
                state: Arc::new(AtomicU8::new(MAPPED)),
            })
            .collect();
        Self {
            buffers,
            next: 0,
            bricks_per_buffer,
            bytes_per_texel,
            scratch: Vec::new(),
        }
    }

    /// Records the copy of as many of `bricks` as the next mapped buffer holds into `atlas`,
    /// in `encoder`; returns how many. Call [`Self::submitted`] once the encoder is submitted.
    pub(crate) fn stage(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        atlas: &wgpu::Texture,
        bricks: &[StagedBrick<'_>],
    ) -> usize {
        let Some(staging) = self.buffers.get(self.next) else {
            return 0;
        };
        if bricks.is_empty() || staging.state.load(Ordering::Acquire) != MAPPED {
            return 0;
        }
        let count = bricks.len().min(self.bricks_per_buffer);
        let side = PADDED_BRICK as u32;
        let row_bytes = (side * self.bytes_per_texel) as usize;
        let stride = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize;
        let brick_bytes = staged_brick_bytes() as usize;
        {
            let Ok(mut mapped) = staging.buffer.slice(..).get_mapped_range_mut() else {
                return 0;
            };
            // Each brick laid out at the row alignment in ordinary memory first, then written
            // to the mapped (possibly write-combining) memory in one sequential copy.
            self.scratch.resize(brick_bytes, 0);
            for (index, brick) in bricks[..count].iter().enumerate() {
                for (row, texels) in brick.texels.chunks_exact(row_bytes).enumerate() {
                    let at = row * stride;
                    self.scratch[at..at + row_bytes].copy_from_slice(texels);
                }
                let base = index * brick_bytes;
                mapped
                    .slice(base..base + brick_bytes)
                    .copy_from_slice(&self.scratch);
            }
        }
        staging.buffer.unmap();
        for (index, brick) in bricks[..count].iter().enumerate() {
            encoder.copy_buffer_to_texture(
                wgpu::TexelCopyBufferInfo {
                    buffer: &staging.buffer,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: (index * brick_bytes) as u64,
                        bytes_per_row: Some(stride as u32),
                        rows_per_image: Some(side),
                    },
                },
                wgpu::TexelCopyTextureInfo {
                    texture: atlas,
                    mip_level: 0,
                    origin: brick.origin,
                    aspect: wgpu::TextureAspect::All,
                },
                wgpu::Extent3d {
                    width: side,
                    height: side,
                    depth_or_array_layers: side,
                },
            );
        }
        staging.state.store(IN_FLIGHT, Ordering::Release);
        count
    }

    /// Maps the buffer [`Self::stage`] wrote again, for a later frame, once the GPU has copied
    /// from it (the encoder holding its copies is submitted); the ring moves on to the next.
    pub(crate) fn submitted(&mut self) {
        let Some(staging) = self.buffers.get(self.next) else {
            return;
        };
        if staging.state.load(Ordering::Acquire) != IN_FLIGHT {
            return;
        }
        let state = Arc::clone(&staging.state);
        staging
            .buffer
            .slice(..)
            .map_async(wgpu::MapMode::Write, move |result| {
                let next = if result.is_ok() { MAPPED } else { FAILED };
                state.store(next, Ordering::Release);
            });
        self.next = (self.next + 1) % self.buffers.len();
    }

    /// Bricks one buffer holds: a frame's uploads through the ring at most.
    pub(crate) fn bricks_per_buffer(&self) -> usize {
        self.bricks_per_buffer
    }
}
