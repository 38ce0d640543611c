//! The streaming benchmark's orbits: a full turn of the camera while detail streams in, from a
//! cold start (a new renderer), each frame updated, drawn and waited for as an app that
//! presents it does; GPU and wall time per frame, the update's parts, what was uploaded.

use std::time::{Duration, Instant};

use serde_json::json;
use voxscope_render::{
    Camera, GpuContext, GpuTimer, RenderSettings, RenderTarget, VolumeRenderer, time_passes,
};
use voxscope_scene::StreamedVolume;
use voxscope_stream::{StreamOptions, UpdatePhases};

use crate::error::BenchError;
use crate::memory::Phases;
use crate::stats::summary;

/// What every orbit shares: the device, the pyramid, the renderer's options, the image and
/// settings, the frames and their pace.
pub(crate) struct Orbits<'a> {
    pub context: &'a GpuContext,
    pub target: &'a RenderTarget,
    pub timer: Option<&'a GpuTimer>,
    pub prepared: &'a StreamedVolume,
    pub stream: StreamOptions,
    pub settings: RenderSettings,
    /// The camera each turn starts from, at the turn's own distance.
    pub camera: Camera,
    /// Frames of a full turn.
    pub frames: u32,
    /// Frames drawn at most this many a second (0: unpaced).
    pub fps: f64,
}

/// What each frame of a turn measured.
#[derive(Default)]
struct Turn {
    /// GPU milliseconds of each frame's pass.
    gpu: Vec<f64>,
    /// Wall milliseconds of each frame: update, encode, submit and the wait for the GPU.
    wall: Vec<f64>,
    update_ms: Vec<f64>,
    wait_ms: Vec<f64>,
    /// Bricks missing from each frame.
    missing: Vec<f64>,
    uploaded: u64,
    /// Milliseconds the update waited for a core, where the system says.
    preempted_ms: Vec<f64>,
    phases: Vec<UpdatePhases>,
    seconds: f64,
}

impl Orbits<'_> {
    /// One orbit at `distance` bounding-sphere radii (`camera_name` in the report), its
    /// memory recorded as the phase `orbit_{camera_name}`.
    pub fn orbit(
        &self,
        camera_name: &str,
        distance: f64,
        memory: &mut Phases,
    ) -> Result<serde_json::Value, BenchError> {
        let mut renderer = VolumeRenderer::new_stream(
            self.context,
            self.prepared.source.clone(),
            self.stream,
            &self.prepared.transfer,
        )
        .map_err(|e| BenchError::renderer(self.prepared.source.name(), e))?;
        let turn = self.turn(&mut renderer, distance)?;
        let status = renderer.update(self.context).expect("a streaming renderer");
        memory.phase(&format!("orbit_{camera_name}"), Some(&status.counters));
        // The renderer goes before the next orbit's is made, once its last update's uploads are
        // done: a GPU resource dropped while in use is freed at the device's next poll, which
        // would be the next renderer's first update (the near orbit's first frame took 10-17
        // ms of update after an orbit that ended uploading in run 131, 1.1 ms otherwise).
        let teardown = Instant::now();
        self.context.wait_idle()?;
        drop(renderer);
        let teardown_ms = teardown.elapsed().as_secs_f64() * 1e3;
        let Turn {
            gpu,
            wall,
            update_ms,
            wait_ms,
            missing,
            uploaded,
            preempted_ms,
            phases,
            seconds,
        } = turn;
        // The waits beyond the frames' own passes (the uploads' copies, mostly), per byte.
        let beyond_pass_s = (wait_ms.iter().sum::<f64>() - gpu.iter().sum::<f64>()) / 1e3;
        let wait_beyond_pass = (beyond_pass_s > 0.0).then(|| uploaded as f64 / beyond_pass_s);
        Ok(json!({
            "camera": camera_name,
            "frames": self.frames,
            "turn_degrees": 360,
            "turn_seconds": seconds,
            "paced_fps": (self.fps > 0.0).then_some(self.fps),
            "gpu_ms": summary(&gpu),
            "wall_ms": summary(&wall),
            "update_ms": summary(&update_ms),
            "wait_ms": summary(&wait_ms),
            "update_preempted_ms": (!preempted_ms.is_empty()).then(|| summary(&preempted_ms)),
            "update_phases_ms": phases_json(&phases),
            "wait_beyond_pass_bytes_per_s": wait_beyond_pass,
            // The first frame of a renderer just made: its update (the always-resident
            // levels' uploads), the GPU's time for its pass, and its wait beyond.
            "first_frame_ms": {
                "wall": wall.first(),
                "update": update_ms.first(),
                "gpu": gpu.first(),
                "wait": wait_ms.first(),
            },
            "frames_over_16ms_wall": wall.iter().filter(|&&w| w > 16.0).count(),
            "slowest_frame": wall
                .iter()
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(b.1))
                .map(|(index, _)| index),
            "missing_bricks": summary(&missing),
            "uploaded_bytes": uploaded,
            "counters": status.counters,
            "teardown_ms": teardown_ms,
        }))
    }

    /// A full turn of `renderer`'s frames at `distance`, each updated, drawn and waited for.
    fn turn(&self, renderer: &mut VolumeRenderer, distance: f64) -> Result<Turn, BenchError> {
        let (context, start) = (self.context, self.camera);
        let mut turn = Turn::default();
        let turn_started = Instant::now();
        turn.gpu = time_passes(context, self.timer, self.frames, |i, writes| {
            let started = Instant::now();
            let runnable = runnable_seconds();
            let status = renderer.update(context).expect("a streaming renderer");
            turn.update_ms.push(started.elapsed().as_secs_f64() * 1e3);
            turn.phases.push(status.phases);
            if let (Some(before), Some(after)) = (runnable, runnable_seconds()) {
                turn.preempted_ms.push((after - before) * 1e3);
            }
            turn.uploaded += status.upload_bytes;
            turn.missing.push(status.missing as f64);
            let camera = Camera {
                distance,
                azimuth_deg: start.azimuth_deg + 360.0 * i as f64 / self.frames as f64,
                ..start
            };
            let mut encoder =
                context
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("voxscope::bench_stream_frame"),
                    });
            renderer.encode(
                context,
                &mut encoder,
                self.target,
                &camera,
                &self.settings,
                writes,
            );
            context.queue.submit([encoder.finish()]);
            // As an app that waits for its frame (a presented swap chain): the wall time
            // includes the GPU's completion (of the frame and of its uploads' copies).
            let waiting = Instant::now();
            let _ = context.wait_idle();
            turn.wait_ms.push(waiting.elapsed().as_secs_f64() * 1e3);
            turn.wall.push(started.elapsed().as_secs_f64() * 1e3);
            // Paced as a display would: the loaders go on meanwhile.
            if self.fps > 0.0 {
                let period = Duration::from_secs_f64(1.0 / self.fps);
                std::thread::sleep(period.saturating_sub(started.elapsed()));
            }
        })?;
        turn.seconds = turn_started.elapsed().as_secs_f64();
        Ok(turn)
    }
}

/// Each update phase's milliseconds over the frames (median, p99, max).
fn phases_json(phases: &[UpdatePhases]) -> serde_json::Value {
    let of = |part: fn(&UpdatePhases) -> f64| {
        summary(&phases.iter().map(|p| part(p) * 1e3).collect::<Vec<_>>())
    };
    json!({
        "readback": of(|p| p.readback),
        "results": of(|p| p.results),
        "feedback": of(|p| p.feedback),
        "choose_uploads": of(|p| p.choose_uploads),
        "write": of(|p| p.write),
    })
}

/// Seconds this thread has spent ready to run but not running (waiting for a core), where the
/// system says (Linux's scheduler statistics).
fn runnable_seconds() -> Option<f64> {
    let stats = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let waited: u64 = stats.split_whitespace().nth(1)?.parse().ok()?;
    Some(waited as f64 / 1e9)
}
