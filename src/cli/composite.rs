//! Several channels drawn together (`--channel all`, the default for a multi-channel file, or
//! `--channels-from`): each channel's color and window (`--channel-colors`,
//! `--channel-window`), as `render`, `info` and `bench` read them. `render --channel N` draws
//! channel N alone the same way: in its color (where the options or the file give one) and
//! its window.

use clap::Args;
use voxscope_scene::option_text::{parse_channel_window, parse_color};

use super::TransferArgs;
use voxscope_octree::DataKind;
use voxscope_render::ChannelLayer;
use voxscope_scene::{ChannelRequest, ChannelState};
use voxscope_volume::{QuantizedVolume, ValueWindow, Volume};

/// Colors and windows of the channels of a composite.
#[derive(Debug, Clone, Args)]
pub struct ChannelArgs {
    /// Colors of channels 0, 1, …: green, magenta, cyan, yellow, red, blue, orange, gray or
    /// #rrggbb (default: the file's channel colors, else green, magenta, cyan, yellow, red,
    /// blue, orange, gray).
    #[arg(long, value_name = "C0,C1,…", value_delimiter = ',', value_parser = parse_color)]
    pub channel_colors: Option<Vec<[u8; 3]>>,
    /// The window of channel N in its data units (repeatable; default: the file's window for
    /// the channel, else its 0.5–99.5 percentiles).
    #[arg(long, value_name = "N:LOW:HIGH", allow_hyphen_values = true, value_parser = parse_channel_window)]
    pub channel_window: Vec<(usize, ValueWindow)>,
    /// The channels drawn, in order (at most 8; default: the file's `omero` active channels,
    /// else its first 8). `--renderer stream` streams them together.
    #[arg(long, value_name = "N,N,…", value_delimiter = ',')]
    pub channels: Option<Vec<usize>>,
}

/// One channel ready to draw: its values and how it is drawn (color, window, opacity).
pub struct PreparedChannel {
    pub volume: Volume,
    pub quantized: QuantizedVolume,
    pub state: ChannelState,
}

impl PreparedChannel {
    /// The layer the renderer takes.
    pub fn layer(&self) -> ChannelLayer<'_> {
        ChannelLayer {
            quantized: &self.quantized,
            transfer: &self.state.transfer,
            color: self.state.color.map(|c| c as f32 / 255.0),
        }
    }
}

impl ChannelArgs {
    /// What these options ask of the channels' colors and windows.
    pub fn request(&self) -> ChannelRequest {
        ChannelRequest {
            colors: self.channel_colors.clone().unwrap_or_default(),
            windows: self.channel_window.clone(),
            hidden: Vec::new(),
            chosen: self.channels.clone().unwrap_or_default(),
        }
    }

    /// Quantizes `channels` and gives each its color and transfer function as the scene
    /// layer opens channels ([`ChannelState::opening_of`]): `transfer`'s request over the
    /// channel's window, in grays, to be tinted. A channel number in --channel-window or
    /// --channel-colors beyond the channels is an error.
    pub fn prepare(
        &self,
        channels: Vec<Volume>,
        transfer: &TransferArgs,
    ) -> Result<Vec<PreparedChannel>, String> {
        let request = self.request();
        // By the file's channel numbers where they are channels of one file (as the scene
        // layer numbers them), else by place (files given as channels).
        let numbers = voxscope_scene::file_channel_numbers(&channels);
        let count = match &numbers {
            Some(_) => channels[0].series.channel_count(),
            None => channels.len(),
        };
        let numbers = numbers.unwrap_or_else(|| (0..channels.len()).collect());
        request.check(count).map_err(|e| e.to_string())?;
        let transfer = transfer.options();
        let saved = transfer.saved().map_err(|e| e.to_string())?;
        let transfer_request = transfer.request(saved.as_ref());
        Ok(channels
            .into_iter()
            .zip(numbers)
            .map(|(volume, index)| {
                let quantized = QuantizedVolume::new(&volume);
                let kind = DataKind::of_volume(&volume, &quantized);
                let state = ChannelState::opening_of(
                    &volume,
                    &quantized,
                    kind,
                    index,
                    &transfer_request,
                    &request,
                );
                PreparedChannel {
                    volume,
                    quantized,
                    state,
                }
            })
            .collect())
    }
}
