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
pub(crate) mod tests;
