//! The streaming renderer on the software Vulkan device: after refinement it draws what the
//! in-memory bricks renderer draws, at full resolution when the budget holds the view and at a
//! coarser level (correctly) when it does not, never beyond its GPU budget; it evicts, asks
//! again and takes transfer edits while streaming; a brick that fails to load leaves its
//! region coarser and the rest as it was.

mod support;

use std::sync::{Arc, LazyLock};
use std::time::{Duration, Instant};

use glam::DVec3;
use image::RgbaImage;
use support::http_server::{Faults, FileServer};
use support::reference::{coverage, psnr};
use support::{Prepared, gpu, image_dir};
use voxscope_octree::{BuildOptions, TransferFunction};
use voxscope_render::{
    Camera, GpuContext, RenderSettings, RenderTarget, RendererKind, VolumeRenderer, read_image,
};
use voxscope_stream::{
    AtlasTexels, AtlasZero, BRICK_SIZE, BrickData, BrickError, BrickId, BrickSource, Downsampling,
    FullDetailBudget, Loader, MemorySource, PADDED_BRICK_VOXELS, Priority, PyramidShape, Request,
    RequestQueue, StreamOptions, StreamStatus, Tier, UploadPath, ValueRange, ZarrSource,
    load_brick,
};
use voxscope_volume::ome_zarr::{Pyramid, PyramidOptions};
use voxscope_volume::remote::RemoteOptions;
use voxscope_volume::{
    Histogram, Quantization, QuantizedVolume, SyntheticKind, ValueWindow, Volume,
};

/// Image size of every test (small: lavapipe draws every pixel on the CPU).
const SIZE: (u32, u32) = (192, 160);

/// A 256³ noise volume: 512 bricks at level 0, none uniform, none transparent, so every brick
/// a ray reaches is marched. Shared by the tests of this binary (made once).
static NOISE: LazyLock<Prepared> = LazyLock::new(|| {
    let volume = SyntheticKind::Noise
        .generate([256; 3])
        .expect("synthetic noise");
    Prepared::new(volume, None)
});

/// Its pyramid, computed once.
static PYRAMID: LazyLock<Arc<MemorySource>> = LazyLock::new(|| {
    let prepared = &*NOISE;
    Arc::new(
        MemorySource::new(
            "noise",
            &prepared.quantized,
            prepared.volume.spacing,
            Downsampling::Mean,
        )
        .expect("pyramid"),
    )
});

/// Bytes of level 0's bricks in the atlas (16-bit texels: the noise is f32).
fn level0_bytes() -> u64 {
    PYRAMID.shape().levels[0].brick_count() * (PADDED_BRICK_VOXELS * 2) as u64
}

/// A camera close to one face, so a view needs a part of the volume.
fn close_camera(azimuth: f64) -> Camera {
    Camera {
        azimuth_deg: azimuth,
        elevation_deg: 15.0,
        distance: 1.6,
        fov_y_deg: 30.0,
        pan: [0.0; 3],
    }
}

/// Full detail, see-through (rays go a few bricks deep).
fn settings(depth: u32) -> RenderSettings {
    RenderSettings {
        density: 0.25,
        ..RenderSettings::full_detail(depth)
    }
}

/// Options of a streaming renderer with `gpu_memory` bytes, no pixel LOD (so level 0 is
/// what a view wants, as the bricks renderer draws), two workers.
fn options(gpu_memory: u64) -> StreamOptions {
    StreamOptions {
        gpu_memory,
        ram_cache: 256 << 20,
        upload_bytes_per_frame: 8 << 20,
        uploads: UploadPath::Scatter,
        atlas_zero: AtlasZero::Auto,
        workers: 2,
        lod_scale: 0.0,
        prefetch: false,
        level_walk: true,
        retry_after: Duration::from_secs(3600),
    }
}

/// What a refinement loop saw.
struct Refined {
    image: RgbaImage,
    status: StreamStatus,
    frames: u32,
    /// The most atlas slots in use after any update.
    most_slots_used: usize,
    /// The most bytes uploaded by one update.
    most_upload_bytes: u64,
    /// Every update's error lines.
    errors: Vec<String>,
}

/// Draws `camera`'s view frame after frame (update, draw, wait) until the streamer says nothing
/// visible is missing, then returns the last image. `edit` runs before frame `at`.
fn refine_with(
    context: &GpuContext,
    renderer: &mut VolumeRenderer,
    camera: &Camera,
    settings: &RenderSettings,
    mut edit: impl FnMut(u32, &GpuContext, &mut VolumeRenderer),
) -> Refined {
    let target = RenderTarget::new(context, SIZE.0, SIZE.1);
    let started = Instant::now();
    let (mut most_slots_used, mut most_upload_bytes) = (0, 0);
    let mut errors = Vec::new();
    // The first frame drawn with this view: completeness judged on earlier ones is another
    // view's.
    let mut first_frame = None;
    for frame in 0.. {
        edit(frame, context, renderer);
        let status = renderer.update(context).expect("a streaming renderer");
        let first = *first_frame.get_or_insert(status.frame);
        errors.extend(status.errors.iter().cloned());
        most_slots_used = most_slots_used.max(status.counters.slots_used);
        most_upload_bytes = most_upload_bytes.max(status.upload_bytes);
        assert!(status.counters.slots_used <= status.counters.slots);
        renderer.render(context, &target, camera, settings);
        context.wait_idle().expect("GPU");
        if status.complete && status.judged_frame.is_some_and(|judged| judged >= first) {
            return Refined {
                image: read_image(context, &target).expect("readback"),
                status,
                frames: frame,
                most_slots_used,
                most_upload_bytes,
                errors,
            };
        }
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "not complete after {frame} frames: {status:?}"
        );
        if status.queued + status.loading > 0 && status.uploads == 0 {
            std::thread::sleep(Duration::from_millis(5));
        }
    }
    unreachable!()
}

fn refine(
    context: &GpuContext,
    renderer: &mut VolumeRenderer,
    camera: &Camera,
    settings: &RenderSettings,
) -> Refined {
    refine_with(context, renderer, camera, settings, |_, _, _| {})
}

fn streaming(
    context: &GpuContext,
    source: Arc<dyn BrickSource>,
    options: StreamOptions,
    transfer: &TransferFunction,
) -> VolumeRenderer {
    VolumeRenderer::new_stream(context, source, options, transfer).expect("streaming renderer")
}

fn gpu_total(renderer: &VolumeRenderer) -> u64 {
    renderer.gpu_bytes().iter().map(|(_, bytes)| bytes).sum()
}

/// The bricks renderer's image of `prepared` under `transfer`.
fn bricks_image(
    context: &GpuContext,
    prepared: &Prepared,
    transfer: &TransferFunction,
    camera: &Camera,
    settings: &RenderSettings,
) -> RgbaImage {
    let renderer = VolumeRenderer::new(
        context,
        RendererKind::Bricks,
        &prepared.octree,
        &prepared.quantized,
        prepared.volume.spacing,
        prepared.octree.depth,
        transfer,
    )
    .expect("bricks");
    support::draw(context, &renderer, camera, settings, SIZE)
}

fn save(image: &RgbaImage, name: &str) {
    image
        .save(image_dir().join(format!("stream-{name}.png")))
        .expect("write test image");
}

#[test]
fn a_refined_view_equals_the_bricks_render_with_a_quarter_of_the_bricks_in_budget() {
    let context = gpu();
    let prepared = &*NOISE;
    let budget = level0_bytes() / 4;
    let mut renderer = streaming(
        &context,
        PYRAMID.clone(),
        options(budget),
        &prepared.transfer,
    );
    assert!(
        gpu_total(&renderer) <= budget,
        "{} bytes on the GPU for a budget of {budget}",
        gpu_total(&renderer)
    );
    let camera = close_camera(30.0);
    let settings = settings(prepared.octree.depth);
    let refined = refine(&context, &mut renderer, &camera, &settings);
    let expected = bricks_image(&context, prepared, &prepared.transfer, &camera, &settings);
    save(&refined.image, "refined");
    save(&expected, "refined-bricks");
    let db = psnr(&refined.image, &expected);
    let status = &refined.status;
    eprintln!(
        "refined in {} frames: {db:.1} dB, {} of {} slots at most, budget {:?}, {:?}",
        refined.frames,
        refined.most_slots_used,
        status.counters.slots,
        status.budget,
        status.counters.levels
    );
    assert!(coverage(&expected) > 0.5, "the view shows the volume");
    assert_eq!(
        status.budget, None,
        "the budget holds this view at full resolution"
    );
    assert!(
        status.counters.levels[0].resident > 8,
        "level 0 was streamed"
    );
    assert!(db >= 40.0, "streamed against bricks: {db:.1} dB");
    assert!(
        refined.most_upload_bytes <= 8 << 20,
        "the per-frame upload budget holds"
    );
    assert!(gpu_total(&renderer) <= budget);
    assert!(status.errors.is_empty());

    // Shaded, the same view against the bricks renderer shaded (gradients through the aprons).
    let shaded = RenderSettings {
        shading: voxscope_render::Shading::default(),
        ..settings
    };
    let refined = refine(&context, &mut renderer, &camera, &shaded);
    let expected = bricks_image(&context, prepared, &prepared.transfer, &camera, &shaded);
    let db = psnr(&refined.image, &expected);
    save(&refined.image, "refined-shaded");
    assert!(db >= 40.0, "shaded, streamed against bricks: {db:.1} dB");
}

/// Pyramid level `level` of the noise as a volume of its own (spacing 2^level), ready for the
/// bricks renderer: what the streaming renderer must draw when it draws that level.
fn level_volume(level: usize) -> Prepared {
    let shape = &PYRAMID.shape().levels[level];
    let levels = PYRAMID.level(level).expect("a level").to_vec();
    let quantization = NOISE.quantized.quantization;
    let mut counts = vec![0u64; 1 << 16];
    for &l in &levels {
        counts[l as usize] += 1;
    }
    let quantized = QuantizedVolume {
        dims: shape.dims,
        histogram: Histogram {
            counts,
            quantization,
            total: levels.len() as u64,
        },
        levels,
        quantization,
        value_range: NOISE.quantized.value_range,
    };
    let mut octree = voxscope_octree::build(&quantized, BuildOptions::default()).expect("octree");
    voxscope_octree::recolor(&mut octree, &NOISE.transfer);
    let scale = shape.scale as f64;
    // Only its dims and spacing are read (by the renderers' camera): the voxels are the
    // quantized ones above.
    let volume = Volume::new(
        format!("noise level {level}"),
        "synthetic",
        [1, 1, 1],
        [1.0; 3],
        voxscope_volume::VoxelData::U8(vec![0]),
    )
    .expect("a placeholder volume");
    Prepared {
        volume: Volume {
            dims: shape.dims,
            spacing: NOISE.volume.spacing.map(|s| s * scale),
            ..volume
        },
        quantized,
        octree,
        transfer: NOISE.transfer,
    }
}

/// Settings without opacity correction: a coarse level's samples then composite as the bricks
/// renderer's samples of that level as a volume of its own do (one voxel, alpha as it is).
fn uncorrected(max_level: u32) -> RenderSettings {
    RenderSettings {
        opacity_correction: false,
        ..settings(max_level)
    }
}

/// The whole noise in view, rays through it (most of level 0 is needed), refined with room
/// for all of its bricks at full detail: the camera, the settings and what was drawn. Segment
/// by segment, so that the view's bricks are those its rays marked (a level walked counts all
/// of the level's bricks in the atlas).
fn the_whole_volume_in_view(context: &GpuContext) -> (Camera, RenderSettings, Refined) {
    let camera = Camera {
        distance: 2.5,
        ..close_camera(30.0)
    };
    let full = settings(NOISE.octree.depth);
    let mut roomy = streaming(
        context,
        PYRAMID.clone(),
        StreamOptions {
            level_walk: false,
            ..options(level0_bytes() * 2)
        },
        &NOISE.transfer,
    );
    let whole = refine(context, &mut roomy, &camera, &full);
    (camera, full, whole)
}

/// A streaming renderer of `source` (the noise's pyramid) and its GPU budget, whose atlas
/// holds a third of a view needing `needed` bricks of `slot_bytes`. (The budget pays for the
/// page table and request buffers too, and a fifth of the slots is the frame's own room: it
/// grows a slot at a time until it fits.)
fn a_third_of_the_view(
    context: &GpuContext,
    source: Arc<dyn BrickSource>,
    needed: usize,
    slot_bytes: u64,
) -> (VolumeRenderer, u64) {
    let mut budget = slot_bytes * (needed as u64 / 3);
    loop {
        let Ok(mut renderer) =
            VolumeRenderer::new_stream(context, source.clone(), options(budget), &NOISE.transfer)
        else {
            budget += slot_bytes; // too small for the pinned levels and a view yet
            continue;
        };
        let counters = renderer.update(context).expect("streaming").counters;
        let unpinned = counters.slots - counters.slots_pinned;
        if (unpinned - unpinned / 5) * 3 + 6 >= needed {
            return (renderer, budget);
        }
        budget += slot_bytes;
    }
}

#[test]
fn a_view_three_times_the_atlas_completes_coarser_where_least_important_and_refines_with_room() {
    let context = gpu();
    let prepared = &*NOISE;
    let (camera, full, whole) = the_whole_volume_in_view(&context);
    assert_eq!(whole.status.budget, None, "2× level 0 holds the view");
    let needed = whole.status.counters.view_slots;
    eprintln!("the view needs {needed} bricks at full detail");
    // An atlas whose room for a view is a third of that: the view's working set is three
    // times what it can hold. (The budget pays for the page table and request buffers too, and
    // a fifth of the slots is the frame's own room: grow it a slot at a time until it fits.)
    let slot_bytes = whole.status.counters.slot_bytes;
    let (mut renderer, budget) = a_third_of_the_view(&context, PYRAMID.clone(), needed, slot_bytes);
    let refined = refine(&context, &mut renderer, &camera, &full);
    let status = &refined.status;
    let counters = &status.counters;
    let limit = status.budget.expect("the budget says it limits the view");
    eprintln!(
        "{needed} bricks at full detail, {} slots: complete after {} frames, {} bricks read; {}",
        counters.slots,
        refined.frames,
        counters.loads,
        limit.describe()
    );
    assert!(
        (needed as f64 / limit.fit as f64 - 3.0).abs() < 0.2,
        "the test's premise, 3×: {needed} bricks for {} that fit",
        limit.fit
    );
    assert!(limit.left_out > 0 && limit.needed >= needed);
    assert_eq!(
        limit.finest,
        Some(0),
        "the view's center stays at full detail"
    );
    assert!(limit.coarsest >= Some(1));
    assert!(
        counters.loads <= 3 * counters.slots as u64,
        "{} bricks read for {} slots",
        counters.loads,
        counters.slots
    );
    assert!(
        gpu_total(&renderer) <= budget,
        "{:?} for {budget}",
        renderer.gpu_bytes()
    );
    // Correct for the cut it says it drew: the same bricks left out of a roomy renderer of the
    // same pyramid draw the same picture.
    let (view, standing) = renderer
        .streamer()
        .and_then(|s| s.budget_cut())
        .expect("bricks are left out");
    let mut reference = streaming(
        &context,
        PYRAMID.clone(),
        options(level0_bytes() * 2),
        &prepared.transfer,
    );
    reference
        .streamer_mut()
        .expect("streaming")
        .apply_budget_cut(view, standing.iter().copied());
    let expected = refine(&context, &mut reference, &camera, &full);
    save(&refined.image, "budget-cut");
    save(&expected.image, "budget-cut-reference");
    let db = psnr(&refined.image, &expected.image);
    assert!(
        db >= 40.0,
        "the cut against the same cut in a roomy atlas: {db:.1} dB"
    );
    // Coarser where least important: the bricks standing for left-out ones lie farther from
    // the view's center than the level-0 bricks drawn.
    let shape = PYRAMID.shape();
    let off = |key: u32| {
        let id = shape.brick_of(key).expect("a key of the pyramid");
        view.off_center(shape.brick_center(id))
    };
    let drawn_fine: Vec<u32> = renderer
        .streamer()
        .expect("streaming")
        .resident_keys()
        .filter(|&k| shape.brick_of(k).is_some_and(|id| id.level == 0))
        .collect();
    let mean = |keys: &[u32]| keys.iter().map(|&k| off(k)).sum::<f32>() / keys.len() as f32;
    assert!(!drawn_fine.is_empty());
    assert!(
        mean(&drawn_fine) < mean(&standing),
        "kept {} vs standing in {}",
        mean(&drawn_fine),
        mean(&standing)
    );
    // And it is not the full-detail picture: the cut shows.
    assert!(psnr(&refined.image, &whole.image) < db);
    // A larger budget refines the same view to full detail.
    let mut larger = streaming(
        &context,
        PYRAMID.clone(),
        options(level0_bytes() * 2),
        &prepared.transfer,
    );
    let again = refine(&context, &mut larger, &camera, &full);
    assert_eq!(again.status.budget, None);
    let db = psnr(&again.image, &whole.image);
    assert!(
        db >= 60.0,
        "room for the view: full detail again ({db:.1} dB)"
    );
    // The budget the limited view said holds it all does: the view completes at full detail,
    // and it is no more than twice what the view's bricks and their coarser ones take.
    let FullDetailBudget::Bytes(suggested) = limit.full_detail else {
        panic!("no budget named: {}", limit.describe());
    };
    assert!(suggested > budget, "{suggested} for {budget}");
    let mut holding = streaming(
        &context,
        PYRAMID.clone(),
        options(suggested),
        &prepared.transfer,
    );
    let held = refine(&context, &mut holding, &camera, &full);
    assert_eq!(held.status.budget, None, "{suggested} bytes");
    assert!(
        suggested <= 2 * (budget + (needed * 8 / 7) as u64 * slot_bytes * 5 / 4),
        "{suggested} bytes named for {needed} bricks of {slot_bytes}"
    );
}

/// The noise's pyramid, whose level-1 bricks a store's per-chunk ranges say hold only the
/// lowest two value levels (invisible under the noise's transfer function) while level 0 is
/// visible: as a mean of a thin bright structure can fall below what the transfer function
/// shows while the voxels it averages do not.
struct InvisibleParents(Arc<MemorySource>);

impl BrickSource for InvisibleParents {
    fn name(&self) -> &str {
        "invisible parents"
    }
    fn shape(&self) -> &PyramidShape {
        self.0.shape()
    }
    fn spacing(&self) -> [f64; 3] {
        self.0.spacing()
    }
    fn quantization(&self) -> Quantization {
        self.0.quantization()
    }
    fn max_value_level(&self) -> u16 {
        self.0.max_value_level()
    }
    fn read_brick(&self, id: BrickId) -> Result<BrickData, BrickError> {
        self.0.read_brick(id)
    }
    fn known_range(&self, id: BrickId) -> Option<ValueRange> {
        (id.level == 1).then_some(ValueRange { min: 0, max: 1 })
    }
}

#[test]
fn a_view_larger_than_the_atlas_completes_where_the_coarser_bricks_are_invisible() {
    let context = gpu();
    let prepared = &*NOISE;
    let table = prepared
        .transfer
        .lookup_table(prepared.quantized.quantization);
    assert!(
        table[..2]
            .iter()
            .all(|&packed| voxscope_octree::unpack_rgba(packed)[3] == 0),
        "the premise: the lowest two levels are transparent"
    );
    let (camera, full, whole) = the_whole_volume_in_view(&context);
    let needed = whole.status.counters.view_slots;
    let source: Arc<dyn BrickSource> = Arc::new(InvisibleParents(PYRAMID.clone()));
    let (mut renderer, _) =
        a_third_of_the_view(&context, source, needed, whole.status.counters.slot_bytes);
    // Before, the cut counted each invisible level-1 brick standing for left-out level-0 ones
    // as a slot to load; never loaded, the cut never stood and the view never completed.
    let refined = refine(&context, &mut renderer, &camera, &full);
    let limit = refined.status.budget.expect("the budget limits the view");
    eprintln!(
        "complete after {} frames, {} bricks read; {}",
        refined.frames,
        refined.status.counters.loads,
        limit.describe()
    );
    assert!(limit.left_out > 0);
    // Each invisible brick enters the page table once, not once a frame.
    for (level, counters) in refined.status.counters.levels.iter().enumerate() {
        assert!(
            counters.empty as u64 <= counters.total,
            "level {level}: {counters:?}"
        );
    }
    save(&refined.image, "invisible-parents");
}

#[test]
fn uploads_scattered_or_copied_through_the_staging_ring_draw_what_queue_writes_draw_whoever_zeroed_the_atlas()
 {
    let context = gpu();
    let prepared = &*NOISE;
    let camera = close_camera(30.0);
    let settings = settings(prepared.octree.depth);
    // The noise as 8-bit texels too: the ring lays seven such bricks side by side in a
    // copy's rows (three of 16 bits), and the scatter takes four a word (two).
    let quantization = prepared.quantized.quantization;
    let eight_bit = Arc::new(
        MemorySource::from_levels(
            "noise8",
            prepared.quantized.levels.iter().map(|&l| l >> 8).collect(),
            prepared.quantized.dims,
            Quantization {
                offset: quantization.offset,
                step: quantization.step * 256.0,
            },
            prepared.volume.spacing,
            Downsampling::Mean,
        )
        .expect("pyramid"),
    );
    for (source, texels) in [(PYRAMID.clone(), 16), (eight_bit, 8)] {
        let image = |uploads: UploadPath, atlas_zero: AtlasZero| {
            let mut renderer = streaming(
                &context,
                source.clone(),
                StreamOptions {
                    uploads,
                    atlas_zero,
                    ..options(level0_bytes())
                },
                &prepared.transfer,
            );
            // lavapipe is Vulkan: an atlas that zeroes itself is made so there too, and
            // `auto` leaves its zeroing to wgpu on a CPU.
            let zeroed = renderer
                .renderer()
                .stream_paths()
                .expect("a stream renderer")
                .atlas_zero;
            assert_eq!(
                zeroed,
                match (uploads, atlas_zero) {
                    (UploadPath::Scatter, AtlasZero::Shader) => AtlasZero::Shader,
                    _ => AtlasZero::Wgpu,
                },
                "{texels}-bit, {uploads:?}, {atlas_zero:?}"
            );
            let refined = refine(&context, &mut renderer, &camera, &settings);
            let counters = &refined.status.counters;
            assert!(counters.bytes_uploaded > 0 && counters.upload_seconds > 0.0);
            assert!(counters.upload_allowance >= counters.slot_bytes);
            assert_eq!(counters.slot_bytes, PADDED_BRICK_VOXELS as u64 * texels / 8);
            let parts = &counters.upload_parts;
            match uploads {
                // lavapipe writes 8- and 16-bit texels from a shader: one dispatch a frame
                // after two copies (placements, bricks).
                UploadPath::Scatter => assert!(
                    parts.scatter_dispatches > 0
                        && parts.ring_copies == 2 * parts.scatter_dispatches
                        && parts.ring_bricks > parts.scatter_dispatches,
                    "{texels}-bit: {parts:?}"
                ),
                // Bricks placed in cells along x go in one copy a run.
                UploadPath::Copies => assert!(
                    parts.scatter_dispatches == 0 && parts.ring_copies < parts.ring_bricks,
                    "{texels}-bit: {parts:?}"
                ),
                UploadPath::Queue => assert!(
                    parts.ring_bricks == 0 && parts.queue_bricks > 0,
                    "{parts:?}"
                ),
            }
            eprintln!(
                "{texels}-bit, {uploads:?}: {} bricks ({} through the ring, {} copies, {} dispatches) in {} frames, {:.0} MB/s to upload, {:.0} MB/s a loader",
                counters.loads,
                parts.ring_bricks,
                parts.ring_copies,
                parts.scatter_dispatches,
                refined.frames,
                counters.bytes_uploaded as f64 / counters.upload_seconds / 1e6,
                counters.bytes_read as f64 / counters.read_seconds / 1e6
            );
            refined.image
        };
        let through_queue = image(UploadPath::Queue, AtlasZero::Auto);
        save(&through_queue, &format!("queue-{texels}bit"));
        assert!(coverage(&through_queue) > 0.5, "the view shows the volume");
        for (uploads, atlas_zero) in [
            (UploadPath::Scatter, AtlasZero::Auto),
            (UploadPath::Scatter, AtlasZero::Shader),
            (UploadPath::Copies, AtlasZero::Shader),
        ] {
            let through_ring = image(uploads, atlas_zero);
            save(
                &through_ring,
                &format!("ring-{uploads:?}-{atlas_zero:?}-{texels}bit"),
            );
            // The same bricks, in other slots where they arrived in another order: a sample's
            // atlas coordinate rounds differently there (about 90 dB); a misplaced row or a
            // brick written over before its copy ran would be tens of dB lower.
            let db = psnr(&through_ring, &through_queue);
            assert!(
                db >= 80.0,
                "{texels}-bit, {uploads:?}, atlas zeroed {atlas_zero:?}: the ring's uploads differ from the queue's: {db:.1} dB"
            );
        }
    }
}

#[test]
fn a_max_level_below_the_voxels_draws_that_pyramid_level() {
    let context = gpu();
    let prepared = &*NOISE;
    let mut renderer = streaming(
        &context,
        PYRAMID.clone(),
        options(level0_bytes()),
        &prepared.transfer,
    );
    let camera = close_camera(30.0);
    // Max level depth − 2 is pyramid level 2 (64³).
    let settings = uncorrected(prepared.octree.depth - 2);
    let refined = refine(&context, &mut renderer, &camera, &settings);
    let levels = &refined.status.counters.levels;
    assert_eq!((levels[0].resident, levels[1].resident), (0, 0));
    assert!(levels[2].resident > 0);
    let coarse = level_volume(2);
    let expected = bricks_image(
        &context,
        &coarse,
        &coarse.transfer,
        &camera,
        &uncorrected(coarse.octree.depth),
    );
    let db = psnr(&refined.image, &expected);
    assert!(
        db >= 40.0,
        "max level 6 against level 2's bricks: {db:.1} dB"
    );
    // And it is not the full-resolution picture.
    let full = bricks_image(
        &context,
        prepared,
        &prepared.transfer,
        &camera,
        &uncorrected(8),
    );
    assert!(psnr(&refined.image, &full) < 35.0);
}

#[test]
fn evicted_bricks_are_asked_for_again_from_ram_and_transfer_edits_apply_while_streaming() {
    let context = gpu();
    let prepared = &*NOISE;
    // A quarter of level 0: one side's view fits, both sides' do not.
    let mut renderer = streaming(
        &context,
        PYRAMID.clone(),
        options(level0_bytes() / 4),
        &prepared.transfer,
    );
    let settings = settings(prepared.octree.depth);
    let front = close_camera(30.0);
    let back = close_camera(210.0);
    let first = refine(&context, &mut renderer, &front, &settings);
    let behind = refine(&context, &mut renderer, &back, &settings);
    assert!(
        behind.status.counters.evictions > 0,
        "the other side's view evicted bricks"
    );
    // The Octree panel's per-level counts add up to the totals.
    let counters = &behind.status.counters;
    let per_level = |count: fn(&voxscope_stream::LevelCounters) -> u64| {
        counters.levels.iter().map(count).sum::<u64>()
    };
    assert_eq!(per_level(|level| level.evicted), counters.evictions);
    assert_eq!(per_level(|level| level.loaded), counters.loads);
    assert!(counters.levels[0].evicted > 0, "level 0 bricks gave way");
    let again = refine(&context, &mut renderer, &front, &settings);
    let (before, after) = (&behind.status.counters, &again.status.counters);
    // The bricks asked for again come from the RAM cache. (A brick or two more may be read:
    // rays drawn from stand-ins reach other depths while the view refines.)
    let (hits, loads) = (after.ram_hits - before.ram_hits, after.loads - before.loads);
    eprintln!("back to the first view: {hits} bricks from RAM, {loads} read");
    assert!(hits >= 20, "evicted bricks came back from RAM: {hits}");
    assert!(
        loads * 10 <= hits,
        "{loads} read again against {hits} from RAM"
    );
    let db = psnr(&first.image, &again.image);
    assert!(db >= 60.0, "the same view again: {db:.1} dB");

    // A transfer edit two frames into a new view's refinement: the finished picture is the
    // new transfer function's, and nothing had to be reloaded for it.
    let side = close_camera(120.0);
    let edited = TransferFunction {
        window: ValueWindow {
            low: prepared.transfer.window.low,
            high: 0.5 * (prepared.transfer.window.low + prepared.transfer.window.high),
        },
        ..prepared.transfer
    };
    let refined = refine_with(
        &context,
        &mut renderer,
        &side,
        &settings,
        |frame, context, renderer| {
            if frame == 2 {
                let mut encoder = context
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
                renderer
                    .set_transfer(context, &mut encoder, &edited, None)
                    .expect("edit");
                context.queue.submit([encoder.finish()]);
            }
        },
    );
    let expected = bricks_image(&context, prepared, &edited, &side, &settings);
    let db = psnr(&refined.image, &expected);
    save(&refined.image, "edited");
    assert!(db >= 40.0, "after the edit: {db:.1} dB");
    assert!(
        psnr(
            &refined.image,
            &bricks_image(&context, prepared, &prepared.transfer, &side, &settings)
        ) < 35.0
    );
}

/// The noise's pyramid with the bricks `fails` names unreadable: damaged (they never decode),
/// or, with `away`, on a server that is away (their fetch fails; it may pass later).
struct Failing {
    inner: Arc<MemorySource>,
    fails: Box<dyn Fn(BrickId) -> bool + Send + Sync>,
    away: bool,
}

impl BrickSource for Failing {
    fn name(&self) -> &str {
        "damaged"
    }
    fn shape(&self) -> &PyramidShape {
        self.inner.shape()
    }
    fn spacing(&self) -> [f64; 3] {
        self.inner.spacing()
    }
    fn quantization(&self) -> Quantization {
        self.inner.quantization()
    }
    fn max_value_level(&self) -> u16 {
        self.inner.max_value_level()
    }
    fn read_brick(&self, id: BrickId) -> Result<BrickData, BrickError> {
        if (self.fails)(id) && self.away {
            return Err(BrickError::fetch(format!("away: {id} cannot be fetched")));
        }
        if (self.fails)(id) {
            return Err(BrickError::decode(format!("damaged: {id} does not decode")));
        }
        self.inner.read_brick(id)
    }
}

/// Level-0 voxel space to pixels for `camera` on the noise (a test-side projection).
fn project(camera: &Camera, voxel: DVec3) -> (f64, f64) {
    let dims = DVec3::splat(256.0);
    let frame = camera.frame(dims.to_array(), SIZE.0 as f64 / SIZE.1 as f64);
    let d = (voxel - dims / 2.0) - frame.eye;
    let depth = d.dot(frame.forward);
    let x = d.dot(frame.right) / depth / (frame.tan_half_fov_y * frame.aspect);
    let y = d.dot(frame.up) / depth / frame.tan_half_fov_y;
    (
        (x + 1.0) / 2.0 * SIZE.0 as f64,
        (1.0 - y) / 2.0 * SIZE.1 as f64,
    )
}

#[test]
fn a_brick_that_fails_to_load_leaves_its_region_coarser_and_the_rest_unchanged() {
    let context = gpu();
    let prepared = &*NOISE;
    let camera = close_camera(30.0);
    let settings = settings(prepared.octree.depth);
    // The level-0 brick where the view's central ray enters the volume.
    let frame = camera.frame([256.0; 3], SIZE.0 as f64 / SIZE.1 as f64);
    let eye = frame.eye + DVec3::splat(128.0);
    let inv = frame.forward.recip();
    let t0 = (DVec3::ZERO - eye) * inv;
    let t1 = (DVec3::splat(256.0) - eye) * inv;
    let t_enter = t0.min(t1).max_element();
    let inside = eye + frame.forward * (t_enter + 4.0);
    let brick = (inside / BRICK_SIZE as f64).floor().as_uvec3().to_array();
    let broken = BrickId {
        level: 0,
        brick,
        channel: 0,
    };

    let mut good = streaming(
        &context,
        PYRAMID.clone(),
        options(level0_bytes()),
        &prepared.transfer,
    );
    let whole = refine(&context, &mut good, &camera, &settings);
    let damaged = Arc::new(Failing {
        inner: PYRAMID.clone(),
        fails: Box::new(move |id| id == broken),
        away: false,
    });
    let mut renderer = streaming(
        &context,
        damaged,
        options(level0_bytes()),
        &prepared.transfer,
    );
    let refined = refine(&context, &mut renderer, &camera, &settings);
    // Later updates report nothing more.
    let mut errors = refined.errors.clone();
    for _ in 0..3 {
        renderer.render(
            &context,
            &RenderTarget::new(&context, 8, 8),
            &camera,
            &settings,
        );
        context.wait_idle().expect("GPU");
        errors.extend(renderer.update(&context).expect("streaming").errors);
    }
    assert_eq!(refined.status.counters.failed, 1);
    save(&refined.image, "damaged");
    // Every pixel whose ray misses the broken brick (outside its projected box) is as the
    // whole pyramid's, but for rounding: the same bricks sit in other atlas slots, and the
    // filter's weights round differently there (at most a level or two of 255).
    let corners: Vec<(f64, f64)> = (0..8)
        .map(|c| {
            let offset = DVec3::new((c & 1) as f64, ((c >> 1) & 1) as f64, (c >> 2) as f64);
            project(
                &camera,
                (DVec3::from(brick.map(f64::from)) + offset) * BRICK_SIZE as f64,
            )
        })
        .collect();
    let (x0, x1) = corners
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), c| (a.min(c.0), b.max(c.0)));
    let (y0, y1) = corners
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), c| (a.min(c.1), b.max(c.1)));
    let (mut inside_most, mut outside_most) = (0u8, 0u8);
    for (x, y, pixel) in refined.image.enumerate_pixels() {
        let other = whole.image.get_pixel(x, y);
        let difference = (0..3)
            .map(|c| pixel[c].abs_diff(other[c]))
            .max()
            .unwrap_or(0);
        let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
        if px >= x0 - 1.0 && px <= x1 + 1.0 && py >= y0 - 1.0 && py <= y1 + 1.0 {
            inside_most = inside_most.max(difference);
        } else {
            outside_most = outside_most.max(difference);
        }
    }
    assert!(
        inside_most >= 10,
        "the broken brick's region is drawn coarser (differs by {inside_most} at most)"
    );
    assert!(
        outside_most <= 2,
        "a pixel whose ray misses the broken brick differs by {outside_most}"
    );
    let db = psnr(&refined.image, &whole.image);
    assert!(db >= 25.0, "the rest renders: {db:.1} dB");
    assert_eq!(errors.len(), 1, "one line for the broken brick: {errors:?}");
    assert!(
        errors[0].contains(&broken.to_string()),
        "the line names the brick: {}",
        errors[0]
    );
}

#[test]
fn a_far_view_streams_the_levels_its_pixels_resolve() {
    let context = gpu();
    let prepared = &*NOISE;
    let mut renderer = streaming(
        &context,
        PYRAMID.clone(),
        StreamOptions {
            lod_scale: 1.0,
            ..options(level0_bytes())
        },
        &prepared.transfer,
    );
    let camera = Camera {
        distance: 6.0,
        ..close_camera(30.0)
    };
    let refined = refine(
        &context,
        &mut renderer,
        &camera,
        &settings(prepared.octree.depth),
    );
    let levels = &refined.status.counters.levels;
    eprintln!(
        "far view: {:?}",
        levels.iter().map(|l| l.resident).collect::<Vec<_>>()
    );
    assert_eq!(
        levels[0].resident, 0,
        "a pixel covers several level-0 voxels"
    );
    let expected = bricks_image(
        &context,
        prepared,
        &prepared.transfer,
        &camera,
        &settings(8),
    );
    let db = psnr(&refined.image, &expected);
    save(&refined.image, "far");
    assert!(
        db >= 25.0,
        "the far view at its pixels' levels against full detail: {db:.1} dB"
    );
}

/// Pixels of `a` and `b` that differ.
fn differing_pixels(a: &RgbaImage, b: &RgbaImage) -> usize {
    a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count()
}

/// The most two images' channels differ by.
fn channels_apart(a: &RgbaImage, b: &RgbaImage) -> u8 {
    a.as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(p, q)| p.abs_diff(*q))
        .max()
        .unwrap_or(0)
}

/// Updates `renderer` on one view until the streamer's level fill is done, drawing a frame
/// only when an update changed what frames draw (uploads, the page table), as a window does
/// once the view is complete; returns the frames the level walk drew then.
fn settle_fill(
    context: &GpuContext,
    renderer: &mut VolumeRenderer,
    camera: &Camera,
    settings: &RenderSettings,
) -> u64 {
    let target = RenderTarget::new(context, SIZE.0, SIZE.1);
    let started = Instant::now();
    loop {
        let status = renderer.update(context).expect("a streaming renderer");
        if status.filling == 0 && status.uploads == 0 && status.complete {
            break;
        }
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "the level fill not done: {status:?}"
        );
        if status.uploads > 0 || status.table_changed {
            renderer.render(context, &target, camera, settings);
            context.wait_idle().expect("GPU");
        } else {
            std::thread::sleep(Duration::from_millis(2));
        }
    }
    let walked = |r: &VolumeRenderer| {
        r.renderer()
            .stream_paths()
            .map_or(0, |p| p.level_walk_frames)
    };
    let before = walked(renderer);
    renderer.render(context, &target, camera, settings);
    context.wait_idle().expect("GPU");
    walked(renderer) - before
}

#[test]
fn the_level_walk_draws_what_the_segments_draw_once_its_level_is_filled() {
    let context = gpu();
    let prepared = &*NOISE;
    let depth = prepared.octree.depth;
    let mip = RenderSettings {
        mode: voxscope_render::RenderMode::Mip,
        ..settings(depth)
    };
    let shaded = RenderSettings {
        shading: voxscope_render::Shading::default(),
        ..settings(depth)
    };
    let opaque = RenderSettings {
        density: 4.0,
        ..settings(depth)
    };
    // (name, camera distance, pixel LOD scale, settings, budget, levels walked): close at
    // level 0, see-through, MIP, shaded and nearly opaque (the bricks behind never asked for,
    // filled); nearer with pixel LOD, where the front wants level 0 and the back level 1 (both
    // walked, each ray switching where its segments would), in DVR, MIP and shaded, and with
    // twice the footprint, levels 1 and 2 (neither at level 0's step); far, where every ray
    // wants one coarser level; a quarter of level 0 in the atlas (it cannot be filled: segment
    // by segment).
    let cases = [
        (
            "close-dvr",
            1.6,
            0.0,
            settings(depth),
            2 * level0_bytes(),
            1,
        ),
        ("close-mip", 1.6, 0.0, mip, 2 * level0_bytes(), 1),
        ("close-shaded", 1.6, 0.0, shaded, 2 * level0_bytes(), 1),
        ("close-opaque", 1.6, 0.0, opaque, 2 * level0_bytes(), 1),
        ("lod-dvr", 2.2, 1.0, settings(depth), 2 * level0_bytes(), 2),
        ("lod-mip", 2.2, 1.0, mip, 2 * level0_bytes(), 2),
        ("lod-shaded", 2.2, 1.0, shaded, 2 * level0_bytes(), 2),
        ("lod2-dvr", 3.0, 2.0, settings(depth), 2 * level0_bytes(), 2),
        ("far-dvr", 12.0, 1.0, settings(depth), 2 * level0_bytes(), 1),
        (
            "quarter-dvr",
            1.6,
            0.0,
            settings(depth),
            level0_bytes() / 4,
            0,
        ),
    ];
    for (name, distance, lod_scale, settings, budget, expect_levels) in cases {
        let camera = Camera {
            distance,
            ..close_camera(30.0)
        };
        let draw = |level_walk: bool| {
            let options = StreamOptions {
                lod_scale,
                level_walk,
                ..options(budget)
            };
            let mut renderer = streaming(&context, PYRAMID.clone(), options, &prepared.transfer);
            refine(&context, &mut renderer, &camera, &settings);
            let walked = settle_fill(&context, &mut renderer, &camera, &settings);
            // The image, and each ray's segments and samples (the heat map's count).
            let target = RenderTarget::new(&context, SIZE.0, SIZE.1);
            renderer.render(&context, &target, &camera, &settings);
            let image = read_image(&context, &target).expect("readback");
            let visits = voxscope_render::read_visits(&context, &target).expect("visits");
            let copied = renderer.streamer().and_then(|s| s.table().copied_level());
            // The walk leaves no usage marks; the CPU keeps the level's bricks in the atlas, so
            // the next frames walk it still.
            renderer.update(&context).expect("a streaming renderer");
            let state = renderer
                .renderer()
                .stream_paths()
                .and_then(|p| p.walk_level);
            if walked > 0 {
                assert_eq!(
                    state,
                    copied.map(|(level, levels)| (level, levels, 0)),
                    "{name}: still walkable"
                );
            }
            (image, visits, copied, walked)
        };
        let (walked, walked_visits, copied, walk_frames) = draw(true);
        let (segments, segments_visits, none, segment_walks) = draw(false);
        save(&walked, &format!("level-walk-{name}"));
        let differing = differing_pixels(&walked, &segments);
        let visits_differing = walked_visits
            .iter()
            .zip(&segments_visits)
            .filter(|(a, b)| a != b)
            .count();
        let most_apart = walked_visits
            .iter()
            .zip(&segments_visits)
            .map(|(&a, &b)| a.abs_diff(b))
            .max()
            .unwrap_or(0);
        eprintln!(
            "{name}: levels {copied:?} copied, {walk_frames} frame walked, {differing} pixels \
             differ, {visits_differing} rays' counts of segments and samples (by {most_apart} \
             at most), coverage {:.3}",
            coverage(&segments)
        );
        assert!(
            coverage(&segments) > 0.02,
            "{name}: the view shows the volume"
        );
        assert_eq!(
            (none, segment_walks),
            (None, 0),
            "{name}: no level copied or walked without the walk"
        );
        assert_eq!(
            if walk_frames > 0 {
                copied.map_or(0, |(_, levels)| levels)
            } else {
                0
            },
            expect_levels,
            "{name}: walked {walk_frames} frames, levels {copied:?} copied"
        );
        // Bit for bit, but for a pixel or two one gray level apart: the two renderers' bricks
        // may arrive in another order and sit in other atlas slots, where a sample's atlas
        // coordinate rounds differently (seen once in `lod-shaded`, not in the next run).
        let apart = channels_apart(&walked, &segments);
        assert!(
            differing <= 4 && apart <= 1,
            "{name}: the walk's image is the segments' ({differing} pixels differ, by {apart} at most)"
        );
        // The same samples (the images are equal bit for bit); a ray's count of segments may
        // differ by one where a segment ends at a brick's face.
        assert!(most_apart <= 1, "{name}: counts {most_apart} apart");
        assert!(
            visits_differing * 100 <= walked_visits.len(),
            "{name}: {visits_differing} rays count differently"
        );
    }
}

#[test]
fn a_folder_store_fills_the_walked_level_and_a_url_reads_only_what_the_view_needs() {
    // 128³ noise, converted, nearly opaque and seen close: rays stop in the front bricks and
    // never ask for those behind. From the folder, once the view lacks nothing, the rest of
    // level 0 is loaded and frames walk it; over HTTP nothing more is fetched.
    let (dir, store) = converted_noise("32");
    let volume = voxscope_volume::load(store.to_str().expect("UTF-8"), &Default::default())
        .expect("the store loads");
    let prepared = Prepared::new(volume, None);
    let context = gpu();
    let server = FileServer::start(dir.path(), Faults::default());
    let settings = RenderSettings {
        density: 4.0,
        ..settings(prepared.octree.depth)
    };
    let camera = close_camera(30.0);
    // The view refined, then settled as a window settles it: (the image, bricks read and
    // requests by then, bricks read, requests and bricks the walk cannot take once settled,
    // frames walked then).
    let draw = |source: Arc<dyn BrickSource>, requests: &dyn Fn() -> usize| {
        let budget = 2 * source.shape().levels[0].brick_count() * (PADDED_BRICK_VOXELS * 2) as u64;
        let mut renderer = streaming(&context, source, options(budget), &prepared.transfer);
        let refined = refine(&context, &mut renderer, &camera, &settings);
        let complete = (refined.status.counters.loads, requests());
        let walked = settle_fill(&context, &mut renderer, &camera, &settings);
        let status = renderer.update(&context).expect("a streaming renderer");
        // Bricks of level 0 (copied flat) the walk could not take as they are.
        let unwalkable = renderer
            .streamer()
            .and_then(|s| s.table().level_unwalkable(false));
        let settled = (status.counters.loads, requests(), unwalkable);
        (refined.image, complete, settled, walked)
    };
    let folder = Pyramid::open(&store, PyramidOptions::default()).expect("the store opens");
    let (from_folder, folder_complete, folder_settled, folder_walked) = draw(
        Arc::new(ZarrSource::new(Arc::new(folder)).expect("a brick source")),
        &|| 0,
    );
    let url = Pyramid::open_url(
        &server.url("noise.ome.zarr"),
        PyramidOptions::default(),
        RemoteOptions::default(),
    )
    .expect("the store opens over HTTP");
    let (over_http, http_complete, http_settled, http_walked) = draw(
        Arc::new(ZarrSource::new(Arc::new(url)).expect("a brick source")),
        &|| server.counters.arrivals().len(),
    );
    eprintln!(
        "folder: (bricks read, requests) {folder_complete:?} complete, {folder_settled:?} \
         settled, {folder_walked} frame walked; HTTP: {http_complete:?}, {http_settled:?}, \
         {http_walked}"
    );
    // The same view (the folder's possibly walked already, where its fill was quick: a
    // sample at a brick's face may then round a value level apart).
    let db = psnr(&from_folder, &over_http);
    assert!(db >= 60.0, "the same view: {db:.1} dB");
    assert_eq!(
        (folder_settled.2, folder_walked),
        (Some(0), 1),
        "the folder's level filled and walked"
    );
    let behind = http_settled.2.expect("level 0 copied");
    assert!(behind > 0, "bricks behind the front are never asked for");
    assert_eq!(
        (http_settled.0, http_settled.1, http_walked),
        (http_complete.0, http_complete.1, 0),
        "nothing more read or fetched over HTTP"
    );
}

/// `voxscope render --renderer stream`, run as a user would.
fn render_stream(args: &[&str]) -> (std::process::ExitStatus, String) {
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(["render", "--renderer", "stream", "--size", "96x72"])
        .args(args)
        .output()
        .expect("voxscope runs");
    (
        output.status,
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

#[test]
fn render_waits_until_nothing_is_missing_or_says_what_was_still_coarse() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let out = dir.path().join("noise.png");
    let out = out.to_str().expect("a UTF-8 path");
    // 1024³ procedural noise in 32 MiB of GPU memory: waits for the view, then writes it.
    let (status, stderr) =
        render_stream(&["synthetic:noise:1024", "--gpu-memory", "32MiB", "-o", out]);
    assert!(status.success(), "{stderr}");
    assert!(
        stderr.contains("stream renderer") && stderr.contains("complete after"),
        "{stderr}"
    );
    let image = image::open(out).expect("the PNG").to_rgba8();
    assert_eq!(image.dimensions(), (96, 72));
    assert!(coverage(&image) > 0.1, "the volume is drawn");
    // Full resolution (no pixel LOD), one brick a frame and 0.3 s: not enough; it says so,
    // and what was missing.
    let (status, stderr) = render_stream(&[
        "synthetic:noise:1024",
        "--gpu-memory",
        "32MiB",
        "--lod-scale",
        "0",
        "--upload-budget",
        "80KiB",
        "--max-wait",
        "0.3",
        "-o",
        out,
    ]);
    // The image is written, and the exit code says it is incomplete (as for unreadable bricks).
    assert_eq!(status.code(), Some(3), "{stderr}");
    assert!(
        stderr.contains("still coarse after")
            && stderr.contains("bricks missing (level")
            && stderr.trim_end().ends_with("; incomplete: still coarse"),
        "{stderr}"
    );
    assert!(std::path::Path::new(out).exists());
    // A budget below what the coarsest levels need is a one-line error.
    let (status, stderr) =
        render_stream(&["synthetic:noise:1024", "--gpu-memory", "1MiB", "-o", out]);
    assert!(!status.success());
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("synthetic:noise:1024"), "{stderr}");
}

/// The OME-Zarr fixtures, as their own folder.
fn ome_zarr_fixture(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("tests/data/ome-zarr/{name}"))
}

#[test]
fn an_ome_zarr_streams_from_its_own_levels_brick_for_brick() {
    // The head as ome-zarr-py wrote it: three stored levels (64×64×31, 32×32×16, 16×16×8),
    // each its finer one's 2× mean. Pyramid levels 0-2 read them; coarser ones reduce level 2.
    let path = ome_zarr_fixture("head-v04-zstd.ome.zarr");
    let pyramid = Pyramid::open(&path, PyramidOptions::default()).expect("the fixture opens");
    let source = ZarrSource::new(Arc::new(pyramid)).expect("a brick source");
    assert_eq!(source.shape().dims(), [64, 64, 31]);
    assert_eq!(source.stored_level(0), Some((0, [1, 1, 1])));
    assert_eq!(source.stored_level(2), Some((2, [1, 1, 1])));
    assert_eq!(source.stored_level(4), Some((2, [4, 4, 4])));
    // The same voxels in memory, their levels computed by voxscope: equal bricks (within the
    // one unit that rounding a mean may differ by).
    let volume = voxscope_volume::load(path.to_str().expect("UTF-8"), &Default::default())
        .expect("the fixture loads");
    let quantized = QuantizedVolume::new(&volume);
    let memory =
        MemorySource::new("head", &quantized, volume.spacing, Downsampling::Mean).expect("pyramid");
    assert_eq!(memory.shape(), source.shape());
    let (zq, mq) = (source.quantization(), memory.quantization());
    for (level, info) in source.shape().levels.iter().enumerate() {
        for z in 0..info.grid[2] as u32 {
            for y in 0..info.grid[1] as u32 {
                for x in 0..info.grid[0] as u32 {
                    let id = BrickId {
                        level: level as u32,
                        brick: [x, y, z],
                        channel: 0,
                    };
                    let streamed = source.read_brick(id).expect("a brick");
                    let computed = memory.read_brick(id).expect("a brick");
                    let worst = streamed
                        .levels
                        .iter()
                        .zip(&computed.levels)
                        .map(|(&a, &b)| (zq.value(a) - mq.value(b)).abs())
                        .fold(0.0, f64::max);
                    let allowed = if level == 0 { 0.0 } else { 1.0 };
                    assert!(worst <= allowed, "{id}: values differ by {worst}");
                }
            }
        }
    }
}

/// 128³ noise written by `voxscope convert` in chunks of `chunk`³ into a temporary folder
/// (kept while the folder is), and the store's path.
fn converted_noise(chunk: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let store = dir.path().join("noise.ome.zarr");
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(["convert", "synthetic:noise:128"])
        .arg(&store)
        .args(["--chunk", chunk])
        .output()
        .expect("voxscope runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    (dir, store)
}

#[test]
fn loaders_meeting_a_chunk_another_decodes_read_other_bricks_meanwhile_and_each_brick_as_one_reader_does()
 {
    // 128³ noise in chunks of 64³, every brick of every level read by eight loaders in the
    // order of the grid (x fastest): neighbours one after the other, which most often need a
    // chunk another loader is decoding (a brick's own, or the one its apron reaches into).
    // Each brick equals what one reader alone reads, and each chunk is decoded once.
    let (_dir, store) = converted_noise("64");
    let open = || {
        let pyramid = Pyramid::open(&store, PyramidOptions::default()).expect("the store opens");
        ZarrSource::new(Arc::new(pyramid)).expect("a brick source")
    };
    let alone = open();
    let shared: Arc<dyn BrickSource> = Arc::new(open());
    let shape = alone.shape().clone();
    let ids: Vec<BrickId> = shape
        .levels
        .iter()
        .enumerate()
        .flat_map(|(level, info)| {
            level_zero_bricks(info.grid).map(move |id| BrickId {
                level: level as u32,
                ..id
            })
        })
        .collect();
    let queue = Arc::new(RequestQueue::default());
    queue.replace(
        ids.iter()
            .enumerate()
            .map(|(order, &id)| Request {
                priority: Priority::new(Tier::Visible, 0, order as f32),
                id,
                key: shape.key(id).expect("a brick of the pyramid"),
            })
            .collect(),
    );
    let loader = Loader::start(Arc::clone(&shared), queue, AtlasTexels::Unorm16, 8);
    let mut read = std::collections::HashMap::new();
    for _ in &ids {
        let result = loader
            .next_received(Duration::from_secs(60))
            .expect("every brick arrives");
        let brick = result.brick.unwrap_or_else(|e| panic!("{e}"));
        assert!(
            read.insert(result.key, brick).is_none(),
            "a brick read twice"
        );
    }
    for &id in &ids {
        let (expected, _) = load_brick(&alone, id, AtlasTexels::Unorm16);
        let expected = expected.unwrap_or_else(|e| panic!("{e}"));
        let brick = &read[&shape.key(id).expect("a brick")];
        assert_eq!(brick.range, expected.range, "{id}");
        assert!(brick.texels == expected.texels, "{id} differs");
    }
    assert_eq!(shared.chunks_decoded(), alone.chunks_decoded());
}

/// Level 0's bricks of a grid of `grid` bricks, x fastest.
fn level_zero_bricks(grid: [usize; 3]) -> impl Iterator<Item = BrickId> {
    (0..grid[2] as u32).flat_map(move |z| {
        (0..grid[1] as u32).flat_map(move |y| {
            (0..grid[0] as u32).map(move |x| BrickId {
                level: 0,
                brick: [x, y, z],
                channel: 0,
            })
        })
    })
}

#[test]
fn aprons_taken_from_the_faces_of_chunks_beside_a_brick_equal_their_decoded_voxels() {
    // 128³ noise in chunks of 64³: each brick's interior lies in one chunk and its apron one
    // voxel into up to seven others. Read brick by brick with a decoded-chunk cache of three
    // chunks, the aprons come from the faces kept of chunks decoded before; the bricks equal
    // those of a source that keeps every chunk. Over HTTP, a chunk whose faces serve is not
    // fetched either.
    let (dir, store) = converted_noise("64");
    let open = || {
        let pyramid = Pyramid::open(&store, PyramidOptions::default()).expect("the store opens");
        ZarrSource::new(Arc::new(pyramid)).expect("a brick source")
    };
    let server = FileServer::start(dir.path(), Faults::default());
    let open_over_http = || {
        Arc::new(
            Pyramid::open_url(
                &server.url("noise.ome.zarr"),
                PyramidOptions::default(),
                RemoteOptions::default(),
            )
            .expect("the store opens over HTTP"),
        )
    };
    let over_http = open_over_http();
    let remote = ZarrSource::new(Arc::clone(&over_http)).expect("a brick source");
    let (roomy, tight) = (open(), open());
    // 1.5 MiB of decoded chunks (three of 64³), 384 KiB of faces (all eight chunks').
    tight.reserve_caches(6 << 20);
    remote.reserve_caches(6 << 20);
    over_http.set_fetch_cache_bytes(4 << 20);
    let opened = server.counters.arrivals().len();
    let grid = tight.shape().levels[0].grid;
    assert_eq!(grid, [4, 4, 4]);
    let mut bricks = 0u64;
    for id in level_zero_bricks(grid) {
        let expected = roomy.read_brick(id).expect("a brick");
        let read = tight.read_brick(id).expect("a brick");
        assert!(read.levels == expected.levels, "{id} differs");
        let read = remote.read_brick(id).expect("a brick over HTTP");
        assert!(read.levels == expected.levels, "{id} differs over HTTP");
        bricks += 1;
    }
    assert_eq!(roomy.chunks_decoded(), 8);
    // A brick's own chunk where the three kept lack it, and each chunk once for its faces:
    // 23 (measured); decoding every chunk an apron reaches that the three kept lack took 160.
    let decoded = tight.chunks_decoded();
    assert!(
        decoded <= 40,
        "{decoded} chunks decoded for {bricks} bricks"
    );
    // Over HTTP (4 MiB of fetched bytes kept: four chunks of this noise, 0.9 MB each) the
    // same decodes, and each chunk fetched is one decoded (some decodes find their bytes
    // still kept): 15 requests for 23 decodes (measured); fetching every chunk of a brick's
    // region whose decoded voxels were not kept, faces or not, took 74.
    let requests = server.counters.arrivals()[opened..].to_vec();
    let chunk_requests = requests
        .iter()
        .filter(|(path, _)| path.starts_with("noise.ome.zarr/0/"))
        .count() as u64;
    assert_eq!(
        requests.len() as u64,
        chunk_requests,
        "only level 0's chunks asked for: {requests:?}"
    );
    assert!(
        remote.chunks_decoded() <= 40,
        "{} chunks decoded over HTTP",
        remote.chunks_decoded()
    );
    assert!(
        chunk_requests <= remote.chunks_decoded(),
        "{chunk_requests} chunk requests for {} decodes: {requests:?}",
        remote.chunks_decoded()
    );
    // With no fetched byte kept at all, the chunks a brick's read fetches in one batch are
    // held for that read: each decode's chunk crosses the link once. Dropped at once, the
    // read fetched them again, a request more for each chunk of a batch.
    let bare_store = open_over_http();
    let bare = ZarrSource::new(Arc::clone(&bare_store)).expect("a brick source");
    bare.reserve_caches(6 << 20);
    bare_store.set_fetch_cache_bytes(0);
    let opened = server.counters.arrivals().len();
    for id in level_zero_bricks(grid) {
        let read = bare.read_brick(id).expect("a brick over HTTP");
        let expected = roomy.read_brick(id).expect("a brick");
        assert!(read.levels == expected.levels, "{id} differs, nothing kept");
    }
    let requests = server.counters.arrivals()[opened..].to_vec();
    assert!(
        requests.len() as u64 == bare.chunks_decoded() && bare.chunks_decoded() >= 8,
        "{} requests for {} decodes, nothing kept: {requests:?}",
        requests.len(),
        bare.chunks_decoded()
    );
}

#[test]
fn a_converted_volume_streams_from_disk_equal_to_the_bricks_render() {
    // 128³ noise written by `voxscope convert` (chunks of 32³, its own levels and chunk ranges),
    // streamed region by region in a budget below the whole pyramid.
    let (_dir, store) = converted_noise("32");
    let pyramid = Pyramid::open(&store, PyramidOptions::default()).expect("the store opens");
    assert!(pyramid.levels.len() > 1, "convert wrote levels");
    let source = Arc::new(ZarrSource::new(Arc::new(pyramid)).expect("a brick source"));
    let volume = voxscope_volume::load(store.to_str().expect("UTF-8"), &Default::default())
        .expect("the store loads");
    let prepared = Prepared::new(volume, None);
    let context = gpu();
    let budget = source.shape().levels[0].brick_count() * (PADDED_BRICK_VOXELS * 2) as u64;
    // A RAM budget of 2 MiB, below the store's 4.6 MiB of value levels: the decoded chunks
    // the source keeps get a quarter of it, their faces a sixteenth, the bricks' cache the rest.
    let ram = 2 << 20;
    let mut renderer = streaming(
        &context,
        source,
        StreamOptions {
            ram_cache: ram,
            ..options(budget)
        },
        &prepared.transfer,
    );
    let camera = close_camera(30.0);
    let settings = settings(prepared.octree.depth);
    let refined = refine(&context, &mut renderer, &camera, &settings);
    let counters = &refined.status.counters;
    let kept = ram / 4 + ram / 16;
    assert_eq!(counters.source_cache_capacity, kept);
    assert_eq!(counters.ram_capacity, ram - kept);
    assert!(
        counters.source_cache_bytes > 0 && counters.source_cache_bytes <= kept,
        "decoded chunks and their faces kept: {} of {kept}",
        counters.source_cache_bytes,
    );
    assert!(counters.ram_bytes <= counters.ram_capacity);
    let expected = bricks_image(&context, &prepared, &prepared.transfer, &camera, &settings);
    save(&refined.image, "zarr-refined");
    let db = psnr(&refined.image, &expected);
    assert!(coverage(&expected) > 0.5, "the view shows the volume");
    assert_eq!(refined.status.budget, None, "the budget holds the view");
    assert!(
        refined.status.counters.levels[0].resident > 4,
        "level 0 streamed"
    );
    assert!(db >= 40.0, "streamed from disk against bricks: {db:.1} dB");
    assert!(gpu_total(&renderer) <= budget);
    assert!(refined.errors.is_empty(), "{:?}", refined.errors);
}

#[test]
fn bricks_a_store_knows_to_be_invisible_are_never_read() {
    // A 128³ ball (1000 inside, 0 outside) written as OME-Zarr with its chunk ranges: under a
    // transfer function that makes 0 transparent, the empty bricks are skipped from the stored
    // ranges alone, while the same voxels in memory are read to find them empty.
    use voxscope_volume::VoxelData;
    use voxscope_volume::ome_zarr::{
        Compression, Downsampling as ZarrDownsampling, PyramidWriter, WriteOptions, ZarrVersion,
    };
    let n = 128usize;
    let values: Vec<u16> = (0..n * n * n)
        .map(|i| {
            let (x, y, z) = (i % n, (i / n) % n, i / (n * n));
            let d2 = [x, y, z]
                .map(|c| (c as f64 + 0.5 - n as f64 / 2.0).powi(2))
                .iter()
                .sum::<f64>();
            if d2 < 24.0f64.powi(2) { 1000 } else { 0 }
        })
        .collect();
    let dir = tempfile::tempdir().expect("a temporary folder");
    let store = dir.path().join("ball.ome.zarr");
    let write_options = WriteOptions {
        version: ZarrVersion::V04,
        chunk: 32,
        shard_chunks: 2,
        compression: Compression::parse("zstd").expect("a codec"),
        downsampling: ZarrDownsampling::Mean,
        name: "ball".into(),
        unit: None,
    };
    let mut writer = PyramidWriter::create(
        &store,
        [n; 3],
        voxscope_volume::VoxelType::U16,
        [1.0; 3],
        &write_options,
    )
    .expect("a writer");
    writer
        .push(&VoxelData::U16(values.clone()))
        .expect("written");
    writer.finish().expect("finished");
    let pyramid = Pyramid::open(&store, PyramidOptions::default()).expect("the store opens");
    let zarr = Arc::new(ZarrSource::new(Arc::new(pyramid)).expect("a brick source"));
    let volume = voxscope_volume::load(store.to_str().expect("UTF-8"), &Default::default())
        .expect("the store loads");
    let transfer = TransferFunction {
        window: ValueWindow {
            low: 0.0,
            high: 1000.0,
        },
        ..TransferFunction::gray(ValueWindow {
            low: 0.0,
            high: 1000.0,
        })
    };
    let prepared = Prepared::new(volume, Some(transfer));
    let memory = Arc::new(
        MemorySource::new("ball", &prepared.quantized, [1.0; 3], Downsampling::Mean)
            .expect("pyramid"),
    );
    let context = gpu();
    let camera = close_camera(30.0);
    let settings = settings(prepared.octree.depth);
    let mut from_store = streaming(&context, zarr, options(64 << 20), &prepared.transfer);
    let stored = refine(&context, &mut from_store, &camera, &settings);
    let mut from_memory = streaming(&context, memory, options(64 << 20), &prepared.transfer);
    let loaded = refine(&context, &mut from_memory, &camera, &settings);
    let (stored_counters, loaded_counters) = (&stored.status.counters, &loaded.status.counters);
    eprintln!(
        "store: {} read, {} skipped unread; memory: {} read",
        stored_counters.loads, stored_counters.skipped_unread, loaded_counters.loads
    );
    assert!(coverage(&loaded.image) > 0.05, "the ball is drawn");
    let db = psnr(&stored.image, &loaded.image);
    assert!(db >= 60.0, "the same picture: {db:.1} dB");
    assert!(
        stored_counters.skipped_unread > 0,
        "empty bricks skipped from the ranges"
    );
    assert!(
        stored_counters.loads < loaded_counters.loads,
        "fewer bricks read: {} against {}",
        stored_counters.loads,
        loaded_counters.loads
    );
}

#[test]
fn bricks_that_failed_are_asked_for_again_and_the_view_recovers() {
    let context = gpu();
    let prepared = &*NOISE;
    let camera = close_camera(30.0);
    let settings = settings(prepared.octree.depth);
    // Level 0 unreadable while the server is down.
    let down = Arc::new(std::sync::atomic::AtomicBool::new(true));
    let source = Arc::new(Failing {
        inner: PYRAMID.clone(),
        fails: Box::new({
            let down = down.clone();
            move |id| id.level == 0 && down.load(std::sync::atomic::Ordering::SeqCst)
        }),
        away: true,
    });
    let mut renderer = streaming(
        &context,
        source.clone(),
        StreamOptions {
            retry_after: Duration::from_millis(200),
            ..options(level0_bytes())
        },
        &prepared.transfer,
    );
    // The server is away: level 0 fails, the view settles coarser, with errors.
    let away = refine(&context, &mut renderer, &camera, &settings);
    assert!(away.status.counters.failed > 0 && !away.errors.is_empty());
    assert_eq!(away.status.counters.levels[0].resident, 0);
    // It returns: the failed bricks are asked for again and the full view comes back.
    down.store(false, std::sync::atomic::Ordering::SeqCst);
    let started = Instant::now();
    let back = loop {
        std::thread::sleep(Duration::from_millis(60));
        let refined = refine(&context, &mut renderer, &camera, &settings);
        if refined.status.counters.failed == 0 {
            break refined;
        }
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "still failed: {:?}",
            refined.status.counters
        );
    };
    let expected = bricks_image(&context, prepared, &prepared.transfer, &camera, &settings);
    let db = psnr(&back.image, &expected);
    assert!(
        back.status.counters.levels[0].resident > 8,
        "level 0 streamed after all"
    );
    assert!(db >= 40.0, "recovered against bricks: {db:.1} dB");
}

#[test]
fn views_beyond_the_atlas_complete_in_mip_and_dvr_at_every_distance() {
    let context = gpu();
    let prepared = &*NOISE;
    // A small atlas: a sixth of level 0 (MIP's rays need every brick they cross).
    let budget = level0_bytes() / 6;
    for mode in [
        voxscope_render::RenderMode::Mip,
        voxscope_render::RenderMode::Dvr,
    ] {
        for distance in [0.6, 1.0, 1.6, 2.5] {
            let camera = Camera {
                distance,
                ..close_camera(30.0)
            };
            let settings = RenderSettings {
                mode,
                ..settings(prepared.octree.depth)
            };
            let mut renderer = streaming(
                &context,
                PYRAMID.clone(),
                options(budget),
                &prepared.transfer,
            );
            let refined = refine(&context, &mut renderer, &camera, &settings);
            let counters = &refined.status.counters;
            eprintln!(
                "{mode:?} at {distance}: complete after {} frames, {} bricks read for {} slots; {:?}",
                refined.frames,
                counters.loads,
                counters.slots,
                refined.status.budget.map(|b| b.describe())
            );
            assert!(
                counters.loads <= 3 * counters.slots as u64,
                "{mode:?} at {distance}: {} bricks read for {} slots",
                counters.loads,
                counters.slots
            );
        }
    }
}
