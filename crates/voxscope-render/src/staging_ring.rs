//! The streaming renderer's uploads into its atlas: a ring of host-visible buffers made once,
//! each written while mapped with every brick of a frame, copied into the atlas's slots by one
//! encoder, and mapped again once the GPU has read it. No buffer, staging allocation or queue
//! write per brick; a frame never waits for a buffer (while none is mapped, its bricks go
//! through `Queue::write_texture` instead).
//!
//! A copy's rows sit 256 bytes apart (`COPY_BYTES_PER_ROW_ALIGNMENT`) and a brick's row is 34
//! texels: 34 or 68 bytes. Rather than pad each row to 256, the bricks of a *group* share the
//! rows: brick `i` of a group starts `i × row` bytes into them, so three 16-bit or seven 8-bit
//! bricks fill what one brick would, and the mapped memory is written front to back, a group at a
//! time (a frame's bytes written are 1.1–1.3× its texels, not 3.8–7.5×).

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};
use std::time::Instant;

use voxscope_stream::PADDED_BRICK;

use super::GpuContext;

const MAPPED: u8 = 0;
const IN_FLIGHT: u8 = 1;
const FAILED: u8 = 2;

/// Buffers in the ring: one being written, one or two the GPU is still reading.
const BUFFERS: usize = 3;

/// Bytes of one group of bricks sharing rows: a brick's 34 × 34 rows at the copy's row
/// alignment.
const GROUP_BYTES: usize =
    PADDED_BRICK * PADDED_BRICK * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize;

/// The most bytes one ring buffer takes (the ring holds three).
const MAX_BUFFER_BYTES: u64 = 24 << 20;

/// How bricks of `bytes_per_texel` sit in a ring buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct RingLayout {
    /// Bytes of one brick's row.
    row_bytes: usize,
    /// Bricks sharing one group's rows.
    bricks_per_group: usize,
}

impl RingLayout {
    /// The layout for texels of `bytes_per_texel` bytes.
    pub(crate) fn new(bytes_per_texel: u32) -> Self {
        let row_bytes = PADDED_BRICK * bytes_per_texel as usize;
        let stride = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize;
        // A copy's offset is a multiple of 4 on some backends: each brick's row starts so.
        let row_pitch = row_bytes.next_multiple_of(4);
        Self {
            row_bytes,
            bricks_per_group: (stride / row_pitch).max(1),
        }
    }

    /// Where brick `i` of its group starts within each of the group's rows.
    fn brick_offset(self, index_in_group: usize) -> usize {
        index_in_group * self.row_bytes.next_multiple_of(4)
    }

    /// Bytes of one group: a brick's 34 × 34 rows at the copy's row alignment.
    pub(crate) fn group_bytes(self) -> usize {
        GROUP_BYTES
    }

    /// Bricks one buffer of at most [`MAX_BUFFER_BYTES`] holds, at most `wanted` (rounded up
    /// to whole groups).
    fn bricks_per_buffer(self, wanted: usize) -> usize {
        let most_groups = (MAX_BUFFER_BYTES / self.group_bytes() as u64).max(1) as usize;
        let groups = wanted.div_ceil(self.bricks_per_group).min(most_groups);
        groups * self.bricks_per_group
    }

    /// Writes one group's bricks (their 34 × 34 rows in order each) into `group`, a group's
    /// bytes.
    fn write_group(self, group: &mut [u8], bricks: &[StagedBrick<'_>]) {
        let stride = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize;
        for (index, brick) in bricks.iter().enumerate() {
            let start = self.brick_offset(index);
            for (row, texels) in brick.texels.chunks_exact(self.row_bytes).enumerate() {
                let at = start + row * stride;
                group[at..at + self.row_bytes].copy_from_slice(texels);
            }
        }
    }

    /// Where brick `index` of a buffer starts in it.
    fn offset(self, index: usize) -> usize {
        index / self.bricks_per_group * self.group_bytes()
            + self.brick_offset(index % self.bricks_per_group)
    }
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

/// What [`StagingRing::stage`] staged and what that took.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Staged {
    pub bricks: usize,
    /// Laying the bricks out and copying them into the mapped buffer (and unmapping it).
    pub staging_seconds: f64,
    /// Recording their copies.
    pub record_seconds: f64,
}

/// The ring. Bricks per buffer bound a frame's uploads through it; more go through the queue.
pub(crate) struct StagingRing {
    buffers: Vec<StagingBuffer>,
    next: usize,
    bricks_per_buffer: usize,
    layout: RingLayout,
    /// One group's rows, laid out before they are copied into a mapped buffer.
    scratch: Vec<u8>,
}

impl StagingRing {
    /// A ring whose buffers hold about `bricks` bricks of `bytes_per_texel` each (whole groups,
    /// within [`MAX_BUFFER_BYTES`]), mapped from the start (none for 0: every brick goes
    /// through the queue).
    pub(crate) fn new(context: &GpuContext, bricks: usize, bytes_per_texel: u32) -> Self {
        let layout = RingLayout::new(bytes_per_texel);
        let bricks_per_buffer = if bricks > 0 {
            layout.bricks_per_buffer(bricks)
        } else {
            0
        };
        let size = (bricks_per_buffer / layout.bricks_per_group * layout.group_bytes()) as u64;
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
            layout,
            scratch: Vec::new(),
        }
    }

    /// Records the copy of as many of `bricks` as the next mapped buffer holds into `atlas`,
    /// in `encoder`: how many, and what that took. Call [`Self::submitted`] once the encoder
    /// is submitted.
    pub(crate) fn stage(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        atlas: &wgpu::Texture,
        bricks: &[StagedBrick<'_>],
    ) -> Staged {
        let started = Instant::now();
        let Some(staging) = self.buffers.get(self.next) else {
            return Staged::default();
        };
        if bricks.is_empty() || staging.state.load(Ordering::Acquire) != MAPPED {
            return Staged::default();
        }
        let count = bricks.len().min(self.bricks_per_buffer);
        let side = PADDED_BRICK as u32;
        {
            let Ok(mut mapped) = staging.buffer.slice(..).get_mapped_range_mut() else {
                return Staged::default();
            };
            // A group's rows are laid out in ordinary memory first, then written to the mapped
            // (possibly write-combining) memory in one sequential copy. (On several cores at
            // once it was slower on the H200, run 71: the loaders hold every other core.)
            self.scratch.resize(GROUP_BYTES, 0);
            let groups = bricks[..count].chunks(self.layout.bricks_per_group);
            for (group, group_bricks) in groups.enumerate() {
                self.layout.write_group(&mut self.scratch, group_bricks);
                let base = group * GROUP_BYTES;
                mapped
                    .slice(base..base + GROUP_BYTES)
                    .copy_from_slice(&self.scratch);
            }
        }
        staging.buffer.unmap();
        let staging_seconds = started.elapsed().as_secs_f64();
        for (index, brick) in bricks[..count].iter().enumerate() {
            encoder.copy_buffer_to_texture(
                wgpu::TexelCopyBufferInfo {
                    buffer: &staging.buffer,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: self.layout.offset(index) as u64,
                        bytes_per_row: Some(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT),
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
        Staged {
            bricks: count,
            staging_seconds,
            record_seconds: started.elapsed().as_secs_f64() - staging_seconds,
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Every byte a brick's copy reads (34 × 34 rows of `row_bytes`, 256 apart from its
    /// offset) within a buffer of `bricks`.
    fn read_by(layout: RingLayout, index: usize) -> Vec<usize> {
        let stride = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize;
        let start = layout.offset(index);
        (0..PADDED_BRICK * PADDED_BRICK)
            .flat_map(|row| start + row * stride..start + row * stride + layout.row_bytes)
            .collect()
    }

    #[test]
    fn bricks_of_a_group_share_its_rows_without_overlapping() {
        for (bytes_per_texel, per_group) in [(1, 7), (2, 3), (4, 1)] {
            let layout = RingLayout::new(bytes_per_texel);
            assert_eq!(
                layout.bricks_per_group, per_group,
                "{bytes_per_texel} bytes"
            );
            let bricks = layout.bricks_per_buffer(2 * per_group + 1);
            assert_eq!(bricks, 3 * per_group, "whole groups");
            let buffer_bytes = bricks / per_group * layout.group_bytes();
            let mut owner = vec![usize::MAX; buffer_bytes];
            for index in 0..bricks {
                assert_eq!(layout.offset(index) % 4, 0);
                for byte in read_by(layout, index) {
                    assert!(byte < buffer_bytes, "brick {index} reads past the buffer");
                    assert_eq!(
                        owner[byte],
                        usize::MAX,
                        "bricks {index} and {} overlap",
                        owner[byte]
                    );
                    owner[byte] = index;
                }
            }
            // What write_group writes is what each copy reads.
            let mut group = vec![0u8; layout.group_bytes()];
            let texels: Vec<Vec<u8>> = (0..per_group)
                .map(|brick| {
                    (0..PADDED_BRICK * PADDED_BRICK * layout.row_bytes)
                        .map(|byte| (byte * 7 + brick * 31) as u8)
                        .collect()
                })
                .collect();
            let staged: Vec<StagedBrick<'_>> = texels
                .iter()
                .map(|texels| StagedBrick {
                    texels,
                    origin: wgpu::Origin3d::ZERO,
                })
                .collect();
            layout.write_group(&mut group, &staged);
            for (index, texels) in texels.iter().enumerate() {
                let read: Vec<u8> = read_by(layout, index).iter().map(|&b| group[b]).collect();
                assert_eq!(
                    &read, texels,
                    "brick {index} of {bytes_per_texel}-byte texels"
                );
            }
        }
        let layout = RingLayout::new(2);
        let most = layout.bricks_per_buffer(usize::MAX / 2);
        assert!(most / layout.bricks_per_group * layout.group_bytes() <= MAX_BUFFER_BYTES as usize);
    }
}
