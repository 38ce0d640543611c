//! The Movie panel's Export: a movie drawn on a job thread by an [`OffscreenDrawer`] (a
//! renderer of its own, never the panes'), each frame complete and read back there, then
//! written by the same writers as `voxscope movie` ([`crate::movie_writer`]). The UI thread
//! only polls the job; Cancel stops it between frames and removes what it wrote.

use std::path::PathBuf;
use std::time::Instant;

use super::OffscreenDevice;
use voxscope_scene::{ChannelState, Job, SceneError, Shot};

use super::offscreen::{OffscreenDrawer, OffscreenSource};
use crate::movie_writer::MovieFormat;

/// Everything a movie export needs, owned by its thread.
pub struct Export {
    pub device: OffscreenDevice,
    pub source: OffscreenSource,
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
            device,
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
        let no_channels = Vec::new();
        let channels_of = |index: usize| channels.get(index).unwrap_or(&no_channels);
        let format = MovieFormat::of(&output).map_err(failed)?;
        progress.begin("uploading");
        let context = device.context().map_err(failed)?;
        let mut drawer =
            OffscreenDrawer::new(context, source, first.transfer, channels_of(0), progress)?;
        let mut writer = format
            .create(&output, (size[0], size[1]), fps, shots.len())
            .map_err(failed)?;
        progress.begin("drawing frames");
        let mut drawn = || -> Result<(), SceneError> {
            for (index, shot) in shots.iter().enumerate() {
                progress.check()?;
                let image = drawer.draw(shot, channels_of(index), size, None)?;
                writer.add(&image).map_err(failed)?;
                progress.set_fraction((index + 1) as f32 / shots.len() as f32);
            }
            Ok(())
        };
        if let Err(error) = drawn() {
            // Cancelled or failed: nothing half-written is left (the frames written so far of
            // a folder, the file of a movie).
            writer.abandon();
            return Err(error);
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
