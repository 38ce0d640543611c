//! The composite of channels (`shaders/composite.wgsl`): MIP equals the clamped sum of the
//! channels' colored MIPs, DVR and MIP equal the CPU reference composite, one white channel
//! equals the dense renderer, and the CLI's composite options and their errors.

mod support;

use std::process::{Command, Output};

use image::RgbaImage;
use support::gpu;
use support::reference::{CompositeChannel, MarchVolume, psnr, reference_composite};
use voxscope_octree::TransferFunction;
use voxscope_render::{
    Camera, ChannelLayer, CompositeVolume, GpuContext, RenderMode, RenderSettings, RenderTarget,
    Renderer, RendererKind, read_image, tinted_lookup_table,
};
use voxscope_volume::{LoadOptions, QuantizedVolume, ValueWindow};

const SIZE: (u32, u32) = (96, 72);

/// Five channels (so the second texture, channels 4–7, is read too) on one 24³ grid, their
/// colors dim enough that their sum rarely saturates (so each one shows in the composite).
fn channels() -> Vec<(QuantizedVolume, TransferFunction, [f32; 3])> {
    let specs = [
        ("synthetic:sphere:24", [0.0, 1.0, 0.0]),
        ("synthetic:shells:24", [1.0, 0.0, 1.0]),
        ("synthetic:noise:24", [0.0, 1.0, 1.0]),
        ("synthetic:gradient:24", [1.0, 1.0, 0.0]),
        ("synthetic:shells:24", [1.0, 0.3, 0.0]),
    ];
    specs
        .iter()
        .enumerate()
        .map(|(index, (spec, color))| {
            let volume = voxscope_volume::load(spec, &LoadOptions::default()).unwrap();
            let quantized = QuantizedVolume::new(&volume);
            let mut window = quantized.robust_window();
            if index == 4 {
                // The same shells as channel 1, windowed apart, so channel 4 differs.
                window = ValueWindow {
                    low: window.low,
                    high: (window.low + window.high) / 2.0,
                };
            }
            let dim = color.map(|c: f32| c * 0.45);
            (quantized, TransferFunction::gray(window), dim)
        })
        .collect()
}

fn layers(channels: &[(QuantizedVolume, TransferFunction, [f32; 3])]) -> Vec<ChannelLayer<'_>> {
    channels
        .iter()
        .map(|(quantized, transfer, color)| ChannelLayer {
            quantized,
            transfer,
            color: *color,
        })
        .collect()
}

fn camera() -> Camera {
    Camera {
        azimuth_deg: 35.0,
        elevation_deg: 25.0,
        distance: 2.2,
        ..Camera::default()
    }
}

fn settings(mode: RenderMode, density: f32) -> RenderSettings {
    RenderSettings {
        mode,
        density,
        // Full detail whatever the depth (each renderer clamps the level to its own).
        ..RenderSettings::full_detail(u32::MAX)
    }
}

fn composite(
    context: &GpuContext,
    layers: &[ChannelLayer<'_>],
    settings: &RenderSettings,
) -> RgbaImage {
    let volume = CompositeVolume::upload(context, layers, [1.0; 3]).expect("upload");
    let target = RenderTarget::new(context, SIZE.0, SIZE.1);
    volume.render(context, &target, &camera(), settings);
    read_image(context, &target).expect("readback")
}

fn reference(
    channels: &[(QuantizedVolume, TransferFunction, [f32; 3])],
    settings: &RenderSettings,
) -> RgbaImage {
    let volumes: Vec<MarchVolume> = channels
        .iter()
        .map(|(q, _, _)| MarchVolume::new(q))
        .collect();
    let composite: Vec<CompositeChannel<'_>> = channels
        .iter()
        .zip(&volumes)
        .map(|((quantized, transfer, color), volume)| CompositeChannel {
            volume,
            table: tinted_lookup_table(transfer, quantized.quantization, *color),
        })
        .collect();
    reference_composite(&composite, [1.0; 3], &camera(), settings, SIZE.0, SIZE.1)
}

fn save(image: &RgbaImage, name: &str) {
    image
        .save(support::image_dir().join(format!("composite-{name}.png")))
        .expect("save");
}

fn lit(image: &RgbaImage) -> f64 {
    support::reference::coverage(image)
}

#[test]
fn composite_mip_is_the_clamped_sum_of_the_channels_colored_mips() {
    let context = gpu();
    let channels = channels();
    let layers = layers(&channels);
    let mip = settings(RenderMode::Mip, 1.0);
    let together = composite(&context, &layers, &mip);
    let mut sum = vec![0u32; (SIZE.0 * SIZE.1 * 3) as usize];
    for layer in &layers {
        let alone = composite(&context, std::slice::from_ref(layer), &mip);
        assert!(lit(&alone) > 0.1, "every channel shows");
        for (i, pixel) in alone.pixels().enumerate() {
            for c in 0..3 {
                sum[i * 3 + c] += pixel[c] as u32;
            }
        }
    }
    let summed = RgbaImage::from_fn(SIZE.0, SIZE.1, |x, y| {
        let i = ((y * SIZE.0 + x) * 3) as usize;
        let [r, g, b] = [0, 1, 2].map(|c| sum[i + c].min(255) as u8);
        image::Rgba([r, g, b, 255])
    });
    save(&together, "mip");
    save(&summed, "mip-summed");
    let db = psnr(&together, &summed);
    eprintln!("composite MIP against the sum of 5 single-channel MIPs: {db:.1} dB");
    assert!(db >= 40.0, "{db:.1} dB");
    // Dropping a channel changes the picture: each counts.
    let four = composite(&context, &layers[..4], &mip);
    assert!(psnr(&together, &four) < 40.0);

    let cpu = reference(&channels, &mip);
    let db = psnr(&together, &cpu);
    eprintln!("composite MIP against the CPU reference: {db:.1} dB");
    assert!(db >= 40.0, "{db:.1} dB");
}

#[test]
fn composite_dvr_matches_the_cpu_reference() {
    let context = gpu();
    let channels = channels();
    for (count, density) in [(2usize, 0.4f32), (5, 0.15)] {
        let dvr = settings(RenderMode::Dvr, density);
        let gpu_image = composite(&context, &layers(&channels[..count]), &dvr);
        let cpu_image = reference(&channels[..count], &dvr);
        save(&gpu_image, &format!("dvr-{count}"));
        save(&cpu_image, &format!("dvr-{count}-cpu"));
        assert!(lit(&gpu_image) > 0.1);
        let db = psnr(&gpu_image, &cpu_image);
        eprintln!("composite DVR of {count} channels against the CPU reference: {db:.1} dB");
        assert!(db >= 40.0, "{count} channels: {db:.1} dB");
    }
}

/// One white channel is the dense renderer's unshaded picture.
#[test]
fn one_white_channel_draws_what_the_dense_renderer_draws() {
    let context = gpu();
    let volume = voxscope_volume::load("synthetic:shells:24", &LoadOptions::default()).unwrap();
    let prepared = support::Prepared::new(volume, None);
    for mode in [RenderMode::Dvr, RenderMode::Mip] {
        let settings = settings(mode, 0.3);
        let dense = support::draw(
            &context,
            &prepared.renderer(&context, RendererKind::Dense),
            &camera(),
            &settings,
            SIZE,
        );
        let layer = ChannelLayer {
            quantized: &prepared.quantized,
            transfer: &prepared.transfer,
            color: [1.0; 3],
        };
        let white = composite(&context, &[layer], &settings);
        let db = psnr(&dense, &white);
        eprintln!("{mode:?}: one white channel against dense: {db:.1} dB");
        assert!(db >= 40.0, "{mode:?}: {db:.1} dB");
    }
}

fn voxscope(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn fixture(name: &str) -> String {
    format!("{}/tests/data/channels/{name}", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn render_composites_multi_channel_files_by_default_and_checks_its_options() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("composite.png");
    let out = out.to_str().unwrap();
    let ome = fixture("two-channels.ome.tif");
    let run = |extra: &[&str]| {
        let mut args = vec!["render", ome.as_str(), "-o", out, "--size", "64x48"];
        args.extend_from_slice(extra);
        voxscope(&args)
    };
    let output = run(&[]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(
        stderr.contains("composite of 2 channels (#00ff00, #ff00ff), dense renderer"),
        "{stderr}"
    );
    let output = run(&[
        "--channel-colors",
        "red,#0000ff",
        "--channel-window",
        "1:3800:5000",
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("(#ff0000, #0000ff)"), "{stderr}");
    let image = image::open(out).unwrap().to_rgba8();
    assert!(lit(&image) > 0.05);
    // Only red and blue: no green anywhere.
    assert!(image.pixels().all(|p| p[1] == 0));

    for (extra, problem) in [
        (
            &["--channel-colors", "chartreuse"][..],
            "color 'chartreuse' is not one of green, magenta",
        ),
        (
            &["--channel-window", "2:0:10"][..],
            "--channel-window 2: there are 2 channels (0 to 1)",
        ),
        (
            &["--renderer", "octree"][..],
            "the composite of 2 channels is drawn by the dense renderer",
        ),
    ] {
        let output = run(extra);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(
            !output.status.success() && stderr.contains(problem),
            "{stderr}"
        );
    }
    // One channel chosen: the usual renderers.
    let output = run(&["--channel", "1", "--renderer", "octree"]);
    assert!(output.status.success());

    // Files as channels: same dimensions, else an error naming both.
    let stack = fixture("hyperstack-c1-t1.tif");
    let both = format!("{stack},{stack}");
    let output = voxscope(&[
        "render",
        "--channels-from",
        &both,
        "-o",
        out,
        "--size",
        "64x48",
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success() && stderr.contains("composite of 2 channels"),
        "{stderr}"
    );
    let mixed = format!("{stack},{}", fixture("series-t1.nii.gz"));
    let output = voxscope(&["render", "--channels-from", &mixed, "-o", out]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success()
            && stderr.contains("dimensions 10x8x6 differ from")
            && stderr.contains("16x12x5; channels need one grid"),
        "{stderr}"
    );
}

#[test]
fn bench_times_the_composite_for_each_channel_count() {
    let output = voxscope(&[
        "bench",
        "synthetic:sphere:24",
        "--renderer",
        "dense",
        "--size",
        "48x32",
        "--frames",
        "2",
        "--composite-channels",
        "1,2,4",
        "--json",
    ]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    let rows: Vec<&serde_json::Value> = json["results"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|row| row["renderer"] == "composite")
        .collect();
    // 3 channel counts × (DVR, MIP) × 3 cameras.
    assert_eq!(rows.len(), 18);
    for mode in ["dvr-gray-1ch", "mip-2ch", "dvr-gray-4ch"] {
        assert_eq!(
            rows.iter().filter(|r| r["mode"] == mode).count(),
            3,
            "{mode}"
        );
    }
    assert!(rows.iter().all(|r| r["median_ms"].as_f64().unwrap() > 0.0));
    assert!(
        json["gpu_bytes"]["composite-4"]["textures_and_tables"]
            .as_u64()
            .unwrap()
            > 0
    );
    // A multi-channel file: channel 0's rows, and its own channels' composite.
    let ome = fixture("two-channels.ome.tif");
    let output = voxscope(&[
        "bench",
        &ome,
        "--renderer",
        "dense",
        "--size",
        "32x24",
        "--frames",
        "2",
        "--json",
    ]);
    assert!(output.status.success());
    let json: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    let results = json["results"].as_array().unwrap();
    let file_rows: Vec<_> = results
        .iter()
        .filter(|r| r["renderer"] == "composite-file")
        .collect();
    assert_eq!(file_rows.len(), 6);
    assert!(
        file_rows
            .iter()
            .all(|r| r["mode"] == "dvr-gray-2ch" || r["mode"] == "mip-2ch")
    );
    assert_eq!(
        results.iter().filter(|r| r["renderer"] == "dense").count(),
        12
    );
    // One channel chosen: no composite.
    let output = voxscope(&[
        "bench",
        &ome,
        "--channel",
        "1",
        "--renderer",
        "dense",
        "--size",
        "32x24",
        "--frames",
        "2",
        "--json",
    ]);
    let json: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(json["results"].as_array().unwrap().len(), 12);

    let refused = voxscope(&["bench", "synthetic:sphere:8", "--composite-channels", "9"]);
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("channel count '9' is not 1 to 8"));
}

#[test]
fn info_lists_each_channels_name_color_range_and_window() {
    let ome = fixture("two-channels.ome.tif");
    let output = voxscope(&["info", &ome, "--channel-window", "1:4000:5000"]);
    assert!(output.status.success());
    let text = String::from_utf8_lossy(&output.stdout);
    assert!(text.contains("composite of 2 channels"), "{text}");
    for (channel, name, color) in [(0, "DAPI", "#00ff00"), (1, "GFP", "#ff00ff")] {
        let options = LoadOptions {
            select: voxscope_volume::Selection { channel, time: 0 },
            ..LoadOptions::default()
        };
        let volume = voxscope_volume::load(&ome, &options).unwrap();
        let values: Vec<f64> = (0..volume.voxel_count())
            .map(|i| volume.data.get(i).unwrap())
            .collect();
        let low = values.iter().copied().fold(f64::INFINITY, f64::min);
        let high = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let line = format!("  channel {channel}  {name}  {color}  range {low} … {high}  window ");
        assert!(text.contains(&line), "{line} in {text}");
    }
    assert!(
        text.contains("range 3737 … 5686  window 4000 … 5000"),
        "{text}"
    );
    // One channel chosen: no composite.
    let output = voxscope(&["info", &ome, "--channel", "0"]);
    assert!(!String::from_utf8_lossy(&output.stdout).contains("composite of"));
}

fn copy_folder(from: &std::path::Path, to: &std::path::Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_folder(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}

/// OME-Zarr's `omero` channels give the composite its colors and windows.
#[test]
fn omero_colors_and_windows_are_the_composites_defaults() {
    let dir = tempfile::tempdir().unwrap();
    let store = dir.path().join("recolored.ome.zarr");
    copy_folder(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data/ome-zarr/tczyx-v04.ome.zarr"),
        &store,
    );
    let attributes = store.join(".zattrs");
    let text = std::fs::read_to_string(&attributes).unwrap();
    // The fixture's colors are the defaults' (green, magenta): make them red and blue.
    let text = text.replace("00FF00", "FF0000").replace("FF00FF", "0000FF");
    std::fs::write(&attributes, text).unwrap();
    let output = voxscope(&["info", store.to_str().unwrap(), "--time", "1"]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        stdout.contains("channel 0  nuclei  #ff0000  range"),
        "{stdout}"
    );
    assert!(stdout.contains("window 2000 … 30000"), "{stdout}");
    assert!(
        stdout.contains("channel 1  head  #0000ff  range"),
        "{stdout}"
    );
    assert!(stdout.contains("window 10 … 200"), "{stdout}");
}

/// An edit of a channel's transfer function or color rewrites the tables only, and draws what
/// a fresh upload with the new layers draws.
#[test]
fn new_layers_on_an_uploaded_composite_draw_as_a_fresh_upload() {
    let context = gpu();
    let channels = channels();
    let before = layers(&channels[..3]);
    let narrower: Vec<TransferFunction> = channels[..3]
        .iter()
        .map(|(quantized, _, _)| {
            let window = quantized.robust_window();
            TransferFunction::gray(ValueWindow {
                low: (window.low + window.high) / 2.0,
                high: window.high,
            })
        })
        .collect();
    let after: Vec<ChannelLayer<'_>> = channels[..3]
        .iter()
        .zip(&narrower)
        .map(|((quantized, _, _), transfer)| ChannelLayer {
            quantized,
            transfer,
            color: [0.2, 0.4, 0.9],
        })
        .collect();
    let dvr = settings(RenderMode::Dvr, 0.3);
    let volume = CompositeVolume::upload(&context, &before, [1.0; 3]).unwrap();
    volume.set_layers(&context, &after);
    let target = RenderTarget::new(&context, SIZE.0, SIZE.1);
    volume.render(&context, &target, &camera(), &dvr);
    let edited = read_image(&context, &target).unwrap();
    let fresh = composite(&context, &after, &dvr);
    assert_eq!(edited, fresh);
    assert!(psnr(&edited, &composite(&context, &before, &dvr)) < 40.0);
}

/// A crop box and a clip plane cut the composite's rays as they cut one channel's.
#[test]
fn a_clipped_composite_matches_the_cpu_reference() {
    let context = gpu();
    let channels = channels();
    let clip = voxscope_octree::Clip {
        bounds: Some([[0.1, 0.8], [0.0, 0.7], [0.2, 1.0]]),
        plane: Some(voxscope_octree::ClipPlane {
            normal: [0.3, -1.0, 0.2],
            distance: -0.4,
        }),
    };
    for mode in [RenderMode::Dvr, RenderMode::Mip] {
        let clipped = RenderSettings {
            clip,
            ..settings(mode, 0.3)
        };
        let gpu_image = composite(&context, &layers(&channels[..3]), &clipped);
        let unclipped = composite(&context, &layers(&channels[..3]), &settings(mode, 0.3));
        let cpu_image = reference(&channels[..3], &clipped);
        let db = psnr(&gpu_image, &cpu_image);
        eprintln!("{mode:?}: clipped composite against the CPU reference: {db:.1} dB");
        assert!(db >= 40.0, "{mode:?}: {db:.1} dB");
        assert!(
            psnr(&gpu_image, &unclipped) < 40.0,
            "{mode:?}: the clip cuts"
        );
    }
}

/// DVR skips blocks where every channel is transparent: fewer samples, the same picture.
#[test]
fn transparent_blocks_are_skipped_without_changing_the_picture() {
    let context = gpu();
    // A ball of radius 8 (values 100…200) in the middle of an empty 48³ cube.
    let side = 48usize;
    let voxels: Vec<u8> = (0..side * side * side)
        .map(|i| {
            let [x, y, z] = [i % side, (i / side) % side, i / (side * side)]
                .map(|c| c as f64 + 0.5 - side as f64 / 2.0);
            let r = (x * x + y * y + z * z).sqrt();
            if r < 8.0 { (200.0 - 12.0 * r) as u8 } else { 0 }
        })
        .collect();
    let volume = voxscope_volume::Volume::new(
        "ball",
        "synthetic",
        [side; 3],
        [1.0; 3],
        voxscope_volume::VoxelData::U8(voxels),
    )
    .unwrap();
    let quantized = QuantizedVolume::new(&volume);
    // Outside the ball the value is 0: transparent under a window from 0, visible under
    // one that starts below 0.
    let transparent_outside = TransferFunction::gray(ValueWindow {
        low: 0.0,
        high: 200.0,
    });
    let visible_everywhere = TransferFunction::gray(ValueWindow {
        low: -1.0,
        high: 200.0,
    });
    let dvr = settings(RenderMode::Dvr, 0.3);
    let mut samples = Vec::new();
    for transfer in [&transparent_outside, &visible_everywhere] {
        let layer = ChannelLayer {
            quantized: &quantized,
            transfer,
            color: [1.0, 0.5, 0.2],
        };
        let gpu_volume = CompositeVolume::upload(&context, &[layer], [1.0; 3]).unwrap();
        let target = RenderTarget::new(&context, SIZE.0, SIZE.1);
        gpu_volume.render(&context, &target, &camera(), &dvr);
        let image = read_image(&context, &target).unwrap();
        let visits = voxscope_render::read_visits(&context, &target).unwrap();
        samples.push(visits.iter().map(|&v| v as u64).sum::<u64>());
        let march = MarchVolume::new(&quantized);
        let cpu = reference_composite(
            &[CompositeChannel {
                volume: &march,
                table: tinted_lookup_table(transfer, quantized.quantization, layer.color),
            }],
            [1.0; 3],
            &camera(),
            &dvr,
            SIZE.0,
            SIZE.1,
        );
        let db = psnr(&image, &cpu);
        assert!(db >= 40.0, "{db:.1} dB");
    }
    eprintln!(
        "samples: {} skipping, {} with every block visible",
        samples[0], samples[1]
    );
    assert!((samples[0] as f64) < 0.8 * samples[1] as f64, "{samples:?}");
}
