//! GPU time of compute passes, from timestamp queries written at each pass's start and end, or
//! wall time with a device wait per pass where the device has no timestamps.

use std::time::{Duration, Instant};

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

    /// How many passes one timing can hold.
    pub fn capacity(&self) -> u32 {
        self.capacity
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

/// How [`warm_up`] ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WarmUp {
    /// Seconds from its start to its end.
    pub seconds: f64,
    /// Whether the passes' time had settled, or the device is a CPU, whose clocks no GPU driver
    /// lowers (false: it gave up at [`WARM_UP_LIMIT`]).
    pub steady: bool,
    /// The median milliseconds of a pass in its last timed batch (none on a CPU).
    pub last_ms: Option<f64>,
}

/// The least time [`warm_up`] keeps the GPU busy before it times anything.
pub const WARM_UP_BUSY: Duration = Duration::from_millis(400);
/// The most time [`warm_up`] takes.
pub const WARM_UP_LIMIT: Duration = Duration::from_secs(3);
/// Passes in each of [`warm_up`]'s timed batches (fewer where the timer holds fewer).
const WARM_UP_TIMED: u32 = 16;
/// Two batches whose medians differ by less than this fraction are steady.
const WARM_UP_TOLERANCE: f64 = 0.03;
/// A batch of [`warm_up`]'s busy phase is grown until it keeps the GPU this long.
const WARM_UP_BATCH: Duration = Duration::from_millis(10);

/// Keeps the GPU busy with `submit`'s passes until their time is steady, so that what is timed
/// next runs at a busy GPU's clocks. A GPU lowers its clocks within seconds of idling (an H200
/// from 1 980 to 345 MHz in about 2 s while a benchmark waited on its loaders) and raises them
/// again only after a few hundred milliseconds of load, longer when the load is light: a
/// benchmark's first configuration was timed 3.7× slow at 345–645 MHz.
///
/// First [`WARM_UP_BUSY`] of batches, each grown until it keeps the GPU busy for
/// [`WARM_UP_BATCH`] (passes of a tenth of a millisecond, a few at a time, leave it idle between
/// waits), then timed batches until two medians in a row agree within 3 %, or
/// [`WARM_UP_LIMIT`] passed. On a CPU's Vulkan (lavapipe) one batch of 5 passes: its speed
/// does not ramp with load. `submit` is called as for [`time_passes`], with pass numbers from 0.
pub fn warm_up<'timer>(
    context: &GpuContext,
    timer: Option<&'timer GpuTimer>,
    mut submit: impl FnMut(u32, Option<wgpu::ComputePassTimestampWrites<'timer>>),
) -> Result<WarmUp, RenderError> {
    let started = Instant::now();
    if context.adapter_info.device_type == wgpu::DeviceType::Cpu {
        for pass in 0..5 {
            submit(pass, None);
        }
        context.wait_idle()?;
        return Ok(WarmUp {
            seconds: started.elapsed().as_secs_f64(),
            steady: true,
            last_ms: None,
        });
    }
    let mut batch = 5u32;
    while started.elapsed() < WARM_UP_BUSY {
        let batch_started = Instant::now();
        for pass in 0..batch {
            submit(pass, None);
        }
        context.wait_idle()?;
        if batch_started.elapsed() < WARM_UP_BATCH {
            batch = (batch * 2).min(4096);
        }
    }
    let timed = timer.map_or(WARM_UP_TIMED, |timer| WARM_UP_TIMED.min(timer.capacity()));
    let mut previous: Option<f64> = None;
    loop {
        let last_ms = median(time_passes(context, timer, timed, &mut submit)?);
        let steady = previous
            .is_some_and(|previous| (last_ms - previous).abs() <= WARM_UP_TOLERANCE * previous);
        if steady || started.elapsed() >= WARM_UP_LIMIT {
            return Ok(WarmUp {
                seconds: started.elapsed().as_secs_f64(),
                steady,
                last_ms: Some(last_ms),
            });
        }
        previous = Some(last_ms);
    }
}

/// The middle value of `values` (the upper one of an even count; 0 of none).
fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(0.0)
}
