//! A multi-channel volume in the app: every channel's own color, visibility and transfer
//! function ([`ChannelState`], edited in the Transfer function panel's channel list), and the
//! composite the central view draws ([`CompositeScene`]: the dense march of
//! [`voxscope_render::CompositeRaycaster`], additive DVR and MIP over up to eight channels).
//!
//! The composite is unshaded and has no probe (src/render/composite.rs says why): the panels
//! say so where those controls are. The other renderers draw one channel; the channel combo
//! of *Channels and time* switches to one.

use std::sync::Arc;

use super::scene::{VolumeData, opening_transfer};
use super::settings::TransferChoice;
use voxscope_octree::{Colormap, TransferFunction};
use voxscope_render::{ChannelLayer, CompositeRaycaster, CompositeVolume, GpuContext, RenderError};
use voxscope_volume::channel_color;

/// What the user set for one channel of the composite.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelState {
    /// The file's name for it, else `channel N`.
    pub name: String,
    /// RGB: the channel is drawn black to this color over its window (napari's additive
    /// colormaps).
    pub color: [u8; 3],
    /// Drawn at all (the eye toggle).
    pub visible: bool,
    /// Its window and opacity (the colors of its colormap are multiplied by `color`).
    pub transfer: TransferFunction,
}

impl ChannelState {
    /// Channel `index` of the file as it opens: the file's name, color and window where it
    /// has them ([`VolumeData::default_window`]), else `channel N`, the default palette and
    /// the robust window; `choice`'s opacity over grays.
    pub fn opening(data: &VolumeData, index: usize, choice: TransferChoice) -> Self {
        let info = data.volume.series.channels.get(index);
        let mut transfer =
            opening_transfer(choice, &data.quantized, data.kind, data.default_window);
        // The tint is the channel's color; a colormap under it would mix two color schemes.
        transfer.colormap = Colormap::Grays;
        Self {
            name: info
                .and_then(|c| c.name.clone())
                .unwrap_or_else(|| format!("channel {index}")),
            color: channel_color(info, index),
            visible: true,
            transfer,
        }
    }
}

/// The channels of one time point on the GPU as the composite, and what its tables follow.
pub struct CompositeScene {
    /// Every channel's data (the panels' histogram, window presets and kind for the channel
    /// being edited); channel 0 is also the scene's [`super::Scene::data`].
    pub channels: Vec<Arc<VolumeData>>,
    pub volume: CompositeVolume,
    pub raycaster: CompositeRaycaster,
    /// The channel states the GPU tables were last written from.
    applied: Vec<ChannelState>,
    /// Bumped whenever the tables change, so panes drawn with the old ones redraw.
    generation: u64,
}

impl CompositeScene {
    /// Uploads `channels` (2 to 8, one grid) drawn as `states` say.
    pub fn new(
        context: &GpuContext,
        channels: Vec<Arc<VolumeData>>,
        states: &[ChannelState],
    ) -> Result<Self, RenderError> {
        if states.len() != channels.len() {
            return Err(RenderError(format!(
                "{} channel settings for {} channels",
                states.len(),
                channels.len()
            )));
        }
        let spacing = channels
            .first()
            .map_or([1.0; 3], |data| data.volume.spacing);
        let volume = CompositeVolume::upload(context, &layers(&channels, states), spacing)?;
        let shown: Vec<bool> = states.iter().map(|s| s.visible).collect();
        volume.set_shown_layers(context, &layers(&channels, states), &shown);
        Ok(Self {
            raycaster: CompositeRaycaster::new(context),
            channels,
            volume,
            applied: states.to_vec(),
            generation: 1,
        })
    }

    /// Writes the tables of `states` where they differ from what the GPU holds (no reload:
    /// edits stay live); returns the tables' generation, which changes with every write.
    pub fn apply(&mut self, context: &GpuContext, states: &[ChannelState]) -> u64 {
        if states.len() == self.channels.len() && states != self.applied.as_slice() {
            let shown: Vec<bool> = states.iter().map(|s| s.visible).collect();
            self.volume
                .set_shown_layers(context, &layers(&self.channels, states), &shown);
            self.applied = states.to_vec();
            self.generation += 1;
        }
        self.generation
    }

    /// The channel states the GPU tables follow now.
    pub fn applied(&self) -> &[ChannelState] {
        &self.applied
    }

    /// Bytes on the CPU: every channel's value levels and octree nodes.
    pub fn cpu_bytes(&self) -> u64 {
        self.channels.iter().map(|data| data.cpu_bytes()).sum()
    }
}

/// The renderer's layers: each channel's levels under its state's transfer function and color.
fn layers<'a>(
    channels: &'a [Arc<VolumeData>],
    states: &'a [ChannelState],
) -> Vec<ChannelLayer<'a>> {
    channels
        .iter()
        .zip(states)
        .map(|(data, state)| ChannelLayer {
            quantized: &data.quantized,
            transfer: &state.transfer,
            color: state.color.map(|c| c as f32 / 255.0),
        })
        .collect()
}
