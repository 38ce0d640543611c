//! Timed frames of one view of an in-memory renderer, and the work its rays do: nodes per ray
//! and how much of what the warps pay for is work.

use std::time::Instant;

use voxscope_render::{
    Camera, GpuContext, GpuTimer, RenderSettings, RenderTarget, VolumeRenderer, read_visits,
    time_passes, warm_up,
};

use crate::error::BenchError;

/// One renderer, target, camera and settings: what a timed frame draws.
pub(crate) struct View<'a> {
    pub renderer: &'a VolumeRenderer,
    pub target: &'a RenderTarget,
    pub camera: Camera,
    pub settings: &'a RenderSettings,
}

/// What [`time_frames`] measured of a full turn.
pub(crate) struct FrameTimes {
    /// Milliseconds of each frame: GPU time from timestamps (else wall time, each waited for).
    pub each: Vec<f64>,
    /// Wall milliseconds per frame of the turn's frames submitted back to back, then the
    /// device's completion: what an app issuing frames sees, each frame's encode and submit
    /// on the CPU included (a Python `Renderer`'s `draw()` calls, then `finish()`).
    pub batch_wall: f64,
}

/// Renders `count` frames with the azimuth sweeping a full turn from the view's, after a warm
/// up: once as a batch timed on the wall clock, then each frame timed.
pub(crate) fn time_frames(
    context: &GpuContext,
    view: &View<'_>,
    count: u32,
    timer: Option<&GpuTimer>,
) -> Result<FrameTimes, BenchError> {
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
    })?;
    let started = Instant::now();
    for i in 0..count {
        submit(&at_azimuth(i), None);
    }
    context.wait_idle()?;
    let batch_wall = started.elapsed().as_secs_f64() * 1e3 / count.max(1) as f64;
    let each = time_passes(context, timer, count, |i, writes| {
        submit(&at_azimuth(i), writes)
    })?;
    Ok(FrameTimes { each, batch_wall })
}

/// Work per ray over four azimuths: nodes (octree), samples (dense) or both (bricks).
pub(crate) struct RayWork {
    /// Average over rays that enter the volume.
    pub average: f64,
    pub max: u32,
    /// Rays that enter the volume, per azimuth.
    pub rays: f64,
    pub simd_efficiency: f64,
}

/// The pixels one warp of 32 invocations covers: 4 rows of an 8×8 workgroup.
const WARP_TILE: (usize, usize) = (8, 4);

/// The work of `view`'s rays from four azimuths, a quarter turn apart.
pub(crate) fn sample_visits(context: &GpuContext, view: &View<'_>) -> Result<RayWork, BenchError> {
    let (mut sum, mut rays, mut max, mut paid) = (0u64, 0u64, 0u32, 0u64);
    let (width, height) = (view.target.width as usize, view.target.height as usize);
    for quarter in 0..4 {
        let camera = Camera {
            azimuth_deg: view.camera.azimuth_deg + 90.0 * quarter as f64,
            ..view.camera
        };
        view.renderer
            .render(context, view.target, &camera, view.settings);
        let visits = read_visits(context, view.target)?;
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

#[cfg(test)]
mod tests {
    use super::warp_cost;

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
}
