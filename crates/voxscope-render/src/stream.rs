//! The streaming renderer's GPU side: a brick atlas of a fixed byte budget, the page table the
//! rays look bricks up in, the request and usage buffers they write, and their asynchronous
//! readback; the pipeline that draws it (`stream.wgsl`). The CPU side, which decides what to
//! load and upload, is [`voxscope_stream::Streamer`].
//!
//! Per frame: [`StreamVolume::step`] (the app calls it once before drawing; it never waits)
//! copies the last drawn frame's requests and usage marks to a staging buffer and maps it,
//! clears the requests for the next frame, takes in whatever readback has arrived, and lets the
//! streamer decide; it then writes the uploads into their atlas slots and the changed page-table
//! entries. Then any number of frames draw with what is resident.

use std::sync::atomic::{AtomicBool, AtomicU8, AtomicU32, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use wgpu::util::DeviceExt;

use super::copy_timer::CopyTimer;
use super::gpu_data::{FLAG_LABELS, MODE_MIP, RaycastParams, STREAM_LEVELS, StreamParams};
use super::pipeline::{
    Variant, VariantPipelines, atlas_entry, atlas_sampler_entry, clamped_sampler,
    numbered_bind_group, output_image_entry, storage_entry, uniform_entry,
};
use super::raycaster::{
    BrickShape, ProbeTarget, RayPass, StandIns, VolumeShape, encode_probe_ray, frame_params_buffer,
};
use super::readback::map_state::{FAILED, IDLE, MAPPED, RECORDED};
use super::readback::{read_mapped, start_map_read};
use super::renderer::{FramePass, Renderer, StreamPaths, level_detail, pipeline_variants};
use super::staging_ring::{self, StagedBrick, StagingRing};
use super::uncleared_texture::{OutOfMemory, uncleared_texture};
use super::{
    ChannelLayer, GpuContext, GpuTransferTable, LevelDetail, RenderError, RenderSettings,
    RenderTarget, RendererKind,
};
use voxscope_octree::TransferFunction;
use voxscope_stream::{
    AtlasTexels, AtlasZero, BRICK_SIZE, BrickSource, Feedback, FullDetailBudget, PADDED_BRICK,
    PADDED_BRICK_VOXELS, StreamOptions, StreamStatus, Streamer, TableEntry, Upload, UploadParts,
    UploadPath, ViewPoint, view_slots,
};

/// Keys the request buffer holds per frame: more asks than this in one frame are counted but
/// their keys lost (they are asked again next frame).
const REQUEST_CAPACITY: u32 = 1 << 14;
/// Entries of the request buffer's deduplicating set.
const REQUEST_SET: u32 = 1 << 14;
/// Readbacks in flight at most.
const READBACKS: usize = 3;
/// Page-table bytes counted per atlas slot when sizing the atlas: the table has up to 16
/// entries of 16 bytes per slot, rounded up to a power of two (so at most twice that).
const TABLE_BYTES_PER_SLOT: u64 = 2 * 16 * 16;
/// The most bricks a level (or two adjacent levels together) may have for the page table to
/// copy it flat, so that frames which want that level walk it (`main_level`, `main_levels`):
/// 1 MiB of entries at most.
const LEVEL_WALK_BRICKS: u64 = 1 << 16;
/// The level walk's buffer without the walk: one entry (a binding is never empty).
const UNWALKED_LEVEL_CELLS_BYTES: u64 = std::mem::size_of::<TableEntry>() as u64;
/// The atlas's usage beyond what drawing needs: a copy from it, for the tests that read it
/// back.
#[cfg(not(test))]
const ATLAS_READ_BACK: wgpu::TextureUsages = wgpu::TextureUsages::empty();
#[cfg(test)]
const ATLAS_READ_BACK: wgpu::TextureUsages = wgpu::TextureUsages::COPY_SRC;
/// No level walked.
const NO_LEVEL: u32 = u32::MAX;
/// No frame drawn since the last [`StreamVolume::step`] (`walk_wanted`).
const NOT_DRAWN: u32 = u32::MAX - 1;
/// No frame drawn by the level walk.
const NO_FRAME: u32 = u32::MAX;
/// `stream.wgsl`'s `main` (segment by segment), as [`VariantPipelines`] numbers it.
const SEGMENTS: usize = 0;
/// `stream.wgsl`'s `main_level` (the level walk), as [`VariantPipelines`] numbers it.
const LEVEL_WALK: usize = 1;
/// `stream.wgsl`'s `main_levels` (the walk of a level and the next coarser one), as
/// [`VariantPipelines`] numbers it.
const LEVELS_WALK: usize = 2;

/// Whether frames of `params` composite by maximum intensity (`max_projection` in
/// ray_common.wgsl: MIP, but not of labels, which composite as DVR).
fn max_projection(params: &RaycastParams) -> bool {
    params.mode == MODE_MIP && params.flags & FLAG_LABELS == 0
}

/// One staging buffer for a frame's requests and usage marks.
struct Readback {
    buffer: wgpu::Buffer,
    frame: u32,
    state: Arc<AtomicU8>,
}

/// A streamed pyramid on the GPU.
pub struct StreamVolume {
    streamer: Streamer,
    atlas: wgpu::Texture,
    atlas_view: wgpu::TextureView,
    atlas_bytes: u64,
    atlas_grid: [usize; 3],
    texels: AtlasTexels,
    table: wgpu::Buffer,
    transfer: GpuTransferTable,
    requests: wgpu::Buffer,
    usage: wgpu::Buffer,
    readbacks: Vec<Readback>,
    /// The flat copy of one level's page-table entries, or of two levels'
    /// ([`voxscope_stream::PageTable::copy_level`]), sized for the largest of at most
    /// [`LEVEL_WALK_BRICKS`].
    level_cells: wgpu::Buffer,
    /// The levels every frame drawn since the last [`Self::step`] wanted to walk
    /// ([`WalkLevels::code`]; [`NO_LEVEL`]: none, or frames (panes of other max levels) that
    /// wanted different ones; [`NOT_DRAWN`]: no frame); the next step has the table copy them.
    walk_wanted: AtomicU32,
    /// Frames drawn by the level walk (`main_level`, `main_levels`) so far.
    walked_frames: AtomicU64,
    /// The streamer's frame the level walk drew last, until the next [`Self::step`] marks the
    /// level's bricks used then ([`NO_FRAME`]: none since).
    walk_drew: AtomicU32,
    /// Where uploads are staged on their way into the atlas.
    ring: StagingRing,
    /// The always-resident levels' bricks, read when the volume was made and written by the
    /// first [`Self::step`].
    unwritten: Vec<Upload>,
    /// The atlas was made without wgpu's zero fill and is not zeroed yet: the first
    /// [`Self::write`] records the pass that does.
    unzeroed: bool,
    /// The next write with uploads follows the zero pass: it sets no upload rate (where a
    /// submission waits for the one before, lavapipe, its time is mostly the pass's).
    skip_upload_rate: bool,
    /// How the atlas was zeroed: [`AtlasZero::Shader`] or [`AtlasZero::Wgpu`].
    atlas_zero: AtlasZero,
    /// The GPU's time for the ring's copies (where it has timestamps).
    copy_timer: Option<CopyTimer>,
    /// Whether a frame was drawn since the last update (its requests are then read back).
    drawn: AtomicBool,
    /// The camera of the latest frame drawn, for the load order.
    view: Mutex<Option<ViewPoint>>,
    /// Whether the latest frame drawn took the maximum (MIP): the loads follow (brightest
    /// bricks first).
    max_projection: AtomicBool,
    spacing: [f64; 3],
    /// How the budget became the atlas, and the latest budget-limited view's size at full
    /// detail with the budget that would hold it.
    sizing: AtlasSizing,
    full_detail: Option<(usize, FullDetailBudget)>,
    /// Where the pyramid has several channels: their tables and which are shown (the
    /// composite, `stream_composite.wgsl`).
    channels: Option<StreamChannels>,
}

impl StreamVolume {
    /// Allocates the atlas and buffers within `options.gpu_memory` and reads the coarsest
    /// levels (always resident), which the first [`Self::step`] writes into it:
    /// [`Self::allocate`], then [`Self::read_pinned`]. Nothing is submitted here, so that a
    /// thread other than the one drawing can make it: a submission from another thread while
    /// egui-wgpu configures its surface fails the configuration (wgpu waits for an empty
    /// queue), which panicked the app opening a store at start.
    pub fn new(
        context: &GpuContext,
        source: Arc<dyn BrickSource>,
        options: StreamOptions,
        transfer: &TransferFunction,
    ) -> Result<Self, RenderError> {
        let mut volume = Self::allocate(context, source, options, transfer)?;
        volume.read_pinned()?;
        Ok(volume)
    }

    /// The atlas, buffers and staging within `options.gpu_memory`, reading nothing from the
    /// source: a store's first chunks may still be on their way (`ZarrSource::warm_first_image`
    /// on another thread) while this is made. [`Self::read_pinned`] must follow before the
    /// first [`Self::step`]. Submits nothing, as [`Self::new`].
    pub fn allocate(
        context: &GpuContext,
        source: Arc<dyn BrickSource>,
        options: StreamOptions,
        transfer: &TransferFunction,
    ) -> Result<Self, RenderError> {
        let texels = atlas_texels(context, source.max_value_level());
        let slot_bytes = (PADDED_BRICK_VOXELS * texels.bytes()) as u64;
        let format = atlas_format(texels);
        // What a frame may upload; through the ring's buffers, scattered into the atlas by a
        // dispatch where the device can (their copy on the GPU counts in the budget).
        let per_frame = (options.upload_bytes_per_frame / slot_bytes).max(1) as usize;
        // (Of every channel.)
        let bricks: u64 = source
            .shape()
            .levels
            .iter()
            .map(|l| l.brick_count())
            .sum::<u64>()
            * source.shape().channels as u64;
        // A frame uploads no more bricks than the pyramid has.
        let most_per_frame = per_frame.min(bricks.min(usize::MAX as u64) as usize);
        let scatter = match options.uploads {
            UploadPath::Scatter => context.atlas_scatter(format).and_then(|pipeline| {
                staging_ring::scatter_size(most_per_frame, slot_bytes as usize, options.gpu_memory)
                    .map(|size| (pipeline, size))
            }),
            UploadPath::Copies | UploadPath::Queue => None,
        };
        let quantization = source.quantization();
        let visible = visible_below(&transfer.lookup_table(quantization));
        let level_cells_bytes =
            walked_level_cells_bytes(&source.shape().levels, options.level_walk);
        // How the budget becomes the atlas (`AtlasSizing::plan`): the scatter's staging and
        // the level copy take their bytes from it where the rest still holds the
        // always-resident levels and a view. Kept, as asked, to size the budget a larger view
        // needs (a larger budget may scatter, or walk, where this one fell back); its pinned
        // slots once they are read (`read_pinned`).
        let sizing = AtlasSizing {
            budget: options.gpu_memory,
            slot_bytes,
            bricks_in_pyramid: bricks,
            scatter_per_frame: (options.uploads == UploadPath::Scatter
                && context.atlas_scatter(format).is_some())
            .then_some(most_per_frame),
            // (The composite's rays look each channel up: it never walks a level.)
            level_cells_bytes: if options.level_walk && !source.composite() {
                level_cells_bytes
            } else {
                0
            },
            pinned_levels: voxscope_stream::pinned_level_count(source.shape()),
            pinned: 0,
        };
        let plan = sizing.plan(context, options.gpu_memory)?;
        let scatter = scatter.filter(|_| plan.scatter);
        let grid = plan.grid;
        let channel_count = source.shape().channels as usize;
        let options = StreamOptions {
            // The composite's rays look each channel up: no level walk.
            level_walk: options.level_walk && plan.level_walk && !source.composite(),
            ..options
        };
        let mut streamer = Streamer::new(Arc::clone(&source), grid, texels, options, visible)
            .map_err(|e| RenderError::DoesNotFit(e.to_string()))?;
        let level_cells_bytes = if streamer.options().level_walk {
            level_cells_bytes
        } else {
            UNWALKED_LEVEL_CELLS_BYTES
        };
        let device = &context.device;
        let out_of_memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let (atlas, uncleared) =
            create_atlas(context, grid, format, scatter.is_some(), options.atlas_zero)?;
        let atlas_view = atlas.create_view(&wgpu::TextureViewDescriptor::default());
        let slots = grid.iter().product::<usize>();
        let buffers = StreamBuffers::new(
            device,
            streamer.table().capacity(),
            slots,
            level_cells_bytes,
        );
        let transfer_table = GpuTransferTable::new(context, quantization, transfer);
        let channels = (channel_count > 1 || source.composite())
            .then(|| StreamChannels::new(context, &*source, channel_count, transfer));
        let bytes_per_texel = texels.bytes() as u32;
        let ring = match (scatter, options.uploads) {
            (Some((pipeline, (bricks, _))), _) => {
                StagingRing::scattering(context, bricks, bytes_per_texel, &atlas, pipeline)
            }
            // A ring buffer holds what a frame may upload, within the ring's own bound (24 MB
            // a buffer: 85 bricks alone, more in runs along x).
            (None, UploadPath::Scatter | UploadPath::Copies) => {
                StagingRing::new(context, per_frame.min(slots), bytes_per_texel)
            }
            (None, UploadPath::Queue) => StagingRing::new(context, 0, bytes_per_texel),
        };
        if let Some(error) = pollster::block_on(out_of_memory.pop()) {
            return Err(RenderError::DoesNotFit(format!(
                "the GPU has no room for the streaming atlas: {error}"
            )));
        }
        if ring.scatters() {
            // A frame uploads no more than the ring's buffer holds: the rest would wait for
            // queue writes, a GPU copy each (run 88).
            streamer.set_upload_ceiling(ring.bricks_per_buffer() as u64 * slot_bytes);
        }
        let volume = Self {
            streamer,
            atlas,
            atlas_view,
            atlas_bytes: slots as u64 * slot_bytes,
            atlas_grid: grid,
            texels,
            table: buffers.table,
            transfer: transfer_table,
            requests: buffers.requests,
            usage: buffers.usage,
            readbacks: buffers.readbacks,
            level_cells: buffers.level_cells,
            walk_wanted: AtomicU32::new(NOT_DRAWN),
            walked_frames: AtomicU64::new(0),
            walk_drew: AtomicU32::new(NO_FRAME),
            ring,
            copy_timer: CopyTimer::new(context),
            drawn: AtomicBool::new(false),
            view: Mutex::new(None),
            max_projection: AtomicBool::new(false),
            spacing: source.spacing(),
            sizing,
            full_detail: None,
            channels,
            unwritten: Vec::new(),
            unzeroed: uncleared,
            skip_upload_rate: false,
            atlas_zero: if uncleared {
                AtlasZero::Shader
            } else {
                AtlasZero::Wgpu
            },
        };
        Ok(volume)
    }

    /// Reads the always-resident coarse levels ([`Streamer::load_pinned`]), which the first
    /// [`Self::step`] writes into the atlas; once, after [`Self::allocate`] (again, nothing).
    /// Submits nothing.
    pub fn read_pinned(&mut self) -> Result<(), RenderError> {
        let pinned = self
            .streamer
            .load_pinned()
            .map_err(|e| RenderError::DoesNotFit(e.to_string()))?;
        self.unwritten.extend(pinned);
        self.sizing.pinned = self.streamer.pinned_slots();
        Ok(())
    }

    /// The path its uploads take: [`UploadPath::Scatter`] only where the device writes the
    /// atlas's format from a shader and the budget left room for the staging.
    pub fn upload_path(&self) -> UploadPath {
        if self.ring.scatters() {
            UploadPath::Scatter
        } else if self.ring.bricks_per_buffer() > 0 {
            UploadPath::Copies
        } else {
            UploadPath::Queue
        }
    }

    /// How its atlas is zeroed before its first use: [`AtlasZero::Shader`] where it was made
    /// without wgpu's fill, else [`AtlasZero::Wgpu`].
    pub fn atlas_zero(&self) -> AtlasZero {
        self.atlas_zero
    }

    /// The per-frame step: reads back what earlier frames asked for and used (without
    /// waiting), loads and uploads within the budgets, and readies the request buffer for the
    /// next frame. Call once per displayed frame, before drawing it ([`Renderer::update`]
    /// does).
    pub fn step(&mut self, context: &GpuContext) -> StreamStatus {
        if let Some(visibility) = self.channels.as_ref().and_then(|c| c.take_visibility()) {
            self.streamer.set_channel_visibility(visibility);
        }
        if !self.unwritten.is_empty() {
            let unwritten = std::mem::take(&mut self.unwritten);
            self.write(context, &unwritten);
        }
        let reading = Instant::now();
        let _ = context.device.poll(wgpu::PollType::Poll);
        if let Some(timer) = self.copy_timer.as_mut() {
            for (bytes, seconds) in timer.take() {
                self.streamer.set_upload_gpu_cost(bytes, seconds);
            }
        }
        let feedback = self.take_readbacks();
        if self.drawn.swap(false, Ordering::AcqRel) {
            self.record_readback(context);
        }
        let readback = reading.elapsed().as_secs_f64();
        let walked = self.walk_drew.swap(NO_FRAME, Ordering::AcqRel);
        if walked != NO_FRAME {
            self.streamer.mark_level_walked(walked);
        }
        let view = *self.view.lock().unwrap_or_else(|p| p.into_inner());
        let (uploads, status) = match &feedback {
            Some((frame, requests, asked, usage)) => self.streamer.begin_frame(
                Some(Feedback {
                    frame: *frame,
                    requests,
                    asked: *asked,
                    usage,
                    max_projection: self.max_projection.load(Ordering::Acquire),
                }),
                view,
            ),
            None => self.streamer.begin_frame(None, view),
        };
        // The level every ray of the frames drawn since wanted: copied flat from now on (until
        // another is wanted, or several), so that the next frames may walk it. Without a frame
        // drawn the copy stays as it is.
        let walk = self.walk_wanted.swap(NOT_DRAWN, Ordering::AcqRel);
        if walk != NOT_DRAWN {
            let wanted = (walk != NO_LEVEL).then(|| WalkLevels::from_code(walk));
            // A copy of two levels serves frames that want either alone: it stays, so that a
            // view whose far corner crosses a level's boundary does not rebuild it each time.
            let covered = wanted
                .zip(WalkLevels::copied(self.streamer.table()))
                .is_some_and(|(wanted, copied)| copied.covers(wanted));
            if !covered {
                let copy = wanted.and_then(|w| Some((w.level, w.bricks(self.streamer.shape())?)));
                self.streamer.table_mut().copy_level(copy);
            }
        }
        let writing = Instant::now();
        self.write(context, &uploads);
        let mut status = status;
        if let Some(budget) = status.budget.as_mut() {
            budget.full_detail = self.full_detail_budget(context, budget.needed);
        }
        status.phases.readback = readback;
        status.phases.write = writing.elapsed().as_secs_f64();
        status
    }

    /// The GPU budget that would hold a view of `needed` bricks at full detail (sized again
    /// only when that count changes).
    fn full_detail_budget(&mut self, context: &GpuContext, needed: usize) -> FullDetailBudget {
        match self.full_detail {
            Some((sized, budget)) if sized == needed => budget,
            _ => {
                let budget = self.sizing.full_detail_budget(context, needed);
                self.full_detail = Some((needed, budget));
                budget
            }
        }
    }

    /// The newest mapped readback's requests, with every mapped one's usage marks merged.
    #[allow(clippy::type_complexity)]
    fn take_readbacks(&mut self) -> Option<(u32, Vec<u32>, u32, Vec<u32>)> {
        let slots = self.atlas_grid.iter().product::<usize>();
        let mut newest: Option<(u32, Vec<u32>, u32, Vec<u32>)> = None;
        let mut usage = vec![0u32; slots];
        for readback in &self.readbacks {
            match readback.state.load(Ordering::Acquire) {
                MAPPED => {}
                FAILED => {
                    readback.state.store(IDLE, Ordering::Release);
                    continue;
                }
                _ => continue,
            }
            read_mapped(&readback.buffer, &readback.state, |bytes| {
                let words: &[u32] = bytemuck::cast_slice(bytes);
                let asked = words[0];
                let keys = &words[1..1 + (asked.min(REQUEST_CAPACITY)) as usize];
                let marks = &words[1 + REQUEST_CAPACITY as usize..];
                for (merged, &mark) in usage.iter_mut().zip(marks) {
                    *merged = (*merged).max(mark);
                }
                if newest
                    .as_ref()
                    .is_none_or(|(frame, ..)| readback.frame > *frame)
                {
                    newest = Some((readback.frame, keys.to_vec(), asked, Vec::new()));
                }
            });
        }
        newest.map(|(frame, keys, asked, _)| (frame, keys, asked, usage))
    }

    /// Copies the last frame's requests and marks to a free staging buffer (if one is free),
    /// clears the requests for the next frame, and starts mapping the copy.
    fn record_readback(&mut self, context: &GpuContext) {
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("voxscope::stream_readback"),
            });
        let frame = self.streamer.frame();
        let free = self
            .readbacks
            .iter_mut()
            .find(|r| r.state.load(Ordering::Acquire) == IDLE);
        let requests_bytes = (1 + REQUEST_CAPACITY as u64) * 4;
        let mut recorded = None;
        if let Some(readback) = free {
            encoder.copy_buffer_to_buffer(&self.requests, 0, &readback.buffer, 0, requests_bytes);
            encoder.copy_buffer_to_buffer(
                &self.usage,
                0,
                &readback.buffer,
                requests_bytes,
                self.usage.size(),
            );
            readback.frame = frame;
            readback.state.store(RECORDED, Ordering::Release);
            recorded = Some(readback);
        }
        encoder.clear_buffer(&self.requests, 0, Some(4));
        encoder.clear_buffer(&self.requests, requests_bytes, Some(REQUEST_SET as u64 * 4));
        context.queue.submit([encoder.finish()]);
        if let Some(readback) = recorded {
            start_map_read(&readback.buffer, &readback.state);
        }
    }

    /// Applies a new transfer function: the lookup table, and each page-table entry's
    /// visibility bit (written now, so the next frame skips by the new function). Nothing is
    /// reloaded.
    fn apply_transfer(&mut self, context: &GpuContext, transfer: &TransferFunction) {
        if self.channels.is_some() {
            // Each channel's transfer function is its own (`set_channels`).
            return;
        }
        self.transfer.write(context, transfer);
        let table = transfer.lookup_table(self.streamer.source().quantization());
        self.streamer.set_visibility(visible_below(&table));
        self.write(context, &[]);
    }

    /// The streamer (its counters, options and shape).
    pub fn streamer(&self) -> &Streamer {
        &self.streamer
    }

    /// The streamer, to prefetch into ([`Streamer::prefetch`]).
    pub fn streamer_mut(&mut self) -> &mut Streamer {
        &mut self.streamer
    }

    /// The uniforms of a frame drawn with `params`.
    fn stream_params(&self, params: &RaycastParams) -> StreamParams {
        let max_level = params.max_level;
        let shape = self.streamer.shape();
        let walked = self.walked_level(params);
        let mut level_grid = [[0u32; 4]; STREAM_LEVELS];
        let mut level_scale = [[1f32; 4]; STREAM_LEVELS];
        for (level, info) in shape.levels.iter().enumerate() {
            let [x, y, z] = info.grid.map(|g| g as u32);
            level_grid[level] = [x, y, z, 0];
            let s = info.scale as f32;
            level_scale[level] = [s, s, s, s];
        }
        StreamParams {
            level_grid,
            level_scale,
            level_count: shape.levels.len() as u32,
            finest_level: shape.depth().saturating_sub(max_level),
            frame: self.streamer.frame(),
            table_mask: self.streamer.table().mask(),
            request_capacity: REQUEST_CAPACITY,
            request_set_mask: REQUEST_SET - 1,
            lod_scale: self.streamer.options().lod_scale.max(0.0),
            walk_level: walked.map_or(NO_LEVEL, |walk| walk.level),
            walk_next: match walked.and_then(|walk| walk.bricks(shape)) {
                Some([bricks, next]) if next > 0 => bricks as u32,
                _ => 0,
            },
            channel_count: self.channels.as_ref().map_or(1, |c| c.count() as u32),
            shown_channels: self.channels.as_ref().map_or(1, StreamChannels::shown_mask),
            _pad2: 0,
            channel_shading: self
                .channels
                .as_ref()
                .map_or([[0.0; 4]; 2], StreamChannels::shading_scales),
        }
    }
}

impl VolumeShape for StreamVolume {
    fn dims(&self) -> [usize; 3] {
        self.streamer.shape().dims()
    }
    fn spacing(&self) -> [f64; 3] {
        self.spacing
    }
    fn depth(&self) -> u32 {
        self.streamer.shape().depth()
    }
    fn level_cap(&self) -> u32 {
        self.streamer.shape().depth()
    }
    fn mip_saturation(&self) -> u16 {
        self.transfer.mip_saturation()
    }
    fn window_levels(&self) -> f32 {
        self.transfer.window_levels()
    }
    /// A label volume's source ([`BrickSource::labels`]): nearest samples, first-label MIP.
    fn labels(&self) -> bool {
        self.streamer.source().labels()
    }
    fn bricks(&self) -> Option<BrickShape> {
        let grid = self.streamer.shape().levels[0].grid.map(|g| g as u32);
        Some(BrickShape {
            level: 0,
            size: BRICK_SIZE as u32,
            atlas_scale: self.texels.scale(),
            atlas_grid: self.atlas_grid.map(|g| g as u32),
            grid,
        })
    }
}

mod allocation;
mod atlas;
mod channels;
mod level_walk;
mod ray_pass;
mod renderer;
mod uploads;

use allocation::{StreamBuffers, create_atlas, walked_level_cells_bytes};
pub use atlas::BUDGET_STEPS;
pub(crate) use atlas::atlas_formats;
use atlas::*;
use channels::StreamChannels;
pub use channels::StreamCompositeRaycaster;
use level_walk::WalkLevels;
pub use ray_pass::StreamRaycaster;

#[cfg(test)]
mod tests;
