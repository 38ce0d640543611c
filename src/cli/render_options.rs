//! What `render` draws a volume with, besides the volume and the output file: the transfer
//! function, clipping, the channels' colors, the renderer and its budgets, the image size and
//! the camera. One group, so that the Python module's keywords are these options, parsed and
//! checked by the same code (`voxscope.render(…, mode="mip")` is `render --mode mip`).

use std::time::Duration;

use clap::Args;

use super::args::RendererArg;
use super::composite::ChannelArgs;
use super::labels::LabelArgs;
use super::stream::StreamArgs;
use super::{ClipArgs, TransferArgs};
use voxscope_render::{Camera, DEFAULT_BRICK_SIZE};
use voxscope_scene::option_text::{max_wait, parse_brick_size, parse_size};
use voxscope_scene::{DEFAULT_MAX_WAIT_SECONDS, DrawOptions};

/// Every option of `render` but the volume and the output.
#[derive(Debug, Clone, Args)]
pub struct RenderOptions {
    #[command(flatten)]
    pub transfer: TransferArgs,
    #[command(flatten)]
    pub clip: ClipArgs,
    #[command(flatten)]
    pub channels: ChannelArgs,
    #[command(flatten)]
    pub labels: LabelArgs,
    /// Which renderer draws the image (default: octree, or bricks, said on stderr, when the
    /// octree does not fit this GPU's storage buffers, as the app does).
    #[arg(long, value_enum)]
    pub renderer: Option<RendererArg>,
    /// Voxels along a brick's side (bricks renderer): 4, 8, 16 or 32.
    #[arg(long, default_value_t = DEFAULT_BRICK_SIZE, value_parser = parse_brick_size)]
    pub brick_size: usize,
    #[command(flatten)]
    pub stream: StreamArgs,
    /// Streaming renderer: draw until nothing visible is missing, at most this long (then the
    /// image is written as it is, and what was still coarse is said).
    #[arg(long, value_name = "SECONDS", default_value_t = DEFAULT_MAX_WAIT_SECONDS)]
    pub max_wait: f64,
    /// Image size WxH.
    #[arg(long, default_value = "1024x768", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Camera rotation around the vertical axis, degrees (0: from the front).
    #[arg(long, default_value_t = 30.0, allow_hyphen_values = true)]
    pub azimuth: f64,
    /// Camera angle above the horizontal, degrees.
    #[arg(long, default_value_t = 20.0, allow_hyphen_values = true)]
    pub elevation: f64,
    /// Camera distance from the volume center in bounding-sphere radii.
    #[arg(long, default_value_t = 3.0)]
    pub distance: f64,
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 45.0)]
    pub fov: f64,
}

impl RenderOptions {
    /// These options as the scene layer draws them.
    pub fn draw_options(&self) -> DrawOptions {
        DrawOptions {
            transfer: self.transfer.options(),
            clip: self.clip.clip(),
            channels: self.channels.request(),
            labels: self.labels.options(),
            renderer: self.renderer.map(Into::into),
            brick_size: self.brick_size,
            stream: self.stream.options(),
            // `check` refuses a negative or non-finite `--max-wait` before anything is drawn.
            max_wait: max_wait(self.max_wait).unwrap_or(Duration::ZERO),
            camera: self.camera(),
            size: self.size,
        }
    }

    /// The camera of --azimuth, --elevation, --distance and --fov.
    pub fn camera(&self) -> Camera {
        Camera {
            azimuth_deg: self.azimuth,
            elevation_deg: self.elevation,
            distance: self.distance,
            fov_y_deg: self.fov,
            pan: [0.0; 3],
        }
    }

    /// What clap cannot check of the values: `--max-wait` is a number of seconds.
    pub fn check(&self) -> Result<(), String> {
        max_wait(self.max_wait)
            .map(|_| ())
            .map_err(|e| e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;
    use voxscope_scene::DrawOptions;

    use super::RenderOptions;

    #[derive(Debug, Parser)]
    struct Render {
        #[command(flatten)]
        options: RenderOptions,
    }

    /// The scene layer's defaults are `render`'s: the Python module starts from them.
    #[test]
    fn no_options_draw_as_the_scene_layer_defaults() {
        let parsed = Render::try_parse_from(["render"]).expect("parses");
        assert_eq!(parsed.options.draw_options(), DrawOptions::default());
    }
}
