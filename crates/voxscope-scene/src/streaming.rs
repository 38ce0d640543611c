//! Volumes drawn by the streaming renderer where nothing drives frames (the command line, the
//! benchmark, the Python module): opening a pyramid (a procedural one, a Zarr store's own
//! levels, or any readable volume's, whose coarser levels are computed in memory) with its
//! transfer function, and drawing one view until nothing visible is missing.

use std::borrow::Borrow;
use std::sync::Arc;
use std::time::{Duration, Instant};

use voxscope_octree::{Colormap, DataKind, OpacityMode, TransferFunction};
use voxscope_render::{Camera, GpuContext, RenderSettings, RenderTarget, VolumeRenderer};
use voxscope_stream::{
    BrickSource, FailedBrick, FailureGroup, MemorySource, NoiseSource, StillUploads, StreamOptions,
    StreamStatus, UpdatePhases, ZarrSource, group, preview,
};
use voxscope_volume::ome_zarr::Pyramid;
use voxscope_volume::{LoadOptions, QuantizedVolume, ValueWindow, Volume, parse_dims};

use crate::prepare::downsampling_of;
use crate::{SceneError, TransferRequest, VolumeSource, default_window, opening_transfer};

/// Loader threads for a URL's pyramid, at least: each waits on the network most of its time
/// (a region's requests are in flight together, up to `--max-requests`), not on a core.
pub const REMOTE_WORKERS: usize = 8;

/// Bricks of the level read whole for the transfer function's defaults (and, for a store,
/// fetched together before the first frame).
pub const PREVIEW_BRICKS: u64 = 64;

/// A pyramid opened for streaming, and the transfer function to draw it with.
pub struct StreamedVolume {
    pub source: Arc<dyn BrickSource>,
    /// The Zarr pyramid the source reads, where it reads one (its remote counters).
    pub pyramid: Option<Arc<Pyramid>>,
    pub transfer: TransferFunction,
    /// How long opening took (reading a volume and computing its levels, or the preview; and
    /// what was made alongside, [`StreamedVolume::open_alongside`]).
    pub open_seconds: f64,
    /// The coarse level read whole for the transfer function's defaults, its data kind and
    /// default window: what [`Self::transfer_for`] chooses another transfer function from.
    pub preview: QuantizedVolume,
    pub kind: DataKind,
    pub default_window: ValueWindow,
}

/// A pyramid opened for streaming with its stream renderer
/// ([`StreamedVolume::open_with_renderer`]).
pub struct OpenedStream<G> {
    /// The pyramid and its transfer function.
    pub volume: StreamedVolume,
    /// The GPU the renderer was made on.
    pub gpu: G,
    /// Drawing with `volume.transfer`.
    pub renderer: VolumeRenderer,
    /// How long making the renderer took (waiting for the GPU's start included): within
    /// `volume.open_seconds`, where for a store it overlapped the open's last round trip.
    pub renderer_seconds: f64,
    /// After the open: reading the always-resident levels and setting the transfer function.
    pub finish_seconds: f64,
}

impl StreamedVolume {
    /// Opens `source` as a pyramid: `synthetic:noise:SIZE` as procedural noise generated brick
    /// by brick (any size: 16384 is 8 TB of voxels), a Zarr store brick by brick from its own
    /// levels, anything else read into memory ([`Self::from_volume`]). Its transfer function
    /// is [`opening_transfer`]'s for `request`.
    pub fn open(
        source: &VolumeSource,
        options: &LoadOptions,
        request: &TransferRequest,
    ) -> Result<Self, SceneError> {
        Self::open_alongside(source, options, request, |_| ()).map(|(volume, ())| volume)
    }

    /// [`Self::open`] with the stream renderer of the volume (`stream`'s options, as
    /// [`stream_options_for`] gives them to the source), made on the GPU that `gpu` gives
    /// once the source is known: for a store, while its first image's chunks are on their way
    /// ([`Self::open_alongside`]), so that the making (atlas, buffers and staging, and any
    /// pipeline not built yet: tens of milliseconds, more where a driver compiles) overlaps
    /// the open's last round trip. Then the always-resident levels are read from the chunks
    /// the open fetched, and the volume's transfer function is set: this submits to the GPU
    /// (the transfer function's table, the atlas's zeroing) on this thread.
    pub fn open_with_renderer<G: Borrow<GpuContext>>(
        source: &VolumeSource,
        options: &LoadOptions,
        request: &TransferRequest,
        stream: StreamOptions,
        gpu: impl FnOnce() -> Result<G, SceneError>,
    ) -> Result<OpenedStream<G>, SceneError> {
        let (volume, made) = Self::open_alongside(source, options, request, |source| {
            let started = Instant::now();
            let gpu = gpu()?;
            // The transfer function comes from the preview, still on its way: every value is
            // visible until it is set below.
            let renderer = VolumeRenderer::new_stream_unread(
                gpu.borrow(),
                source.clone(),
                stream_options_for(&**source, stream),
                &every_value_visible(),
            )
            .map_err(|e| SceneError::render(source.name(), e))?;
            Ok::<_, SceneError>((gpu, renderer, started.elapsed().as_secs_f64()))
        })?;
        let (gpu, mut renderer, renderer_seconds) = made?;
        let finishing = Instant::now();
        let failed = |e| SceneError::render(volume.source.name(), e);
        renderer.read_pinned().map_err(failed)?;
        let context: &GpuContext = gpu.borrow();
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("voxscope::opening_transfer"),
            });
        renderer
            .set_transfer(context, &mut encoder, &volume.transfer, None)
            .map_err(failed)?;
        context.queue.submit([encoder.finish()]);
        Ok(OpenedStream {
            finish_seconds: finishing.elapsed().as_secs_f64(),
            volume,
            gpu,
            renderer,
            renderer_seconds,
        })
    }

    /// [`Self::open`], calling `alongside` with the volume's brick source as soon as it is
    /// known, on this thread: for a Zarr store, once its metadata is read, while the chunks
    /// of its first image (the preview's and the always-resident levels', in one batch) are
    /// fetched on another; else once the volume is read or its generator made. Its result
    /// comes back with the volume, and its time counts in `open_seconds`.
    pub fn open_alongside<R>(
        source: &VolumeSource,
        options: &LoadOptions,
        request: &TransferRequest,
        alongside: impl FnOnce(&Arc<dyn BrickSource>) -> R,
    ) -> Result<(Self, R), SceneError> {
        let started = Instant::now();
        let spec = source.spec();
        let headered = options.raw.is_none();
        let (mut volume, made) = match spec.strip_prefix("synthetic:noise:") {
            Some(size) if headered => {
                let dims = parse_dims(size).ok_or_else(|| {
                    SceneError::failed(format!(
                        "synthetic:noise:{size}: the size is not N or XxYxZ"
                    ))
                })?;
                let name = format!("synthetic:noise:{size}");
                let source = Arc::new(NoiseSource::new(&name, dims)?);
                let volume = Self::finish(source, None, None, None, request, started)?;
                let made = alongside(&volume.source);
                (volume, made)
            }
            _ if source.zarr_spec().is_some() && headered => {
                // Read region by region from the file's own levels (a folder's or a URL's),
                // never whole.
                let pyramid = Pyramid::open_spec(spec, options.select, options.remote)?;
                let window = pyramid.omero_window();
                let pyramid = Arc::new(pyramid);
                let zarr = Arc::new(ZarrSource::new(pyramid.clone())?);
                let source: Arc<dyn BrickSource> = zarr.clone();
                let made = zarr.warm_first_image_while(PREVIEW_BRICKS, || alongside(&source));
                let volume = Self::finish(source, None, window, Some(pyramid), request, started)?;
                (volume, made)
            }
            _ => {
                let volume = Self::from_volume(source.load_with(options)?, request, started)?;
                let made = alongside(&volume.source);
                (volume, made)
            }
        };
        // What was made alongside is part of the open.
        volume.open_seconds = started.elapsed().as_secs_f64();
        Ok((volume, made))
    }

    /// A volume read whole already (since `started`), its coarser levels computed in memory
    /// (2× mean; max for label volumes): any loader's volume, of any size the RAM holds.
    pub fn from_volume(
        loaded: Volume,
        request: &TransferRequest,
        started: Instant,
    ) -> Result<Self, SceneError> {
        let quantized = QuantizedVolume::new(&loaded);
        Self::from_quantized(&loaded, quantized, request, started)
    }

    /// [`Self::from_volume`] of values quantized already (the Python module's arrays, read
    /// in place); `volume` describes them.
    pub fn from_quantized(
        volume: &Volume,
        quantized: QuantizedVolume,
        request: &TransferRequest,
        started: Instant,
    ) -> Result<Self, SceneError> {
        let kind = DataKind::of_volume(volume, &quantized);
        let source = MemorySource::from_levels(
            &volume.name,
            quantized.levels,
            quantized.dims,
            quantized.quantization,
            volume.spacing,
            downsampling_of(kind),
        )?;
        let window = crate::file_window(volume);
        Self::finish(Arc::new(source), Some(kind), window, None, request, started)
    }

    /// The transfer function of `source` (its kind and window where known, else its preview's)
    /// and the rest of a prepared pyramid.
    fn finish(
        source: Arc<dyn BrickSource>,
        kind: Option<DataKind>,
        window: Option<ValueWindow>,
        pyramid: Option<Arc<Pyramid>>,
        request: &TransferRequest,
        started: Instant,
    ) -> Result<Self, SceneError> {
        let (preview, _) = preview(&*source, PREVIEW_BRICKS)
            .map_err(|e| SceneError::failed(format!("{}: {e}", source.name())))?;
        let kind = kind.unwrap_or_else(|| DataKind::of(&preview, None, false));
        let window = default_window(window, &preview);
        let transfer = opening_transfer(&preview, kind, window, request);
        Ok(Self {
            source,
            pyramid,
            transfer,
            open_seconds: started.elapsed().as_secs_f64(),
            preview,
            kind,
            default_window: window,
        })
    }

    /// The transfer function `request` asks for, chosen as at opening ([`opening_transfer`]
    /// over the preview): a Python `Renderer`'s frame with another preset or window.
    pub fn transfer_for(&self, request: &TransferRequest) -> TransferFunction {
        opening_transfer(&self.preview, self.kind, self.default_window, request)
    }

    /// The stream renderer of this volume (`stream`'s options, as [`stream_options_for`]
    /// gives them to its source) on `gpu`, made now.
    pub fn with_renderer<G: Borrow<GpuContext>>(
        self,
        gpu: G,
        stream: StreamOptions,
    ) -> Result<OpenedStream<G>, SceneError> {
        let started = Instant::now();
        let renderer = VolumeRenderer::new_stream(
            gpu.borrow(),
            self.source.clone(),
            self.stream_options(stream),
            &self.transfer,
        )
        .map_err(|e| SceneError::render(self.source.name(), e))?;
        Ok(OpenedStream {
            volume: self,
            gpu,
            renderer,
            renderer_seconds: started.elapsed().as_secs_f64(),
            finish_seconds: 0.0,
        })
    }

    /// `options` for this source ([`stream_options_for`]).
    pub fn stream_options(&self, options: StreamOptions) -> StreamOptions {
        stream_options_for(&*self.source, options)
    }

    /// The octree depth of the pyramid (levels − 1): the max level's range.
    pub fn depth(&self) -> u32 {
        self.source.shape().depth()
    }
}

/// `options` for `source`: a URL's pyramid gets at least [`REMOTE_WORKERS`] loaders.
pub fn stream_options_for(source: &dyn BrickSource, options: StreamOptions) -> StreamOptions {
    StreamOptions {
        workers: if source.remote_stats().is_some() {
            options.workers.max(REMOTE_WORKERS)
        } else {
            options.workers
        },
        ..options
    }
}

/// A transfer function under which every value is visible (opaque white): a stream
/// renderer's until the volume's own is known.
fn every_value_visible() -> TransferFunction {
    TransferFunction {
        opacity: OpacityMode::Binary,
        window: ValueWindow {
            low: 0.0,
            high: 1.0,
        },
        threshold: 0.0,
        colormap: Colormap::Grays,
    }
}

/// How a view's refinement ended.
pub struct Refinement {
    pub status: StreamStatus,
    /// Frames drawn.
    pub frames: u32,
    pub seconds: f64,
    /// Seconds until the first frame was drawn and finished.
    pub first_frame_seconds: f64,
    /// Nothing visible was missing at the end but what could not be read (else `max_wait`
    /// ran out).
    pub complete: bool,
    /// Every update's error lines (one for the first brick of each cause).
    pub errors: Vec<String>,
    /// The bricks the final view needed and could not have (drawn from the finest coarser
    /// level that could be read): the image is incomplete when there are any.
    pub unreadable: Vec<FailedBrick>,
    /// Bricks that failed besides those (not needed by the final view).
    pub other_failures: usize,
    /// Where the refinement's time went, frame part by frame part.
    pub parts: FrameParts,
}

/// Where a refinement's time went, summed over its frames, in seconds: what bounds a view's
/// completion (`bench --stream`'s near stopped views report it).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct FrameParts {
    /// The streamer's updates (their steps in `phases`).
    pub update: f64,
    /// Recording and submitting the frames' draws.
    pub draw: f64,
    /// Waiting for the GPU to finish each frame (its pass and its uploads' copies).
    pub wait: f64,
    /// Pausing between frames that had nothing to upload while bricks were being loaded.
    pub pause: f64,
    /// The updates' steps, summed.
    pub phases: UpdatePhases,
    /// Frames that uploaded nothing while bricks were queued or being loaded: frames the
    /// loaders were behind.
    pub frames_waiting_for_loads: u32,
}

impl FrameParts {
    /// Adds `other`'s (another refinement's: a tile's).
    pub fn add(&mut self, other: &FrameParts) {
        self.update += other.update;
        self.draw += other.draw;
        self.wait += other.wait;
        self.pause += other.pause;
        self.phases += other.phases;
        self.frames_waiting_for_loads += other.frames_waiting_for_loads;
    }
}

impl Refinement {
    /// `complete at the budget after 16 frames (budget-limited: …)` where the view completed
    /// coarser than full detail because the budget left bricks out ([`describe_budget_limit`]).
    pub fn completed_at_budget(&self) -> Option<String> {
        let limit = describe_budget_limit(&self.status).filter(|_| self.complete)?;
        Some(format!(
            "complete at the budget after {} frames ({limit})",
            self.frames
        ))
    }

    /// What stderr says of the bricks that could not be read: each brick on a line of its own
    /// when there are few, else one summary line per cause; and how many others failed.
    pub fn failure_lines(&self) -> Vec<String> {
        /// Bricks listed one by one, at most.
        const LISTED: usize = 8;
        let mut lines: Vec<String> = if self.unreadable.len() <= LISTED {
            self.unreadable
                .iter()
                .map(|brick| format!("unreadable: {}", brick.error))
                .collect()
        } else {
            group(self.unreadable.iter())
                .iter()
                .map(FailureGroup::describe)
                .collect()
        };
        if self.other_failures > 0 {
            lines.push(format!(
                "{} more bricks could not be read that this view does not need",
                self.other_failures
            ));
        }
        lines
    }
}

/// Draws `camera`'s view into `target` frame after frame (update, draw, wait for the GPU)
/// until nothing visible is missing or `max_wait` has passed. No one watches these frames: a
/// still one uploads every brick ready ([`StillUploads::AllReady`]). While loads are under way
/// and nothing arrived, no frame is drawn (it drew frame after frame, 254 in 31 s on a CPU's
/// Vulkan, for the same image): the streamer is updated every [`IDLE_POLL`] until bricks
/// arrive, the page table changes, bricks wait for room (a frame's feedback frees it or cuts
/// the view to the budget) or no load is left to wait for.
pub fn refine(
    context: &GpuContext,
    renderer: &mut VolumeRenderer,
    target: &RenderTarget,
    camera: &Camera,
    settings: &RenderSettings,
    max_wait: Duration,
) -> Result<Refinement, SceneError> {
    let set_still = |renderer: &mut VolumeRenderer, still| {
        renderer
            .streamer_mut()
            .map(|streamer| streamer.set_still_uploads(still))
    };
    let before = set_still(renderer, StillUploads::AllReady);
    let mut draw = || -> Result<Refinement, SceneError> {
        let started = Instant::now();
        let mut first_frame = None;
        let mut first_frame_seconds = None;
        let mut errors = Vec::new();
        let mut parts = FrameParts::default();
        let mut frames = 0;
        loop {
            let updating = Instant::now();
            let status = renderer
                .update(context)
                .ok_or_else(|| SceneError::failed("refine needs the streaming renderer"))?;
            parts.update += updating.elapsed().as_secs_f64();
            parts.phases += status.phases;
            errors.extend(status.errors.iter().cloned());
            let first = *first_frame.get_or_insert(status.frame);
            // A frame can differ from the last (bricks arrived, the table changed), or it is
            // what moves the streamer on: bricks wait for room that only a frame's feedback
            // frees (or cuts the view to the budget), or no load is under way to wait for.
            let differs = frames == 0
                || status.uploads > 0
                || status.table_changed
                || status.waiting_for_room > 0
                || status.queued + status.loading == 0;
            if differs {
                let drawing = Instant::now();
                renderer.render(context, target, camera, settings);
                let waiting = Instant::now();
                parts.draw += (waiting - drawing).as_secs_f64();
                context
                    .wait_idle()
                    .map_err(|e| SceneError::failed(e.to_string()))?;
                parts.wait += waiting.elapsed().as_secs_f64();
                frames += 1;
            }
            let first_frame_seconds =
                *first_frame_seconds.get_or_insert_with(|| started.elapsed().as_secs_f64());
            let complete = status.complete && status.judged_frame.is_some_and(|f| f >= first);
            if complete || started.elapsed() >= max_wait {
                let (unreadable, failed) =
                    renderer.streamer().map_or((Vec::new(), 0), |streamer| {
                        let unreadable: Vec<FailedBrick> = streamer.unreadable().cloned().collect();
                        (unreadable, streamer.failures().count())
                    });
                return Ok(Refinement {
                    status,
                    frames,
                    seconds: started.elapsed().as_secs_f64(),
                    first_frame_seconds,
                    complete,
                    errors,
                    other_failures: failed.saturating_sub(unreadable.len()),
                    unreadable,
                    parts,
                });
            }
            if !differs {
                let pausing = Instant::now();
                std::thread::sleep(IDLE_POLL);
                parts.pause += pausing.elapsed().as_secs_f64();
            } else if status.uploads == 0 && status.queued + status.loading > 0 {
                parts.frames_waiting_for_loads += 1;
                let pausing = Instant::now();
                std::thread::sleep(Duration::from_millis(1));
                parts.pause += pausing.elapsed().as_secs_f64();
            }
        }
    };
    let refined = draw();
    if let Some(before) = before {
        set_still(renderer, before);
    }
    refined
}

/// How often [`refine`] looks for bricks while none arrive and nothing is drawn.
pub const IDLE_POLL: Duration = Duration::from_millis(2);

/// Where the budget limits the view: `budget-limited: finest level 1, level 2 where least
/// important; the view needs 227 bricks at full detail (a GPU budget of 32 MiB holds it all),
/// 25 fit in 1.9 MiB of atlas`.
pub fn describe_budget_limit(status: &StreamStatus) -> Option<String> {
    let budget = status.budget.as_ref()?;
    Some(format!(
        "{} in {:.1} MiB of atlas",
        budget.describe(),
        (status.counters.slot_bytes * budget.fit as u64) as f64 / (1u64 << 20) as f64
    ))
}

/// `12 bricks missing (level 0: 10, level 1: 2)`.
pub fn describe_missing(status: &StreamStatus) -> String {
    let per_level: Vec<String> = status
        .counters
        .levels
        .iter()
        .enumerate()
        .filter(|(_, l)| l.requested > 0)
        .map(|(level, l)| format!("level {level}: {}", l.requested))
        .collect();
    format!(
        "{} bricks missing ({})",
        status.missing,
        if per_level.is_empty() {
            "none requested".to_owned()
        } else {
            per_level.join(", ")
        }
    )
}
