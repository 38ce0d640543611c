//! The streaming renderer's uploads into its atlas: a ring of host-visible buffers made once,
//! each written while mapped with every brick of a frame, recorded into one encoder, and mapped
//! again once the GPU has read it. No buffer, staging allocation or queue write per brick; a
//! frame never waits for a buffer (while none is mapped, its bricks go through
//! `Queue::write_texture` instead).
//!
//! Two layouts. Where the device can write the atlas's texel format from a shader (every
//! desktop GPU we met, and lavapipe), each brick is staged whole after the last, behind the
//! frame's [`BrickPlacement`]s: two copies (placements, bricks) take them to a buffer on the GPU
//! and one dispatch of
//! `atlas_scatter.wgsl` writes every texel into its cell. Elsewhere, bricks are copied into
//! the atlas by copy commands: a copy's rows sit a multiple of 256 bytes apart
//! (`COPY_BYTES_PER_ROW_ALIGNMENT`) and a brick's row is 34 texels (34 or 68 bytes), so the
//! bricks are sorted by atlas cell and cut into *runs* whose cells follow each other along x.
//! A run's bricks share its rows (brick `i` starts `i × row` bytes into each), so they are
//! the rows of one box of the atlas, and one copy fills the whole run. On the H200 the copy
//! commands bound the uploads: a copy per brick moved 1.35 GB/s, runs of up to three
//! 1.9–3.4, runs of any length 3.0–6.9 (docs/performance-log.md, "Uploads into the atlas").

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};
use std::time::Instant;

use voxscope_stream::PADDED_BRICK;

use super::GpuContext;
use super::atlas_scatter::{self, AtlasScatter};
use super::gpu_data::BrickPlacement;

const MAPPED: u8 = 0;
const IN_FLIGHT: u8 = 1;
const FAILED: u8 = 2;

/// Buffers in the ring: one being written, one or two the GPU is still reading.
const BUFFERS: usize = 3;

/// The most bytes one ring buffer takes (the ring holds three).
const MAX_BUFFER_BYTES: usize = 24 << 20;

/// The most bytes one buffer of a scattering ring takes, and so a frame's uploads: one core
/// stages them at about 7 GB/s, 2.3 ms. On the H200, frames of 24 MB took the near orbit's
/// p99 to 12 ms, of 16 MB to 8.8–10.8 ms, while the bricks it missed rose from 5 % of the
/// view to 10 % (docs/performance-log.md, "Uploads into the atlas").
const MAX_SCATTER_BYTES: usize = 16 << 20;

/// The share of the GPU budget a scattering ring's buffer on the GPU may take (it counts in
/// the budget, as the atlas does): 1/16.
const SCATTER_BUDGET_SHARE: u64 = 16;

/// Bytes of the placements of `bricks` bricks, to where the bricks start (a storage binding's
/// offset alignment: 256 bytes at most on every device).
fn placement_bytes(bricks: usize) -> usize {
    (bricks * std::mem::size_of::<BrickPlacement>()).next_multiple_of(256)
}

/// Bytes of a buffer holding `bricks` whole bricks of `brick_bytes` behind their placements.
fn whole_bytes(bricks: usize, brick_bytes: usize) -> usize {
    placement_bytes(bricks) + bricks * brick_bytes
}

/// Bricks of `brick_bytes` a scattering ring's buffer holds: a frame's `per_frame` at most,
/// within [`MAX_SCATTER_BYTES`] and [`SCATTER_BUDGET_SHARE`] of `gpu_budget`; and its GPU-side
/// buffer's bytes. `None` where not one brick fits (the ring then copies in runs).
pub(crate) fn scatter_size(
    per_frame: usize,
    brick_bytes: usize,
    gpu_budget: u64,
) -> Option<(usize, u64)> {
    let room = (MAX_SCATTER_BYTES as u64).min(gpu_budget / SCATTER_BUDGET_SHARE) as usize;
    let mut bricks = per_frame.min(room / (brick_bytes + std::mem::size_of::<BrickPlacement>()));
    while bricks > 0 && whole_bytes(bricks, brick_bytes) > room {
        bricks -= 1;
    }
    (bricks > 0).then(|| (bricks, whole_bytes(bricks, brick_bytes) as u64))
}

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
    /// Copies recorded: one per run, or two (placements and bricks) before a dispatch.
    pub copies: usize,
    /// Dispatches recorded that scatter the bricks into their cells.
    pub dispatches: usize,
    /// Laying the bricks out and copying them into the mapped buffer (and unmapping it).
    pub staging_seconds: f64,
    /// Recording their copies (and the dispatch that scatters them).
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

/// Bricks staged whole and scattered into their cells by a dispatch.
struct Scatter {
    /// Bricks a buffer holds.
    bricks: usize,
    /// Bytes of one brick (34³ texels).
    brick_bytes: usize,
    /// The ring buffer's bytes on the GPU, which the dispatch reads.
    source: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    pipeline: wgpu::ComputePipeline,
    /// Writes 0 into every texel of the atlas (`atlas_scatter.wgsl`'s `zero`).
    zero: wgpu::ComputePipeline,
    /// The atlas's size in texels.
    atlas_size: wgpu::Extent3d,
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
    /// Where the bricks are scattered by a dispatch; `None`: copied in runs.
    scatter: Option<Scatter>,
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
        Self::with_buffers(context, capacity, row_bytes, None)
    }

    /// A ring whose buffers hold `bricks` whole bricks (sized by [`scatter_size`]), which
    /// `scatter` writes into their cells of `atlas` (made with `STORAGE_BINDING`).
    pub(crate) fn scattering(
        context: &GpuContext,
        bricks: usize,
        bytes_per_texel: u32,
        atlas: &wgpu::Texture,
        scatter: &AtlasScatter,
    ) -> Self {
        let row_bytes = PADDED_BRICK * bytes_per_texel as usize;
        let brick_bytes = PADDED_BRICK * PADDED_BRICK * row_bytes;
        let capacity = whole_bytes(bricks, brick_bytes);
        let source = context.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::stream_scatter_source"),
            size: capacity as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let atlas_view = atlas.create_view(&wgpu::TextureViewDescriptor::default());
        let placements = placement_bytes(bricks) as u64;
        let bind_group = context
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("voxscope::stream_scatter"),
                layout: &scatter.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &source,
                            offset: 0,
                            size: wgpu::BufferSize::new(placements),
                        }),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &source,
                            offset: placements,
                            size: wgpu::BufferSize::new(capacity as u64 - placements),
                        }),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::TextureView(&atlas_view),
                    },
                ],
            });
        let scatter = Scatter {
            bricks,
            brick_bytes,
            source,
            bind_group,
            pipeline: scatter.pipeline.clone(),
            zero: scatter.zero.clone(),
            atlas_size: atlas.size(),
        };
        Self::with_buffers(context, capacity, row_bytes, Some(scatter))
    }

    fn with_buffers(
        context: &GpuContext,
        capacity: usize,
        row_bytes: usize,
        scatter: Option<Scatter>,
    ) -> Self {
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
            scatter,
        }
    }

    /// Whether the ring's bricks are scattered into their cells by a dispatch (else copied).
    pub(crate) fn scatters(&self) -> bool {
        self.scatter.is_some()
    }

    /// Records a pass that writes 0 into every texel of the atlas a scattering ring was made
    /// with: the first use of an atlas made without wgpu's zero fill (`uncleared_texture.rs`).
    /// Whether it did (a copying ring has no shader that writes the atlas).
    pub(crate) fn zero_atlas(&self, encoder: &mut wgpu::CommandEncoder) -> bool {
        let Some(scatter) = &self.scatter else {
            return false;
        };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("voxscope::stream_atlas_zero"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&scatter.zero);
        pass.set_bind_group(0, &scatter.bind_group, &[]);
        let size = scatter.atlas_size;
        pass.dispatch_workgroups(
            size.width.div_ceil(atlas_scatter::WORKGROUP),
            size.height,
            size.depth_or_array_layers,
        );
        true
    }

    /// Bytes the ring holds on the GPU: the buffer a scattering ring's dispatch reads.
    pub(crate) fn gpu_bytes(&self) -> u64 {
        self.scatter.as_ref().map_or(0, |s| s.source.size())
    }

    /// Records the uploads of as many of `bricks` as the next mapped buffer holds into
    /// `encoder`: their copies into `atlas` run by run, or (a scattering ring) their copy to
    /// the GPU and the dispatch that writes them into the atlas it was made with. Which were
    /// staged, and what that took. Call [`Self::submitted`] once the encoder is submitted.
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
        if let Some(scatter) = &self.scatter {
            return stage_whole(staging, scatter, encoder, bricks, started);
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
            dispatches: 0,
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

    /// Bricks one buffer holds at most (whole, or in long runs): a frame's uploads through the
    /// ring.
    pub(crate) fn bricks_per_buffer(&self) -> usize {
        match &self.scatter {
            Some(scatter) => scatter.bricks,
            None => self.capacity / (PADDED_BRICK * PADDED_BRICK * self.row_bytes),
        }
    }
}

/// Stages the first of `bricks` that `staging` holds whole, behind their placements, and
/// records their copy to the GPU and the dispatch writing them into their cells.
fn stage_whole(
    staging: &StagingBuffer,
    scatter: &Scatter,
    encoder: &mut wgpu::CommandEncoder,
    bricks: &[StagedBrick<'_>],
    started: Instant,
) -> Staged {
    let mut staged = vec![false; bricks.len()];
    let mut placements = Vec::with_capacity(scatter.bricks);
    let texels_start = placement_bytes(scatter.bricks);
    {
        let Ok(mut mapped) = staging.buffer.slice(..).get_mapped_range_mut() else {
            return Staged::default();
        };
        for (index, brick) in bricks.iter().enumerate() {
            if placements.len() == scatter.bricks {
                break;
            }
            if brick.texels.len() != scatter.brick_bytes {
                continue; // not a padded brick of the atlas's texels: the queue writes it
            }
            let at = texels_start + placements.len() * scatter.brick_bytes;
            mapped
                .slice(at..at + scatter.brick_bytes)
                .copy_from_slice(brick.texels);
            placements.push(BrickPlacement {
                origin: [brick.origin.x, brick.origin.y, brick.origin.z],
                _pad: 0,
            });
            staged[index] = true;
        }
        let placement_bytes: &[u8] = bytemuck::cast_slice(&placements);
        mapped
            .slice(..placement_bytes.len())
            .copy_from_slice(placement_bytes);
    }
    if placements.is_empty() {
        return Staged::default(); // the buffer stays mapped
    }
    staging.buffer.unmap();
    let staging_seconds = started.elapsed().as_secs_f64();
    let count = placements.len();
    let placement_size = (count * std::mem::size_of::<BrickPlacement>()) as u64;
    encoder.copy_buffer_to_buffer(&staging.buffer, 0, &scatter.source, 0, placement_size);
    encoder.copy_buffer_to_buffer(
        &staging.buffer,
        texels_start as u64,
        &scatter.source,
        texels_start as u64,
        (count * scatter.brick_bytes) as u64,
    );
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("voxscope::stream_scatter"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&scatter.pipeline);
        pass.set_bind_group(0, &scatter.bind_group, &[]);
        let words = (scatter.brick_bytes / 4) as u32;
        pass.dispatch_workgroups(words.div_ceil(atlas_scatter::WORKGROUP), count as u32, 1);
    }
    staging.state.store(IN_FLIGHT, Ordering::Release);
    Staged {
        staged,
        copies: 2,
        dispatches: 1,
        staging_seconds,
        record_seconds: started.elapsed().as_secs_f64() - staging_seconds,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::readback::read_buffer;
    use crate::uncleared_texture::uncleared_texture;

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

    #[test]
    fn a_scattering_ring_holds_a_frame_within_its_bound_and_its_share_of_the_budget() {
        let brick = PADDED_BRICK * PADDED_BRICK * PADDED_BRICK; // 8-bit texels
        // 512 MiB: the bound (16 MB) holds 426 bricks behind their placements.
        let (bricks, bytes) = scatter_size(10_000, brick, 512 << 20).expect("room");
        assert_eq!(bricks, 426);
        assert_eq!(bytes as usize, whole_bytes(426, brick));
        assert!(bytes as usize <= MAX_SCATTER_BYTES);
        assert!(whole_bytes(427, brick) > MAX_SCATTER_BYTES);
        // A frame's own allowance of bricks, when smaller.
        assert_eq!(scatter_size(100, brick, 512 << 20).map(|s| s.0), Some(100));
        // 16 MiB: a sixteenth, 1 MiB, holds 26.
        assert_eq!(scatter_size(10_000, brick, 16 << 20).map(|s| s.0), Some(26));
        // Not one brick in a sixteenth of 512 KiB: the ring copies instead.
        assert_eq!(scatter_size(10_000, brick, 512 << 10), None);
    }

    /// A brick of `bytes_per_texel` texels numbered by `seed`: every byte differs from its
    /// neighbours and from other seeds' bricks; 16-bit texels are finite half floats (normal
    /// and subnormal), so each format stores them as they are.
    fn numbered_brick(seed: usize, bytes_per_texel: usize) -> Vec<u8> {
        let texels = PADDED_BRICK * PADDED_BRICK * PADDED_BRICK;
        let mut bytes = Vec::with_capacity(texels * bytes_per_texel);
        for texel in 0..texels {
            let n = (texel * 2654435761 + seed * 40503) as u32;
            match bytes_per_texel {
                1 => bytes.push((n >> 13) as u8),
                _ => {
                    // Exponent 0–30 (31 is infinity and NaN), any sign and mantissa.
                    let half = (((n >> 7) as u16) % (31 << 10)) | ((n as u16) & 0x8000);
                    bytes.extend_from_slice(&half.to_le_bytes());
                }
            }
        }
        bytes
    }

    /// The atlas's texels, as `format`'s bytes, x fastest.
    pub(crate) fn read_atlas(
        context: &GpuContext,
        atlas: &wgpu::Texture,
        bytes_per_texel: usize,
    ) -> Vec<u8> {
        let size = atlas.size();
        let row = size.width as usize * bytes_per_texel;
        let pitch = row.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize);
        let rows = (size.height * size.depth_or_array_layers) as usize;
        let buffer = context.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("test_atlas_copy"),
            size: (pitch * rows) as u64,
            usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        encoder.copy_texture_to_buffer(
            atlas.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(pitch as u32),
                    rows_per_image: Some(size.height),
                },
            },
            size,
        );
        context.queue.submit([encoder.finish()]);
        let padded = read_buffer(context, &buffer, buffer.size()).expect("atlas read back");
        padded
            .chunks_exact(pitch)
            .flat_map(|r| &r[..row])
            .copied()
            .collect()
    }

    #[test]
    fn scattered_and_copied_bricks_land_in_their_cells_bit_for_bit_the_rest_zeroed() {
        let context = GpuContext::new_headless()
            .expect("a GPU adapter (lavapipe: mesa-vulkan-drivers, WGPU_BACKEND=vulkan)");
        let side = PADDED_BRICK as u32;
        // Height and depth differ: a dispatch that swapped them would leave texels unwritten.
        let grid = [3u32, 3, 2];
        // Five frames through the three buffers (the first two mapped again and written a
        // second time): five bricks (three cells in a run along x); one over a cell the first
        // filled, while the GPU's staging still holds the first frame's later placements (a
        // dispatch over more than this frame's bricks would write them again); then more,
        // over cells already filled.
        let frames: [&[(usize, [u32; 3])]; 5] = [
            &[
                (0, [1, 0, 0]),
                (1, [0, 1, 1]),
                (2, [0, 0, 0]),
                (3, [2, 1, 0]),
                (4, [2, 0, 0]),
            ],
            &[(5, [0, 1, 1])],
            &[(6, [1, 1, 1]), (7, [2, 0, 0])],
            &[(8, [0, 0, 0])],
            &[(9, [1, 0, 0]), (10, [2, 1, 1]), (11, [1, 1, 1])],
        ];
        for (format, bytes_per_texel) in [
            (wgpu::TextureFormat::R8Unorm, 1),
            (wgpu::TextureFormat::R16Unorm, 2),
            (wgpu::TextureFormat::R16Float, 2),
        ] {
            if format == wgpu::TextureFormat::R16Unorm && !context.has_norm16_textures {
                // No atlas of this device has this format (16-bit values go as half floats).
                continue;
            }
            let scatter = context
                .atlas_scatter(format)
                .unwrap_or_else(|| panic!("{format:?}: the device cannot write it from a shader"));
            let size = wgpu::Extent3d {
                width: grid[0] * side,
                height: grid[1] * side,
                depth_or_array_layers: grid[2] * side,
            };
            // What the atlas holds after both frames.
            let row = size.width as usize * bytes_per_texel;
            let mut expected = vec![0u8; row * (size.height * size.depth_or_array_layers) as usize];
            let bricks: Vec<Vec<u8>> = (0..12)
                .map(|seed| numbered_brick(seed, bytes_per_texel))
                .collect();
            for &(seed, cell) in frames.iter().flat_map(|f| f.iter()) {
                let brick_row = PADDED_BRICK * bytes_per_texel;
                for (r, texels) in bricks[seed].chunks_exact(brick_row).enumerate() {
                    let y = cell[1] as usize * PADDED_BRICK + r % PADDED_BRICK;
                    let z = cell[2] as usize * PADDED_BRICK + r / PADDED_BRICK;
                    let at = (z * size.height as usize + y) * row + cell[0] as usize * brick_row;
                    expected[at..at + brick_row].copy_from_slice(texels);
                }
            }
            eprintln!("{format:?}: {} bytes checked", expected.len());
            for scattering in [true, false] {
                let desc = wgpu::TextureDescriptor {
                    label: Some("test_atlas"),
                    size,
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D3,
                    format,
                    usage: wgpu::TextureUsages::COPY_DST
                        | wgpu::TextureUsages::COPY_SRC
                        | wgpu::TextureUsages::STORAGE_BINDING,
                    view_formats: &[],
                };
                // A scattering ring's atlas is made as the stream renderer makes it on Vulkan,
                // without wgpu's zero fill; the bytes it may hold are written first, then the
                // ring's pass zeroes them, and the cells no frame fills must read 0.
                // SAFETY: every texel is written (by the queue) before anything reads it.
                let atlas = match scattering
                    .then(|| unsafe { uncleared_texture(&context.device, &desc) })
                {
                    Some(Some(made)) => made.expect("room for a test atlas"),
                    Some(None) => {
                        assert_ne!(
                            context.adapter_info.backend,
                            wgpu::Backend::Vulkan,
                            "a Vulkan device makes the atlas without wgpu's zero fill"
                        );
                        context.device.create_texture(&desc)
                    }
                    None => context.device.create_texture(&desc),
                };
                let mut ring = if scattering {
                    let garbage = vec![0xa5u8; expected.len()];
                    context.queue.write_texture(
                        atlas.as_image_copy(),
                        &garbage,
                        wgpu::TexelCopyBufferLayout {
                            offset: 0,
                            bytes_per_row: Some(row as u32),
                            rows_per_image: Some(size.height),
                        },
                        size,
                    );
                    let ring = StagingRing::scattering(
                        &context,
                        8,
                        bytes_per_texel as u32,
                        &atlas,
                        scatter,
                    );
                    let mut encoder = context
                        .device
                        .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
                    assert!(ring.zero_atlas(&mut encoder));
                    context.queue.submit([encoder.finish()]);
                    ring
                } else {
                    StagingRing::new(&context, 8, bytes_per_texel as u32)
                };
                for frame in frames {
                    // Wait for the ring's next buffer to be mapped again (the app never does:
                    // it writes through the queue meanwhile).
                    context.wait_idle().expect("GPU");
                    let staged: Vec<StagedBrick<'_>> = frame
                        .iter()
                        .map(|&(seed, cell)| StagedBrick {
                            texels: &bricks[seed],
                            origin: wgpu::Origin3d {
                                x: cell[0] * side,
                                y: cell[1] * side,
                                z: cell[2] * side,
                            },
                        })
                        .collect();
                    let mut encoder = context
                        .device
                        .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
                    let done = ring.stage(&mut encoder, &atlas, &staged);
                    assert!(
                        done.staged.len() == frame.len() && done.staged.iter().all(|&s| s),
                        "{format:?}, scattering {scattering}: {:?}",
                        done.staged
                    );
                    assert_eq!(done.dispatches, scattering as usize);
                    context.queue.submit([encoder.finish()]);
                    ring.submitted();
                }
                let atlas_bytes = read_atlas(&context, &atlas, bytes_per_texel);
                let wrong = atlas_bytes.iter().zip(&expected).position(|(a, b)| a != b);
                assert!(
                    wrong.is_none(),
                    "{format:?}, scattering {scattering}: byte {wrong:?} of the atlas differs"
                );
            }
        }
    }
}
