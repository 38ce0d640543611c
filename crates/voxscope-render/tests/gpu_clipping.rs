//! Clipping (a crop box, a clip plane, both) in every renderer and mode against the CPU
//! reference renderers with the same clip: the octree against the octree reference, dense
//! against the trilinear marcher, bricks (grid walk and tree walk) against dense.

mod support;

use support::reference::{MarchVolume, coverage, psnr, reference_march, reference_render};
use support::{Prepared, draw, gpu, image_dir};
use voxscope_octree::{Clip, ClipPlane};
use voxscope_render::{Camera, RenderMode, RenderSettings, RendererKind, RendererOptions, Shading};
use voxscope_volume::{LoadOptions, Volume};

const SIZE: (u32, u32) = (96, 72);

fn load(spec: &str) -> Volume {
    voxscope_volume::load(spec, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// The clips every renderer is tested with, by name.
fn clips() -> [(&'static str, Clip); 3] {
    let crop = Some([[0.2, 0.85], [0.0, 0.6], [0.1, 0.9]]);
    // Oblique, through the volume: keeps the side away from the origin corner.
    let plane = Some(ClipPlane {
        normal: [0.6, 0.3, 0.8],
        distance: 0.8,
    });
    [
        (
            "box",
            Clip {
                bounds: crop,
                plane: None,
            },
        ),
        (
            "plane",
            Clip {
                bounds: None,
                plane,
            },
        ),
        (
            "both",
            Clip {
                bounds: crop,
                plane: Some(ClipPlane {
                    normal: [-1.0, 0.0, 0.2],
                    distance: -0.6,
                }),
            },
        ),
    ]
}

fn camera() -> Camera {
    Camera {
        azimuth_deg: -40.0,
        elevation_deg: 25.0,
        distance: 1.7,
        ..Camera::default()
    }
}

/// The volumes: solid (clipping cuts it open) and semi-transparent.
fn volumes() -> Vec<(&'static str, Prepared, f32)> {
    vec![
        (
            "sphere",
            Prepared::new(load("synthetic:sphere:40x36x32"), None),
            1.0,
        ),
        (
            "noise",
            Prepared::new(load("synthetic:noise:45x30x21"), None),
            0.4,
        ),
    ]
}

fn settings(prepared: &Prepared, mode: RenderMode, density: f32, clip: Clip) -> RenderSettings {
    RenderSettings {
        mode,
        density,
        clip,
        ..RenderSettings::full_detail(prepared.octree.depth)
    }
}

fn check(name: &str, image: &image::RgbaImage, expected: &image::RgbaImage, min_db: f64) {
    let dir = image_dir();
    image.save(dir.join(format!("{name}.png"))).unwrap();
    expected
        .save(dir.join(format!("{name}-expected.png")))
        .unwrap();
    let db = psnr(image, expected);
    eprintln!("{name}: {db:.1} dB, coverage {:.2}", coverage(expected));
    assert!(coverage(expected) > 0.02, "{name}: the clip left nothing");
    assert!(db >= min_db, "{name}: {db:.1} dB");
}

#[test]
fn clipped_octree_matches_the_reference() {
    let context = gpu();
    for (volume_name, prepared, density) in volumes() {
        let renderer = prepared.renderer(&context, RendererKind::Octree);
        for mode in [RenderMode::Dvr, RenderMode::Mip] {
            let unclipped = draw(
                &context,
                &renderer,
                &camera(),
                &settings(&prepared, mode, density, Clip::NONE),
                SIZE,
            );
            for (clip_name, clip) in clips() {
                let settings = settings(&prepared, mode, density, clip);
                let image = draw(&context, &renderer, &camera(), &settings, SIZE);
                let reference = reference_render(
                    &prepared.octree,
                    prepared.volume.spacing,
                    &prepared.transfer,
                    &camera(),
                    &settings,
                    SIZE.0,
                    SIZE.1,
                );
                let name = format!("clip-octree-{volume_name}-{mode:?}-{clip_name}");
                check(&name, &image, &reference, 40.0);
                let change = psnr(&image, &unclipped);
                assert!(
                    change < 30.0,
                    "{name}: the clip changed little ({change:.1} dB)"
                );
            }
        }
    }
}

#[test]
fn clipped_dense_matches_the_marcher_and_clipped_bricks_match_dense() {
    let context = gpu();
    for (volume_name, prepared, density) in volumes() {
        let march = MarchVolume::new(&prepared.quantized);
        let dense = prepared.renderer(&context, RendererKind::Dense);
        let grid_walk = prepared.renderer(
            &context,
            RendererOptions {
                kind: RendererKind::Bricks,
                brick_size: 8,
                ..Default::default()
            },
        );
        for mode in [RenderMode::Dvr, RenderMode::Mip] {
            for (clip_name, clip) in clips() {
                let settings = settings(&prepared, mode, density, clip);
                let dense_image = draw(&context, &dense, &camera(), &settings, SIZE);
                let marched = reference_march(
                    &march,
                    prepared.volume.spacing,
                    &prepared.transfer,
                    &camera(),
                    &settings,
                    SIZE.0,
                    SIZE.1,
                );
                let name = format!("{volume_name}-{mode:?}-{clip_name}");
                check(&format!("clip-dense-{name}"), &dense_image, &marched, 40.0);
                // The grid walk, and the tree walk (the pixel LOD sends rays down the tree;
                // at this distance it cuts no brick).
                for (walk, pixel_lod) in [("grid", false), ("tree", true)] {
                    let bricks = draw(
                        &context,
                        &grid_walk,
                        &camera(),
                        &RenderSettings {
                            pixel_lod,
                            ..settings
                        },
                        SIZE,
                    );
                    check(
                        &format!("clip-bricks-{walk}-{name}"),
                        &bricks,
                        &dense_image,
                        40.0,
                    );
                }
            }
        }
    }
}

#[test]
fn clipping_and_shading_together_match_the_references() {
    let context = gpu();
    let prepared = Prepared::new(load("synthetic:sphere:40x36x32"), None);
    let march = MarchVolume::new(&prepared.quantized);
    let [_, _, (_, clip)] = clips();
    let settings = RenderSettings {
        shading: Shading::default(),
        ..settings(&prepared, RenderMode::Dvr, 1.0, clip)
    };
    let octree = draw(
        &context,
        &prepared.renderer(&context, RendererKind::Octree),
        &camera(),
        &settings,
        SIZE,
    );
    let reference = reference_render(
        &prepared.octree,
        prepared.volume.spacing,
        &prepared.transfer,
        &camera(),
        &settings,
        SIZE.0,
        SIZE.1,
    );
    check("clip-shaded-octree", &octree, &reference, 40.0);
    let dense = draw(
        &context,
        &prepared.renderer(&context, RendererKind::Dense),
        &camera(),
        &settings,
        SIZE,
    );
    let marched = reference_march(
        &march,
        prepared.volume.spacing,
        &prepared.transfer,
        &camera(),
        &settings,
        SIZE.0,
        SIZE.1,
    );
    check("clip-shaded-dense", &dense, &marched, 40.0);
    let bricks = draw(
        &context,
        &prepared.renderer(&context, RendererKind::Bricks),
        &camera(),
        &settings,
        SIZE,
    );
    check("clip-shaded-bricks", &bricks, &dense, 40.0);
}

#[test]
fn a_clip_that_keeps_nothing_draws_nothing() {
    let context = gpu();
    let prepared = Prepared::new(load("synthetic:sphere:32"), None);
    // Keeps n · p ≥ 2 with p in the unit cube and n = (1, 0, 0): nowhere.
    let nothing = Clip {
        bounds: None,
        plane: Some(ClipPlane {
            normal: [1.0, 0.0, 0.0],
            distance: 2.0,
        }),
    };
    for kind in RendererKind::ALL {
        let renderer = prepared.renderer(&context, kind);
        for mode in [RenderMode::Dvr, RenderMode::Mip] {
            let image = draw(
                &context,
                &renderer,
                &camera(),
                &settings(&prepared, mode, 1.0, nothing),
                SIZE,
            );
            assert_eq!(
                coverage(&image),
                0.0,
                "{} {mode:?}: drew something outside the clip",
                kind.name()
            );
        }
    }
}
