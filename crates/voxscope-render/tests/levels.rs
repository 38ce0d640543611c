//! Every max level draws that level's resolution in every renderer (lavapipe). Below the bricks'
//! level, `dense` and `bricks` march the max level's own pyramid level (the volume reduced 2×
//! per level by the mean, one sample per voxel of that level) as the streaming renderer does,
//! so the three agree level by level; at and above the brick level `bricks` draws its nodes,
//! as the paper's octree does.

mod support;

use std::sync::LazyLock;
use std::time::{Duration, Instant};

use image::RgbaImage;
use support::reference::psnr;
use support::{Prepared, draw, gpu, image_dir};
use voxscope_render::{
    Camera, GpuContext, RenderMode, RenderSettings, RenderTarget, RendererKind, RendererOptions,
    Shading, VolumeRenderer, read_image,
};
use voxscope_volume::SyntheticKind;

/// Image size of every test (small: lavapipe draws every pixel on the CPU).
const SIZE: (u32, u32) = (192, 160);

/// A 128³ noise volume (depth 7, 32³ bricks at level 2): no brick is uniform or transparent,
/// so every brick a ray reaches is marched, and a level's picture differs from the next one's.
static NOISE: LazyLock<Prepared> = LazyLock::new(|| {
    let volume = SyntheticKind::Noise
        .generate([128; 3])
        .expect("synthetic noise");
    Prepared::new(volume, None)
});

/// The bricks' level of `NOISE`: 128 / 32 = 4 bricks a side.
const BRICK_LEVEL: u32 = 2;

fn camera() -> Camera {
    Camera {
        azimuth_deg: 30.0,
        elevation_deg: 20.0,
        distance: 2.2,
        fov_y_deg: 30.0,
        pan: [0.0; 3],
    }
}

/// See-through (rays cross several bricks), opacity correction on.
fn settings(max_level: u32) -> RenderSettings {
    RenderSettings {
        density: 0.25,
        ..RenderSettings::full_detail(max_level)
    }
}

fn renderer(context: &GpuContext, kind: RendererKind) -> VolumeRenderer {
    NOISE.renderer(
        context,
        RendererOptions {
            // The whole pyramid fits: the stream draws the level asked for, nothing coarser.
            gpu_memory: 256 << 20,
            ..kind.into()
        },
    )
}

/// The streaming renderer's image once nothing visible is missing.
fn refined(
    context: &GpuContext,
    renderer: &mut VolumeRenderer,
    settings: &RenderSettings,
) -> RgbaImage {
    let target = RenderTarget::new(context, SIZE.0, SIZE.1);
    let started = Instant::now();
    let mut first_frame = None;
    loop {
        let status = renderer.update(context).expect("a streaming renderer");
        let first = *first_frame.get_or_insert(status.frame);
        renderer.render(context, &target, &camera(), settings);
        context.wait_idle().expect("GPU");
        if status.complete && status.judged_frame.is_some_and(|judged| judged >= first) {
            return read_image(context, &target).expect("readback");
        }
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "not complete: {status:?}"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
}

fn save(image: &RgbaImage, name: &str) {
    image
        .save(image_dir().join(format!("levels-{name}.png")))
        .expect("write test image");
}

#[test]
fn each_level_below_the_bricks_draws_its_own_pyramid_level_in_dense_bricks_and_stream() {
    let context = gpu();
    let depth = NOISE.octree.depth;
    assert_eq!((depth, NOISE.octree.depth - 5), (7, BRICK_LEVEL));
    let dense = renderer(&context, RendererKind::Dense);
    let bricks = renderer(&context, RendererKind::Bricks);
    let mut stream = renderer(&context, RendererKind::Stream);
    let mut finer: Option<RgbaImage> = None;
    for max_level in (BRICK_LEVEL + 1..=depth).rev() {
        let settings = settings(max_level);
        let dense_image = draw(&context, &dense, &camera(), &settings, SIZE);
        let bricks_image = draw(&context, &bricks, &camera(), &settings, SIZE);
        let stream_image = refined(&context, &mut stream, &settings);
        save(&dense_image, &format!("dense-{max_level}"));
        save(&bricks_image, &format!("bricks-{max_level}"));
        save(&stream_image, &format!("stream-{max_level}"));
        let dense_db = psnr(&dense_image, &stream_image);
        let bricks_db = psnr(&bricks_image, &stream_image);
        eprintln!("max level {max_level}: dense {dense_db:.1} dB, bricks {bricks_db:.1} dB");
        assert!(
            dense_db >= 40.0 && bricks_db >= 40.0,
            "max level {max_level} against the stream's: dense {dense_db:.1} dB, bricks {bricks_db:.1} dB"
        );
        // Each level is a picture of its own, not the finer one's: further from it than the
        // renderers are from each other.
        if let Some(finer) = &finer {
            let db = psnr(&bricks_image, finer);
            assert!(
                db < 38.0,
                "max level {max_level} draws level {}'s picture ({db:.1} dB)",
                max_level + 1
            );
        }
        finer = Some(bricks_image);
    }
}

#[test]
fn on_a_head_with_empty_and_uniform_regions_bricks_draw_each_level_as_dense_does() {
    // The sample head (128×62×128, depth 7): background cells are transparent or uniform, the
    // cells a coarser level blurs across; bricks sample them as dense does, skipping none.
    let context = gpu();
    let head = Prepared::new(voxscope_volume::sample().expect("the sample"), None);
    let dense = head.renderer(&context, RendererKind::Dense);
    let bricks = head.renderer(&context, RendererKind::Bricks);
    for max_level in 3..head.octree.depth {
        for mode in [RenderMode::Dvr, RenderMode::Mip] {
            let settings = RenderSettings {
                mode,
                ..RenderSettings::full_detail(max_level)
            };
            let expected = draw(&context, &dense, &camera(), &settings, SIZE);
            let image = draw(&context, &bricks, &camera(), &settings, SIZE);
            save(&image, &format!("head-bricks-{mode:?}-{max_level}"));
            let db = psnr(&image, &expected);
            assert!(
                db >= 60.0,
                "{mode:?} at max level {max_level}: {db:.1} dB against dense"
            );
        }
    }
}

#[test]
fn shaded_and_mip_frames_of_a_pyramid_level_agree_across_renderers() {
    let context = gpu();
    let dense = renderer(&context, RendererKind::Dense);
    let bricks = renderer(&context, RendererKind::Bricks);
    let mut stream = renderer(&context, RendererKind::Stream);
    let max_level = NOISE.octree.depth - 2;
    let shaded = RenderSettings {
        shading: Shading::default(),
        ..settings(max_level)
    };
    let mip = RenderSettings {
        mode: RenderMode::Mip,
        ..settings(max_level)
    };
    for (name, settings) in [("shaded", shaded), ("mip", mip)] {
        let expected = refined(&context, &mut stream, &settings);
        let dense_db = psnr(
            &draw(&context, &dense, &camera(), &settings, SIZE),
            &expected,
        );
        let bricks_image = draw(&context, &bricks, &camera(), &settings, SIZE);
        save(&bricks_image, &format!("bricks-{name}-{max_level}"));
        let bricks_db = psnr(&bricks_image, &expected);
        eprintln!(
            "{name}, max level {max_level}: dense {dense_db:.1} dB, bricks {bricks_db:.1} dB"
        );
        assert!(
            dense_db >= 40.0 && bricks_db >= 40.0,
            "{name} at max level {max_level}: dense {dense_db:.1} dB, bricks {bricks_db:.1} dB"
        );
    }
}

#[test]
fn at_the_brick_level_bricks_draw_their_nodes_as_the_octree_does() {
    let context = gpu();
    let settings = settings(BRICK_LEVEL);
    let octree = draw(
        &context,
        &renderer(&context, RendererKind::Octree),
        &camera(),
        &settings,
        SIZE,
    );
    let bricks = renderer(&context, RendererKind::Bricks);
    let at_level = draw(&context, &bricks, &camera(), &settings, SIZE);
    save(&at_level, &format!("bricks-{BRICK_LEVEL}"));
    let db = psnr(&at_level, &octree);
    assert!(
        db >= 40.0,
        "bricks at their own level against the octree: {db:.1} dB"
    );
    let below = draw(
        &context,
        &bricks,
        &camera(),
        &self::settings(BRICK_LEVEL + 1),
        SIZE,
    );
    assert!(
        psnr(&at_level, &below) < 35.0,
        "the brick level draws the level below it"
    );
}
