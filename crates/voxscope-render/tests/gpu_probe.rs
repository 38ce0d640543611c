//! The GPU probe against the CPU reference renderers: for a grid of pixels, the 3D point where
//! the ray's opacity reaches `PROBE_ALPHA` (DVR) or of its maximum (MIP), in every renderer,
//! clipped and not; and the non-blocking form against the blocking one.

mod support;

use glam::DVec3;
use support::reference::{MarchVolume, ReferenceProbe, reference_march_probe, reference_probe};
use support::{Prepared, gpu};
use voxscope_octree::{Clip, ClipPlane, TransferFunction};
use voxscope_render::{
    Camera, GpuContext, GpuProbe, ProbeRequest, RenderMode, RenderSettings, RendererKind,
    RendererOptions, VolumeRenderer, probe_pixel,
};
use voxscope_volume::{LoadOptions, ValueWindow, Volume};

const SIZE: (u32, u32) = (64, 48);

fn load(spec: &str) -> Volume {
    voxscope_volume::load(spec, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn camera() -> Camera {
    Camera {
        azimuth_deg: 35.0,
        elevation_deg: 20.0,
        distance: 1.3,
        ..Camera::default()
    }
}

/// A 16×12 grid of pixels over the image.
fn pixels() -> Vec<(u32, u32)> {
    (0..12)
        .flat_map(|row| (0..16).map(move |column| (column * 4 + 1, row * 4 + 2)))
        .collect()
}

/// The GPU's probe of `pixel` with `renderer`.
fn gpu_probe(
    context: &GpuContext,
    renderer: &VolumeRenderer,
    settings: &RenderSettings,
    pixel: (u32, u32),
) -> Option<DVec3> {
    let request = ProbeRequest {
        size: [SIZE.0, SIZE.1],
        pixel: [pixel.0, pixel.1],
        camera: &camera(),
        settings,
    };
    probe_pixel(context, renderer, &request)
        .expect("probe")
        .map(|hit| DVec3::from_array(hit.point.map(f64::from)))
}

/// Compares the GPU's and the reference's probes over [`pixels`]: found on both sides or on
/// neither, and where found, within `tolerance` voxels, except at pixels whose reference
/// margin is below `ambiguous` (a neighbouring sample within f32 arithmetic's reach), which
/// must be at most `max_ambiguous` of those found. Returns how many were compared exactly.
fn compare(
    name: &str,
    pixels: &[(u32, u32)],
    gpu: impl Fn((u32, u32)) -> Option<DVec3>,
    reference: impl Fn((u32, u32)) -> ReferenceProbe,
    tolerance: f64,
    ambiguous: f64,
) -> usize {
    let (mut found, mut compared, mut skipped) = (0, 0, 0);
    for &pixel in pixels {
        let expected = reference(pixel);
        let got = gpu(pixel);
        if expected.margin < ambiguous {
            skipped += 1;
            continue;
        }
        match (got, expected.point) {
            (None, None) => {}
            (Some(got), Some(point)) => {
                found += 1;
                let distance = got.distance(point);
                assert!(
                    distance <= tolerance,
                    "{name}, pixel {pixel:?}: GPU probe {got:.3} is {distance:.4} voxels from the reference's {point:.3} (margin {margin})",
                    margin = expected.margin
                );
                compared += 1;
            }
            (got, point) => panic!(
                "{name}, pixel {pixel:?}: GPU probe {got:?}, reference {point:?} (margin {})",
                expected.margin
            ),
        }
    }
    eprintln!(
        "{name}: {found} found and compared, {} missed on both sides, {skipped} ambiguous",
        pixels.len() - found - skipped
    );
    assert!(found >= 20, "{name}: only {found} pixels hit something");
    assert!(
        skipped * 4 <= pixels.len(),
        "{name}: {skipped} of {} pixels ambiguous",
        pixels.len()
    );
    compared
}

/// The sphere with the window's top above its maximum (no MIP ray saturates), and a clip.
fn scene() -> (Prepared, Vec<(&'static str, Clip)>) {
    let volume = load("synthetic:sphere:40x36x32");
    let transfer = TransferFunction::gray(ValueWindow {
        low: 40.0,
        high: 300.0,
    });
    let clips = vec![
        ("unclipped", Clip::NONE),
        (
            "clipped",
            Clip {
                bounds: Some([[0.0, 1.0], [0.0, 0.55], [0.0, 1.0]]),
                plane: Some(ClipPlane {
                    normal: [1.0, 0.0, 0.3],
                    distance: 0.35,
                }),
            },
        ),
    ];
    (Prepared::new(volume, Some(transfer)), clips)
}

fn settings(prepared: &Prepared, mode: RenderMode, clip: Clip) -> RenderSettings {
    RenderSettings {
        mode,
        clip,
        ..RenderSettings::full_detail(prepared.octree.depth)
    }
}

#[test]
fn the_octree_probe_equals_the_reference() {
    let context = gpu();
    let (prepared, clips) = scene();
    let renderer = prepared.renderer(&context, RendererKind::Octree);
    for mode in [RenderMode::Dvr, RenderMode::Mip] {
        for (clip_name, clip) in &clips {
            let settings = settings(&prepared, mode, *clip);
            compare(
                &format!("octree {mode:?} {clip_name}"),
                &pixels(),
                |pixel| gpu_probe(&context, &renderer, &settings, pixel),
                |pixel| {
                    reference_probe(
                        &prepared.octree,
                        prepared.volume.spacing,
                        &prepared.transfer,
                        &camera(),
                        &settings,
                        SIZE,
                        pixel,
                    )
                },
                0.01,
                1e-4,
            );
        }
    }
}

#[test]
fn the_dense_and_bricks_probes_equal_the_marcher() {
    let context = gpu();
    let (sphere, clips) = scene();
    // MIP on float data: its 16-bit float texture is filtered in floating point, so the GPU's
    // filtered values are the marcher's to far below a level. (An 8-bit texture is filtered
    // with 8-bit weights on some devices, lavapipe included: a tenth of a level and more on
    // the sphere's slopes, which moves the first sample of a maximum by one.)
    let noise = Prepared::new(load("synthetic:noise:40x36x32"), None);
    for (mode, prepared) in [(RenderMode::Dvr, &sphere), (RenderMode::Mip, &noise)] {
        let march = MarchVolume::new(&prepared.quantized);
        let renderers = [
            ("dense", prepared.renderer(&context, RendererKind::Dense)),
            (
                "bricks",
                prepared.renderer(
                    &context,
                    RendererOptions {
                        kind: RendererKind::Bricks,
                        brick_size: 8,
                        ..Default::default()
                    },
                ),
            ),
        ];
        // A sample is a voxel from the next; where the reference has one clearly, the GPU
        // must have the same one (f32 and f64 sample positions agree to 1e-3 voxels).
        let (tolerance, ambiguous) = match mode {
            RenderMode::Dvr => (0.01, 0.02),
            RenderMode::Mip => (0.01, 0.1),
        };
        for (clip_name, clip) in &clips {
            for pixel_lod in [false, true] {
                let settings = RenderSettings {
                    pixel_lod,
                    ..settings(prepared, mode, *clip)
                };
                for (renderer_name, renderer) in &renderers {
                    if pixel_lod && *renderer_name == "dense" {
                        continue; // dense has no level of detail
                    }
                    let walk = if pixel_lod { " tree walk" } else { "" };
                    compare(
                        &format!("{renderer_name}{walk} {mode:?} {clip_name}"),
                        &pixels(),
                        |pixel| gpu_probe(&context, renderer, &settings, pixel),
                        |pixel| {
                            reference_march_probe(
                                &march,
                                prepared.volume.spacing,
                                &prepared.transfer,
                                &camera(),
                                &settings,
                                SIZE,
                                pixel,
                            )
                        },
                        tolerance,
                        ambiguous,
                    );
                }
            }
        }
    }
}

#[test]
fn the_frame_probe_answers_later_without_waiting_as_the_blocking_one_does() {
    let context = gpu();
    let (prepared, _) = scene();
    let renderer = prepared.renderer(&context, RendererKind::Bricks);
    let settings = settings(&prepared, RenderMode::Dvr, Clip::NONE);
    let mut probe = GpuProbe::new(&context);
    let target = voxscope_render::RenderTarget::new(&context, SIZE.0, SIZE.1);
    let mut answers = Vec::new();
    for pixel in [(32, 24), (3, 3), (40, 30)] {
        let request = ProbeRequest {
            size: [SIZE.0, SIZE.1],
            pixel: [pixel.0, pixel.1],
            camera: &camera(),
            settings: &settings,
        };
        // A frame with the probe recorded into its encoder.
        let mut encoder = context.device.create_command_encoder(&Default::default());
        renderer.encode(&context, &mut encoder, &target, &camera(), &settings, None);
        assert!(
            probe
                .record(&context, &mut encoder, &renderer, &request)
                .unwrap()
        );
        // While it is in flight, another request is declined.
        assert!(
            !probe
                .record(&context, &mut encoder, &renderer, &request)
                .unwrap()
        );
        context.queue.submit([encoder.finish()]);
        probe.submitted();
        let outcome = loop {
            if let Some(outcome) = probe.poll(&context) {
                break outcome;
            }
            std::thread::sleep(std::time::Duration::from_millis(1));
        };
        assert!(probe.is_idle());
        assert_eq!(outcome.pixel, [pixel.0, pixel.1]);
        let blocking = probe_pixel(&context, &renderer, &request).unwrap();
        assert_eq!(outcome.hit, blocking, "pixel {pixel:?}");
        answers.push(outcome.hit);
    }
    assert!(answers[0].is_some(), "the center hits the sphere");
    assert!(answers[1].is_none(), "the corner misses it");
    let hit = answers[0].unwrap();
    let [x, y, z] = hit.voxel(prepared.volume.dims);
    assert!(x < 40 && y < 36 && z < 32);
    // A pixel outside the image is an error, not a probe.
    let outside = ProbeRequest {
        size: [SIZE.0, SIZE.1],
        pixel: [SIZE.0, 0],
        camera: &camera(),
        settings: &settings,
    };
    let error = probe_pixel(&context, &renderer, &outside).unwrap_err();
    assert!(error.to_string().contains("outside"), "{error}");
}

#[test]
fn the_composite_probe_of_one_channel_in_white_equals_the_marcher() {
    // One channel in white is the channel's own picture: its opacity and maximum are the
    // composite's, so its probe must find the marcher's point, as the dense renderer's does.
    // (The composite's MIP probes the brightest channel's maximum, so none where the pixel is
    // black: its window starts below the lowest value, which the marcher's MIP takes for
    // nothing, so that every other maximum is lit.)
    let context = gpu();
    let (plain, clips) = scene();
    let lowest = plain.quantized.value_range[0];
    let lit = TransferFunction::gray(ValueWindow {
        low: lowest - 100.0,
        high: 300.0,
    });
    for (mode, transfer) in [(RenderMode::Dvr, plain.transfer), (RenderMode::Mip, lit)] {
        let sphere = Prepared::new(load("synthetic:sphere:40x36x32"), Some(transfer));
        let march = MarchVolume::new(&sphere.quantized);
        let layer = voxscope_render::ChannelLayer {
            quantized: &sphere.quantized,
            transfer: &sphere.transfer,
            color: [1.0; 3],
        };
        let renderer = VolumeRenderer::new_composite(&context, &[layer], sphere.volume.spacing)
            .expect("composite");
        for (clip_name, clip) in &clips {
            let settings = settings(&sphere, mode, *clip);
            compare(
                &format!("composite {mode:?} {clip_name}"),
                &pixels(),
                |pixel| gpu_probe(&context, &renderer, &settings, pixel),
                |pixel| {
                    reference_march_probe(
                        &march,
                        sphere.volume.spacing,
                        &sphere.transfer,
                        &camera(),
                        &settings,
                        SIZE,
                        pixel,
                    )
                },
                0.01,
                match mode {
                    RenderMode::Dvr => 0.02,
                    RenderMode::Mip => 0.1,
                },
            );
        }
    }
}
