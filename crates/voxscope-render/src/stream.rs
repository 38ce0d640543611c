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
use super::renderer::{FramePass, Renderer, level_detail, pipeline_variants};
use super::staging_ring::{self, StagedBrick, StagingRing};
use super::uncleared_texture::{OutOfMemory, uncleared_texture};
use super::{
    GpuContext, GpuTransferTable, LevelDetail, RenderError, RenderSettings, RenderTarget,
    RendererKind,
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

/// The levels every ray of a frame wants wherever it meets the volume: `level`, and where
/// `two`, the next coarser one too (from some distance on, each ray from its own).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct WalkLevels {
    level: u32,
    two: bool,
}

impl WalkLevels {
    /// As `walk_wanted` holds it (far below its [`NO_LEVEL`] and [`NOT_DRAWN`]).
    fn code(self) -> u32 {
        self.level * 2 + u32::from(self.two)
    }

    fn from_code(code: u32) -> Self {
        Self {
            level: code / 2,
            two: code % 2 == 1,
        }
    }

    /// The coarsest of them.
    fn last(self) -> u32 {
        self.level + u32::from(self.two)
    }

    /// Whether these levels include all of `other`'s: a copy of these serves frames that want
    /// those (`main_levels`: a ray that wants only the coarser level starts in it).
    fn covers(self, other: Self) -> bool {
        self.level <= other.level && other.last() <= self.last()
    }

    /// The levels of both, where they make one level or two adjacent ones.
    fn union(self, other: Self) -> Option<Self> {
        let (first, last) = (self.level.min(other.level), self.last().max(other.last()));
        (last - first <= 1).then_some(Self {
            level: first,
            two: last > first,
        })
    }

    /// The levels the page table copies, if any.
    fn copied(table: &voxscope_stream::PageTable) -> Option<Self> {
        let (level, levels) = table.copied_level()?;
        Some(Self {
            level,
            two: levels == 2,
        })
    }

    /// The bricks of the level and of the next coarser one (0 where it is not walked).
    fn bricks(self, shape: &voxscope_stream::PyramidShape) -> Option<[usize; 2]> {
        let bricks = |level: u32| {
            (shape.levels.get(level as usize)).map(|level| level.brick_count() as usize)
        };
        Some([
            bricks(self.level)?,
            if self.two { bricks(self.level + 1)? } else { 0 },
        ])
    }
}

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
}

/// The level a ray wants where its footprint is `footprint` finest-level voxels: the coarsest
/// from `finest` on whose voxel is no larger (`stream.wgsl`'s `wanted_level`).
fn wanted_level(shape: &voxscope_stream::PyramidShape, finest: usize, footprint: f32) -> usize {
    let mut level = finest;
    while level + 1 < shape.levels.len() && shape.levels[level + 1].scale as f32 <= footprint {
        level += 1;
    }
    level
}

/// Slots an atlas of `budget` bytes holds (after the renderer's other buffers), bounded by
/// what the pyramid can use and the device's 3D texture size; as a grid of slots.
fn atlas_grid(
    context: &GpuContext,
    budget: u64,
    staging_bytes: u64,
    slot_bytes: u64,
    bricks_in_pyramid: u64,
) -> Result<[usize; 3], RenderError> {
    // The lookup table, the request buffer and its set, each readback's copy of the requests
    // (the usage marks are counted per slot), and the uploads' staging on the GPU (with the
    // level copy's buffer).
    let fixed = staging_bytes
        + 65536 * 4
        + (1 + REQUEST_CAPACITY as u64 + REQUEST_SET as u64) * 4
        + READBACKS as u64 * (1 + REQUEST_CAPACITY as u64) * 4;
    let per_slot = slot_bytes + TABLE_BYTES_PER_SLOT + 4 + READBACKS as u64 * 4;
    let max_side = (context.limits.max_texture_dimension_3d as usize / PADDED_BRICK).min(1024);
    let slots = (budget.saturating_sub(fixed) / per_slot)
        .min((max_side * max_side * max_side) as u64) as usize;
    // Every brick of the pyramid and the streamer's margin where the budget allows, in whole
    // layers of a square grid.
    let wanted = slots.min(bricks_in_pyramid.saturating_add(8).min(usize::MAX as u64) as usize);
    let side = ((wanted as f64).cbrt().floor() as usize).clamp(1, max_side);
    let mut depth = wanted.div_ceil(side * side);
    if side * side * depth > slots {
        depth = slots / (side * side);
    }
    let depth = depth.clamp(1, max_side);
    let grid = [side, side, depth];
    if side * side * depth > slots {
        return Err(RenderError::DoesNotFit(format!(
            "a GPU budget of {budget} bytes holds no atlas (a brick takes {slot_bytes} bytes)"
        )));
    }
    Ok(grid)
}

/// The GPU budgets a budget-limited view's status may name: from 1 MiB on, each power of two
/// and the step halfway to the next (64, 96, 128, 192 MiB, …); the app offers those from
/// 64 MiB to 16 GiB.
pub const BUDGET_STEPS: [u64; 50] = {
    let mut steps = [0u64; 50];
    let mut i = 0;
    while i < 25 {
        steps[2 * i] = 1 << (20 + i);
        steps[2 * i + 1] = 3 << (19 + i);
        i += 1;
    }
    steps
};

/// How a GPU budget becomes this volume's atlas, as [`StreamVolume::new`] makes it: to size
/// the budget a view larger than the atlas would need.
#[derive(Debug, Clone, Copy)]
struct AtlasSizing {
    /// The budget the atlas was made in: a larger one is named, never this or less.
    budget: u64,
    slot_bytes: u64,
    bricks_in_pyramid: u64,
    /// Bricks a frame uploads through the scattering ring, whose buffer the budget holds,
    /// where the options ask for it and the device can (`None`: the ring copies, out of no
    /// share of the budget).
    scatter_per_frame: Option<usize>,
    /// The level copy's bytes where the options ask for the level walk (else 0).
    level_cells_bytes: u64,
    /// Bricks of the always-resident levels, which every atlas must hold with a view.
    pinned_levels: usize,
    /// Slots of the always-resident levels once read (a uniform one takes none).
    pinned: usize,
}

/// What [`AtlasSizing::plan`] chose for a budget: the atlas's grid of slots, and whether the
/// scattering ring's staging and the level copy took their bytes from the budget.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct AtlasPlan {
    grid: [usize; 3],
    scatter: bool,
    level_walk: bool,
}

impl AtlasSizing {
    /// The atlas a budget of `budget` bytes gives: with the scattering ring's staging and the
    /// level copy out of the budget; where the rest cannot hold the always-resident levels and
    /// a view ([`Streamer::check_capacity`]), without the staging (the ring copies, needing
    /// none); where even then it cannot, without the level walk too (its copy's bytes).
    fn plan(&self, context: &GpuContext, budget: u64) -> Result<AtlasPlan, RenderError> {
        let staging = self
            .scatter_per_frame
            .and_then(|most| staging_ring::scatter_size(most, self.slot_bytes as usize, budget))
            .map(|(_, bytes)| bytes);
        let steps = [
            staging.map(|bytes| (bytes, true, self.level_cells_bytes > 0)),
            Some((0, false, self.level_cells_bytes > 0)),
            Some((0, false, false)),
        ];
        let mut last = None;
        for (staging_bytes, scatter, level_walk) in steps.into_iter().flatten() {
            let cells = if level_walk {
                self.level_cells_bytes
            } else {
                UNWALKED_LEVEL_CELLS_BYTES
            };
            let fitted = atlas_grid(
                context,
                budget,
                staging_bytes + cells,
                self.slot_bytes,
                self.bricks_in_pyramid,
            )
            .and_then(|grid| {
                Streamer::check_capacity(self.pinned_levels, grid.iter().product())
                    .map_err(RenderError::DoesNotFit)?;
                Ok(grid)
            });
            match fitted {
                Ok(grid) => {
                    return Ok(AtlasPlan {
                        grid,
                        scatter,
                        level_walk,
                    });
                }
                Err(error) => last = Some(error),
            }
        }
        Err(last.expect("the last step is always tried"))
    }

    /// Of the atlas a budget of `budget` bytes gives ([`Self::plan`]), the slots a view may
    /// fill ([`view_slots`]) and all its slots; `None` where it holds no atlas.
    fn slots(&self, context: &GpuContext, budget: u64) -> Option<(usize, usize)> {
        let plan = self.plan(context, budget).ok()?;
        let slots = plan.grid.iter().product::<usize>();
        Some((view_slots(slots, self.pinned), slots))
    }

    /// The smallest of [`BUDGET_STEPS`] above the budget in use whose atlas holds a view of
    /// `needed` bricks at full detail, with the coarser bricks its refinement loads on the
    /// way (an eighth more for each finer level: a seventh in all), or every brick of the
    /// pyramid; where none does, more than the largest atlas this device makes.
    fn full_detail_budget(&self, context: &GpuContext, needed: usize) -> FullDetailBudget {
        let wanted = needed + needed.div_ceil(7);
        BUDGET_STEPS
            .into_iter()
            .filter(|&budget| budget > self.budget)
            .find(|&budget| {
                self.slots(context, budget).is_some_and(|(view, slots)| {
                    view >= wanted || slots as u64 >= self.bricks_in_pyramid
                })
            })
            .map_or(FullDetailBudget::BeyondDevice, FullDetailBudget::Bytes)
    }
}

/// `visible_below[i]`: how many value levels below `i` the lookup table makes visible.
fn visible_below(table: &[u32]) -> Vec<u32> {
    let mut counts = Vec::with_capacity(table.len() + 1);
    let mut count = 0u32;
    counts.push(0);
    for &color in table {
        count += (color >> 24 != 0) as u32;
        counts.push(count);
    }
    counts
}

/// How an atlas on `context`'s device stores value levels up to `max_level`: a byte where
/// they fit in one, else two (normalized where the device filters such textures).
fn atlas_texels(context: &GpuContext, max_level: u16) -> AtlasTexels {
    if max_level <= 255 {
        AtlasTexels::Unorm8
    } else if context.has_norm16_textures {
        AtlasTexels::Unorm16
    } else {
        AtlasTexels::Float16
    }
}

/// The atlas texture's format for `texels`.
fn atlas_format(texels: AtlasTexels) -> wgpu::TextureFormat {
    match texels {
        AtlasTexels::Unorm8 => wgpu::TextureFormat::R8Unorm,
        AtlasTexels::Unorm16 => wgpu::TextureFormat::R16Unorm,
        AtlasTexels::Float16 => wgpu::TextureFormat::R16Float,
    }
}

/// The formats an atlas on `context`'s device may have: a byte's, and two bytes'.
pub(crate) fn atlas_formats(context: &GpuContext) -> [wgpu::TextureFormat; 2] {
    [0, u16::MAX].map(|max_level| atlas_format(atlas_texels(context, max_level)))
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
        let bricks: u64 = source.shape().levels.iter().map(|l| l.brick_count()).sum();
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
        // The flat copy of one level, or of one and the next coarser one (none kept without
        // the level walk: one entry bound).
        let levels = &source.shape().levels;
        let level_cells_bytes = (0..levels.len())
            .flat_map(|l| {
                let one = levels[l].brick_count();
                [
                    Some(one),
                    levels.get(l + 1).map(|next| one + next.brick_count()),
                ]
            })
            .flatten()
            .filter(|&bricks| options.level_walk && bricks <= LEVEL_WALK_BRICKS)
            .max()
            .unwrap_or(1)
            .max(1)
            * std::mem::size_of::<TableEntry>() as u64;
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
            level_cells_bytes: if options.level_walk {
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
        let options = StreamOptions {
            level_walk: options.level_walk && plan.level_walk,
            ..options
        };
        let mut streamer = Streamer::new(Arc::clone(&source), grid, texels, options, visible)
            .map_err(RenderError::DoesNotFit)?;
        let level_cells_bytes = if streamer.options().level_walk {
            level_cells_bytes
        } else {
            UNWALKED_LEVEL_CELLS_BYTES
        };
        let device = &context.device;
        let out_of_memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let size = wgpu::Extent3d {
            width: (grid[0] * PADDED_BRICK) as u32,
            height: (grid[1] * PADDED_BRICK) as u32,
            depth_or_array_layers: (grid[2] * PADDED_BRICK) as u32,
        };
        let atlas_desc = wgpu::TextureDescriptor {
            label: Some("voxscope::stream_atlas"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format,
            usage: wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_DST
                | ATLAS_READ_BACK
                | if scatter.is_some() {
                    wgpu::TextureUsages::STORAGE_BINDING
                } else {
                    wgpu::TextureUsages::empty()
                },
            view_formats: &[],
        };
        // Where the scatter pass can write the atlas, a GPU's atlas is made without wgpu's zero
        // fill and a pass zeroes it instead (`write`, before the first uploads). A CPU
        // (lavapipe) stores texels from a shader more slowly than it copies them (80 ms against
        // a few for 17 M texels), and its next submission waits for that: wgpu fills it there.
        let zeroes_itself = scatter.is_some()
            && match options.atlas_zero {
                AtlasZero::Auto => context.adapter_info.device_type != wgpu::DeviceType::Cpu,
                AtlasZero::Shader => true,
                AtlasZero::Wgpu => false,
            };
        // SAFETY: no texel is read before the zero pass: every sample is of a brick the page
        // table (or its level copy) says is in the atlas, and the first `write` submits the
        // pass before its uploads, the first that put one there; the format is one the device
        // writes from a shader (`atlas_storage_formats`, as the scatter needs).
        let uncleared = if zeroes_itself {
            unsafe { uncleared_texture(device, &atlas_desc) }
        } else {
            None
        };
        let (atlas, uncleared) = match uncleared {
            Some(Ok(atlas)) => (atlas, true),
            Some(Err(OutOfMemory)) => {
                return Err(RenderError::DoesNotFit(
                    "the GPU has no room for the streaming atlas: out of memory".to_owned(),
                ));
            }
            None => (device.create_texture(&atlas_desc), false),
        };
        let atlas_view = atlas.create_view(&wgpu::TextureViewDescriptor::default());
        let slots = grid.iter().product::<usize>();
        let table = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::stream_page_table"),
            size: (streamer.table().capacity() * std::mem::size_of::<TableEntry>()) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let requests = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::stream_requests"),
            size: (1 + REQUEST_CAPACITY as u64 + REQUEST_SET as u64) * 4,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let usage = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::stream_usage"),
            size: slots as u64 * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let level_cells = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::stream_level_cells"),
            size: level_cells_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let readback_bytes = (1 + REQUEST_CAPACITY as u64 + slots as u64) * 4;
        let readbacks = (0..READBACKS)
            .map(|_| Readback {
                buffer: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("voxscope::stream_readback"),
                    size: readback_bytes,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                frame: 0,
                state: Arc::new(AtomicU8::new(IDLE)),
            })
            .collect();
        let transfer_table = GpuTransferTable::new(context, quantization, transfer);
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
            table,
            transfer: transfer_table,
            requests,
            usage,
            readbacks,
            level_cells,
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
            .map_err(RenderError::DoesNotFit)?;
        self.unwritten.extend(pinned);
        self.sizing.pinned = self.streamer.pinned_slots();
        Ok(())
    }

    /// Writes `uploads` into their atlas slots (through the staging ring, the rest through the
    /// queue while no ring buffer is mapped) and the page table's changed entries; tells the
    /// streamer what that cost.
    fn write(&mut self, context: &GpuContext, uploads: &[Upload]) {
        if std::mem::take(&mut self.unzeroed) {
            // On the frame's thread: an app's loading thread, which made the volume, submits
            // nothing to the window's device (docs/architecture.md).
            let mut encoder =
                context
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("voxscope::stream_atlas_zero"),
                    });
            let zeroed = self.ring.zero_atlas(&mut encoder);
            assert!(zeroed, "an atlas zeroes itself only with a scattering ring");
            context.queue.submit([encoder.finish()]);
            self.skip_upload_rate = true;
        }
        let started = Instant::now();
        let side = PADDED_BRICK as u32;
        let [gx, gy, _] = self.atlas_grid.map(|g| g as u32);
        let origin = |slot: u32| wgpu::Origin3d {
            x: (slot % gx) * side,
            y: ((slot / gx) % gy) * side,
            z: (slot / (gx * gy)) * side,
        };
        let mut parts = UploadParts::default();
        let mut staged = Vec::new();
        if !uploads.is_empty() {
            let bricks: Vec<StagedBrick<'_>> = uploads
                .iter()
                .take(self.ring.bricks_per_buffer())
                .map(|upload| StagedBrick {
                    texels: &upload.texels,
                    origin: origin(upload.slot),
                })
                .collect();
            let mut encoder =
                context
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("voxscope::stream_uploads"),
                    });
            let timing = self.copy_timer.as_mut().and_then(|t| t.begin(&mut encoder));
            let staging = self.ring.stage(&mut encoder, &self.atlas, &bricks);
            staged = staging.staged;
            parts.ring_copies = staging.copies as u64;
            parts.scatter_dispatches = staging.dispatches as u64;
            parts.staging_seconds = staging.staging_seconds;
            let submitting = Instant::now();
            if staged.contains(&true) {
                if let (Some(timer), Some(timing)) = (self.copy_timer.as_mut(), timing) {
                    let bytes = bricks
                        .iter()
                        .zip(&staged)
                        .filter(|(_, staged)| **staged)
                        .map(|(brick, _)| brick.texels.len() as u64)
                        .sum();
                    timer.end(&mut encoder, timing, bytes);
                }
                context.queue.submit([encoder.finish()]);
                self.ring.submitted();
                if let Some(timer) = self.copy_timer.as_mut() {
                    timer.submitted();
                }
            }
            parts.submit_seconds = staging.record_seconds + submitting.elapsed().as_secs_f64();
        }
        let queueing = Instant::now();
        staged.resize(uploads.len(), false);
        let to_queue = uploads.iter().zip(&staged).filter(|(_, staged)| !**staged);
        for (upload, _) in to_queue {
            context.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &self.atlas,
                    mip_level: 0,
                    origin: origin(upload.slot),
                    aspect: wgpu::TextureAspect::All,
                },
                &upload.texels,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(side * self.texels.bytes() as u32),
                    rows_per_image: Some(side),
                },
                wgpu::Extent3d {
                    width: side,
                    height: side,
                    depth_or_array_layers: side,
                },
            );
        }
        parts.queue_seconds = queueing.elapsed().as_secs_f64();
        parts.ring_bricks = staged.iter().filter(|&&s| s).count() as u64;
        parts.queue_bricks = uploads.len() as u64 - parts.ring_bricks;
        // The first uploads after the zero pass count their time but set no rate.
        let skip_rate = !uploads.is_empty() && std::mem::take(&mut self.skip_upload_rate);
        let bytes: u64 = if skip_rate {
            0
        } else {
            uploads.iter().map(|u| u.texels.len() as u64).sum()
        };
        self.streamer
            .set_upload_cost(bytes, started.elapsed().as_secs_f64(), &parts);
        let entry_bytes = std::mem::size_of::<TableEntry>() as u64;
        for (start, entries) in self.streamer.table_mut().take_dirty() {
            context.queue.write_buffer(
                &self.table,
                start as u64 * entry_bytes,
                bytemuck::cast_slice(entries),
            );
        }
        if let Some((start, cells)) = self.streamer.table_mut().take_level_dirty() {
            context.queue.write_buffer(
                &self.level_cells,
                start as u64 * entry_bytes,
                bytemuck::cast_slice(cells),
            );
        }
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

    /// The level every ray of a frame of `params` wants wherever it meets the volume (the
    /// pixel LOD's, `wanted_level` in `stream.wgsl`), or the two levels (one and the next
    /// coarser) between which every ray's wanted level lies, where the page table may copy them
    /// flat (at most [`LEVEL_WALK_BRICKS`] bricks); `None` where rays want more levels. Worked
    /// out from the depths of the volume box's corners and the widest pixel's footprint, with a
    /// margin, so that it never leaves out a level some ray would want.
    fn walk_level(&self, params: &RaycastParams) -> Option<WalkLevels> {
        if !self.streamer.options().level_walk {
            return None;
        }
        let shape = self.streamer.shape();
        let finest = shape.depth().saturating_sub(params.max_level) as usize;
        let per_depth = params.lod_factor * self.streamer.options().lod_scale.max(0.0);
        let level = if per_depth > 0.0 {
            // A point's depth (its ray's t: the world distance along the image center's
            // direction) is linear in its voxel coordinates; a ray's footprint at depth t is
            // t · its world length · `per_depth`, the world length 1 at the center and largest
            // at the image's corners.
            let vector = |v: [f32; 4]| glam::Vec3::new(v[0], v[1], v[2]);
            let camera = glam::Mat3::from_cols(
                vector(params.forward),
                vector(params.right),
                vector(params.up),
            );
            if camera.determinant().abs() < 1e-20 {
                return None;
            }
            let depth_of = camera.inverse().row(0);
            let eye = vector(params.eye);
            let dims = vector(params.volume);
            let depths = (0..8).map(|corner| {
                let select = glam::Vec3::new(
                    (corner & 1) as f32,
                    (corner >> 1 & 1) as f32,
                    (corner >> 2 & 1) as f32,
                );
                depth_of.dot(dims * select - eye)
            });
            let (nearest, farthest) = depths.fold((f32::MAX, f32::MIN), |(lo, hi), depth| {
                (lo.min(depth), hi.max(depth))
            });
            let widest = (1.0 + params.right[3].powi(2) + params.up[3].powi(2)).sqrt();
            let level = wanted_level(shape, finest, nearest.max(0.0) * per_depth * 0.999);
            let far = wanted_level(
                shape,
                finest,
                farthest.max(0.0) * widest * per_depth * 1.001,
            );
            let two = match far.checked_sub(level)? {
                0 => false,
                1 => true,
                _ => return None,
            };
            WalkLevels {
                level: level as u32,
                two,
            }
        } else {
            WalkLevels {
                level: finest as u32,
                two: false,
            }
        };
        let bricks: usize = level.bricks(shape)?.iter().sum();
        (bricks as u64 <= LEVEL_WALK_BRICKS).then_some(level)
    }

    /// The levels a frame of `params` walks (`main_level`, `main_levels`): those the table
    /// copies, where they include [`Self::walk_level`]'s and every brick of them there is
    /// walkable in the frame's mode.
    fn walked_level(&self, params: &RaycastParams) -> Option<WalkLevels> {
        let table = self.streamer.table();
        let copied = WalkLevels::copied(table)?;
        let walkable = table.level_unwalkable(max_projection(params)) == Some(0);
        (walkable && copied.covers(self.walk_level(params)?)).then_some(copied)
    }

    /// The finest level whose bricks the page table copies flat (every ray of the latest frame
    /// wanted it, or it and the next coarser one), how many levels it copies (1 or 2), and how
    /// many of their bricks the level walk could not take in that frame's mode: 0 when frames
    /// walk them. `None` where rays want more levels, or levels too large to copy.
    pub fn walk_level_state(&self) -> Option<(u32, u32, usize)> {
        let table = self.streamer.table();
        let mip = self.max_projection.load(Ordering::Acquire);
        let (level, levels) = table.copied_level()?;
        Some((level, levels, table.level_unwalkable(mip)?))
    }

    /// How many frames (a band of one counts too) the level walk has drawn.
    pub fn level_walk_frames(&self) -> u64 {
        self.walked_frames.load(Ordering::Relaxed)
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
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
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

/// The streaming ray caster's pipelines (plain, shaded, probe, clipped variants), one per
/// device ([`GpuContext::stream_raycaster`]).
pub struct StreamRaycaster {
    pipelines: VariantPipelines,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    /// For labels, or with trilinear filtering off.
    nearest: wgpu::Sampler,
    stand_ins: StandIns,
}

impl StreamRaycaster {
    /// Builds the plain pipeline; [`GpuContext::stream_raycaster`] does, once per device.
    pub(crate) fn new(context: &GpuContext) -> Self {
        let (pipelines, layout) = VariantPipelines::new(
            context,
            "stream",
            super::shaders::STREAM,
            &["main", "main_level", "main_levels"],
            &[
                uniform_entry(0, false),
                uniform_entry(1, false),
                storage_entry(2, true),
                output_image_entry(3),
                storage_entry(4, false),
                atlas_entry(5),
                atlas_sampler_entry(6),
                storage_entry(7, true),
                storage_entry(8, false),
                storage_entry(9, false),
                storage_entry(10, false),
                storage_entry(11, true),
            ],
        );
        Self {
            pipelines,
            layout,
            sampler: clamped_sampler(
                &context.device,
                wgpu::FilterMode::Linear,
                "voxscope::stream_sampler",
            ),
            nearest: clamped_sampler(
                &context.device,
                wgpu::FilterMode::Nearest,
                "voxscope::stream_nearest",
            ),
            stand_ins: StandIns::new(context),
        }
    }

    /// Builds, where not built yet, the pipelines of `variant`: the segment loop's, and the
    /// level walk's where frames of `variant` may walk (not probes; `level_walk` on).
    pub(crate) fn prepare(&self, context: &GpuContext, variant: Variant, level_walk: bool) {
        self.pipelines.get(context, SEGMENTS, variant);
        if level_walk && !variant.probe {
            self.pipelines.get(context, LEVEL_WALK, variant);
            self.pipelines.get(context, LEVELS_WALK, variant);
        }
    }
}

impl RayPass<StreamVolume> for StreamRaycaster {
    const NAME: &'static str = "stream";

    fn pipelines(&self) -> &VariantPipelines {
        &self.pipelines
    }

    fn stand_ins(&self) -> &StandIns {
        &self.stand_ins
    }

    /// The level walk where every ray wants one level and the table can show that the walk
    /// takes each of its bricks ([`StreamVolume::walked_level`]), else segment by segment.
    fn entry_point(&self, volume: &StreamVolume, params: &RaycastParams) -> usize {
        match volume.walked_level(params) {
            Some(walk) if walk.two => LEVELS_WALK,
            Some(_) => LEVEL_WALK,
            None => SEGMENTS,
        }
    }

    /// Segment by segment: the level walk draws frames only.
    fn probe_entry_point(&self, _volume: &StreamVolume, _params: &RaycastParams) -> usize {
        SEGMENTS
    }

    /// Each segment picks its own level from the page table: no coarse variant; the `LABELS`
    /// one for a label volume.
    fn variant(&self, base: Variant, params: &RaycastParams) -> Variant {
        Variant {
            labels: params.flags & FLAG_LABELS != 0,
            ..base
        }
    }

    /// Notes the camera (the load order follows it) and that a frame was drawn (its requests
    /// are read back). Probes ask for nothing.
    fn before_frame(&self, volume: &StreamVolume, params: &RaycastParams) {
        let forward = glam::Vec3::from_slice(&params.forward[..3]).normalize_or_zero();
        *volume.view.lock().unwrap_or_else(|p| p.into_inner()) = Some(ViewPoint {
            eye: [params.eye[0], params.eye[1], params.eye[2]].map(f64::from),
            forward: forward.to_array().map(f64::from),
        });
        volume
            .max_projection
            .store(max_projection(params), Ordering::Release);
        // Panes of different max levels on one volume want different levels: two adjacent
        // ones are copied together, else none (copying each in turn would rebuild the copy at
        // every step).
        let wanted = volume.walk_level(params).map_or(NO_LEVEL, WalkLevels::code);
        let _ = volume
            .walk_wanted
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |drawn| match drawn {
                NOT_DRAWN => Some(wanted),
                same if same == wanted => None,
                NO_LEVEL => None,
                _ if wanted == NO_LEVEL => Some(NO_LEVEL),
                other => Some(
                    WalkLevels::from_code(other)
                        .union(WalkLevels::from_code(wanted))
                        .map_or(NO_LEVEL, WalkLevels::code),
                ),
            });
        if volume.walked_level(params).is_some() {
            volume.walked_frames.fetch_add(1, Ordering::Relaxed);
            volume
                .walk_drew
                .store(volume.streamer.frame(), Ordering::Release);
        }
        volume.drawn.store(true, Ordering::Release);
    }

    fn bind_group(
        &self,
        context: &GpuContext,
        volume: &StreamVolume,
        params: &RaycastParams,
        settings: &RenderSettings,
        target: &RenderTarget,
        probe: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let device = &context.device;
        let sampler = if volume.filters(settings) {
            &self.sampler
        } else {
            &self.nearest
        };
        let params_buffer = frame_params_buffer(context, "voxscope::stream_params", params);
        let stream_params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("voxscope::stream_level_params"),
            contents: bytemuck::bytes_of(&volume.stream_params(params)),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        numbered_bind_group(
            device,
            "voxscope::stream_bind_group",
            &self.layout,
            &[
                params_buffer.as_entire_binding(),
                stream_params.as_entire_binding(),
                volume.transfer.buffer.as_entire_binding(),
                wgpu::BindingResource::TextureView(&target.view),
                target.visits.as_entire_binding(),
                wgpu::BindingResource::TextureView(&volume.atlas_view),
                wgpu::BindingResource::Sampler(sampler),
                volume.table.as_entire_binding(),
                volume.requests.as_entire_binding(),
                volume.usage.as_entire_binding(),
                probe.as_entire_binding(),
                volume.level_cells.as_entire_binding(),
            ],
        )
    }
}

/// The streaming renderer: driven once a frame ([`Renderer::update`]), drawn and probed by the
/// device's [`StreamRaycaster`] with whatever is resident.
impl Renderer for StreamVolume {
    fn kind(&self) -> RendererKind {
        RendererKind::Stream
    }

    fn level_detail(&self, max_level: u32) -> LevelDetail {
        let depth = self.depth();
        level_detail(
            depth,
            self.dims(),
            depth.saturating_sub(max_level),
            max_level,
        )
    }

    /// The whole frame, whatever `region` asks: a frame's requests and usage marks are of all
    /// its rays ([`Renderer::draws_regions`] is false).
    fn encode_region(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        pass: FramePass<'_>,
    ) {
        pass.of_whole_target()
            .encode_with(context.stream_raycaster(), context, encoder, self);
    }

    fn encode_probe(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        probe: &ProbeTarget<'_>,
    ) -> bool {
        encode_probe_ray(context.stream_raycaster(), context, encoder, self, probe);
        true
    }

    fn set_transfer(
        &mut self,
        context: &GpuContext,
        _encoder: &mut wgpu::CommandEncoder,
        transfer: &TransferFunction,
        _timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<(), RenderError> {
        self.apply_transfer(context, transfer);
        Ok(())
    }

    fn prepare_pipelines(&self, context: &GpuContext, settings: &RenderSettings, probe: bool) {
        for variant in pipeline_variants(settings, probe, false, self.labels()) {
            context.stream_raycaster().prepare(
                context,
                variant,
                self.streamer.options().level_walk,
            );
        }
    }

    /// Together within the budget given.
    fn gpu_bytes(&self) -> Vec<(&'static str, u64)> {
        vec![
            ("atlas", self.atlas_bytes),
            ("page_table", self.table.size()),
            ("requests", self.requests.size()),
            ("usage", self.usage.size()),
            (
                "readback",
                self.readbacks.iter().map(|r| r.buffer.size()).sum(),
            ),
            ("lookup_table", self.transfer.size()),
            ("upload_staging", self.ring.gpu_bytes()),
            ("level_cells", self.level_cells.size()),
        ]
    }

    fn update(&mut self, context: &GpuContext) -> Option<StreamStatus> {
        Some(self.step(context))
    }

    fn stream(&self) -> Option<&StreamVolume> {
        Some(self)
    }

    fn stream_mut(&mut self) -> Option<&mut StreamVolume> {
        Some(self)
    }
}

#[cfg(test)]
mod tests {
    use std::collections::HashSet;

    use super::*;
    use crate::raycaster::raycast_params;
    use crate::staging_ring::tests::read_atlas;
    use crate::{Camera, RenderSettings};
    use voxscope_stream::{Downsampling, ENTRY_VISIBLE, MemorySource};
    use voxscope_volume::{Quantization, ValueWindow};

    #[test]
    fn walked_levels_cover_and_join_only_adjacent_levels() {
        let one = |level| WalkLevels { level, two: false };
        let two = |level| WalkLevels { level, two: true };
        for walk in [one(0), two(0), one(7), two(14)] {
            assert_eq!(WalkLevels::from_code(walk.code()), walk);
            assert!(walk.code() < NOT_DRAWN && walk.code() < NO_LEVEL);
        }
        assert!(two(3).covers(one(3)) && two(3).covers(one(4)) && two(3).covers(two(3)));
        assert!(!two(3).covers(one(5)) && !two(3).covers(two(4)) && !one(3).covers(two(3)));
        assert_eq!(one(3).union(one(4)), Some(two(3)));
        assert_eq!(one(4).union(two(3)), Some(two(3)));
        assert_eq!(one(3).union(one(3)), Some(one(3)));
        assert_eq!(one(3).union(one(5)), None);
        assert_eq!(two(3).union(one(5)), None);
    }

    /// The levels the rays of a frame of `params` want, from the nearest to the farthest point
    /// any ray meets (`stream.wgsl`'s `wanted_level` at each pixel ray's entry and exit).
    fn levels_rays_want(volume: &StreamVolume, params: &RaycastParams) -> Option<(u32, u32)> {
        let shape = volume.streamer.shape();
        let finest = shape.depth().saturating_sub(params.max_level) as usize;
        let per_t = params.lod_factor * volume.streamer.options().lod_scale;
        let wanted = |footprint: f32| wanted_level(shape, finest, footprint) as u32;
        let v = |a: [f32; 4]| glam::Vec3::new(a[0], a[1], a[2]);
        let [width, height] = params.image_size;
        let mut levels: Option<(u32, u32)> = None;
        for y in 0..height {
            for x in 0..width {
                let ndc_x = 2.0 * (x as f32 + 0.5) / width as f32 - 1.0;
                let ndc_y = 1.0 - 2.0 * (y as f32 + 0.5) / height as f32;
                let dir = v(params.forward) + ndc_x * v(params.right) + ndc_y * v(params.up);
                let length =
                    (1.0 + (ndc_x * params.right[3]).powi(2) + (ndc_y * params.up[3]).powi(2))
                        .sqrt();
                // The ray through the box [0, dims], from the eye on.
                let (mut enter, mut leave) = (0.0f32, f32::MAX);
                for axis in 0..3 {
                    let (origin, step) = (params.eye[axis], dir[axis]);
                    if step.abs() < 1e-12 {
                        if origin < 0.0 || origin > params.volume[axis] {
                            leave = -1.0;
                        }
                        continue;
                    }
                    let (a, b) = ((0.0 - origin) / step, (params.volume[axis] - origin) / step);
                    enter = enter.max(a.min(b));
                    leave = leave.min(a.max(b));
                }
                if enter >= leave {
                    continue;
                }
                let (near, far) = (
                    wanted(enter * length * per_t),
                    wanted(leave * length * per_t),
                );
                levels = Some(levels.map_or((near, far), |(lo, hi)| (lo.min(near), hi.max(far))));
            }
        }
        levels
    }

    #[test]
    fn the_levels_a_frame_walks_hold_every_level_its_rays_want() {
        let context = GpuContext::new_headless()
            .expect("a GPU adapter (lavapipe: mesa-vulkan-drivers, WGPU_BACKEND=vulkan)");
        // 256×192×96 voxels, twice as long along z: levels 0-3 of 32³ bricks and more.
        let dims = [256, 192, 96];
        let source = MemorySource::from_levels(
            "flat",
            vec![7; dims.iter().product()],
            dims,
            Quantization {
                offset: 0.0,
                step: 1.0,
            },
            [1.0, 1.0, 2.0],
            Downsampling::Mean,
        )
        .expect("a pyramid");
        let options = StreamOptions {
            gpu_memory: 16 << 20,
            ..StreamOptions::default()
        };
        let transfer = TransferFunction::gray(ValueWindow {
            low: 0.0,
            high: 10.0,
        });
        let volume = StreamVolume::new(&context, Arc::new(source), options, &transfer)
            .expect("a streaming volume");
        let (mut one, mut two, mut more) = (0, 0, 0);
        for distance in [0.45, 0.6, 0.8, 1.0, 1.5, 2.2, 3.0, 5.0, 9.0] {
            for (azimuth_deg, elevation_deg) in [(30.0, 20.0), (90.0, 0.0), (200.0, 60.0)] {
                for size in [[64, 48], [160, 120], [320, 240]] {
                    for max_level in [volume.streamer.shape().depth(), 2] {
                        let camera = Camera {
                            distance,
                            azimuth_deg,
                            elevation_deg,
                            ..Camera::default()
                        };
                        let settings = RenderSettings {
                            max_level,
                            ..RenderSettings::full_detail(volume.streamer.shape().depth())
                        };
                        let params = raycast_params(&volume, size, &camera, &settings);
                        let case = format!("{distance} {azimuth_deg}/{elevation_deg} {size:?}");
                        let Some((lo, hi)) = levels_rays_want(&volume, &params) else {
                            continue;
                        };
                        match volume.walk_level(&params) {
                            Some(walk) => {
                                // Never a level a ray wants left out.
                                assert!(
                                    walk.level <= lo && walk.last() >= hi,
                                    "{case}: {walk:?} for rays wanting {lo}-{hi}"
                                );
                                if walk.two {
                                    two += 1;
                                } else {
                                    one += 1;
                                }
                            }
                            // Only where rays want more than two levels (or may: the corners'
                            // depths bound each ray's).
                            None => {
                                assert!(hi > lo, "{case}: no walk for rays wanting {lo}-{hi}");
                                more += 1;
                            }
                        }
                    }
                }
            }
        }
        // Each kind of frame was met.
        assert!(
            one > 0 && two > 0 && more > 0,
            "{one} one-level, {two} two-level, {more} other frames"
        );
    }

    #[test]
    fn an_atlas_made_without_wgpus_fill_reads_zero_wherever_the_first_step_put_no_brick() {
        let context = GpuContext::new_headless()
            .expect("a GPU adapter (lavapipe: mesa-vulkan-drivers, WGPU_BACKEND=vulkan)");
        // Value levels up to 251: an 8-bit atlas, one byte a texel.
        let dims = [96, 64, 40];
        let levels = (0..dims.iter().product::<usize>())
            .map(|i| (i % 251) as u16 + 1)
            .collect();
        let quantization = Quantization {
            offset: 0.0,
            step: 1.0,
        };
        let source = MemorySource::from_levels(
            "ramp",
            levels,
            dims,
            quantization,
            [1.0; 3],
            Downsampling::Mean,
        )
        .expect("a pyramid");
        let options = StreamOptions {
            gpu_memory: 8 << 20,
            atlas_zero: AtlasZero::Shader,
            ..StreamOptions::default()
        };
        let transfer = TransferFunction::gray(ValueWindow {
            low: 0.0,
            high: 252.0,
        });
        let mut volume = StreamVolume::new(&context, Arc::new(source), options, &transfer)
            .expect("a streaming volume");
        assert_eq!(
            volume.atlas_zero(),
            AtlasZero::Shader,
            "lavapipe is Vulkan and writes 8-bit texels from a shader"
        );
        // What the memory may hold: every texel written before the first step.
        let size = volume.atlas.size();
        let texels = (size.width * size.height * size.depth_or_array_layers) as usize;
        context.queue.write_texture(
            volume.atlas.as_image_copy(),
            &vec![0xa5u8; texels],
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(size.width),
                rows_per_image: Some(size.height),
            },
            size,
        );
        volume.step(&context);
        let atlas = read_atlas(&context, &volume.atlas, 1);
        let held: HashSet<u32> = (volume.streamer.table().entries().iter())
            .filter(|entry| entry.is_resident())
            .map(|entry| entry.slot & !ENTRY_VISIBLE)
            .collect();
        let [gx, gy, gz] = volume.atlas_grid;
        let slots = gx * gy * gz;
        assert!(
            !held.is_empty() && held.len() < slots,
            "{} of {slots} slots hold a brick",
            held.len()
        );
        let (width, height) = (size.width as usize, size.height as usize);
        for slot in (0..slots).filter(|&s| !held.contains(&(s as u32))) {
            let corner = [slot % gx, (slot / gx) % gy, slot / (gx * gy)].map(|c| c * PADDED_BRICK);
            for z in 0..PADDED_BRICK {
                for y in 0..PADDED_BRICK {
                    let row = ((corner[2] + z) * height + corner[1] + y) * width + corner[0];
                    assert!(
                        atlas[row..row + PADDED_BRICK].iter().all(|&t| t == 0),
                        "slot {slot} (no brick), row {y} of slice {z}: {:?}",
                        &atlas[row..row + PADDED_BRICK]
                    );
                }
            }
        }
    }
}
