//! What the GPU's copies of a frame's uploads take, read back without waiting: two timestamps
//! around the copies (empty compute passes that write them, which a device with timestamp
//! queries has without further features), resolved into a buffer that is mapped a frame or two
//! later. The streamer counts the copies' time with the CPU's in the bytes a frame may upload:
//! a frame waits for its uploads' copies before it is drawn.

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

use super::GpuContext;
use super::readback::map_state::{FAILED, IDLE, MAPPED, RECORDED};
use super::readback::{read_mapped, start_map_read};

/// Bytes of the two resolved timestamps.
const TIMESTAMP_BYTES: u64 = 16;

/// Readbacks in flight at most: the copies of a frame every frame, read a few frames late.
const READBACKS: usize = 4;

/// One readback: the bytes its copies moved, and its state.
struct Readback {
    buffer: wgpu::Buffer,
    bytes: u64,
    state: Arc<AtomicU8>,
}

/// Timestamps around upload copies, where the device has timestamp queries.
pub(crate) struct CopyTimer {
    query_set: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    period_ns: f64,
    readbacks: Vec<Readback>,
}

/// A measurement begun in an encoder ([`CopyTimer::begin`]).
pub(crate) struct Timing(usize);

impl CopyTimer {
    /// A timer, or `None` where the device has no timestamp queries.
    pub(crate) fn new(context: &GpuContext) -> Option<Self> {
        if !context.has_timestamps {
            return None;
        }
        let query_set = context.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("voxscope::upload_copy_timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: 2,
        });
        let resolved = context.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::upload_copy_resolved"),
            size: TIMESTAMP_BYTES,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readbacks = (0..READBACKS)
            .map(|_| Readback {
                buffer: context.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("voxscope::upload_copy_readback"),
                    size: TIMESTAMP_BYTES,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                bytes: 0,
                state: Arc::new(AtomicU8::new(IDLE)),
            })
            .collect();
        Some(Self {
            query_set,
            resolved,
            period_ns: context.queue.get_timestamp_period() as f64,
            readbacks,
        })
    }

    /// Writes the first timestamp into `encoder`, before the copies, if a readback is free.
    pub(crate) fn begin(&mut self, encoder: &mut wgpu::CommandEncoder) -> Option<Timing> {
        let free = self
            .readbacks
            .iter()
            .position(|r| r.state.load(Ordering::Acquire) == IDLE)?;
        encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("voxscope::upload_copies_begin"),
            timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                query_set: &self.query_set,
                beginning_of_pass_write_index: Some(0),
                end_of_pass_write_index: None,
            }),
        });
        Some(Timing(free))
    }

    /// Writes the second timestamp after the copies of `bytes` and copies both out; call
    /// [`Self::submitted`] once the encoder is submitted.
    pub(crate) fn end(&mut self, encoder: &mut wgpu::CommandEncoder, timing: Timing, bytes: u64) {
        encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("voxscope::upload_copies_end"),
            timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                query_set: &self.query_set,
                beginning_of_pass_write_index: None,
                end_of_pass_write_index: Some(1),
            }),
        });
        encoder.resolve_query_set(&self.query_set, 0..2, &self.resolved, 0);
        let readback = &mut self.readbacks[timing.0];
        encoder.copy_buffer_to_buffer(&self.resolved, 0, &readback.buffer, 0, TIMESTAMP_BYTES);
        readback.bytes = bytes;
        readback.state.store(RECORDED, Ordering::Release);
    }

    /// Starts mapping what [`Self::end`] recorded.
    pub(crate) fn submitted(&mut self) {
        for readback in &self.readbacks {
            if readback.state.load(Ordering::Acquire) != RECORDED {
                continue;
            }
            start_map_read(&readback.buffer, &readback.state);
        }
    }

    /// The copies measured since the last call, as (bytes, GPU seconds); never waits (the
    /// device is polled by the caller).
    pub(crate) fn take(&mut self) -> Vec<(u64, f64)> {
        let mut measured = Vec::new();
        for readback in &mut self.readbacks {
            match readback.state.load(Ordering::Acquire) {
                MAPPED => {}
                FAILED => {
                    readback.state.store(IDLE, Ordering::Release);
                    continue;
                }
                _ => continue,
            }
            let period_ns = self.period_ns;
            let seconds = read_mapped(&readback.buffer, &readback.state, |bytes| {
                let ticks: &[u64] = bytemuck::cast_slice(bytes);
                ticks[1].saturating_sub(ticks[0]) as f64 * period_ns * 1e-9
            });
            if let Some(seconds) = seconds {
                measured.push((readback.bytes, seconds));
            }
        }
        measured
    }
}
