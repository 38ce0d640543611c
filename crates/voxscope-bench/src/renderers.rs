//! The in-memory renderers' benchmark (`voxscope bench`): GPU time per frame for the paper's
//! three camera distances and the three transfer modes (and gray DVR shaded), for each of the
//! octree, dense and bricks renderers, plus build, recolor and memory figures; and the
//! composite of channels (the volume as N channels, and a multi-channel file's own).

use std::time::{Duration, Instant};

use serde::Serialize;
use serde_json::json;
use voxscope_octree::{Clip, OpacityMode, TransferFunction};
use voxscope_render::{
    Camera, ChannelLayer, GpuContext, GpuTimer, RenderMode, RenderSettings, RenderTarget,
    RendererKind, RendererOptions, Shading, VolumeRenderer, timing_name,
};
use voxscope_scene::{
    Channel, ChannelRequest, ChannelState, Progress, TransferRequest, VolumeData, VolumeSource,
    opening_transfer,
};
use voxscope_volume::Volume;

use crate::edits::{EditTimes, RECOLOR_RUNS, apply_transfer, time_transfer_edits};
use crate::error::BenchError;
use crate::frames::{View, sample_visits, time_frames};
use crate::options::{BenchOptions, CAMERAS, MEDIUM};
use crate::stats::percentile;

/// The volume the in-memory renderers are timed on: its data with the octree colored by the
/// transfer function it opens with, and a multi-channel file's channels.
pub struct BenchVolume {
    data: VolumeData,
    transfer: TransferFunction,
    /// How long coloring the octree took on the CPU.
    recolor_time: Duration,
    /// A file of several channels (`--channel` not a number): each channel as it opens in the
    /// composite (the rows of the volume are channel 0's).
    file_channels: Option<Vec<FileChannel>>,
}

/// One channel of a multi-channel file, with its opening color and transfer function.
struct FileChannel {
    channel: Channel,
    state: ChannelState,
}

impl FileChannel {
    /// The layer the composite takes.
    fn layer(&self) -> ChannelLayer<'_> {
        ChannelLayer {
            quantized: &self.channel.quantized,
            transfer: &self.state.transfer,
            color: self.state.color.map(|c| c as f32 / 255.0),
        }
    }
}

impl BenchVolume {
    /// Reads and prepares the volume `options` name (a multi-channel file, unless one channel
    /// is chosen: channel 0 and all of its channels); `progress` follows the octree's build
    /// (its stage is empty again once the build is over).
    pub fn open(options: &BenchOptions, progress: &Progress) -> Result<Self, BenchError> {
        options.check()?;
        // The benchmark's transfer function names no file: nothing saved to read.
        let request = options.transfer().request(None);
        match options
            .open
            .composite_channels()
            .map_err(BenchError::Open)?
        {
            Some(channels) if channels.len() > 1 => {
                let first = channels[0].clone();
                let channels = channels
                    .into_iter()
                    .enumerate()
                    .map(|(index, volume)| {
                        let channel = Channel::from_volume(volume);
                        let kind = voxscope_octree::DataKind::of_volume(
                            &channel.volume,
                            &channel.quantized,
                        );
                        let state = ChannelState::opening_of(
                            &channel.volume,
                            &channel.quantized,
                            kind,
                            index,
                            &request,
                            &ChannelRequest::default(),
                        );
                        FileChannel { channel, state }
                    })
                    .collect();
                Ok(Self {
                    file_channels: Some(channels),
                    ..Self::prepare(first, &request, progress)?
                })
            }
            Some(mut channels) => {
                let volume = channels.pop().ok_or(BenchError::NoChannel)?;
                Self::prepare(volume, &request, progress)
            }
            None => {
                let volume = options.open.load().map_err(BenchError::Open)?;
                Self::prepare(volume, &request, progress)
            }
        }
    }

    /// Quantizes `volume`, builds its octree and colors it with the transfer function
    /// `request` opens it with.
    fn prepare(
        volume: Volume,
        request: &TransferRequest,
        progress: &Progress,
    ) -> Result<Self, BenchError> {
        let source = VolumeSource::from_spec(&volume.name);
        let prepared = VolumeData::prepare(&source, volume, Instant::now(), progress);
        // The build is over: nothing more to report as its progress.
        progress.begin("");
        let mut data = prepared.map_err(BenchError::Open)?;
        let transfer = opening_transfer(&data.quantized, data.kind, data.default_window, request);
        let recolor_time = voxscope_octree::recolor(&mut data.octree, &transfer);
        Ok(Self {
            data,
            transfer,
            recolor_time,
            file_channels: None,
        })
    }
}

/// One row of the results.
#[derive(Debug, Clone, Serialize)]
pub struct BenchResult {
    pub renderer: &'static str,
    pub mode: &'static str,
    pub camera: &'static str,
    pub median_ms: f64,
    pub p95_ms: f64,
    /// Wall milliseconds per frame of the turn's frames as one batch (submitted back to back,
    /// then the device's completion), each frame's encode and submit on the CPU included:
    /// what a Python `Renderer`'s `draw()` calls then `finish()` take a frame.
    pub wall_ms_per_frame: f64,
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

/// The benchmark's report: one JSON object (device, volume, rows, build, recolor and GPU
/// memory figures) and its rows.
pub struct Report {
    pub json: serde_json::Value,
    pub results: Vec<BenchResult>,
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

/// The cases of each renderer, of the volume's gray transfer function: the unshaded rows
/// first, in the order of every run before shading existed.
fn cases(gray: TransferFunction) -> [Case; 4] {
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
    [
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
    ]
}

/// Times the in-memory renderers (`options.renderer`, else octree, dense and bricks) on
/// `volume`, then the composites of `options.composite_channels` channels and of a
/// multi-channel file's own.
pub fn run(options: &BenchOptions, volume: &BenchVolume) -> Result<Report, BenchError> {
    let context = GpuContext::new_headless()?;
    let data = &volume.data;
    let depth = data.octree.depth;
    let target = RenderTarget::new(&context, options.size.0, options.size.1);
    let timer = GpuTimer::new(&context, options.frames.max(RECOLOR_RUNS));
    let bench = Bench {
        context: &context,
        target: &target,
        timer: timer.as_ref(),
        frames: options.frames,
        camera: options.camera(MEDIUM),
        density: options.density,
        clip: options.clip,
        depth,
        max_level: options.level.unwrap_or(depth).min(depth),
    };
    let kinds: Vec<RendererKind> = match options.renderer {
        Some(one) => vec![one],
        None => RendererKind::ALL.to_vec(),
    };
    let mut results = Vec::new();
    let mut recolor_ms = serde_json::Map::new();
    let mut recolor_wall_ms = serde_json::Map::new();
    let mut gpu_bytes = serde_json::Map::new();
    let cases = cases(volume.transfer);
    for kind in kinds {
        let renderer = VolumeRenderer::new(
            &context,
            RendererOptions {
                kind,
                brick_size: options.brick_size,
                ..Default::default()
            },
            &data.octree,
            &data.quantized,
            data.volume.spacing,
            depth,
            &volume.transfer,
        )
        .map_err(|e| BenchError::renderer(&data.volume.name, e))?;
        gpu_bytes.insert(kind.name().to_owned(), bytes_json(&renderer));
        let edits = bench.renderer_rows(kind.name(), renderer, &cases, &mut results)?;
        // GPU time where the renderer recolors on the GPU with timestamps, else wall time.
        let edit_ms = edits.gpu.as_ref().unwrap_or(&edits.wall);
        recolor_ms.insert(kind.name().to_owned(), percentile(edit_ms, 50.0).into());
        recolor_wall_ms.insert(kind.name().to_owned(), percentile(&edits.wall, 50.0).into());
    }
    for &count in &options.composite_channels {
        let layers: Vec<ChannelLayer<'_>> = (0..count)
            .map(|index| ChannelLayer {
                quantized: &data.quantized,
                transfer: &volume.transfer,
                color: voxscope_volume::DEFAULT_CHANNEL_COLORS[index]
                    .1
                    .map(|c| c as f32 / 255.0),
            })
            .collect();
        let renderer = VolumeRenderer::new_composite(&context, &layers, data.volume.spacing)
            .map_err(|e| BenchError::renderer(&data.volume.name, e))?;
        gpu_bytes.insert(format!("composite-{count}"), bytes_json(&renderer));
        bench.composite_rows(&renderer, count, "composite", &mut results)?;
    }
    // A multi-channel file: the composite of its own channels too (`--channel all`).
    if let Some(channels) = &volume.file_channels {
        let layers: Vec<ChannelLayer<'_>> = channels.iter().map(FileChannel::layer).collect();
        let renderer = VolumeRenderer::new_composite(&context, &layers, data.volume.spacing)
            .map_err(|e| BenchError::renderer(&data.volume.name, e))?;
        gpu_bytes.insert("composite-file".into(), bytes_json(&renderer));
        bench.composite_rows(&renderer, channels.len(), "composite-file", &mut results)?;
    }
    gpu_bytes.insert(
        "target".into(),
        json!({"texture": target.width as u64 * target.height as u64 * 4, "visits": target.visits.size()}),
    );
    let json = json!({
        "adapter": context.adapter_info.name,
        "backend": format!("{:?}", context.adapter_info.backend),
        "driver": format!("{} {}", context.adapter_info.driver, context.adapter_info.driver_info),
        "timing": timing_name(timer.as_ref()),
        "size": [target.width, target.height],
        "frames": options.frames,
        // Where each case's turn starts, in degrees.
        "azimuth": options.azimuth,
        "volume": {
            "file": data.volume.name,
            "dims": data.volume.dims,
            "voxel_type": data.volume.voxel_type().name(),
            "octree_depth": depth,
            "max_level": bench.max_level,
            "octree_nodes": data.octree.nodes.len(),
        },
        "results": results,
        "build_seconds": data.octree.build_seconds,
        "recolor_ms": recolor_ms,
        "recolor_wall_ms": recolor_wall_ms,
        "brick_size": options.brick_size,
        "clip": options.clip,
        "recolor_cpu_ms": volume.recolor_time.as_secs_f64() * 1e3,
        "gpu_bytes": gpu_bytes,
    });
    Ok(Report { json, results })
}

/// What every row shares: device, target, timing and settings.
struct Bench<'a> {
    context: &'a GpuContext,
    target: &'a RenderTarget,
    timer: Option<&'a GpuTimer>,
    frames: u32,
    /// The camera of every view, at each view's own distance.
    camera: Camera,
    density: f32,
    clip: Clip,
    /// The octree's depth: the composites draw at full detail.
    depth: u32,
    /// The in-memory renderers' max level.
    max_level: u32,
}

impl Bench<'_> {
    /// Times `renderer` (called `name` in the rows) in each case from the three cameras, as
    /// rows; returns its transfer edits' times.
    fn renderer_rows(
        &self,
        name: &'static str,
        mut renderer: VolumeRenderer,
        cases: &[Case],
        results: &mut Vec<BenchResult>,
    ) -> Result<EditTimes, BenchError> {
        let (mut edit_gpu_ms, mut edit_wall_ms) = (Vec::new(), Vec::new());
        for case in cases {
            if case.time_edit {
                let edits =
                    time_transfer_edits(self.context, &mut renderer, &case.transfer, self.timer)?;
                edit_gpu_ms.extend(edits.gpu.unwrap_or_default());
                edit_wall_ms.extend(edits.wall);
            } else {
                apply_transfer(self.context, &mut renderer, &case.transfer)?;
            }
            let settings = RenderSettings {
                mode: case.mode,
                density: self.density,
                shading: case.shading,
                clip: self.clip,
                ..RenderSettings::full_detail(self.max_level)
            };
            renderer.prepare_pipelines(self.context, &settings, false);
            for (camera_name, distance) in CAMERAS {
                let view = self.view(&renderer, distance, &settings);
                results.push(self.row(&view, name, case.name, camera_name)?);
            }
        }
        Ok(EditTimes {
            gpu: (!edit_gpu_ms.is_empty()).then_some(edit_gpu_ms),
            wall: edit_wall_ms,
        })
    }

    /// Times the composite `composite` (of `channels` channels), DVR and MIP, from the three
    /// cameras, as rows of `renderer`.
    fn composite_rows(
        &self,
        composite: &VolumeRenderer,
        channels: usize,
        renderer: &'static str,
        results: &mut Vec<BenchResult>,
    ) -> Result<(), BenchError> {
        for (mode_name, mode) in [("dvr-gray", RenderMode::Dvr), ("mip", RenderMode::Mip)] {
            let settings = RenderSettings {
                mode,
                density: self.density,
                shading: Shading::OFF,
                clip: self.clip,
                ..RenderSettings::full_detail(self.depth)
            };
            for (camera_name, distance) in CAMERAS {
                let view = self.view(composite, distance, &settings);
                let mode = composite_mode_name(mode_name, channels);
                results.push(self.row(&view, renderer, mode, camera_name)?);
            }
        }
        Ok(())
    }

    /// `renderer` from `distance` bounding-sphere radii, drawn with `settings`.
    fn view<'a>(
        &'a self,
        renderer: &'a VolumeRenderer,
        distance: f64,
        settings: &'a RenderSettings,
    ) -> View<'a> {
        View {
            renderer,
            target: self.target,
            camera: Camera {
                distance,
                ..self.camera
            },
            settings,
        }
    }

    /// The row of `view`: its frames timed, its rays' work sampled.
    fn row(
        &self,
        view: &View<'_>,
        renderer: &'static str,
        mode: &'static str,
        camera: &'static str,
    ) -> Result<BenchResult, BenchError> {
        let times = time_frames(self.context, view, self.frames, self.timer)?;
        let work = sample_visits(self.context, view)?;
        let median = percentile(&times.each, 50.0);
        let pixels = self.target.width as f64 * self.target.height as f64;
        Ok(BenchResult {
            renderer,
            mode,
            camera,
            median_ms: median,
            p95_ms: percentile(&times.each, 95.0),
            wall_ms_per_frame: times.batch_wall,
            fps: 1000.0 / median,
            rays_per_s: pixels / (median * 1e-3),
            nodes_per_ray_avg: work.average,
            nodes_per_ray_max: work.max,
            rays_in_volume: work.rays,
            simd_efficiency: work.simd_efficiency,
        })
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

impl Report {
    /// The report as a table: the device, the volume, a row a case, then build, transfer
    /// edit and GPU memory figures (each line ended by a newline).
    pub fn table(&self) -> String {
        let report = &self.json;
        let mut lines = vec![
            format!(
                "{} ({}), {}, {}x{}, {} frames per case (a turn from azimuth {}°)",
                report["adapter"].as_str().unwrap_or_default(),
                report["backend"].as_str().unwrap_or_default(),
                report["timing"].as_str().unwrap_or_default(),
                report["size"][0],
                report["size"][1],
                report["frames"],
                report["azimuth"]
            ),
            format!(
                "volume {}  octree {} nodes",
                report["volume"]["file"], report["volume"]["octree_nodes"]
            ),
            format!(
                "{:<8} {:<15} {:<7} {:>10} {:>10} {:>10} {:>9} {:>12} {:>11} {:>10} {:>6}",
                "renderer",
                "mode",
                "camera",
                "median ms",
                "p95 ms",
                "wall ms",
                "fps",
                "Mrays/s",
                "nodes/ray",
                "max nodes",
                "SIMD"
            ),
        ];
        for r in &self.results {
            lines.push(format!(
                "{:<8} {:<15} {:<7} {:>10.3} {:>10.3} {:>10.3} {:>9.1} {:>12.1} {:>11.1} {:>10} {:>6.2}",
                r.renderer,
                r.mode,
                r.camera,
                r.median_ms,
                r.p95_ms,
                r.wall_ms_per_frame,
                r.fps,
                r.rays_per_s / 1e6,
                r.nodes_per_ray_avg,
                r.nodes_per_ray_max,
                r.simd_efficiency
            ));
        }
        lines.push(format!(
            "build {:.3} s   transfer edit {} ms (CPU recolor {:.1} ms)   GPU memory of all renderers {:.1} MiB",
            report["build_seconds"].as_f64().unwrap_or_default(),
            report["recolor_ms"],
            report["recolor_cpu_ms"].as_f64().unwrap_or_default(),
            total_bytes(&report["gpu_bytes"]) / (1 << 20) as f64
        ));
        lines.iter().map(|line| format!("{line}\n")).collect()
    }
}

/// Sum of every number in a (nested) JSON object.
fn total_bytes(value: &serde_json::Value) -> f64 {
    match value {
        serde_json::Value::Object(map) => map.values().map(total_bytes).sum(),
        other => other.as_f64().unwrap_or_default(),
    }
}
