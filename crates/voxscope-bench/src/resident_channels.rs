//! The streamed composite once resident (`bench --stream --composite-channels 1,2,4`): the
//! resident level of the streaming benchmark as N channels streamed together (each a copy of
//! it, its own table and color, one atlas and page table), against the streaming renderer of
//! the one channel on the same views: what a frame of N channels costs over a frame of one.

use std::sync::Arc;

use serde_json::json;

use voxscope_octree::TransferFunction;
use voxscope_render::{
    ChannelLayer, GpuContext, GpuTimer, RenderMode, RenderSettings, RenderTarget, Shading,
    VolumeRenderer,
};
use voxscope_scene::refine;
use voxscope_stream::{BrickSource, ChannelSources, StreamOptions};
use voxscope_volume::{DEFAULT_CHANNEL_COLORS, QuantizedVolume};

use crate::error::BenchError;
use crate::options::{BenchOptions, CAMERAS, MAX_WAIT};
use crate::resident::time_view;
use crate::stats::percentile;

/// What the composite rows are measured against and with.
pub(crate) struct ChannelBench<'a> {
    pub context: &'a GpuContext,
    pub options: &'a BenchOptions,
    pub target: &'a RenderTarget,
    pub timer: Option<&'a GpuTimer>,
    /// The resident level's source, and its values (the tables' quantization).
    pub source: Arc<dyn BrickSource>,
    pub quantized: &'a QuantizedVolume,
    pub transfer: TransferFunction,
    pub depth: u32,
}

/// Rows of `counts` channels streamed together, DVR and MIP from the three cameras at full
/// detail (no pixel LOD), each with the one-channel streaming renderer's time of the view.
pub(crate) fn resident_channels(
    bench: &ChannelBench<'_>,
    stream_options: StreamOptions,
    counts: &[usize],
) -> Result<serde_json::Value, BenchError> {
    let options = StreamOptions {
        lod_scale: 0.0,
        ..stream_options
    };
    let mut one = VolumeRenderer::new_stream(
        bench.context,
        bench.source.clone(),
        options,
        &bench.transfer,
    )?;
    let mut rows = Vec::new();
    for &count in counts {
        let channels = vec![bench.source.clone(); count];
        let together = ChannelSources::new(bench.source.name(), channels)
            .map_err(|e| BenchError::Pyramid(e.to_string()))?;
        let mut composite = VolumeRenderer::new_stream(
            bench.context,
            Arc::new(together),
            options,
            &bench.transfer,
        )?;
        let layers: Vec<ChannelLayer<'_>> = (0..count)
            .map(|index| ChannelLayer {
                quantized: bench.quantized,
                transfer: &bench.transfer,
                color: DEFAULT_CHANNEL_COLORS[index].1.map(|c| c as f32 / 255.0),
            })
            .collect();
        composite
            .renderer()
            .set_channels(bench.context, &layers, &vec![true; count])?;
        for (mode_name, mode) in [("dvr-gray", RenderMode::Dvr), ("mip", RenderMode::Mip)] {
            let settings = RenderSettings {
                mode,
                density: bench.options.density,
                shading: Shading::OFF,
                ..RenderSettings::full_detail(bench.depth)
            };
            for (camera_name, distance) in CAMERAS {
                let camera = bench.options.camera(distance);
                let time = |renderer: &mut VolumeRenderer| {
                    let refined = refine(
                        bench.context,
                        renderer,
                        bench.target,
                        &camera,
                        &settings,
                        MAX_WAIT,
                    )
                    .map_err(BenchError::Scene)?;
                    let times = time_view(
                        bench.context,
                        renderer,
                        bench.target,
                        &camera,
                        &settings,
                        bench.options.frames,
                        bench.timer,
                    )?;
                    Ok::<_, BenchError>((refined.complete, percentile(&times.gpu, 50.0)))
                };
                let (complete, composite_ms) = time(&mut composite)?;
                let (_, one_ms) = time(&mut one)?;
                rows.push(json!({
                    "channels": count,
                    "mode": mode_name,
                    "camera": camera_name,
                    "complete": complete,
                    "composite_gpu_ms": composite_ms,
                    "one_channel_gpu_ms": one_ms,
                    "over_one_channel": composite_ms / one_ms,
                }));
            }
        }
    }
    Ok(json!(rows))
}
