//! GPU time of compute passes, from timestamp queries written at each pass's start and end, or
//! wall time with a device wait per pass where the device has no timestamps.

use std::time::Instant;

use super::{GpuContext, RenderError, read_buffer};

/// Timestamps for up to `capacity` passes.
pub struct GpuTimer {
    query_set: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    capacity: u32,
    /// Nanoseconds per timestamp tick.
    period_ns: f64,
}

impl GpuTimer {
    /// A timer for `capacity` passes, or `None` when the device has no timestamp queries.
    pub fn new(context: &GpuContext, capacity: u32) -> Option<Self> {
        if !context.has_timestamps || capacity == 0 {
            return None;
        }
        let count = 2 * capacity;
        let query_set = context.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("voxscope::pass_timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count,
        });
        let resolved = context.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::pass_timestamps_resolved"),
            size: count as u64 * 8,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Some(Self {
            query_set,
            resolved,
            capacity,
            period_ns: context.queue.get_timestamp_period() as f64,
        })
    }

    /// Timestamp writes for pass number `pass` (0-based, below the capacity).
    pub fn pass_writes(&self, pass: u32) -> wgpu::ComputePassTimestampWrites<'_> {
        assert!(pass < self.capacity, "timer holds {} passes", self.capacity);
        wgpu::ComputePassTimestampWrites {
            query_set: &self.query_set,
            beginning_of_pass_write_index: Some(2 * pass),
            end_of_pass_write_index: Some(2 * pass + 1),
        }
    }

    /// Milliseconds of passes `0..passes`, after they were submitted.
    pub fn read_ms(&self, context: &GpuContext, passes: u32) -> Result<Vec<f64>, RenderError> {
        let passes = passes.min(self.capacity);
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("voxscope::resolve_timestamps"),
            });
        encoder.resolve_query_set(&self.query_set, 0..2 * passes, &self.resolved, 0);
        context.queue.submit([encoder.finish()]);
        let bytes = read_buffer(context, &self.resolved, passes as u64 * 16)?;
        let ticks: &[u64] = bytemuck::cast_slice(&bytes);
        Ok(ticks
            .chunks_exact(2)
            .map(|pair| pair[1].saturating_sub(pair[0]) as f64 * self.period_ns * 1e-6)
            .collect())
    }
}

/// How [`time_passes`] times with `timer`: `gpu-timestamps`, or `wall-clock-with-device-wait`.
pub fn timing_name(timer: Option<&GpuTimer>) -> &'static str {
    if timer.is_some() {
        "gpu-timestamps"
    } else {
        "wall-clock-with-device-wait"
    }
}

/// Milliseconds of `passes` passes, each encoded and submitted by `submit(pass, writes)`: GPU
/// time from `timer`'s timestamps (all passes submitted, then one wait), or without a timer
/// wall time from submission to the device's idle, pass by pass.
pub fn time_passes<'timer>(
    context: &GpuContext,
    timer: Option<&'timer GpuTimer>,
    passes: u32,
    mut submit: impl FnMut(u32, Option<wgpu::ComputePassTimestampWrites<'timer>>),
) -> Result<Vec<f64>, RenderError> {
    match timer {
        Some(timer) => {
            for pass in 0..passes {
                submit(pass, Some(timer.pass_writes(pass)));
            }
            context.wait_idle()?;
            timer.read_ms(context, passes)
        }
        None => (0..passes)
            .map(|pass| {
                let started = Instant::now();
                submit(pass, None);
                context.wait_idle()?;
                Ok(started.elapsed().as_secs_f64() * 1e3)
            })
            .collect(),
    }
}
