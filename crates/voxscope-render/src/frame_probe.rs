//! What a drawn frame cost, read back without waiting: GPU time from two timestamps around the
//! ray-casting pass, and the nodes each ray visited. The copy rides along with the frame's own
//! commands; the result is picked up a frame or two later, so an interactive view never stalls.

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

use super::readback::map_state::{FAILED, IDLE, MAPPED, MAPPING, RECORDED};
use super::readback::{read_mapped, start_map_read};
use super::{GpuContext, RenderTarget};

/// The measured cost of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameReport {
    /// GPU time of the ray-casting pass, when the device has timestamp queries.
    pub gpu_ms: Option<f64>,
    /// Nodes (or samples) visited per ray, averaged over the image.
    pub nodes_per_ray_avg: f64,
    pub nodes_per_ray_max: u32,
    pub pixels: u64,
}

/// Timestamps and a staging buffer for one frame's report at a time.
pub struct FrameProbe {
    timestamps: Option<(wgpu::QuerySet, wgpu::Buffer, f64)>,
    staging: Option<wgpu::Buffer>,
    pixels: u64,
    state: Arc<AtomicU8>,
}

/// Bytes of the two resolved timestamps at the start of the staging buffer.
const TIMESTAMP_BYTES: u64 = 16;

impl FrameProbe {
    pub fn new(context: &GpuContext) -> Self {
        let timestamps = context.has_timestamps.then(|| {
            let query_set = context.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("voxscope::frame_probe_timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            });
            let resolved = context.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("voxscope::frame_probe_resolved"),
                size: TIMESTAMP_BYTES,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let period_ns = context.queue.get_timestamp_period() as f64;
            (query_set, resolved, period_ns)
        });
        Self {
            timestamps,
            staging: None,
            pixels: 0,
            state: Arc::new(AtomicU8::new(IDLE)),
        }
    }

    /// True when no report is in flight, so the next frame can be measured.
    pub fn is_idle(&self) -> bool {
        self.state.load(Ordering::Acquire) == IDLE
    }

    /// Timestamp writes for the pass to measure, when idle and timestamps exist.
    pub fn timestamp_writes(&self) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        if !self.is_idle() {
            return None;
        }
        self.timestamps
            .as_ref()
            .map(|(query_set, _, _)| wgpu::ComputePassTimestampWrites {
                query_set,
                beginning_of_pass_write_index: Some(0),
                end_of_pass_write_index: Some(1),
            })
    }

    /// Records the copies of this frame's timestamps and visit counts (after the pass in
    /// `encoder`). Does nothing while an earlier report is in flight.
    pub fn record(
        &mut self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        target: &RenderTarget,
    ) {
        if !self.is_idle() {
            return;
        }
        let visits_bytes = target.visits.size();
        let size = TIMESTAMP_BYTES + visits_bytes;
        if self.staging.as_ref().is_none_or(|b| b.size() != size) {
            self.staging = Some(context.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("voxscope::frame_probe_staging"),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        let staging = self.staging.as_ref().expect("created above");
        if let Some((query_set, resolved, _)) = &self.timestamps {
            encoder.resolve_query_set(query_set, 0..2, resolved, 0);
            encoder.copy_buffer_to_buffer(resolved, 0, staging, 0, TIMESTAMP_BYTES);
        }
        encoder.copy_buffer_to_buffer(&target.visits, 0, staging, TIMESTAMP_BYTES, visits_bytes);
        self.pixels = target.width as u64 * target.height as u64;
        self.state.store(RECORDED, Ordering::Release);
    }

    /// Starts mapping what [`Self::record`] copied; call after the encoder was submitted.
    pub fn submitted(&mut self) {
        if self.state.load(Ordering::Acquire) != RECORDED {
            return;
        }
        let Some(staging) = &self.staging else { return };
        start_map_read(staging, &self.state);
    }

    /// The report of the last measured frame, once the GPU has delivered it; never waits.
    pub fn poll(&mut self, context: &GpuContext) -> Option<FrameReport> {
        match self.state.load(Ordering::Acquire) {
            MAPPING => {
                let _ = context.device.poll(wgpu::PollType::Poll);
                if self.state.load(Ordering::Acquire) != MAPPED {
                    return self.take_failure();
                }
            }
            MAPPED => {}
            FAILED => return self.take_failure(),
            _ => return None,
        }
        let staging = self.staging.as_ref()?;
        read_mapped(staging, &self.state, |bytes| {
            let gpu_ms = self.timestamps.as_ref().map(|(_, _, period_ns)| {
                let ticks: &[u64] = bytemuck::cast_slice(&bytes[..TIMESTAMP_BYTES as usize]);
                ticks[1].saturating_sub(ticks[0]) as f64 * period_ns * 1e-6
            });
            let visits: &[u32] = bytemuck::cast_slice(&bytes[TIMESTAMP_BYTES as usize..]);
            let visits = &visits[..(self.pixels as usize).min(visits.len())];
            let total: u64 = visits.iter().map(|&v| v as u64).sum();
            FrameReport {
                gpu_ms,
                nodes_per_ray_avg: total as f64 / visits.len().max(1) as f64,
                nodes_per_ray_max: visits.iter().copied().max().unwrap_or(0),
                pixels: self.pixels,
            }
        })
    }

    fn take_failure(&mut self) -> Option<FrameReport> {
        if self.state.load(Ordering::Acquire) == FAILED {
            self.state.store(IDLE, Ordering::Release);
        }
        None
    }
}
