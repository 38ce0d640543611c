//! `voxscope bench`: GPU time per frame for the paper's three camera distances and the three
//! transfer modes, plus build, recolor and memory figures.

use std::time::Instant;

use clap::Args;
use serde::Serialize;
use serde_json::json;

use super::args::{OpacityArg, RendererArg, TransferArgs};
use super::{Prepared, VolumeArgs};
use crate::octree::{OpacityMode, TransferFunction};
use crate::render::{
    Camera, DEFAULT_BRICK_SIZE, GpuContext, GpuTimer, RenderMode, RenderSettings, RenderTarget,
    RendererKind, RendererOptions, VolumeRenderer, read_visits,
};
use crate::volume::ValueWindow;

#[derive(Debug, Args)]
pub struct BenchArgs {
    #[command(flatten)]
    pub volume: VolumeArgs,
    /// Image size WxH.
    #[arg(long, default_value = "1024x768", value_parser = super::render::parse_size)]
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
    /// Only this renderer (default: all).
    #[arg(long, value_enum)]
    pub renderer: Option<RendererArg>,
    /// Voxels along a brick's side (bricks renderer): 4, 8, 16 or 32.
    #[arg(long, default_value_t = DEFAULT_BRICK_SIZE, value_parser = super::args::parse_brick_size)]
    pub brick_size: usize,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
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
}

/// The paper's three cases: near, medium and far, in bounding-sphere radii.
const CAMERAS: [(&str, f64); 3] = [("near", 1.5), ("medium", 3.0), ("far", 6.0)];
const WARMUP_FRAMES: u32 = 5;
const RECOLOR_RUNS: u32 = 20;

pub fn run(args: &BenchArgs) -> Result<(), String> {
    if args.frames == 0 {
        return Err("--frames must be at least 1".into());
    }
    let mut transfer_args = TransferArgs::defaults();
    transfer_args.window = args.window;
    transfer_args.threshold = args.threshold;
    transfer_args.opacity = OpacityArg::Gray;
    let prepared = Prepared::new(&args.volume, &transfer_args)?;
    let context = GpuContext::new_headless().map_err(|e| e.to_string())?;
    let depth = prepared.octree.depth;
    let target = RenderTarget::new(&context, args.size.0, args.size.1);
    let timer = GpuTimer::new(&context, args.frames.max(RECOLOR_RUNS));
    let timing = if timer.is_some() {
        "gpu-timestamps"
    } else {
        "wall-clock-with-device-wait"
    };

    let gray = prepared.transfer;
    let binary = TransferFunction {
        opacity: OpacityMode::Binary,
        ..gray
    };
    let modes: [(&str, TransferFunction, RenderMode); 3] = [
        ("dvr-gray", gray, RenderMode::Dvr),
        ("dvr-binary", binary, RenderMode::Dvr),
        ("mip", gray, RenderMode::Mip),
    ];
    let kinds: Vec<RendererKind> = match args.renderer {
        Some(one) => vec![one.into()],
        None => RendererKind::ALL.to_vec(),
    };
    let mut results = Vec::new();
    let mut recolor_ms = serde_json::Map::new();
    let mut gpu_bytes = serde_json::Map::new();
    for kind in kinds {
        let mut renderer = VolumeRenderer::new(
            &context,
            RendererOptions {
                kind,
                brick_size: args.brick_size,
            },
            &prepared.octree,
            &prepared.quantized,
            prepared.volume.spacing,
            depth,
            &prepared.transfer,
        )
        .map_err(|e| format!("{}: {e}", prepared.volume.name))?;
        let buffers: serde_json::Map<String, serde_json::Value> = renderer
            .gpu_bytes()
            .into_iter()
            .map(|(name, bytes)| (name.to_owned(), bytes.into()))
            .collect();
        gpu_bytes.insert(kind.name().to_owned(), buffers.into());
        let mut edit_ms = Vec::new();
        for (mode_name, transfer, mode) in modes {
            edit_ms.extend(time_transfer_edits(
                &context,
                &mut renderer,
                &transfer,
                timer.as_ref(),
            )?);
            let settings = RenderSettings {
                mode,
                density: args.density,
                ..RenderSettings::full_detail(depth)
            };
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
                let (nodes_avg, nodes_max) = sample_visits(&context, &view)?;
                let median = percentile(&times, 50.0);
                results.push(BenchResult {
                    renderer: kind.name(),
                    mode: mode_name,
                    camera: camera_name,
                    median_ms: median,
                    p95_ms: percentile(&times, 95.0),
                    fps: 1000.0 / median,
                    rays_per_s: (target.width as f64 * target.height as f64) / (median * 1e-3),
                    nodes_per_ray_avg: nodes_avg,
                    nodes_per_ray_max: nodes_max,
                });
            }
        }
        recolor_ms.insert(kind.name().to_owned(), percentile(&edit_ms, 50.0).into());
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
            "file": prepared.volume.name,
            "dims": prepared.volume.dims,
            "voxel_type": prepared.volume.voxel_type().name(),
            "octree_depth": depth,
            "octree_nodes": prepared.octree.nodes.len(),
        },
        "results": results,
        "build_seconds": prepared.octree.build_seconds,
        "recolor_ms": recolor_ms,
        "brick_size": args.brick_size,
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
    for i in 0..WARMUP_FRAMES {
        submit(&at_azimuth(i * count / WARMUP_FRAMES), None);
    }
    wait(context)?;
    match timer {
        Some(timer) => {
            for i in 0..count {
                submit(&at_azimuth(i), Some(timer.pass_writes(i)));
            }
            wait(context)?;
            timer.read_ms(context, count).map_err(|e| e.to_string())
        }
        None => (0..count)
            .map(|i| {
                let started = Instant::now();
                submit(&at_azimuth(i), None);
                wait(context)?;
                Ok(started.elapsed().as_secs_f64() * 1e3)
            })
            .collect(),
    }
}

fn wait(context: &GpuContext) -> Result<(), String> {
    context
        .device
        .poll(wgpu::PollType::wait_indefinitely())
        .map(|_| ())
        .map_err(|e| format!("GPU wait failed: {e}"))
}

/// Average and largest nodes (octree) or samples (dense) per ray that enters the volume, over
/// four azimuths.
fn sample_visits(context: &GpuContext, view: &View<'_>) -> Result<(f64, u32), String> {
    let (mut sum, mut rays, mut max) = (0u64, 0u64, 0u32);
    for quarter in 0..4 {
        let camera = Camera {
            azimuth_deg: view.camera.azimuth_deg + 90.0 * quarter as f64,
            ..view.camera
        };
        view.renderer
            .render(context, view.target, &camera, view.settings);
        for visits in read_visits(context, view.target).map_err(|e| e.to_string())? {
            if visits > 0 {
                sum += visits as u64;
                rays += 1;
                max = max.max(visits);
            }
        }
    }
    Ok((
        if rays > 0 {
            sum as f64 / rays as f64
        } else {
            0.0
        },
        max,
    ))
}

/// Applies `transfer` `RECOLOR_RUNS` times; milliseconds of each (GPU time of the recolor for
/// the octree and bricks; for dense, which only rewrites its lookup table, wall time).
fn time_transfer_edits(
    context: &GpuContext,
    renderer: &mut VolumeRenderer,
    transfer: &TransferFunction,
    timer: Option<&GpuTimer>,
) -> Result<Vec<f64>, String> {
    let mut times = Vec::new();
    for run in 0..RECOLOR_RUNS {
        let started = Instant::now();
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("voxscope::bench_transfer_edit"),
            });
        let writes = timer
            .filter(|_| renderer.kind() == RendererKind::Octree)
            .map(|t| t.pass_writes(run));
        renderer
            .set_transfer(context, &mut encoder, transfer, writes)
            .map_err(|e| e.to_string())?;
        context.queue.submit([encoder.finish()]);
        wait(context)?;
        times.push(started.elapsed().as_secs_f64() * 1e3);
    }
    match timer {
        Some(timer) if renderer.kind() == RendererKind::Octree => timer
            .read_ms(context, RECOLOR_RUNS)
            .map_err(|e| e.to_string()),
        _ => Ok(times),
    }
}

/// The `p`-th percentile (nearest rank) of `values`.
fn percentile(values: &[f64], p: f64) -> f64 {
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
        "{:<8} {:<11} {:<7} {:>10} {:>10} {:>9} {:>12} {:>11} {:>10}",
        "renderer",
        "mode",
        "camera",
        "median ms",
        "p95 ms",
        "fps",
        "Mrays/s",
        "nodes/ray",
        "max nodes"
    );
    for r in results {
        println!(
            "{:<8} {:<11} {:<7} {:>10.3} {:>10.3} {:>9.1} {:>12.1} {:>11.1} {:>10}",
            r.renderer,
            r.mode,
            r.camera,
            r.median_ms,
            r.p95_ms,
            r.fps,
            r.rays_per_s / 1e6,
            r.nodes_per_ray_avg,
            r.nodes_per_ray_max
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

#[cfg(test)]
mod tests {
    use super::percentile;

    #[test]
    fn percentiles_are_nearest_rank() {
        let values = [5.0, 1.0, 3.0, 2.0, 4.0];
        assert_eq!(percentile(&values, 50.0), 3.0);
        assert_eq!(percentile(&values, 95.0), 5.0);
        assert_eq!(percentile(&values, 0.0), 1.0);
    }
}
