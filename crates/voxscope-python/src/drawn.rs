//! What a `Renderer` keeps on the GPU: the scene layer's [`Drawable`] on the process's shared
//! device, made as `voxscope render` makes it, and the words a frame drawn to completion has
//! for the user (Python's `max_wait=` where the command line says `--max-wait`).

use std::sync::Arc;
use std::time::Duration;

use voxscope_render::{Camera, GpuContext, RenderSettings, RenderTarget};
use voxscope_scene::{DrawOptions, Drawable};

use crate::errors::Failure;

/// A volume on the shared device.
pub type Drawn = Drawable<Arc<GpuContext>>;

/// How a frame is drawn: its settings, camera, size and patience.
pub struct Frame {
    pub settings: RenderSettings,
    pub camera: Camera,
    pub size: (u32, u32),
    pub max_wait: Duration,
}

impl Frame {
    /// The frame `options` ask of `drawn`.
    pub fn of(drawn: &Drawn, options: &DrawOptions) -> Self {
        Self {
            settings: drawn.render_settings(options),
            camera: options.camera,
            size: options.size,
            max_wait: options.max_wait,
        }
    }
}

/// A one-line remark for the user (the octree did not fit and bricks draw instead).
pub type Notice = Option<String>;

/// What a frame drawn to completion has to say ([`draw_complete`]): what went wrong or
/// stayed coarse (each frame it happens), and, apart, where the GPU budget limited the view:
/// the line to say, and the limit alone (the same frame after frame while the view is), so
/// that a Renderer says it once until it changes.
#[derive(Debug, Default)]
pub struct CompleteNotice {
    pub lines: Vec<String>,
    pub budget: Option<(String, String)>,
}

/// Draws `frame` into `target` until it is complete: once, or for the streaming renderer
/// frame after frame until nothing visible is missing or `frame.max_wait` passed (then what
/// was still coarse is said, as `render` says it).
pub fn draw_complete(
    drawn: &mut Drawn,
    target: &RenderTarget,
    frame: &Frame,
) -> Result<CompleteNotice, Failure> {
    let Some(refinement) =
        drawn.draw_complete(target, &frame.camera, &frame.settings, frame.max_wait)?
    else {
        return Ok(CompleteNotice::default());
    };
    let mut lines = refinement.errors.clone();
    if !refinement.complete {
        lines.push(format!(
            "still coarse after {:.1} s (max_wait): {}",
            refinement.seconds,
            voxscope_scene::describe_missing(&refinement.status)
        ));
    }
    // Complete, but coarser than full detail where the budget left bricks out.
    let budget = refinement
        .completed_at_budget()
        .zip(voxscope_scene::describe_budget_limit(&refinement.status));
    Ok(CompleteNotice { lines, budget })
}

/// The notices of a new `drawn`, as one line (none: `None`).
pub fn notice_of(drawn: &Drawn) -> Notice {
    (!drawn.notices.is_empty()).then(|| drawn.notices.join("; "))
}
