//! The Movie panel's Export: a movie drawn on a job thread by a renderer of its own (uploaded
//! from the data on screen, on the app's device, never the panes' renderer or targets), each
//! frame drawn, waited for and read back there, then written by the same writers as
//! `voxscope movie` ([`crate::movie_writer`]). The UI thread only polls the job; Cancel stops
//! it between frames.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use voxscope_render::{GpuContext, RenderTarget, RendererKind, RendererOptions, read_image};
use voxscope_scene::{ChannelState, CompositeScene, Job, SceneError, Shot, VolumeData, refine};

use crate::movie_writer::MovieFormat;

/// How long a streamed store's frame may take to complete before it is written as it is.
const STREAMED_FRAME_WAIT: Duration = Duration::from_secs(60);

/// What an export draws from: the data on screen.
pub enum ExportSource {
    /// One volume, drawn by a renderer of these options (the streaming renderer refines each
    /// frame until nothing visible is missing).
    Volume {
        data: Arc<VolumeData>,
        options: RendererOptions,
    },
    /// The composite of these channels.
    Composite { channels: Vec<Arc<VolumeData>> },
}

/// Everything a movie export needs, owned by its thread.
pub struct Export {
    pub context: Arc<GpuContext>,
    pub source: ExportSource,
    /// What each frame draws.
    pub shots: Vec<Shot>,
    /// The composite's channels for each frame (empty for one volume).
    pub channels: Vec<Vec<ChannelState>>,
    pub size: [u32; 2],
    pub fps: f64,
    pub output: PathBuf,
}

/// A movie written.
#[derive(Debug, Clone, PartialEq)]
pub struct Exported {
    pub output: PathBuf,
    pub frames: usize,
    pub seconds: f64,
}

/// Starts drawing and writing `export` on a job thread; `wake` is called when it ends.
pub fn spawn(export: Export, wake: impl Fn() + Send + 'static) -> Job<Exported> {
    let title = format!("movie {}", export.output.display());
    Job::spawn(title, wake, move |progress| {
        let started = Instant::now();
        let failed = |e: String| SceneError::failed(e);
        let Export {
            context,
            source,
            shots,
            channels,
            size,
            fps,
            output,
        } = export;
        let first = shots
            .first()
            .ok_or_else(|| SceneError::failed("the movie has no frames"))?;
        let format = MovieFormat::of(&output).map_err(failed)?;
        progress.begin("uploading");
        // The movie's own renderer: the panes' stay as they are.
        let mut composite = None;
        let mut volume = None;
        match source {
            ExportSource::Volume { data, options } => {
                volume = Some(voxscope_scene::upload(
                    data,
                    &context,
                    options,
                    first.transfer,
                    progress,
                )?);
            }
            ExportSource::Composite { channels: data } => {
                let states = channels
                    .first()
                    .ok_or_else(|| SceneError::failed("the composite's movie has no channels"))?;
                composite = Some(
                    CompositeScene::new(&context, data, states)
                        .map_err(|e| SceneError::failed(format!("the movie's composite: {e}")))?,
                );
            }
        }
        let mut writer = format
            .create(&output, (size[0], size[1]), fps, shots.len())
            .map_err(failed)?;
        let target = RenderTarget::new(&context, size[0], size[1]);
        let mut transfer = first.transfer;
        progress.begin("drawing frames");
        for (index, shot) in shots.iter().enumerate() {
            progress.check()?;
            if let Some(scene) = &mut volume {
                if shot.transfer != transfer {
                    let mut encoder =
                        context
                            .device
                            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                                label: Some("voxscope::movie_export_transfer"),
                            });
                    scene
                        .renderer
                        .set_transfer(&context, &mut encoder, &shot.transfer, None)
                        .map_err(|e| SceneError::render(&scene.data.volume.name, e))?;
                    context.queue.submit([encoder.finish()]);
                    transfer = shot.transfer;
                }
                if scene.options.kind == RendererKind::Stream {
                    refine(
                        &context,
                        &mut scene.renderer,
                        &target,
                        &shot.camera,
                        &shot.settings,
                        STREAMED_FRAME_WAIT,
                    )?;
                } else {
                    scene
                        .renderer
                        .render(&context, &target, &shot.camera, &shot.settings);
                }
            }
            if let Some(composite) = &mut composite {
                if let Some(states) = channels.get(index) {
                    composite.apply(&context, states);
                }
                composite
                    .renderer
                    .render(&context, &target, &shot.camera, &shot.settings);
            }
            let image = read_image(&context, &target)
                .map_err(|e| SceneError::failed(format!("the movie's frame {index}: {e}")))?;
            writer.add(&image).map_err(failed)?;
            progress.set_fraction((index + 1) as f32 / shots.len() as f32);
        }
        progress.begin("finishing");
        writer.finish().map_err(failed)?;
        Ok(Exported {
            output,
            frames: shots.len(),
            seconds: started.elapsed().as_secs_f64(),
        })
    })
}
