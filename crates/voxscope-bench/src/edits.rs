//! Transfer function edits of an in-memory renderer, applied and timed: what recoloring costs
//! on the GPU, and what a blocking edit costs its caller.

use std::time::Instant;

use voxscope_octree::TransferFunction;
use voxscope_render::{GpuContext, GpuTimer, RendererKind, VolumeRenderer};

use crate::error::BenchError;

/// Timed transfer edits per renderer.
pub(crate) const RECOLOR_RUNS: u32 = 20;

/// Milliseconds of each transfer edit.
pub(crate) struct EditTimes {
    /// GPU time of the recolor passes (octree and bricks, with timestamps); the dense renderer
    /// only rewrites its lookup table and has none.
    pub gpu: Option<Vec<f64>>,
    /// Wall time from encoding to the device's idle: what a blocking edit would cost.
    pub wall: Vec<f64>,
}

/// Applies `transfer` once and waits for it.
pub(crate) fn apply_transfer(
    context: &GpuContext,
    renderer: &mut VolumeRenderer,
    transfer: &TransferFunction,
) -> Result<(), BenchError> {
    let mut encoder = context
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("voxscope::bench_transfer"),
        });
    renderer.set_transfer(context, &mut encoder, transfer, None)?;
    context.queue.submit([encoder.finish()]);
    Ok(context.wait_idle()?)
}

/// Applies `transfer` [`RECOLOR_RUNS`] times.
pub(crate) fn time_transfer_edits(
    context: &GpuContext,
    renderer: &mut VolumeRenderer,
    transfer: &TransferFunction,
    timer: Option<&GpuTimer>,
) -> Result<EditTimes, BenchError> {
    let timer = timer.filter(|_| renderer.kind() != RendererKind::Dense);
    let mut wall = Vec::new();
    for run in 0..RECOLOR_RUNS {
        let started = Instant::now();
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("voxscope::bench_transfer_edit"),
            });
        renderer.set_transfer(
            context,
            &mut encoder,
            transfer,
            timer.map(|t| t.pass_writes(run)),
        )?;
        context.queue.submit([encoder.finish()]);
        context.wait_idle()?;
        wall.push(started.elapsed().as_secs_f64() * 1e3);
    }
    let gpu = timer
        .map(|timer| timer.read_ms(context, RECOLOR_RUNS))
        .transpose()?;
    Ok(EditTimes { gpu, wall })
}
