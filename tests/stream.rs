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
use support::reference::{coverage, psnr};
use support::{Prepared, gpu, image_dir};
use voxscope::octree::{self, BuildOptions, OpacityMode, TransferFunction};
use voxscope::render::{
    Camera, GpuContext, RenderSettings, RenderTarget, RendererKind, VolumeRenderer, read_image,
};
use voxscope::stream::{
    BrickData, BrickError, BrickId, BrickSource, Downsampling, MemorySource, PADDED_BRICK_VOXELS,
    PyramidShape, StreamOptions, StreamStatus,
};
use voxscope::volume::{Histogram, Quantization, QuantizedVolume, SyntheticKind};

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
        workers: 2,
        lod_scale: 0.0,
        prefetch: false,
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
    for frame in 0.. {
        edit(frame, context, renderer);
        let status = renderer.update(context).expect("a streaming renderer");
        most_slots_used = most_slots_used.max(status.counters.slots_used);
        most_upload_bytes = most_upload_bytes.max(status.upload_bytes);
        assert!(status.counters.slots_used <= status.counters.slots);
        renderer.render(context, &target, camera, settings);
        context.wait_idle().expect("GPU");
        if status.complete {
            return Refined {
                image: read_image(context, &target).expect("readback"),
                status,
                frames: frame,
                most_slots_used,
                most_upload_bytes,
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
    let mut renderer = streaming(&context, PYRAMID.clone(), options(budget), &prepared.transfer);
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
        "refined in {} frames: {db:.1} dB, {} of {} slots at most, lod bias {}, {:?}",
        refined.frames, refined.most_slots_used, status.counters.slots, status.lod_bias,
        status.counters.levels
    );
    assert!(coverage(&expected) > 0.5, "the view shows the volume");
    assert_eq!(status.lod_bias, 0, "the budget holds this view at full resolution");
    assert!(status.counters.levels[0].resident > 8, "level 0 was streamed");
    assert!(db >= 40.0, "streamed against bricks: {db:.1} dB");
    assert!(refined.most_upload_bytes <= 8 << 20, "the per-frame upload budget holds");
    assert!(gpu_total(&renderer) <= budget);
    assert!(status.errors.is_empty());
}

