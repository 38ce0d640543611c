//! The GPU probe: for one pixel of a view, the 3D point its ray reaches that the pointer is
//! "on": in DVR where the accumulated opacity first reaches [`PROBE_ALPHA`], in MIP the sample
//! (or octree node) of the ray's maximum. Traced on the GPU by the ray casters' probe variant
//! (one invocation, the same walk as the frame's), so it sees exactly what the frame draws,
//! clipping and skipping included.
//!
//! [`GpuProbe`] never stalls a frame: [`GpuProbe::record`] adds the probe's dispatch and a copy
//! to the frame's encoder, [`GpuProbe::submitted`] starts mapping the copy once the encoder is
//! submitted, and [`GpuProbe::poll`] takes the answer a frame or two later (as
//! [`super::FrameProbe`] does for timestamps). [`probe_pixel`] is the blocking form for the
//! command line and tests.

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

use super::gpu_data::ProbeResult;
use super::raycaster::ProbeTarget;
use super::readback::map_state::{FAILED, IDLE, MAPPED, MAPPING, RECORDED};
use super::readback::{read_mapped, start_map_read};
use super::{Camera, GpuContext, RenderError, RenderSettings, VolumeRenderer};

/// The accumulated opacity a DVR probe looks for. Keep in sync with `PROBE_ALPHA` in
/// `ray_common.wgsl`.
pub const PROBE_ALPHA: f32 = 0.5;

/// What the probe of one pixel found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbeHit {
    /// The point in voxel space (voxel (i, j, k) is the cube [i, i + 1) × [j, j + 1) ×
    /// [k, k + 1); the volume's displayed, RAS-reordered axes): in DVR where the ray's
    /// opacity reached [`PROBE_ALPHA`] (a sample, or for the octree the place inside the node
    /// where its path-length-corrected opacity gets there); in MIP the sample of the maximum
    /// (for the octree, the middle of the ray's path through the node of the maximum).
    pub point: [f32; 3],
}

impl ProbeHit {
    /// The voxel the point lies in, clamped into a volume of `dims` voxels.
    pub fn voxel(&self, dims: [usize; 3]) -> [usize; 3] {
        std::array::from_fn(|axis| {
            let index = self.point[axis].floor().max(0.0) as usize;
            index.min(dims[axis].saturating_sub(1))
        })
    }
}

/// A pixel to probe in the view that `camera` and `settings` draw into an image of `size`
/// pixels (`pixel` counted from the top-left corner, as the image's rows are).
#[derive(Debug, Clone, Copy)]
pub struct ProbeRequest<'a> {
    pub size: [u32; 2],
    pub pixel: [u32; 2],
    pub camera: &'a Camera,
    pub settings: &'a RenderSettings,
}

impl ProbeRequest<'_> {
    fn check(&self) -> Result<(), RenderError> {
        let [x, y] = self.pixel;
        let [width, height] = self.size;
        if x >= width || y >= height {
            return Err(RenderError::Invalid(format!(
                "the probed pixel ({x}, {y}) is outside the {width}x{height} image"
            )));
        }
        Ok(())
    }
}

/// The answer to a [`ProbeRequest`] taken by [`GpuProbe::poll`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbeOutcome {
    /// The pixel that was probed.
    pub pixel: [u32; 2],
    /// What its ray reached, or `None` where it never got there (it missed the volume, stayed
    /// below [`PROBE_ALPHA`], or in MIP saw nothing above the lowest value).
    pub hit: Option<ProbeHit>,
}

const RESULT_BYTES: u64 = std::mem::size_of::<ProbeResult>() as u64;

/// The buffers of one probe in flight at a time: the result the shader writes and its staging
/// copy for the CPU.
pub struct GpuProbe {
    output: wgpu::Buffer,
    staging: wgpu::Buffer,
    pixel: [u32; 2],
    state: Arc<AtomicU8>,
}

impl GpuProbe {
    pub fn new(context: &GpuContext) -> Self {
        let output = context.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::probe_result"),
            size: RESULT_BYTES,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let staging = context.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::probe_staging"),
            size: RESULT_BYTES,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            output,
            staging,
            pixel: [0, 0],
            state: Arc::new(AtomicU8::new(IDLE)),
        }
    }

    /// True when no probe is in flight, so [`Self::record`] will take a new one.
    pub fn is_idle(&self) -> bool {
        self.state.load(Ordering::Acquire) == IDLE
    }

    /// Records the probe of `request` into `encoder` (before or after the frame's pass: it
    /// draws nothing) and the copy of its answer. Returns false, recording nothing, while an
    /// earlier probe is in flight; an error for a pixel outside the image or a renderer
    /// without a probe (the composite).
    pub fn record(
        &mut self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        renderer: &VolumeRenderer,
        request: &ProbeRequest<'_>,
    ) -> Result<bool, RenderError> {
        request.check()?;
        if !self.is_idle() {
            return Ok(false);
        }
        // A ray that never writes (none does: every probed ray writes) would leave the last
        // answer; cleared, it reads as "not found".
        encoder.clear_buffer(&self.output, 0, None);
        let probed = renderer.encode_probe(
            context,
            encoder,
            &ProbeTarget {
                size: request.size,
                pixel: request.pixel,
                camera: request.camera,
                settings: request.settings,
                output: &self.output,
            },
        );
        if !probed {
            return Err(RenderError::Invalid(format!(
                "the {} renderer has no probe",
                renderer.kind().name()
            )));
        }
        encoder.copy_buffer_to_buffer(&self.output, 0, &self.staging, 0, RESULT_BYTES);
        self.pixel = request.pixel;
        self.state.store(RECORDED, Ordering::Release);
        Ok(true)
    }

    /// Starts mapping what [`Self::record`] copied; call after the encoder was submitted.
    pub fn submitted(&mut self) {
        if self.state.load(Ordering::Acquire) != RECORDED {
            return;
        }
        start_map_read(&self.staging, &self.state);
    }

    /// The answer of the last recorded probe once the GPU has delivered it; never waits.
    /// (A failed mapping is dropped, and the probe becomes idle again.)
    pub fn poll(&mut self, context: &GpuContext) -> Option<ProbeOutcome> {
        match self.state.load(Ordering::Acquire) {
            MAPPING => {
                let _ = context.device.poll(wgpu::PollType::Poll);
                match self.state.load(Ordering::Acquire) {
                    MAPPED => {}
                    FAILED => return self.take_failure(),
                    _ => return None,
                }
            }
            MAPPED => {}
            FAILED => return self.take_failure(),
            _ => return None,
        }
        let result = read_mapped(&self.staging, &self.state, |bytes| {
            *bytemuck::from_bytes::<ProbeResult>(bytes)
        })?;
        Some(ProbeOutcome {
            pixel: self.pixel,
            hit: (result.found != 0).then_some(ProbeHit {
                point: result.point,
            }),
        })
    }

    fn take_failure(&mut self) -> Option<ProbeOutcome> {
        self.state.store(IDLE, Ordering::Release);
        None
    }
}

/// Probes one pixel and waits for the answer: for the command line and tests (an interactive
/// view uses [`GpuProbe`], which never waits).
pub fn probe_pixel(
    context: &GpuContext,
    renderer: &VolumeRenderer,
    request: &ProbeRequest<'_>,
) -> Result<Option<ProbeHit>, RenderError> {
    let mut probe = GpuProbe::new(context);
    let mut encoder = context
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("voxscope::probe"),
        });
    probe.record(context, &mut encoder, renderer, request)?;
    context.queue.submit([encoder.finish()]);
    probe.submitted();
    context.wait_idle()?;
    probe
        .poll(context)
        .map(|outcome| outcome.hit)
        .ok_or_else(|| {
            RenderError::DeviceLost("the GPU probe's answer could not be read back".into())
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hit_names_the_voxel_it_lies_in_clamped_to_the_volume() {
        let hit = ProbeHit {
            point: [3.999, 0.0, 7.5],
        };
        assert_eq!(hit.voxel([10, 10, 10]), [3, 0, 7]);
        assert_eq!(hit.voxel([3, 10, 5]), [2, 0, 4]);
        let outside = ProbeHit {
            point: [-0.5, 12.0, 1.0],
        };
        assert_eq!(outside.voxel([10, 10, 10]), [0, 9, 1]);
    }
}
