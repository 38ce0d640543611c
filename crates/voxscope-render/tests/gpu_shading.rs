//! Headlight shading on the GPU against the CPU reference renderers: the octree's face shading
//! against the octree reference, dense's gradient shading against the trilinear marcher, and
//! bricks against dense; a composite's channel in white as one volume; MIP is never shaded.

mod support;

use support::reference::{MarchVolume, coverage, psnr, reference_march, reference_render};
use support::{Prepared, draw, gpu, image_dir};
use voxscope_octree::{OpacityMode, TransferFunction};
use voxscope_render::{
    Camera, DEFAULT_BRICK_SIZE, RenderMode, RenderSettings, RendererKind, RendererOptions, Shading,
};
use voxscope_volume::{LoadOptions, Volume};

const SIZE: (u32, u32) = (96, 72);

fn load(spec: &str) -> Volume {
    voxscope_volume::load(spec, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn shaded(depth: u32) -> RenderSettings {
    RenderSettings {
        shading: Shading::default(),
        ..RenderSettings::full_detail(depth)
    }
}

fn camera(azimuth_deg: f64, elevation_deg: f64, distance: f64) -> Camera {
    Camera {
        azimuth_deg,
        elevation_deg,
        distance,
        ..Camera::default()
    }
}

/// Saves both images, prints and returns their PSNR.
fn agreement(name: &str, gpu_image: &image::RgbaImage, cpu_image: &image::RgbaImage) -> f64 {
    let dir = image_dir();
    gpu_image.save(dir.join(format!("{name}-gpu.png"))).unwrap();
    cpu_image.save(dir.join(format!("{name}-cpu.png"))).unwrap();
    let db = psnr(gpu_image, cpu_image);
    eprintln!("{name}: {db:.1} dB, coverage {:.2}", coverage(cpu_image));
    db
}

/// The cases every renderer is shaded in: volume, transfer function, density, camera.
fn cases() -> Vec<(&'static str, Volume, Option<OpacityMode>, f32, Camera)> {
    vec![
        (
            "sphere",
            load("synthetic:sphere:40"),
            None,
            1.0,
            camera(30.0, 20.0, 1.8),
        ),
        (
            "shells-binary",
            load("synthetic:shells:40x36x29"),
            Some(OpacityMode::Binary),
            1.0,
            camera(75.0, 40.0, 1.7),
        ),
        (
            "noise",
            load("synthetic:noise:45x30x21"),
            None,
            0.4,
            camera(-40.0, 25.0, 1.7),
        ),
        // Anisotropic (2×2×3 mm), i16: normals go through the spacing.
        (
            "sample",
            voxscope_volume::sample().unwrap(),
            None,
            1.0,
            camera(20.0, 10.0, 1.6),
        ),
    ]
}

fn prepare(volume: Volume, opacity: Option<OpacityMode>) -> Prepared {
    let window = voxscope_volume::QuantizedVolume::new(&volume).robust_window();
    let transfer = TransferFunction {
        opacity: opacity.unwrap_or(OpacityMode::Gray),
        threshold: 0.5,
        ..TransferFunction::gray(window)
    };
    Prepared::new(volume, Some(transfer))
}

#[test]
fn octree_face_shading_matches_the_reference() {
    let context = gpu();
    for (name, volume, opacity, density, camera) in cases() {
        let prepared = prepare(volume, opacity);
        let renderer = prepared.renderer(&context, RendererKind::Octree);
        let settings = RenderSettings {
            density,
            ..shaded(prepared.octree.depth)
        };
        let gpu_image = draw(&context, &renderer, &camera, &settings, SIZE);
        let cpu_image = reference_render(
            &prepared.octree,
            prepared.volume.spacing,
            &prepared.transfer,
            &camera,
            &settings,
            SIZE.0,
            SIZE.1,
        );
        let db = agreement(&format!("shaded-octree-{name}"), &gpu_image, &cpu_image);
        assert!(
            db >= 40.0,
            "{name}: shaded octree differs from the reference: {db:.1} dB"
        );
        // Shading changed the picture (the test would pass with shading ignored on both
        // sides otherwise).
        let unshaded = draw(
            &context,
            &renderer,
            &camera,
            &RenderSettings {
                shading: Shading::OFF,
                ..settings
            },
            SIZE,
        );
        let change = psnr(&unshaded, &gpu_image);
        assert!(
            change < 35.0,
            "{name}: shading changed little ({change:.1} dB)"
        );
    }
}

#[test]
fn dense_matches_the_cpu_marcher_shaded_and_not() {
    let context = gpu();
    for (name, volume, opacity, density, camera) in cases() {
        let prepared = prepare(volume, opacity);
        let renderer = prepared.renderer(&context, RendererKind::Dense);
        let march = MarchVolume::new(&prepared.quantized);
        for shading in [Shading::OFF, Shading::default()] {
            let settings = RenderSettings {
                density,
                shading,
                ..RenderSettings::full_detail(prepared.octree.depth)
            };
            let gpu_image = draw(&context, &renderer, &camera, &settings, SIZE);
            let cpu_image = reference_march(
                &march,
                prepared.volume.spacing,
                &prepared.transfer,
                &camera,
                &settings,
                SIZE.0,
                SIZE.1,
            );
            let label = if shading.enabled { "shaded" } else { "plain" };
            let db = agreement(&format!("{label}-dense-{name}"), &gpu_image, &cpu_image);
            assert!(coverage(&cpu_image) > 0.05, "{name}: nothing drawn");
            assert!(
                db >= 40.0,
                "{name}: {label} dense differs from the CPU marcher: {db:.1} dB"
            );
        }
    }
}

#[test]
fn shaded_bricks_match_shaded_dense_in_the_grid_walk_and_the_tree_walk() {
    let context = gpu();
    for (name, volume, opacity, density, camera) in cases() {
        let prepared = prepare(volume, opacity);
        let settings = RenderSettings {
            density,
            ..shaded(prepared.octree.depth)
        };
        let dense = draw(
            &context,
            &prepared.renderer(&context, RendererKind::Dense),
            &camera,
            &settings,
            SIZE,
        );
        // Small bricks test the gradient across brick faces (the apron), the default size what
        // users get; the pixel LOD sends rays down the tree walk, whose bricks are marched by
        // `march_brick` (at this distance no brick projects below a pixel).
        for (brick_size, pixel_lod) in [(4, false), (DEFAULT_BRICK_SIZE, false), (8, true)] {
            let bricks = prepared.renderer(
                &context,
                RendererOptions {
                    kind: RendererKind::Bricks,
                    brick_size,
                    ..Default::default()
                },
            );
            let image = draw(
                &context,
                &bricks,
                &camera,
                &RenderSettings {
                    pixel_lod,
                    ..settings
                },
                SIZE,
            );
            let walk = if pixel_lod { "tree" } else { "grid" };
            let db = agreement(
                &format!("shaded-bricks-{name}-b{brick_size}-{walk}"),
                &image,
                &dense,
            );
            assert!(
                db >= 40.0,
                "{name}, bricks of {brick_size}, {walk} walk: shaded bricks differ from dense: {db:.1} dB"
            );
        }
    }
}

#[test]
fn mip_and_the_heat_map_are_never_shaded() {
    let context = gpu();
    let prepared = prepare(load("synthetic:noise:45x30x21"), None);
    let camera = camera(-40.0, 25.0, 1.7);
    for kind in RendererKind::ALL {
        let renderer = prepared.renderer(&context, kind);
        for base in [
            RenderSettings {
                mode: RenderMode::Mip,
                ..RenderSettings::full_detail(prepared.octree.depth)
            },
            RenderSettings {
                heatmap: true,
                ..RenderSettings::full_detail(prepared.octree.depth)
            },
        ] {
            let plain = draw(&context, &renderer, &camera, &base, SIZE);
            let with_shading = draw(
                &context,
                &renderer,
                &camera,
                &RenderSettings {
                    shading: Shading::default(),
                    ..base
                },
                SIZE,
            );
            assert!(coverage(&plain) > 0.05);
            assert!(
                plain == with_shading,
                "{}: shading changed a MIP or heat-map image",
                kind.name()
            );
        }
    }
}

#[test]
fn a_composite_of_one_channel_in_white_shades_as_the_cpu_marcher() {
    // Each channel of a composite is lit by its own gradient, weighted by its own window, its
    // highlight in its own hue: in white, that is one volume's shading. (The composite holds
    // 16-bit floats: exact up to level 2048, so the i16 sample differs by that rounding.)
    let context = gpu();
    for (name, volume, opacity, density, camera) in cases() {
        let prepared = prepare(volume, opacity);
        let layer = voxscope_render::ChannelLayer {
            quantized: &prepared.quantized,
            transfer: &prepared.transfer,
            color: [1.0; 3],
        };
        let renderer = voxscope_render::VolumeRenderer::new_composite(
            &context,
            &[layer],
            prepared.volume.spacing,
        )
        .expect("composite");
        let march = MarchVolume::new(&prepared.quantized);
        let settings = RenderSettings {
            density,
            ..shaded(prepared.octree.depth)
        };
        let gpu_image = draw(&context, &renderer, &camera, &settings, SIZE);
        let cpu_image = reference_march(
            &march,
            prepared.volume.spacing,
            &prepared.transfer,
            &camera,
            &settings,
            SIZE.0,
            SIZE.1,
        );
        let unlit = draw(
            &context,
            &renderer,
            &camera,
            &RenderSettings {
                shading: Shading::OFF,
                ..settings
            },
            SIZE,
        );
        assert!(psnr(&unlit, &cpu_image) < 35.0, "{name}: shading shows");
        let db = agreement(&format!("shaded-composite-{name}"), &gpu_image, &cpu_image);
        assert!(
            db >= 38.0,
            "{name}: the shaded composite differs from the CPU marcher: {db:.1} dB"
        );
    }
}
