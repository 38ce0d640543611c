//! `voxscope bench`: GPU time per frame for the paper's three camera distances and the three
//! transfer modes (and gray DVR shaded), plus build, recolor and memory figures.

use std::time::Instant;

use clap::Args;
use serde::Serialize;
use serde_json::json;

use super::args::{OpacityArg, RendererArg, TransferArgs};
use super::stream::StreamArgs;
use super::{ClipArgs, Prepared, VolumeArgs};
use voxscope_octree::{OpacityMode, TransferFunction};
use voxscope_render::{
    Camera, ChannelLayer, DEFAULT_BRICK_SIZE, GpuContext, GpuTimer, RenderMode, RenderSettings,
    RenderTarget, RendererKind, RendererOptions, Shading, VolumeRenderer, read_visits, time_passes,
    timing_name, warm_up,
};
use voxscope_volume::ValueWindow;

#[derive(Debug, Args)]
pub struct BenchArgs {
    #[command(flatten)]
    pub volume: VolumeArgs,
    /// Image size WxH.
    #[arg(long, default_value = "1024x768", value_parser = voxscope_scene::option_text::parse_size)]
    pub size: (u32, u32),
    /// Timed frames per case; the azimuth sweeps a full turn over them.
    #[arg(long, default_value_t = 200)]
    pub frames: u32,
    /// Binary threshold on the windowed value, 0…1.
    #[arg(long, default_value_t = 0.3)]
    pub threshold: f32,
    /// Value window LOW:HIGH (default: 0.5–99.5 percentiles).
    #[arg(long, value_name = "LOW:HIGH", allow_hyphen_values = true, value_parser = ValueWindow::parse)]
    pub window: Option<ValueWindow>,
    /// Global opacity scale.
    #[arg(long, default_value_t = 1.0)]
    pub density: f32,
    /// Max level of every case (default: the voxels): what each renderer draws there, the
    /// octree's nodes or a pyramid level (docs/octree.md, "Which renderer draws what").
    #[arg(long)]
    pub level: Option<u32>,
    /// Only this renderer (default: all).
    #[arg(long, value_enum)]
    pub renderer: Option<RendererArg>,
    /// Voxels along a brick's side (bricks renderer): 4, 8, 16 or 32.
    #[arg(long, default_value_t = DEFAULT_BRICK_SIZE, value_parser = voxscope_scene::option_text::parse_brick_size)]
    pub brick_size: usize,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Every case drawn clipped.
    #[command(flatten)]
    pub clip: ClipArgs,
    /// Measure the streaming renderer instead (`--renderer stream` too): first image, frame
    /// times while streaming during orbits, time to complete a stopped view, bytes read against
    /// the view's floor, and resident frame time against the bricks renderer.
    #[arg(long)]
    pub stream: bool,
    #[command(flatten)]
    pub stream_options: StreamArgs,
    /// With --stream: draw the orbits' frames at most F a second, as a display does (60: a
    /// full turn of 200 frames in 3.3 s); 0 draws each as soon as the last is done.
    #[arg(long, value_name = "F", default_value_t = 0.0, value_parser = parse_orbit_fps, requires = "stream")]
    pub orbit_fps: f64,
    /// Also time the composite of channels: the volume as N channels (each a copy, its own
    /// table and color) for each N listed (1 to 8), DVR and MIP, renderer `composite`.
    #[arg(long, value_name = "N,…", value_delimiter = ',', value_parser = parse_channel_count)]
    pub composite_channels: Option<Vec<usize>>,
}

/// Frames a second for --orbit-fps: 0 (unpaced), or from 1 up to 1000.
fn parse_orbit_fps(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(fps) if fps == 0.0 || (1.0..=1000.0).contains(&fps) => Ok(fps),
        _ => Err(format!(
            "frame rate '{text}' is not 0 or a number from 1 to 1000"
        )),
    }
}

/// A channel count for --composite-channels: 1 to [`voxscope_volume::MAX_CHANNELS`].
fn parse_channel_count(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(n) if (1..=voxscope_volume::MAX_CHANNELS).contains(&n) => Ok(n),
        _ => Err(format!(
            "channel count '{text}' is not 1 to {}",
            voxscope_volume::MAX_CHANNELS
        )),
    }
}

/// One transfer setting of the benchmark: its name in the results, transfer function, mode,
/// shading, and whether its transfer edit is timed (the shaded row's edit is dvr-gray's).
struct Case {
    name: &'static str,
    transfer: TransferFunction,
    mode: RenderMode,
    shading: Shading,
    time_edit: bool,
}

/// One row of the results.
#[derive(Debug, Clone, Serialize)]
pub struct BenchResult {
    pub renderer: &'static str,
    pub mode: &'static str,
    pub camera: &'static str,
    pub median_ms: f64,
    pub p95_ms: f64,
    pub fps: f64,
    pub rays_per_s: f64,
    /// Over rays that enter the volume, sampled from four azimuths.
    pub nodes_per_ray_avg: f64,
    pub nodes_per_ray_max: u32,
    /// Rays that enter the volume (do any work), averaged over the four azimuths: with
    /// `nodes_per_ray_avg`, the work of a frame.
    pub rays_in_volume: f64,
    /// Work done ÷ work the warps pay for: each 8×4-pixel warp of an 8×8 workgroup runs as long
    /// as its longest ray, so 1 means no divergence.
    pub simd_efficiency: f64,
}

/// The paper's three cases: near, medium and far, in bounding-sphere radii.
const CAMERAS: [(&str, f64); 3] = [("near", 1.5), ("medium", 3.0), ("far", 6.0)];
const RECOLOR_RUNS: u32 = 20;

impl BenchArgs {
    /// Whether these options ask for the streaming renderer's benchmark
    /// (`super::stream_bench`) rather than the in-memory renderers'.
    pub fn streams(&self) -> bool {
        self.stream || self.renderer == Some(RendererArg::Stream)
    }

    /// The checks both benchmarks make before anything is read.
    pub fn check(&self) -> Result<(), String> {
        if self.frames == 0 {
            return Err("--frames must be at least 1".into());
        }
        Ok(())
    }
}

/// `bench` of the in-memory renderers (octree, dense, bricks, and composites).
pub fn run(args: &BenchArgs) -> Result<(), String> {
    args.check()?;
    let mut transfer_args = TransferArgs::defaults();
    transfer_args.window = args.window;
    transfer_args.threshold = args.threshold;
    transfer_args.opacity = Some(OpacityArg::Gray);
    // A multi-channel file (unless --channel N): channel 0's rows, then the composite's.
    let (prepared, file_channels) = match args.volume.composite_channels()? {
        Some(channels) if channels.len() > 1 => {
            let first = channels[0].clone();
            let channel_args = super::composite::ChannelArgs {
                channel_colors: None,
                channel_window: Vec::new(),
            };
            let channels = channel_args.prepare(channels, &transfer_args)?;
            (
                Prepared::from_volume(first, &transfer_args)?,
                Some(channels),
            )
        }
        Some(mut channels) => {
            let volume = channels.pop().ok_or("no channel was read")?;
            (Prepared::from_volume(volume, &transfer_args)?, None)
        }
        None => (Prepared::new(&args.volume, &transfer_args)?, None),
    };
    let context = GpuContext::new_headless().map_err(|e| e.to_string())?;
    let depth = prepared.data.octree.depth;
    let max_level = args.level.unwrap_or(depth).min(depth);
    let target = RenderTarget::new(&context, args.size.0, args.size.1);
    let timer = GpuTimer::new(&context, args.frames.max(RECOLOR_RUNS));
    let timing = timing_name(timer.as_ref());

    let gray = prepared.transfer;
    let binary = TransferFunction {
        opacity: OpacityMode::Binary,
        ..gray
    };
    let case = |name, transfer, mode, shading: Shading, time_edit| Case {
        name,
        transfer,
        mode,
        shading,
        time_edit,
    };
    // The unshaded rows first, in the order of every run before shading existed.
    let cases = [
        case("dvr-gray", gray, RenderMode::Dvr, Shading::OFF, true),
        case("dvr-binary", binary, RenderMode::Dvr, Shading::OFF, true),
        case("mip", gray, RenderMode::Mip, Shading::OFF, true),
        case(
            "dvr-gray-shaded",
            gray,
            RenderMode::Dvr,
            Shading::default(),
            false,
        ),
    ];
    let clip = args.clip.clip();
    let kinds: Vec<RendererKind> = match args.renderer {
        Some(one) => vec![one.into()],
        None => RendererKind::ALL.to_vec(),
    };
    let mut results = Vec::new();
    let mut recolor_ms = serde_json::Map::new();
    let mut recolor_wall_ms = serde_json::Map::new();
    let mut gpu_bytes = serde_json::Map::new();
    for kind in kinds {
        let mut renderer = VolumeRenderer::new(
            &context,
            RendererOptions {
                kind,
                brick_size: args.brick_size,
                ..Default::default()
            },
            &prepared.data.octree,
            &prepared.data.quantized,
            prepared.data.volume.spacing,
            depth,
            &prepared.transfer,
        )
        .map_err(|e| format!("{}: {e}", prepared.data.volume.name))?;
        gpu_bytes.insert(kind.name().to_owned(), bytes_json(&renderer));
        let (mut edit_gpu_ms, mut edit_wall_ms) = (Vec::new(), Vec::new());
        for case in &cases {
            if case.time_edit {
                let edits =
                    time_transfer_edits(&context, &mut renderer, &case.transfer, timer.as_ref())?;
                edit_gpu_ms.extend(edits.gpu.unwrap_or_default());
                edit_wall_ms.extend(edits.wall);
            } else {
                apply_transfer(&context, &mut renderer, &case.transfer)?;
            }
            let settings = RenderSettings {
                mode: case.mode,
                density: args.density,
                shading: case.shading,
                clip,
                ..RenderSettings::full_detail(max_level)
            };
            renderer.prepare_pipelines(&context, &settings, false);
            for (camera_name, distance) in CAMERAS {
                let camera = Camera {
                    distance,
                    ..Camera::default()
                };
                let view = View {
                    renderer: &renderer,
                    target: &target,
                    camera,
                    settings: &settings,
                };
                let times = time_frames(&context, &view, args.frames, timer.as_ref())?;
                let work = sample_visits(&context, &view)?;
                let median = percentile(&times, 50.0);
                results.push(BenchResult {
                    renderer: kind.name(),
                    mode: case.name,
                    camera: camera_name,
                    median_ms: median,
                    p95_ms: percentile(&times, 95.0),
                    fps: 1000.0 / median,
                    rays_per_s: (target.width as f64 * target.height as f64) / (median * 1e-3),
                    nodes_per_ray_avg: work.average,
                    nodes_per_ray_max: work.max,
                    rays_in_volume: work.rays,
                    simd_efficiency: work.simd_efficiency,
                });
            }
        }
        // GPU time where the renderer recolors on the GPU with timestamps, else wall time.
        let edit_ms = if edit_gpu_ms.is_empty() {
            &edit_wall_ms
        } else {
            &edit_gpu_ms
        };
        recolor_ms.insert(kind.name().to_owned(), percentile(edit_ms, 50.0).into());
        recolor_wall_ms.insert(
            kind.name().to_owned(),
            percentile(&edit_wall_ms, 50.0).into(),
        );
    }
    let composite = CompositeBench {
        context: &context,
        target: &target,
        timer: timer.as_ref(),
        frames: args.frames,
        density: args.density,
        clip,
        depth,
    };
    for &count in args.composite_channels.as_deref().unwrap_or_default() {
        let layers: Vec<ChannelLayer<'_>> = (0..count)
            .map(|index| ChannelLayer {
                quantized: &prepared.data.quantized,
                transfer: &gray,
                color: voxscope_volume::DEFAULT_CHANNEL_COLORS[index]
                    .1
                    .map(|c| c as f32 / 255.0),
            })
            .collect();
        let renderer =
            VolumeRenderer::new_composite(&context, &layers, prepared.data.volume.spacing)
                .map_err(|e| format!("{}: {e}", prepared.data.volume.name))?;
        gpu_bytes.insert(format!("composite-{count}"), bytes_json(&renderer));
        composite.rows(&renderer, count, "composite", &mut results)?;
    }
    // A multi-channel file: the composite of its own channels too (`--channel all`).
    if let Some(channels) = &file_channels {
        let layers: Vec<ChannelLayer<'_>> = channels.iter().map(|c| c.layer()).collect();
        let renderer =
            VolumeRenderer::new_composite(&context, &layers, prepared.data.volume.spacing)
                .map_err(|e| format!("{}: {e}", prepared.data.volume.name))?;
        gpu_bytes.insert("composite-file".into(), bytes_json(&renderer));
        composite.rows(&renderer, channels.len(), "composite-file", &mut results)?;
    }
    gpu_bytes.insert(
        "target".into(),
        json!({"texture": target.width as u64 * target.height as u64 * 4, "visits": target.visits.size()}),
    );
    let report = json!({
        "adapter": context.adapter_info.name,
        "backend": format!("{:?}", context.adapter_info.backend),
        "driver": format!("{} {}", context.adapter_info.driver, context.adapter_info.driver_info),
        "timing": timing,
        "size": [target.width, target.height],
        "frames": args.frames,
        "volume": {
            "file": prepared.data.volume.name,
            "dims": prepared.data.volume.dims,
            "voxel_type": prepared.data.volume.voxel_type().name(),
            "octree_depth": depth,
            "max_level": max_level,
            "octree_nodes": prepared.data.octree.nodes.len(),
        },
        "results": results,
        "build_seconds": prepared.data.octree.build_seconds,
        "recolor_ms": recolor_ms,
        "recolor_wall_ms": recolor_wall_ms,
        "brick_size": args.brick_size,
        "clip": clip,
        "recolor_cpu_ms": prepared.recolor_time.as_secs_f64() * 1e3,
        "gpu_bytes": gpu_bytes,
    });
    if args.json {
        println!("{report}");
    } else {
        print_table(&report, &results);
    }
    Ok(())
}

/// What every composite row shares: device, target, timing and settings.
struct CompositeBench<'a> {
    context: &'a GpuContext,
    target: &'a RenderTarget,
    timer: Option<&'a GpuTimer>,
    frames: u32,
    density: f32,
    clip: voxscope_octree::Clip,
    depth: u32,
}

impl CompositeBench<'_> {
    /// Times the composite `composite` (of `channels` channels), DVR and MIP, from the three
    /// cameras, as rows of `renderer`.
    fn rows(
        &self,
        composite: &VolumeRenderer,
        channels: usize,
        renderer: &'static str,
        results: &mut Vec<BenchResult>,
    ) -> Result<(), String> {
        for (mode_name, mode) in [("dvr-gray", RenderMode::Dvr), ("mip", RenderMode::Mip)] {
            let settings = RenderSettings {
                mode,
                density: self.density,
                shading: Shading::OFF,
                clip: self.clip,
                ..RenderSettings::full_detail(self.depth)
            };
            for (camera_name, distance) in CAMERAS {
                let view = View {
                    renderer: composite,
                    target: self.target,
                    camera: Camera {
                        distance,
                        ..Camera::default()
                    },
                    settings: &settings,
                };
                let times = time_frames(self.context, &view, self.frames, self.timer)?;
                let work = sample_visits(self.context, &view)?;
                let median = percentile(&times, 50.0);
                let pixels = self.target.width as f64 * self.target.height as f64;
                results.push(BenchResult {
                    renderer,
                    mode: composite_mode_name(mode_name, channels),
                    camera: camera_name,
                    median_ms: median,
                    p95_ms: percentile(&times, 95.0),
                    fps: 1000.0 / median,
                    rays_per_s: pixels / (median * 1e-3),
                    nodes_per_ray_avg: work.average,
                    nodes_per_ray_max: work.max,
                    rays_in_volume: work.rays,
                    simd_efficiency: work.simd_efficiency,
                });
            }
        }
        Ok(())
    }
}

/// `dvr-gray-2ch`: the name of a composite row (static, as the other rows' modes).
fn composite_mode_name(mode: &str, channels: usize) -> &'static str {
    const DVR: [&str; 8] = [
        "dvr-gray-1ch",
        "dvr-gray-2ch",
        "dvr-gray-3ch",
        "dvr-gray-4ch",
        "dvr-gray-5ch",
        "dvr-gray-6ch",
        "dvr-gray-7ch",
        "dvr-gray-8ch",
    ];
    const MIP: [&str; 8] = [
        "mip-1ch", "mip-2ch", "mip-3ch", "mip-4ch", "mip-5ch", "mip-6ch", "mip-7ch", "mip-8ch",
    ];
    let names = if mode == "mip" { &MIP } else { &DVR };
    names[channels.clamp(1, 8) - 1]
}

/// `renderer`'s GPU memory by buffer and texture, as the report's JSON has it.
fn bytes_json(renderer: &VolumeRenderer) -> serde_json::Value {
    let buffers: serde_json::Map<String, serde_json::Value> = renderer
        .gpu_bytes()
        .into_iter()
        .map(|(name, bytes)| (name.to_owned(), bytes.into()))
        .collect();
    buffers.into()
}

/// One renderer, target, camera and settings: what a timed frame draws.
struct View<'a> {
    renderer: &'a VolumeRenderer,
    target: &'a RenderTarget,
    camera: Camera,
    settings: &'a RenderSettings,
}

/// Renders `count` frames with the azimuth sweeping a full turn; milliseconds per frame.
fn time_frames(
    context: &GpuContext,
    view: &View<'_>,
    count: u32,
    timer: Option<&GpuTimer>,
) -> Result<Vec<f64>, String> {
    let at_azimuth = |i: u32| Camera {
        azimuth_deg: view.camera.azimuth_deg + 360.0 * i as f64 / count as f64,
        ..view.camera
    };
    let submit = |camera: &Camera, writes| {
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("voxscope::bench_frame"),
            });
        view.renderer.encode(
            context,
            &mut encoder,
            view.target,
            camera,
            view.settings,
            writes,
        );
        context.queue.submit([encoder.finish()]);
    };
    // A full turn every 16 passes, so that the warm-up's timed batches compare alike.
    warm_up(context, timer, |i, writes| {
        submit(&at_azimuth((i % 16) * count / 16), writes)
    })
    .map_err(|e| e.to_string())?;
    time_passes(context, timer, count, |i, writes| {
        submit(&at_azimuth(i), writes)
    })
    .map_err(|e| e.to_string())
}

fn wait(context: &GpuContext) -> Result<(), String> {
    context.wait_idle().map_err(|e| e.to_string())
}

/// Work per ray over four azimuths: nodes (octree), samples (dense) or both (bricks).
struct RayWork {
    /// Average over rays that enter the volume.
    average: f64,
    max: u32,
    /// Rays that enter the volume, per azimuth.
    rays: f64,
    simd_efficiency: f64,
}

/// The pixels one warp of 32 invocations covers: 4 rows of an 8×8 workgroup.
const WARP_TILE: (usize, usize) = (8, 4);

fn sample_visits(context: &GpuContext, view: &View<'_>) -> Result<RayWork, String> {
    let (mut sum, mut rays, mut max, mut paid) = (0u64, 0u64, 0u32, 0u64);
    let (width, height) = (view.target.width as usize, view.target.height as usize);
    for quarter in 0..4 {
        let camera = Camera {
            azimuth_deg: view.camera.azimuth_deg + 90.0 * quarter as f64,
            ..view.camera
        };
        view.renderer
            .render(context, view.target, &camera, view.settings);
        let visits = read_visits(context, view.target).map_err(|e| e.to_string())?;
        for &work in visits.iter().filter(|&&work| work > 0) {
            sum += work as u64;
            rays += 1;
            max = max.max(work);
        }
        paid += warp_cost(&visits, width, height);
    }
    Ok(RayWork {
        average: if rays > 0 {
            sum as f64 / rays as f64
        } else {
            0.0
        },
        max,
        rays: rays as f64 / 4.0,
        simd_efficiency: if paid > 0 {
            sum as f64 / paid as f64
        } else {
            1.0
        },
    })
}

/// The work the warps pay for: per warp tile, its longest ray times the lanes.
fn warp_cost(visits: &[u32], width: usize, height: usize) -> u64 {
    let (tile_width, tile_height) = WARP_TILE;
    let mut paid = 0u64;
    for tile_y in (0..height).step_by(tile_height) {
        for tile_x in (0..width).step_by(tile_width) {
            let longest = (tile_y..(tile_y + tile_height).min(height))
                .flat_map(|y| {
                    let row = y * width;
                    visits[row + tile_x..row + (tile_x + tile_width).min(width)].iter()
                })
                .max()
                .copied()
                .unwrap_or(0);
            paid += longest as u64 * (tile_width * tile_height) as u64;
        }
    }
    paid
}

/// Milliseconds of each transfer edit.
struct EditTimes {
    /// GPU time of the recolor passes (octree and bricks, with timestamps); the dense renderer
    /// only rewrites its lookup table and has none.
    gpu: Option<Vec<f64>>,
    /// Wall time from encoding to the device's idle: what a blocking edit would cost.
    wall: Vec<f64>,
}

/// Applies `transfer` once and waits for it.
fn apply_transfer(
    context: &GpuContext,
    renderer: &mut VolumeRenderer,
    transfer: &TransferFunction,
) -> Result<(), String> {
    let mut encoder = context
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("voxscope::bench_transfer"),
        });
    renderer
        .set_transfer(context, &mut encoder, transfer, None)
        .map_err(|e| e.to_string())?;
    context.queue.submit([encoder.finish()]);
    wait(context)
}

/// Applies `transfer` `RECOLOR_RUNS` times.
fn time_transfer_edits(
    context: &GpuContext,
    renderer: &mut VolumeRenderer,
    transfer: &TransferFunction,
    timer: Option<&GpuTimer>,
) -> Result<EditTimes, String> {
    let timer = timer.filter(|_| renderer.kind() != RendererKind::Dense);
    let mut wall = Vec::new();
    for run in 0..RECOLOR_RUNS {
        let started = Instant::now();
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("voxscope::bench_transfer_edit"),
            });
        renderer
            .set_transfer(
                context,
                &mut encoder,
                transfer,
                timer.map(|t| t.pass_writes(run)),
            )
            .map_err(|e| e.to_string())?;
        context.queue.submit([encoder.finish()]);
        wait(context)?;
        wall.push(started.elapsed().as_secs_f64() * 1e3);
    }
    let gpu = timer
        .map(|timer| timer.read_ms(context, RECOLOR_RUNS))
        .transpose()
        .map_err(|e| e.to_string())?;
    Ok(EditTimes { gpu, wall })
}

/// Nearest-rank percentile.
pub(super) fn percentile(values: &[f64], p: f64) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let rank = ((p / 100.0) * sorted.len() as f64).ceil().max(1.0) as usize;
    sorted[rank.min(sorted.len()) - 1]
}

fn print_table(report: &serde_json::Value, results: &[BenchResult]) {
    println!(
        "{} ({}), {}, {}x{}, {} frames per case",
        report["adapter"].as_str().unwrap_or_default(),
        report["backend"].as_str().unwrap_or_default(),
        report["timing"].as_str().unwrap_or_default(),
        report["size"][0],
        report["size"][1],
        report["frames"]
    );
    println!(
        "volume {}  octree {} nodes",
        report["volume"]["file"], report["volume"]["octree_nodes"]
    );
    println!(
        "{:<8} {:<15} {:<7} {:>10} {:>10} {:>9} {:>12} {:>11} {:>10} {:>6}",
        "renderer",
        "mode",
        "camera",
        "median ms",
        "p95 ms",
        "fps",
        "Mrays/s",
        "nodes/ray",
        "max nodes",
        "SIMD"
    );
    for r in results {
        println!(
            "{:<8} {:<15} {:<7} {:>10.3} {:>10.3} {:>9.1} {:>12.1} {:>11.1} {:>10} {:>6.2}",
            r.renderer,
            r.mode,
            r.camera,
            r.median_ms,
            r.p95_ms,
            r.fps,
            r.rays_per_s / 1e6,
            r.nodes_per_ray_avg,
            r.nodes_per_ray_max,
            r.simd_efficiency
        );
    }
    println!(
        "build {:.3} s   transfer edit {} ms (CPU recolor {:.1} ms)   GPU memory of all renderers {:.1} MiB",
        report["build_seconds"].as_f64().unwrap_or_default(),
        report["recolor_ms"],
        report["recolor_cpu_ms"].as_f64().unwrap_or_default(),
        total_bytes(&report["gpu_bytes"]) / (1 << 20) as f64
    );
}

/// Sum of every number in a (nested) JSON object.
fn total_bytes(value: &serde_json::Value) -> f64 {
    match value {
        serde_json::Value::Object(map) => map.values().map(total_bytes).sum(),
        other => other.as_f64().unwrap_or_default(),
    }
}

/// How long a stopped view may take to complete before the benchmark says it did not.
pub(super) const MAX_WAIT: std::time::Duration = std::time::Duration::from_secs(20);

#[cfg(test)]
mod tests {
    use super::{percentile, warp_cost};

    #[test]
    fn warps_pay_for_their_longest_ray() {
        // 16×4 pixels: two warp tiles. The left one has one ray of 10, the right one is empty.
        let mut visits = vec![0u32; 16 * 4];
        visits[3 * 16 + 2] = 10;
        assert_eq!(warp_cost(&visits, 16, 4), 10 * 32);
        // Uniform work costs what it does.
        assert_eq!(warp_cost(&[7; 16 * 4], 16, 4), 7 * 64);
        // A partial tile at the edge pays for its lanes as if full.
        assert_eq!(warp_cost(&[1; 9], 9, 1), 64);
    }

    #[test]
    fn percentiles_are_nearest_rank() {
        let values = [5.0, 1.0, 3.0, 2.0, 4.0];
        assert_eq!(percentile(&values, 50.0), 3.0);
        assert_eq!(percentile(&values, 95.0), 5.0);
        assert_eq!(percentile(&values, 0.0), 1.0);
    }
}
