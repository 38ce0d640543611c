//! The streaming renderer's uploads into its atlas: a ring of host-visible buffers made once,
//! each written while mapped with every brick of a frame, copied into the atlas's slots by one
//! encoder, and mapped again once the GPU has read it. No buffer, staging allocation or queue
//! write per brick; a frame never waits for a buffer (while none is mapped, its bricks go
//! through `Queue::write_texture` instead).
//!
//! A copy's rows sit a multiple of 256 bytes apart (`COPY_BYTES_PER_ROW_ALIGNMENT`) and a
//! brick's row is 34 texels: 34 or 68 bytes. The bricks a frame uploads are sorted by atlas cell
//! and cut into *runs* of bricks whose cells follow each other along x. A run's bricks share its
//! rows (brick `i` starts `i × row` bytes into each), so they are the rows of one box of the
//! atlas, and one copy fills the whole run. On the H200 the GPU's copies, not the CPU, bound the
//! uploads: a copy per brick moved 1.35 GB/s, runs of up to three 1.9–3.4, runs of any
//! length 3.0–6.9 (docs/benchmarks.md, runs 72 and 74).

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

/// The most bytes one ring buffer takes (the ring holds three).
const MAX_BUFFER_BYTES: usize = 24 << 20;

/// Bytes between a run's rows: its bricks' rows side by side, at the copy's row alignment.
fn run_pitch(bricks: usize, row_bytes: usize) -> usize {
    (bricks * row_bytes).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize)
}

/// Bytes of a run of `bricks` in a ring buffer: 34 × 34 rows at [`run_pitch`].
fn run_bytes(bricks: usize, row_bytes: usize) -> usize {
    PADDED_BRICK * PADDED_BRICK * run_pitch(bricks, row_bytes)
}

/// Where one staged brick goes: its texels, and the atlas cell it fills.
pub(crate) struct StagedBrick<'a> {
    pub texels: &'a [u8],
    pub origin: wgpu::Origin3d,
}

/// What [`StagingRing::stage`] staged and what that took.
#[derive(Clone, Debug, Default)]
pub(crate) struct Staged {
    /// Per brick given, whether it was staged (the rest go through the queue).
    pub staged: Vec<bool>,
    /// Copies recorded: one per run.
    pub copies: usize,
    /// Laying the bricks out and copying them into the mapped buffer (and unmapping it).
    pub staging_seconds: f64,
    /// Recording their copies.
    pub record_seconds: f64,
}

/// The runs of `origins` (atlas cells of `side` texels): indices into `origins`, sorted by
/// cell (z, then y, then x), each run bricks whose cells follow each other along x, all within
/// `capacity` bytes of runs of rows of `row_bytes` ([`run_bytes`]). Whether each brick is in
/// one.
fn plan_runs(
    origins: &[wgpu::Origin3d],
    side: u32,
    row_bytes: usize,
    capacity: usize,
) -> (Vec<Vec<usize>>, Vec<bool>) {
    let mut order: Vec<usize> = (0..origins.len()).collect();
    order.sort_unstable_by_key(|&i| {
        let o = origins[i];
        (o.z, o.y, o.x)
    });
    let mut runs: Vec<Vec<usize>> = Vec::new();
    let mut staged = vec![false; origins.len()];
    let mut used = 0;
    for i in order {
        let here = origins[i];
        if let Some(run) = runs.last_mut() {
            let last = origins[run[run.len() - 1]];
            let grown =
                used - run_bytes(run.len(), row_bytes) + run_bytes(run.len() + 1, row_bytes);
            if last.z == here.z && last.y == here.y && last.x + side == here.x && grown <= capacity
            {
                used = grown;
                run.push(i);
                staged[i] = true;
                continue;
            }
        }
        if used + run_bytes(1, row_bytes) <= capacity {
            used += run_bytes(1, row_bytes);
            runs.push(vec![i]);
            staged[i] = true;
        }
    }
    (runs, staged)
}

/// Writes a run's bricks (their 34 × 34 rows of `row_bytes` each, in order) into `rows`, the
/// run's bytes: row `r` of brick `i` at `r × pitch + i × row_bytes`.
fn write_run(rows: &mut [u8], bricks: &[&[u8]], row_bytes: usize, pitch: usize) {
    for (index, texels) in bricks.iter().enumerate() {
        let start = index * row_bytes;
        for (row, texels) in texels.chunks_exact(row_bytes).enumerate() {
            let at = start + row * pitch;
            rows[at..at + row_bytes].copy_from_slice(texels);
        }
    }
}

/// One buffer of the ring and whether it is mapped for writing.
struct StagingBuffer {
    buffer: wgpu::Buffer,
    state: Arc<AtomicU8>,
}

/// The ring. A buffer's bytes bound a frame's uploads through it; more go through the queue.
pub(crate) struct StagingRing {
    buffers: Vec<StagingBuffer>,
    next: usize,
    /// Bytes of one buffer.
    capacity: usize,
    /// Bytes of a brick's row.
    row_bytes: usize,
    /// One run's rows, laid out before they are copied into a mapped buffer.
    scratch: Vec<u8>,
}

impl StagingRing {
    /// A ring whose buffers hold `bricks` bricks of `bytes_per_texel` each as runs of one
    /// (within [`MAX_BUFFER_BYTES`]; longer runs take less room), mapped from the start (none
    /// for 0: every brick goes through the queue).
    pub(crate) fn new(context: &GpuContext, bricks: usize, bytes_per_texel: u32) -> Self {
        let row_bytes = PADDED_BRICK * bytes_per_texel as usize;
        let capacity = bricks
            .saturating_mul(run_bytes(1, row_bytes))
            .min(MAX_BUFFER_BYTES);
        let buffers = (0..if capacity > 0 { BUFFERS } else { 0 })
            .map(|_| StagingBuffer {
                buffer: context.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("voxscope::stream_staging"),
                    size: capacity as u64,
                    usage: wgpu::BufferUsages::MAP_WRITE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: true,
                }),
                state: Arc::new(AtomicU8::new(MAPPED)),
            })
            .collect();
        Self {
            buffers,
            next: 0,
            capacity,
            row_bytes,
            scratch: Vec::new(),
        }
    }

    /// Records the copies of as many of `bricks` as the next mapped buffer's runs hold into
    /// `atlas`, in `encoder`: which, and what that took. Call [`Self::submitted`] once the
    /// encoder is submitted.
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
        let side = PADDED_BRICK as u32;
        // The frame's first bricks (its most important) that could fit; of those, the runs
        // the buffer holds.
        let count = bricks.len().min(self.bricks_per_buffer());
        let origins: Vec<wgpu::Origin3d> = bricks[..count].iter().map(|b| b.origin).collect();
        let (runs, mut staged) = plan_runs(&origins, side, self.row_bytes, self.capacity);
        staged.resize(bricks.len(), false);
        let mut offsets = Vec::with_capacity(runs.len());
        {
            let Ok(mut mapped) = staging.buffer.slice(..).get_mapped_range_mut() else {
                return Staged::default();
            };
            // A run's rows are laid out in ordinary memory first, then written to the mapped
            // (possibly write-combining) memory in one sequential copy. (On several cores at
            // once it was slower on the H200, run 71: the loaders hold the other cores.)
            let mut base = 0;
            for run in &runs {
                let pitch = run_pitch(run.len(), self.row_bytes);
                let bytes = run_bytes(run.len(), self.row_bytes);
                self.scratch.resize(bytes, 0);
                let texels: Vec<&[u8]> = run.iter().map(|&i| bricks[i].texels).collect();
                write_run(&mut self.scratch[..bytes], &texels, self.row_bytes, pitch);
                mapped
                    .slice(base..base + bytes)
                    .copy_from_slice(&self.scratch[..bytes]);
                offsets.push((base, pitch));
                base += bytes;
            }
        }
        staging.buffer.unmap();
        let staging_seconds = started.elapsed().as_secs_f64();
        for (run, &(offset, pitch)) in runs.iter().zip(&offsets) {
            encoder.copy_buffer_to_texture(
                wgpu::TexelCopyBufferInfo {
                    buffer: &staging.buffer,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: offset as u64,
                        bytes_per_row: Some(pitch as u32),
                        rows_per_image: Some(side),
                    },
                },
                wgpu::TexelCopyTextureInfo {
                    texture: atlas,
                    mip_level: 0,
                    origin: bricks[run[0]].origin,
                    aspect: wgpu::TextureAspect::All,
                },
                wgpu::Extent3d {
                    width: side * run.len() as u32,
                    height: side,
                    depth_or_array_layers: side,
                },
            );
        }
        staging.state.store(IN_FLIGHT, Ordering::Release);
        Staged {
            staged,
            copies: runs.len(),
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

    /// Bricks one buffer holds at most (in long runs): a frame's uploads through the ring.
    pub(crate) fn bricks_per_buffer(&self) -> usize {
        self.capacity / (PADDED_BRICK * PADDED_BRICK * self.row_bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cell(x: u32, y: u32, z: u32) -> wgpu::Origin3d {
        let side = PADDED_BRICK as u32;
        wgpu::Origin3d {
            x: x * side,
            y: y * side,
            z: z * side,
        }
    }

    #[test]
    fn runs_are_cells_that_follow_each_other_along_x_within_the_buffer() {
        let side = PADDED_BRICK as u32;
        let row_bytes = 2 * PADDED_BRICK;
        // Given out of order: cells 0–4 of row (0, 0), cell 7 of it, cell 1 of row (1, 0)
        // and cell 0 of slice 1.
        let origins = [
            cell(3, 0, 0),
            cell(0, 0, 1),
            cell(1, 0, 0),
            cell(7, 0, 0),
            cell(0, 0, 0),
            cell(1, 1, 0),
            cell(2, 0, 0),
            cell(4, 0, 0),
        ];
        let (runs, staged) = plan_runs(&origins, side, row_bytes, MAX_BUFFER_BYTES);
        // x 0–4, then 7, row y = 1, slice z = 1.
        assert_eq!(runs, vec![vec![4, 2, 6, 0, 7], vec![3], vec![5], vec![1]]);
        assert!(staged.iter().all(|&s| s));
        // Five bricks' rows (340 bytes) take two of a copy's 256-byte rows: with room for four
        // such, the run and one more; the last two cells wait for the queue.
        let (runs, staged) = plan_runs(&origins, side, row_bytes, 4 * run_bytes(1, row_bytes));
        assert_eq!(runs, vec![vec![4, 2, 6, 0, 7], vec![3], vec![5]]);
        assert_eq!(
            staged,
            vec![true, false, true, true, true, true, true, true]
        );
        // Room for one brick: the first cell alone.
        let (runs, _) = plan_runs(&origins, side, row_bytes, run_bytes(1, row_bytes));
        assert_eq!(runs, vec![vec![4, 2, 6]]);
    }

    #[test]
    fn a_runs_rows_are_the_rows_of_its_box_in_the_atlas() {
        for bytes_per_texel in [1, 2, 4] {
            let row_bytes = PADDED_BRICK * bytes_per_texel;
            for count in [1, 3, 8] {
                let pitch = run_pitch(count, row_bytes);
                assert_eq!(pitch % 256, 0);
                assert!(pitch >= count * row_bytes && pitch < count * row_bytes + 256);
                let bricks: Vec<Vec<u8>> = (0..count)
                    .map(|brick| {
                        (0..PADDED_BRICK * PADDED_BRICK * row_bytes)
                            .map(|byte| (byte * 7 + brick * 31) as u8)
                            .collect()
                    })
                    .collect();
                let texels: Vec<&[u8]> = bricks.iter().map(|b| b.as_slice()).collect();
                let mut rows = vec![0u8; run_bytes(count, row_bytes)];
                write_run(&mut rows, &texels, row_bytes, pitch);
                // The copy reads row r (y and z of the box) as `count × row_bytes` bytes at
                // r × pitch: brick i's row r, for i in order.
                for row in 0..PADDED_BRICK * PADDED_BRICK {
                    let read = &rows[row * pitch..row * pitch + count * row_bytes];
                    for (index, brick) in bricks.iter().enumerate() {
                        assert_eq!(
                            &read[index * row_bytes..(index + 1) * row_bytes],
                            &brick[row * row_bytes..(row + 1) * row_bytes],
                            "row {row} of brick {index} of {count}, {bytes_per_texel}-byte texels"
                        );
                    }
                }
            }
        }
    }
}
