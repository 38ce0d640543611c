//! A multi-channel volume: every channel's own color, visibility and transfer function
//! ([`ChannelState`], which the app's channel list edits and the command line's
//! `--channel-colors` and `--channel-window` set), and the composite drawn of them
//! ([`CompositeScene`]: the dense march of [`voxscope_render::CompositeRaycaster`], additive
//! DVR and MIP over up to eight channels).
//!
//! Shaded, each channel is lit by its own gradient (voxscope-render's composite.rs); its probe
//! finds the point the pointer is on, and [`CompositeScene::describe_voxel`] reads each shown channel
//! there. The other renderers draw one channel.

use std::sync::Arc;

use voxscope_octree::{Colormap, DataKind, TransferFunction};
use voxscope_render::{ChannelLayer, GpuContext, RenderError, VolumeRenderer};
use voxscope_volume::{QuantizedVolume, ValueWindow, Volume, channel_color};

use crate::{
    SceneError, TransferRequest, VolumeData, default_window, file_window, opening_transfer,
};

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

/// What was asked of the channels' colors and windows (the command line's `--channel-colors`
/// and `--channel-window`); where nothing is, each channel takes the file's.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ChannelRequest {
    /// Colors of channels 0, 1, … (fewer than the channels: the rest take their defaults).
    pub colors: Vec<[u8; 3]>,
    /// Windows by channel number (the last given for a channel wins).
    pub windows: Vec<(usize, ValueWindow)>,
    /// Channels not drawn (the app's eye toggle; a saved view's).
    #[serde(default)]
    pub hidden: Vec<usize>,
    /// The file's channels drawn, in order (`--channels 0,3,5`; at most
    /// [`voxscope_volume::MAX_CHANNELS`]); empty: the file's choice (its `omero` list's
    /// active channels, else its first ones).
    #[serde(default)]
    pub chosen: Vec<usize>,
}

impl ChannelRequest {
    /// The window asked for channel `index`, if any (the last given wins).
    pub fn window_of(&self, index: usize) -> Option<ValueWindow> {
        self.windows
            .iter()
            .rev()
            .find(|(channel, _)| *channel == index)
            .map(|(_, window)| *window)
    }

    /// Checks the request against a file of `count` channels: no window or color for a
    /// channel that is not there.
    pub fn check(&self, count: usize) -> Result<(), SceneError> {
        if let Some(&(channel, _)) = self.windows.iter().find(|(c, _)| *c >= count) {
            return Err(SceneError::NoSuchChannel { channel, count });
        }
        if self.colors.len() > count {
            return Err(SceneError::TooManyColors {
                colors: self.colors.len(),
                count,
            });
        }
        if let Some(&channel) = self.chosen.iter().find(|&&c| c >= count) {
            return Err(SceneError::NoChosenChannel { channel, count });
        }
        Ok(())
    }

    /// What `states` show: every channel's color, window and visibility.
    pub fn of_states(states: &[ChannelState]) -> Self {
        Self {
            colors: states.iter().map(|s| s.color).collect(),
            windows: states
                .iter()
                .enumerate()
                .map(|(index, s)| (index, s.transfer.window))
                .collect(),
            hidden: (0..states.len()).filter(|&i| !states[i].visible).collect(),
            chosen: Vec::new(),
        }
    }

    /// What `states` show of the file's channels `indices` (a streamed composite's, in order):
    /// each one's color, window and visibility by its file number, and which are drawn. (A
    /// color for a file channel not drawn is the palette's: `colors` is by file number.)
    pub fn of_chosen(states: &[ChannelState], indices: &[usize]) -> Self {
        let count = indices.iter().max().map_or(0, |&i| i + 1);
        let colors = (0..count)
            .map(|file| {
                indices
                    .iter()
                    .position(|&i| i == file)
                    .map_or_else(|| channel_color(None, file), |p| states[p].color)
            })
            .collect();
        let pairs = || states.iter().zip(indices.iter().copied());
        Self {
            colors,
            windows: pairs().map(|(s, i)| (i, s.transfer.window)).collect(),
            hidden: pairs()
                .filter(|(s, _)| !s.visible)
                .map(|(_, i)| i)
                .collect(),
            chosen: indices.to_vec(),
        }
    }

    /// Whether this request is of channels numbered `numbers` in their file (a streamed
    /// composite's, `chosen`), or of `count` channels in order.
    pub fn fits(&self, numbers: &[usize]) -> bool {
        if self.chosen.is_empty() {
            self.colors.len() == numbers.len()
        } else {
            self.chosen == numbers
        }
    }

    /// [`Self::apply_to`] where `states[i]` is the file's channel `numbers[i]` (what is asked
    /// goes by channel number in the file).
    pub fn apply_to_numbered(&self, states: &mut [ChannelState], numbers: &[usize]) {
        for (state, &number) in states.iter_mut().zip(numbers) {
            if let Some(color) = self.colors.get(number) {
                state.color = *color;
            }
            if let Some(window) = self.window(number) {
                state.transfer.window = window;
            }
            state.visible = !self.hidden.contains(&number);
        }
    }

    /// Sets what is asked of each channel into `states`: its color, window and visibility
    /// (what is not asked stays).
    pub fn apply_to(&self, states: &mut [ChannelState]) {
        for (index, state) in states.iter_mut().enumerate() {
            if let Some(color) = self.colors.get(index) {
                state.color = *color;
            }
            if let Some(window) = self.window(index) {
                state.transfer.window = window;
            }
            state.visible = !self.hidden.contains(&index);
        }
    }

    fn window(&self, index: usize) -> Option<ValueWindow> {
        self.windows
            .iter()
            .rev()
            .find(|(c, _)| *c == index)
            .map(|(_, w)| *w)
    }
}

impl ChannelState {
    /// Channel `index` of the file as it opens ([`Self::opening_of`] with nothing asked of
    /// its color and window).
    pub fn opening(data: &VolumeData, index: usize, request: &TransferRequest) -> Self {
        Self::opening_of(
            &data.volume,
            &data.quantized,
            data.kind,
            index,
            request,
            &ChannelRequest::default(),
        )
    }

    /// Channel `index` of `volume` (its values `quantized`, of `kind`) as it opens: the
    /// file's name, else `channel N`; the color `channels` asks for, else the file's, else
    /// the default palette's; the transfer function [`opening_transfer`] gives for
    /// `request` over the channel's default window, with the window `channels` asks for, in
    /// grays (the channel's color tints it; a colormap under it would mix two schemes).
    pub fn opening_of(
        volume: &Volume,
        quantized: &QuantizedVolume,
        kind: DataKind,
        index: usize,
        request: &TransferRequest,
        channels: &ChannelRequest,
    ) -> Self {
        // The file's facts of the channel this volume holds (for `--channels-from`, each
        // file's own first channel).
        let info = volume.series.channels.get(volume.series.selected.channel);
        Self::opening_with(
            info,
            file_window(volume),
            quantized,
            kind,
            index,
            request,
            channels,
        )
    }

    /// Channel `index` as it opens (see [`Self::opening_of`]) from what its file says of it
    /// (`info`, `file_window`) and its values `quantized` (all of them, or a streamed
    /// pyramid's coarse level).
    pub fn opening_with(
        info: Option<&voxscope_volume::ChannelInfo>,
        file_window: Option<ValueWindow>,
        quantized: &QuantizedVolume,
        kind: DataKind,
        index: usize,
        request: &TransferRequest,
        channels: &ChannelRequest,
    ) -> Self {
        let window = default_window(file_window, quantized);
        let request = TransferRequest {
            window: channels.window(index).or(request.window),
            ..*request
        };
        let mut transfer = opening_transfer(quantized, kind, window, &request);
        transfer.colormap = Colormap::Grays;
        Self {
            name: info
                .and_then(|c| c.name.clone())
                .unwrap_or_else(|| format!("channel {index}")),
            color: channels
                .colors
                .get(index)
                .copied()
                .unwrap_or_else(|| channel_color(info, index)),
            visible: !channels.hidden.contains(&index) && !info.is_some_and(|c| c.inactive),
            transfer,
        }
    }
}

/// The file's channel numbers of `volumes`, in order, where they are channels of one file of
/// several (one file name, each its own channel of it, none twice); `None` for files given as
/// channels (`--channels-from`), which are numbered by their places.
pub fn file_channel_numbers<'a>(
    volumes: impl IntoIterator<Item = &'a voxscope_volume::Volume>,
) -> Option<Vec<usize>> {
    let volumes: Vec<&voxscope_volume::Volume> = volumes.into_iter().collect();
    let first = volumes.first()?;
    if first.series.channel_count() < 2 || volumes.iter().any(|v| v.name != first.name) {
        return None;
    }
    let numbers: Vec<usize> = volumes.iter().map(|v| v.series.selected.channel).collect();
    let distinct = numbers
        .iter()
        .enumerate()
        .all(|(i, n)| !numbers[..i].contains(n));
    distinct.then_some(numbers)
}

/// The channels of one time point on the GPU as the composite, and what its tables follow.
pub struct CompositeScene {
    /// Every channel's data (the panels' histogram, window presets and kind for the channel
    /// being edited; a streamed store's panel level); channel 0 is also the scene's
    /// [`crate::Scene::data`].
    pub channels: Vec<Arc<VolumeData>>,
    /// The in-memory composite's renderer ([`voxscope_render::RendererKind::Composite`]);
    /// `None` for a store's channels streamed together, which the scene's own renderer draws
    /// ([`Self::streamed`]).
    renderer: Option<VolumeRenderer>,
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
            return Err(RenderError::Invalid(format!(
                "{} channel settings for {} channels",
                states.len(),
                channels.len()
            )));
        }
        let spacing = channels
            .first()
            .map_or([1.0; 3], |data| data.volume.spacing);
        let quantized = || channels.iter().map(|data| &data.quantized);
        let renderer =
            VolumeRenderer::new_composite(context, &layers(quantized(), states), spacing)?;
        write_states(context, &renderer, quantized(), states)?;
        Ok(Self {
            channels,
            renderer: Some(renderer),
            applied: states.to_vec(),
            generation: 1,
        })
    }

    /// The channels of a store streamed together by the scene's renderer (`streamed`, whose
    /// channels are `channels`, in order), drawn as `states` say.
    pub fn streamed(
        context: &GpuContext,
        streamed: &VolumeRenderer,
        channels: Vec<Arc<VolumeData>>,
        states: &[ChannelState],
    ) -> Result<Self, RenderError> {
        if streamed.renderer().channel_count() != channels.len() || states.len() != channels.len() {
            return Err(RenderError::Invalid(format!(
                "{} channel settings for {} channels of a renderer of {}",
                states.len(),
                channels.len(),
                streamed.renderer().channel_count()
            )));
        }
        let quantized = channels.iter().map(|data| &data.quantized);
        write_states(context, streamed, quantized, states)?;
        Ok(Self {
            channels,
            renderer: None,
            applied: states.to_vec(),
            generation: 1,
        })
    }

    /// The renderer that draws the composite: its own, or (streamed) the scene's
    /// `scene_renderer`.
    pub fn renderer<'a>(&'a self, scene_renderer: &'a VolumeRenderer) -> &'a VolumeRenderer {
        self.renderer.as_ref().unwrap_or(scene_renderer)
    }

    /// What a status bar says of `voxel`: its indices and position, and each shown channel's
    /// value there in its units, by name (`voxel (3, 4, 5) · (3.0, 4.0, 5.0) µm · nuclei 523
    /// · membranes 88`).
    pub fn describe_voxel(&self, voxel: [usize; 3]) -> Option<String> {
        let mut text = self.channels.first()?.describe_place(voxel)?;
        for (data, state) in self.channels.iter().zip(&self.applied) {
            if let (true, Some(value)) = (state.visible, data.describe_value(voxel)) {
                text.push_str(&format!(" · {} {value}", state.name));
            }
        }
        Some(text)
    }

    /// Whether the scene's renderer streams the channels (no renderer of its own).
    pub fn is_streamed(&self) -> bool {
        self.renderer.is_none()
    }

    /// Writes the tables of `states` where they differ from what the GPU holds (no reload:
    /// edits stay live); returns the tables' generation, which changes with every write.
    /// States for another number of channels are refused, and the tables stay.
    /// `scene_renderer` is the scene's, which draws a streamed composite.
    pub fn apply(
        &mut self,
        context: &GpuContext,
        scene_renderer: &VolumeRenderer,
        states: &[ChannelState],
    ) -> Result<u64, RenderError> {
        if states != self.applied.as_slice() {
            let quantized = self.channels.iter().map(|data| &data.quantized);
            let renderer = self.renderer.as_ref().unwrap_or(scene_renderer);
            write_states(context, renderer, quantized, states)?;
            self.applied = states.to_vec();
            self.generation += 1;
        }
        Ok(self.generation)
    }

    /// Its channels' data, renderer (`None`: streamed by the scene's) and the states its
    /// tables follow, apart.
    pub fn into_parts(
        self,
    ) -> (
        Vec<Arc<VolumeData>>,
        Option<VolumeRenderer>,
        Vec<ChannelState>,
    ) {
        (self.channels, self.renderer, self.applied)
    }

    /// The tables' generation: it changes with every write.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// The channel states the GPU tables follow now.
    pub fn applied(&self) -> &[ChannelState] {
        &self.applied
    }

    /// Of the blocks of 8³ voxels empty-space skipping divides the volume into, how many
    /// frames march (some shown channel is visible there) and how many there are.
    /// (None while streamed: the streamer skips by bricks.)
    pub fn skipped_blocks(&self) -> Option<(usize, usize)> {
        self.renderer.as_ref()?.renderer().skipped_blocks()
    }

    /// Bytes on the GPU: textures and tables (0 while streamed: the scene's renderer holds
    /// them).
    pub fn gpu_bytes(&self) -> u64 {
        self.renderer.as_ref().map_or(0, |renderer| {
            renderer.gpu_bytes().iter().map(|(_, bytes)| bytes).sum()
        })
    }

    /// Bytes on the CPU: every channel's value levels and octree nodes.
    pub fn cpu_bytes(&self) -> u64 {
        self.channels.iter().map(|data| data.cpu_bytes()).sum()
    }
}

/// The renderer's layers: each channel's levels under its state's transfer function and color.
pub(crate) fn layers<'a>(
    quantized: impl IntoIterator<Item = &'a QuantizedVolume>,
    states: &'a [ChannelState],
) -> Vec<ChannelLayer<'a>> {
    quantized
        .into_iter()
        .zip(states)
        .map(|(quantized, state)| ChannelLayer {
            quantized,
            transfer: &state.transfer,
            color: state.color.map(|c| c as f32 / 255.0),
        })
        .collect()
}

/// Gives the channels of the composite `renderer` (their values `quantized`) the transfer
/// functions, colors and visibility of `states`: nothing is read or uploaded again.
pub(crate) fn write_states<'a>(
    context: &GpuContext,
    renderer: &VolumeRenderer,
    quantized: impl IntoIterator<Item = &'a QuantizedVolume>,
    states: &'a [ChannelState],
) -> Result<(), RenderError> {
    let shown: Vec<bool> = states.iter().map(|s| s.visible).collect();
    renderer.set_channels(context, &layers(quantized, states), &shown)
}
