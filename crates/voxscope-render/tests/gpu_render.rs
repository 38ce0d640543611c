//! The GPU ray caster against the CPU reference renderer, across volumes (real and synthetic,
//! cubic and not), cameras, levels, opacity modes and MIP; and GPU recolor against CPU recolor.

mod support;

use support::reference::{coverage, psnr, reference_render};
use support::{colored_octree, gpu, gpu_render, image_dir, shared_data};
use voxscope_octree::{BuildOptions, OpacityMode, TransferFunction};
use voxscope_render::{
    Camera, DEFAULT_BRICK_SIZE, GpuContext, GpuVolume, RenderMode, RenderSettings, RendererKind,
    RendererOptions, VolumeRenderer, read_buffer,
};
use voxscope_volume::{LoadOptions, Volume};

const SIZE: (u32, u32) = (96, 72);

fn load(spec: &str) -> Volume {
    voxscope_volume::load(spec, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn cameras() -> [Camera; 4] {
    [
        Camera::default(),
        Camera {
            azimuth_deg: -120.0,
            elevation_deg: -35.0,
            distance: 1.6,
            ..Camera::default()
        },
        Camera {
            azimuth_deg: 0.0,
            elevation_deg: 89.0,
            distance: 2.2,
            fov_y_deg: 30.0,
            ..Camera::default()
        },
        // Inside the volume: rays start at the eye, not at the box.
        Camera {
            azimuth_deg: 200.0,
            elevation_deg: 10.0,
            distance: 0.25,
            fov_y_deg: 70.0,
            ..Camera::default()
        },
    ]
}

/// Renders one case on both sides, saves both images, and checks they agree.
fn compare(
    context: &GpuContext,
    name: &str,
    volume: &Volume,
    transfer: Option<TransferFunction>,
    camera: &Camera,
    settings: impl Fn(u32) -> RenderSettings,
) -> f64 {
    let (octree, transfer) = colored_octree(volume, transfer, BuildOptions::default());
    let settings = settings(octree.depth);
    let gpu_image = gpu_render(
        context,
        &octree,
        volume.spacing,
        &transfer,
        camera,
        &settings,
        SIZE,
    );
    let cpu_image = reference_render(
        &octree,
        volume.spacing,
        &transfer,
        camera,
        &settings,
        SIZE.0,
        SIZE.1,
    );
    let dir = image_dir();
    gpu_image.save(dir.join(format!("{name}-gpu.png"))).unwrap();
    cpu_image.save(dir.join(format!("{name}-cpu.png"))).unwrap();
    let db = psnr(&gpu_image, &cpu_image);
    eprintln!("{name}: {db:.1} dB, coverage {:.2}", coverage(&cpu_image));
    assert!(
        db >= 40.0,
        "{name}: GPU and CPU reference differ, PSNR {db:.1} dB"
    );
    db
}

fn full(depth: u32) -> RenderSettings {
    RenderSettings::full_detail(depth)
}

#[test]
fn synthetic_cube_matches_reference_from_every_camera() {
    let context = gpu();
    let volume = load("synthetic:sphere:32");
    for (i, camera) in cameras().iter().enumerate() {
        compare(
            &context,
            &format!("sphere-cam{i}"),
            &volume,
            None,
            camera,
            full,
        );
    }
    // The default view is not an empty picture.
    let (octree, transfer) = colored_octree(&volume, None, BuildOptions::default());
    let image = reference_render(
        &octree,
        volume.spacing,
        &transfer,
        &Camera::default(),
        &full(octree.depth),
        SIZE.0,
        SIZE.1,
    );
    assert!(
        coverage(&image) > 0.05,
        "the sphere covers {:.3} of the image",
        coverage(&image)
    );
}

#[test]
fn non_cubic_float_volume_matches_reference_at_every_level() {
    let context = gpu();
    let volume = load("synthetic:noise:20x27x13");
    let camera = Camera {
        distance: 1.8,
        ..Camera::default()
    };
    for level in 0..=5 {
        let db = compare(
            &context,
            &format!("noise-level{level}"),
            &volume,
            None,
            &camera,
            |depth| RenderSettings {
                max_level: level.min(depth),
                density: 0.3,
                ..full(depth)
            },
        );
        eprintln!("noise level {level}: {db:.1} dB");
    }
}

#[test]
fn binary_opacity_and_plain_compositing_match_reference() {
    let context = gpu();
    let volume = load("synthetic:shells:40x30x24");
    let window = voxscope_volume::QuantizedVolume::new(&volume).robust_window();
    let binary = TransferFunction {
        opacity: OpacityMode::Binary,
        window,
        threshold: 0.5,
        colormap: Default::default(),
    };
    let camera = Camera {
        azimuth_deg: 75.0,
        elevation_deg: 40.0,
        distance: 1.7,
        ..Camera::default()
    };
    compare(
        &context,
        "shells-binary",
        &volume,
        Some(binary),
        &camera,
        full,
    );
    compare(
        &context,
        "shells-binary-level3",
        &volume,
        Some(binary),
        &camera,
        |d| RenderSettings {
            max_level: 3,
            ..full(d)
        },
    );
    compare(&context, "shells-gray-plain", &volume, None, &camera, |d| {
        RenderSettings {
            opacity_correction: false,
            density: 0.2,
            ..full(d)
        }
    });
}

#[test]
fn mip_matches_reference() {
    let context = gpu();
    let volume = load("synthetic:noise:24x24x30");
    for (i, camera) in cameras().iter().take(2).enumerate() {
        compare(
            &context,
            &format!("noise-mip-cam{i}"),
            &volume,
            None,
            camera,
            |d| RenderSettings {
                mode: RenderMode::Mip,
                ..full(d)
            },
        );
    }
    compare(
        &context,
        "noise-mip-level2",
        &volume,
        None,
        &Camera::default(),
        |d| RenderSettings {
            mode: RenderMode::Mip,
            max_level: 2,
            ..full(d)
        },
    );
}

#[test]
fn pixel_footprint_lod_matches_reference() {
    let context = gpu();
    let volume = load("synthetic:sphere:64");
    // Far away at a small size, many nodes project below a pixel.
    let camera = Camera {
        distance: 6.0,
        ..Camera::default()
    };
    compare(&context, "sphere-pixel-lod", &volume, None, &camera, |d| {
        RenderSettings {
            pixel_lod: true,
            ..full(d)
        }
    });
}

#[test]
fn real_mri_heads_match_reference() {
    let context = gpu();
    // Anisotropic (2×2×3 mm), reoriented, i16: the embedded sample.
    let sample = voxscope_volume::sample().unwrap();
    let camera = Camera {
        azimuth_deg: 20.0,
        elevation_deg: 10.0,
        distance: 1.6,
        ..Camera::default()
    };
    compare(&context, "sample-gray", &sample, None, &camera, full);
    compare(&context, "sample-mip", &sample, None, &camera, |d| {
        RenderSettings {
            mode: RenderMode::Mip,
            ..full(d)
        }
    });
    compare(&context, "sample-level4", &sample, None, &camera, |d| {
        RenderSettings {
            max_level: 4,
            ..full(d)
        }
    });
    // Non-cubic 197×233×189 template.
    let mni = load(
        shared_data("mni152-t1-197x233x189.nii.gz")
            .to_str()
            .unwrap(),
    );
    let window = voxscope_volume::QuantizedVolume::new(&mni).robust_window();
    let binary = TransferFunction {
        opacity: OpacityMode::Binary,
        window,
        threshold: 0.35,
        colormap: Default::default(),
    };
    compare(&context, "mni152-binary", &mni, Some(binary), &camera, full);
}

#[test]
fn gpu_recolor_equals_cpu_recolor_bit_for_bit() {
    let context = gpu();
    let recolor = context.recolor();
    for spec in ["synthetic:noise:37x20x29", "synthetic:shells:32"] {
        let volume = load(spec);
        let (mut octree, first) = colored_octree(&volume, None, BuildOptions::default());
        let mut gpu_volume =
            GpuVolume::upload(&context, &octree, volume.spacing, octree.depth, &first).unwrap();
        // A different transfer function, applied on both sides.
        let second = TransferFunction {
            opacity: OpacityMode::Binary,
            window: voxscope_volume::ValueWindow {
                low: first.window.low,
                high: first.window.high * 0.8,
            },
            threshold: 0.4,
            colormap: Default::default(),
        };
        gpu_volume.write_lookup_table(&context, &second);
        let mut encoder = context.device.create_command_encoder(&Default::default());
        recolor
            .encode(&context, &mut encoder, &gpu_volume, None)
            .unwrap();
        context.queue.submit([encoder.finish()]);
        let bytes = read_buffer(&context, &gpu_volume.nodes, gpu_volume.nodes.size()).unwrap();
        let gpu_nodes: &[voxscope_octree::Node] = bytemuck::cast_slice(&bytes);
        voxscope_octree::recolor(&mut octree, &second);
        assert_eq!(gpu_nodes.len(), octree.nodes.len());
        let differing = gpu_nodes
            .iter()
            .zip(&octree.nodes)
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(
            differing, 0,
            "{spec}: {differing} nodes differ after GPU recolor"
        );
        assert!(
            octree.nodes.iter().any(|n| n.alpha() == 255),
            "{spec}: binary recolor made opaque nodes"
        );
    }
}

#[test]
fn an_octree_beyond_the_device_limit_fails_with_both_sizes_and_a_level_to_try() {
    let mut context = gpu();
    let volume = load("synthetic:sphere:64");
    let (octree, transfer) = colored_octree(
        &volume,
        None,
        BuildOptions {
            collapse_uniform: false,
            ..BuildOptions::default()
        },
    );
    // Pretend the device allows a bit more than levels 0..=4 (4681 nodes).
    context.limits.max_storage_buffer_binding_size = 40_000;
    let error = GpuVolume::upload(&context, &octree, volume.spacing, octree.depth, &transfer)
        .err()
        .expect("upload must fail")
        .to_string();
    assert!(error.contains("MiB"), "{error}");
    // Said as a max level, which the command line (--level) and the app both set.
    assert!(error.contains("it fits through max level 4"), "{error}");
    // The suggested level fits.
    GpuVolume::upload(&context, &octree, volume.spacing, 4, &transfer).expect("level 4 fits");
}

#[test]
fn rays_visit_a_bounded_number_of_nodes_from_every_direction() {
    // A ray crosses at most 3·side voxels and each step descends at most depth + 1 nodes;
    // a traversal that revisits nodes (as a rounding-sensitive child choice once did, near the
    // volume at some azimuths) blows far past this.
    let context = gpu();
    let volume = load("synthetic:sphere:64");
    let (octree, transfer) = colored_octree(&volume, None, BuildOptions::default());
    let bound = 3 * octree.side() as u32 * (octree.depth + 1);
    let gpu_volume =
        GpuVolume::upload(&context, &octree, volume.spacing, octree.depth, &transfer).unwrap();
    let target = voxscope_render::RenderTarget::new(&context, 64, 48);
    let settings = full(octree.depth);
    for distance in [0.4, 1.5, 3.0] {
        for elevation in [-50.0, 20.0, 70.0] {
            for step in 0..12 {
                let camera = Camera {
                    azimuth_deg: 30.0 * step as f64,
                    elevation_deg: elevation,
                    distance,
                    ..Camera::default()
                };
                let frame = voxscope_render::Frame {
                    volume: &gpu_volume,
                    target: &target,
                    camera: &camera,
                    settings: &settings,
                };
                voxscope_render::render_frame(&context, &frame);
                let visits = voxscope_render::read_visits(&context, &target).unwrap();
                let max = visits.iter().copied().max().unwrap();
                assert!(
                    max <= bound,
                    "azimuth {} elevation {elevation} distance {distance}: a ray visited {max} nodes (bound {bound})",
                    camera.azimuth_deg
                );
            }
        }
    }
}

#[test]
fn dense_with_nearest_sampling_agrees_with_the_octree_at_full_level() {
    // Fixed one-voxel steps against exact node intervals: the same picture up to sampling.
    let context = gpu();
    for (spec, mode) in [
        ("synthetic:sphere:48", RenderMode::Dvr),
        ("synthetic:noise:40x32x24", RenderMode::Dvr),
        ("synthetic:noise:40x32x24", RenderMode::Mip),
    ] {
        let volume = load(spec);
        let quantized = voxscope_volume::QuantizedVolume::new(&volume);
        let (octree, transfer) = colored_octree(&volume, None, BuildOptions::default());
        let settings = RenderSettings {
            mode,
            trilinear: false,
            density: 0.5,
            ..full(octree.depth)
        };
        let camera = Camera {
            distance: 1.8,
            ..Camera::default()
        };
        let images: Vec<image::RgbaImage> = RendererKind::ALL
            .iter()
            .map(|&kind| {
                let renderer = VolumeRenderer::new(
                    &context,
                    kind,
                    &octree,
                    &quantized,
                    volume.spacing,
                    octree.depth,
                    &transfer,
                )
                .unwrap();
                let target = voxscope_render::RenderTarget::new(&context, SIZE.0, SIZE.1);
                renderer.render(&context, &target, &camera, &settings);
                voxscope_render::read_image(&context, &target).unwrap()
            })
            .collect();
        let db = psnr(&images[0], &images[1]);
        let name = format!("{}-{mode:?}", spec.replace(':', "-"));
        images[0]
            .save(image_dir().join(format!("{name}-octree.png")))
            .unwrap();
        images[1]
            .save(image_dir().join(format!("{name}-dense.png")))
            .unwrap();
        eprintln!(
            "{name}: octree vs dense-nearest {db:.1} dB, coverage {:.2}",
            coverage(&images[0])
        );
        assert!(coverage(&images[1]) > 0.05);
        // DVR: grazed voxels add little opacity, the images agree closely (measured 36–46 dB).
        // MIP: one voxel decides a pixel, so the slivers that exact intervals include and
        // one-voxel point samples step over show as speckle (measured 24 dB, 89 % of pixels
        // within 10 levels); the rest must match.
        let within: usize = images[0]
            .pixels()
            .zip(images[1].pixels())
            .filter(|(a, b)| (0..3).all(|c| a[c].abs_diff(b[c]) <= 10))
            .count();
        let within = within as f64 / (SIZE.0 * SIZE.1) as f64;
        let (min_db, min_within) = match mode {
            RenderMode::Dvr => (33.0, 0.95),
            RenderMode::Mip => (22.0, 0.85),
        };
        assert!(
            db >= min_db && within >= min_within,
            "{name}: dense and octree differ: PSNR {db:.1} dB, {within:.3} of pixels within 10 levels"
        );
    }
}

/// 40×36×29 u8: a uniform block of 180 where x < 16, a pattern of varied values elsewhere.
fn uniform_block_volume() -> Volume {
    let dims = [40, 36, 29];
    let mut values = Vec::with_capacity(dims.iter().product());
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                values.push(if x < 16 {
                    180
                } else if (x + y + z) % 7 == 0 {
                    255
                } else {
                    ((x * y + z * 5) % 97) as u8
                });
            }
        }
    }
    Volume::new(
        "uniform-block",
        "test",
        dims,
        [1.0; 3],
        voxscope_volume::VoxelData::U8(values),
    )
    .unwrap()
}

#[test]
fn bricks_match_dense_sample_for_sample() {
    // Same sample positions and, thanks to the one-voxel apron, the same trilinear values: the
    // bricks renderer differs from dense only where it skips what is transparent anyway.
    let context = gpu();
    let sample = voxscope_volume::sample().unwrap();
    let cases: Vec<(Volume, RenderMode, OpacityMode)> = vec![
        (
            load("synthetic:noise:45x30x21"),
            RenderMode::Dvr,
            OpacityMode::Gray,
        ),
        (
            load("synthetic:shells:40x36x29"),
            RenderMode::Dvr,
            OpacityMode::Binary,
        ),
        // A uniform block: leaves above the brick level, composited by the grid walk as runs
        // of equal samples.
        (uniform_block_volume(), RenderMode::Dvr, OpacityMode::Gray),
        (uniform_block_volume(), RenderMode::Mip, OpacityMode::Gray),
        (
            load("synthetic:noise:45x30x21"),
            RenderMode::Mip,
            OpacityMode::Gray,
        ),
        (sample.clone(), RenderMode::Dvr, OpacityMode::Gray),
        (sample, RenderMode::Mip, OpacityMode::Gray),
    ];
    for (volume, mode, opacity) in cases {
        let quantized = voxscope_volume::QuantizedVolume::new(&volume);
        let transfer = TransferFunction {
            opacity,
            ..TransferFunction::gray(quantized.robust_window())
        };
        let (octree, transfer) = colored_octree(&volume, Some(transfer), BuildOptions::default());
        if volume.name == "uniform-block" {
            // The premise of the shells cases: cells the walk meets as uniform, visible leaves.
            let layout = voxscope_octree::BrickLayout::new(&octree, &quantized, 4, 2048).unwrap();
            let uniform_visible = layout.grid_leaves.iter().any(|&index| {
                let node = layout.nodes[index as usize];
                node.first_child == voxscope_octree::LEAF && node.color >> 24 != 0
            });
            assert!(
                uniform_visible,
                "no uniform visible cell in {}",
                volume.name
            );
        }
        let settings = RenderSettings {
            mode,
            density: 0.4,
            ..full(octree.depth)
        };
        let camera = Camera {
            azimuth_deg: -40.0,
            elevation_deg: 25.0,
            distance: 1.7,
            ..Camera::default()
        };
        let render = |options: RendererOptions| {
            let renderer = VolumeRenderer::new(
                &context,
                options,
                &octree,
                &quantized,
                volume.spacing,
                octree.depth,
                &transfer,
            )
            .unwrap();
            let target = voxscope_render::RenderTarget::new(&context, SIZE.0, SIZE.1);
            renderer.render(&context, &target, &camera, &settings);
            voxscope_render::read_image(&context, &target).unwrap()
        };
        let dense = render(RendererKind::Dense.into());
        // Small bricks test the apron seams; the default size is what users get.
        for brick_size in [4, DEFAULT_BRICK_SIZE] {
            let bricks = render(RendererOptions {
                kind: RendererKind::Bricks,
                brick_size,
                ..Default::default()
            });
            let name = format!(
                "{}-{mode:?}-{opacity:?}-b{brick_size}",
                volume.name.replace(':', "-")
            );
            dense
                .save(image_dir().join(format!("{name}-dense.png")))
                .unwrap();
            bricks
                .save(image_dir().join(format!("{name}-bricks.png")))
                .unwrap();
            let db = psnr(&dense, &bricks);
            eprintln!(
                "{name}: bricks vs dense {db:.1} dB, coverage {:.2}",
                coverage(&dense)
            );
            assert!(coverage(&bricks) > 0.05, "{name}: bricks drew nothing");
            // The same samples, placed by two f32 expressions: where a sample of noise lands
            // within rounding of a level's edge the two round it differently, and a MIP's
            // maximum follows (79 of 50 000 pixels of the noise in the uniform block, 43 dB).
            let floor = if mode == RenderMode::Mip { 40.0 } else { 45.0 };
            assert!(
                db >= floor,
                "{name}: bricks and dense differ, PSNR {db:.1} dB"
            );
        }
    }
}

#[test]
fn bricks_recolor_on_the_gpu_keeps_empty_bricks_transparent() {
    // After a transfer edit on the GPU, a brick is transparent exactly when all its voxels are:
    // rendering with a binary threshold above every value of a region leaves it black.
    let context = gpu();
    let volume = load("synthetic:sphere:48");
    let quantized = voxscope_volume::QuantizedVolume::new(&volume);
    let (octree, gray) = colored_octree(&volume, None, BuildOptions::default());
    let mut renderer = VolumeRenderer::new(
        &context,
        RendererKind::Bricks,
        &octree,
        &quantized,
        volume.spacing,
        octree.depth,
        &gray,
    )
    .unwrap();
    let settings = full(octree.depth);
    let camera = Camera {
        distance: 1.8,
        ..Camera::default()
    };
    let target = voxscope_render::RenderTarget::new(&context, SIZE.0, SIZE.1);
    let mut frame_after = |transfer: &TransferFunction| {
        let mut encoder = context.device.create_command_encoder(&Default::default());
        renderer
            .set_transfer(&context, &mut encoder, transfer, None)
            .unwrap();
        context.queue.submit([encoder.finish()]);
        renderer.render(&context, &target, &camera, &settings);
        voxscope_render::read_image(&context, &target).unwrap()
    };
    let visible = frame_after(&gray);
    assert!(coverage(&visible) > 0.1);
    let nothing = TransferFunction {
        opacity: OpacityMode::Binary,
        threshold: 1.0,
        colormap: Default::default(),
        window: voxscope_volume::ValueWindow {
            low: 0.0,
            high: 1000.0,
        },
    };
    assert_eq!(
        coverage(&frame_after(&nothing)),
        0.0,
        "every brick became transparent"
    );
    assert!(coverage(&frame_after(&gray)) > 0.1, "and visible again");
}

#[test]
fn gpu_brick_recolor_equals_the_cpu_rule_bit_for_bit() {
    use voxscope_octree::{BRICK_FLAG, BrickLayout, LEAF, average_color};
    use voxscope_render::{GpuBricks, OctreeOnGpu};
    let context = gpu();
    let recolor = context.brick_recolor();
    // u8 data (8-bit atlas), u16 and f32 data (16-bit atlas), bricks of 4 and 8, non-cubic.
    for (spec, brick_size) in [
        ("synthetic:noise:37x26x19", 4),
        ("synthetic:sphere:40x33x21", 8),
        ("synthetic:shells:36x30x28", 8),
    ] {
        let volume = load(spec);
        let quantized = voxscope_volume::QuantizedVolume::new(&volume);
        let (octree, first) = colored_octree(&volume, None, BuildOptions::default());
        let layout = BrickLayout::new(&octree, &quantized, brick_size, 2048).unwrap();
        let mut bricks = GpuBricks::upload(
            &context,
            &layout,
            &quantized,
            volume.spacing,
            octree.depth,
            &first,
        )
        .unwrap();
        let second = TransferFunction {
            opacity: OpacityMode::Binary,
            threshold: 0.35,
            colormap: Default::default(),
            ..first
        };
        bricks.write_lookup_table(&context, &second);
        let mut encoder = context.device.create_command_encoder(&Default::default());
        recolor.encode(&context, &mut encoder, &bricks, None);
        context.queue.submit([encoder.finish()]);
        let bytes = read_buffer(&context, bricks.nodes(), bricks.nodes().size()).unwrap();
        let gpu_nodes: &[voxscope_octree::Node] = bytemuck::cast_slice(&bytes);

        // The rule on the CPU: a brick is the opacity-weighted mean of its voxels (alpha: the
        // mean rounded up), a leaf its table color, an inner node the average of its children.
        let table = second.lookup_table(octree.quantization);
        let dims = volume.dims;
        // What the atlas holds: levels as they are (8-bit and 16-bit normalized atlases), or
        // rounded to half floats (devices without 16-bit normalized textures).
        let eight_bit = layout.atlas.iter().all(|&l| l <= 255);
        let stored = |level: u16| {
            if eight_bit || context.has_norm16_textures {
                level
            } else {
                half::f16::from_f32(level as f32).to_f32().round() as u16
            }
        };
        let mut expected = vec![0u32; layout.nodes.len()];
        for level in (0..=layout.brick_level).rev() {
            for index in
                layout.level_starts[level as usize]..layout.level_starts[level as usize + 1]
            {
                let node = layout.nodes[index];
                let bounds = layout.bounds[index];
                expected[index] = if node.first_child == LEAF {
                    if bounds.is_empty() {
                        0
                    } else {
                        table[bounds.min() as usize]
                    }
                } else if node.first_child & BRICK_FLAG != 0 {
                    let origin = layout.brick_origins[(node.first_child & !BRICK_FLAG) as usize];
                    let (mut sums, mut count) = ([0u64; 4], 0u64);
                    for z in origin[2]..(origin[2] + brick_size).min(dims[2]) {
                        for y in origin[1]..(origin[1] + brick_size).min(dims[1]) {
                            for x in origin[0]..(origin[0] + brick_size).min(dims[0]) {
                                let [r, g, b, a] = voxscope_octree::unpack_rgba(
                                    table[stored(quantized.levels[x + dims[0] * (y + dims[1] * z)])
                                        as usize],
                                )
                                .map(u64::from);
                                sums = [
                                    sums[0] + a,
                                    sums[1] + r * a,
                                    sums[2] + g * a,
                                    sums[3] + b * a,
                                ];
                                count += 1;
                            }
                        }
                    }
                    if sums[0] == 0 {
                        0
                    } else {
                        let channel = |w: u64| ((w + sums[0] / 2) / sums[0]) as u8;
                        voxscope_octree::pack_rgba([
                            channel(sums[1]),
                            channel(sums[2]),
                            channel(sums[3]),
                            sums[0].div_ceil(count) as u8,
                        ])
                    }
                } else {
                    let first = node.first_child as usize;
                    average_color(std::array::from_fn(|c| expected[first + c]))
                };
            }
        }
        let differing = gpu_nodes
            .iter()
            .zip(&expected)
            .filter(|(n, e)| n.color != **e)
            .count();
        assert_eq!(
            differing,
            0,
            "{spec}: {differing} of {} node colors differ",
            expected.len()
        );
        assert!(
            expected.iter().any(|&c| c >> 24 > 0),
            "{spec}: the recolor made nothing visible"
        );
    }
}

/// Uploads `volume` for `options` with its own robust gray transfer function.
fn volume_renderer(
    context: &GpuContext,
    volume: &Volume,
    options: impl Into<RendererOptions>,
) -> VolumeRenderer {
    let quantized = voxscope_volume::QuantizedVolume::new(volume);
    let (octree, transfer) = colored_octree(volume, None, BuildOptions::default());
    VolumeRenderer::new(
        context,
        options,
        &octree,
        &quantized,
        volume.spacing,
        octree.depth,
        &transfer,
    )
    .unwrap_or_else(|e| panic!("{}: {e}", volume.name))
}

#[test]
fn pipelines_are_built_once_per_device() {
    // Opening volumes and switching renderers compiles each pipeline family once: the first
    // renderer of each kind builds what it lacks, nothing after that builds anything.
    let context = gpu();
    assert_eq!(
        context.pipelines_built(),
        0,
        "a new device has no pipelines"
    );
    let volumes = [
        load("synthetic:sphere:40"),
        load("synthetic:noise:37x20x29"),
    ];
    let target = voxscope_render::RenderTarget::new(&context, 32, 24);
    let camera = Camera::default();
    let gray =
        TransferFunction::gray(voxscope_volume::QuantizedVolume::new(&volumes[0]).robust_window());
    let binary = TransferFunction {
        opacity: OpacityMode::Binary,
        ..gray
    };
    // Draw and edit the transfer function, as the app does after opening and on every edit.
    let use_renderer = |renderer: &mut VolumeRenderer| {
        for transfer in [&binary, &gray] {
            let mut encoder = context.device.create_command_encoder(&Default::default());
            renderer
                .set_transfer(&context, &mut encoder, transfer, None)
                .unwrap();
            context.queue.submit([encoder.finish()]);
            renderer.render(&context, &target, &camera, &full(8));
        }
        context.wait_idle().unwrap();
    };
    for kind in RendererKind::ALL {
        let before = context.pipelines_built();
        use_renderer(&mut volume_renderer(&context, &volumes[0], kind));
        assert!(
            context.pipelines_built() > before,
            "the first {} renderer built its pipelines",
            kind.name()
        );
    }
    let built = context.pipelines_built();
    // Octree, dense and bricks: the two ray casters (three entry points), the two recolors and
    // the grid refresh.
    assert_eq!(
        built, 6,
        "pipelines built by the first renderer of each kind"
    );
    for volume in &volumes {
        for kind in [
            RendererKind::Bricks,
            RendererKind::Octree,
            RendererKind::Dense,
            RendererKind::Bricks,
        ] {
            use_renderer(&mut volume_renderer(&context, volume, kind));
            use_renderer(&mut volume_renderer(
                &context,
                volume,
                RendererOptions {
                    kind,
                    brick_size: 8,
                    ..Default::default()
                },
            ));
        }
    }
    assert_eq!(
        context.pipelines_built(),
        built,
        "opening volumes and switching renderers built pipelines again"
    );
    // Shading, the probe and clipping are variants of their own, each built on its first use:
    // for the octree (the tree walk), bricks at full detail (the grid walk) and dense, one
    // shaded, one probe and one clipped pipeline each.
    let shaded = RenderSettings {
        shading: voxscope_render::Shading::default(),
        ..full(8)
    };
    let clipped = RenderSettings {
        clip: voxscope_octree::Clip {
            bounds: Some([[0.0, 0.5], [0.0, 1.0], [0.0, 1.0]]),
            plane: None,
        },
        ..full(8)
    };
    let use_variants = |renderer: &VolumeRenderer| {
        renderer.render(&context, &target, &camera, &shaded);
        renderer.render(&context, &target, &camera, &clipped);
        let request = voxscope_render::ProbeRequest {
            size: [target.width, target.height],
            pixel: [16, 12],
            camera: &camera,
            settings: &full(8),
        };
        voxscope_render::probe_pixel(&context, renderer, &request).unwrap();
    };
    for volume in &volumes {
        for kind in RendererKind::ALL {
            use_variants(&volume_renderer(&context, volume, kind));
        }
    }
    assert_eq!(
        context.pipelines_built(),
        built + 9,
        "shaded, probe and clipped pipelines, each built once"
    );
}

#[test]
fn panes_of_several_volumes_recorded_into_one_encoder_draw_as_if_alone() {
    // The pipelines are shared, so each frame must carry its own parameters: two volumes, each
    // in two panes with other cameras and levels, all recorded into one encoder and submitted
    // once, give the images each pane gives drawn and submitted alone.
    let context = gpu();
    let sphere = load("synthetic:sphere:40");
    let noise = load("synthetic:noise:45x30x21");
    let renderers = [
        volume_renderer(&context, &sphere, RendererKind::Octree),
        volume_renderer(&context, &noise, RendererKind::Bricks),
        volume_renderer(&context, &sphere, RendererKind::Dense),
    ];
    let near = Camera {
        azimuth_deg: 60.0,
        distance: 1.4,
        ..Camera::default()
    };
    let far = Camera {
        azimuth_deg: -30.0,
        elevation_deg: -20.0,
        distance: 2.5,
        ..Camera::default()
    };
    let level_3 = RenderSettings {
        max_level: 3,
        ..full(8)
    };
    let mip = RenderSettings {
        mode: RenderMode::Mip,
        ..full(8)
    };
    // Renderer, camera, settings, size of each pane.
    let panes = [
        (0, &near, full(8), (48, 40)),
        (0, &far, level_3, (40, 48)),
        (1, &near, mip, (48, 40)),
        (1, &far, full(8), (64, 24)),
        (2, &far, full(8), (48, 40)),
        (2, &near, mip, (32, 32)),
    ];
    let targets: Vec<_> = panes
        .iter()
        .map(|&(_, _, _, (w, h))| voxscope_render::RenderTarget::new(&context, w, h))
        .collect();
    let alone: Vec<image::RgbaImage> = panes
        .iter()
        .zip(&targets)
        .map(|(&(renderer, camera, settings, _), target)| {
            renderers[renderer].render(&context, target, camera, &settings);
            voxscope_render::read_image(&context, target).unwrap()
        })
        .collect();
    // Fresh targets (zeroed): a pane left undrawn cannot pass.
    let targets: Vec<_> = panes
        .iter()
        .map(|&(_, _, _, (w, h))| voxscope_render::RenderTarget::new(&context, w, h))
        .collect();
    let mut encoder = context.device.create_command_encoder(&Default::default());
    for (&(renderer, camera, settings, _), target) in panes.iter().zip(&targets) {
        renderers[renderer].encode(&context, &mut encoder, target, camera, &settings, None);
    }
    context.queue.submit([encoder.finish()]);
    for (index, (target, expected)) in targets.iter().zip(&alone).enumerate() {
        let together = voxscope_render::read_image(&context, target).unwrap();
        assert!(
            coverage(expected) > 0.02,
            "pane {index} draws something ({})",
            coverage(expected)
        );
        assert!(
            together == *expected,
            "pane {index} differs when recorded with the others"
        );
    }
}
