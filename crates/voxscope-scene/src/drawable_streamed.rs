//! The streamed composite as `render`, `movie`, the Python module and the app's pictures draw
//! it: a store's channels (or stores given as channels) streamed together, and the channel
//! states its tables follow.

use std::borrow::Borrow;

use voxscope_render::{GpuContext, VolumeRenderer};
use voxscope_volume::ome_zarr::Pyramid;

use super::{Drawable, Drawn};
use crate::channels::write_states;
use crate::{
    ChannelState, DrawOptions, SavedTransfer, SceneError, StreamedChannel, StreamedChannels,
    VolumeSource,
};

/// The channels of a streamed composite and the states its tables follow.
pub(super) struct StreamComposite {
    pub(super) channels: Vec<StreamedChannel>,
    pub(super) applied: Vec<ChannelState>,
}

impl StreamComposite {
    /// Writes `states` into `renderer`'s tables where they differ from those applied.
    pub(super) fn apply(
        &mut self,
        context: &GpuContext,
        renderer: &VolumeRenderer,
        states: Vec<ChannelState>,
        name: &str,
    ) -> Result<(), SceneError> {
        if states != self.applied {
            let previews = self.channels.iter().map(|c| &c.preview);
            write_states(context, renderer, previews, &states)
                .map_err(|e| SceneError::render(name, e))?;
            self.applied = states;
        }
        Ok(())
    }
}

impl<G: Borrow<GpuContext>> Drawable<G> {
    /// The channels of the store `pyramid` that `options` choose, streamed together (the
    /// streamed composite), each channel's color and window as `options` ask.
    pub(super) fn streamed_channels(
        open: impl FnOnce(&crate::TransferRequest) -> Result<StreamedChannels, SceneError>,
        options: &DrawOptions,
        saved: Option<SavedTransfer>,
        gpu: impl FnOnce() -> Result<G, SceneError>,
    ) -> Result<Self, SceneError> {
        let request = options.transfer.request(saved.as_ref());
        let opened = open(&request)?;
        let states = opened.states(&request, &options.channels);
        let gpu = gpu()?;
        let volume = opened.volume;
        let name = volume.source.name().to_owned();
        let mut renderer = VolumeRenderer::new_stream(
            gpu.borrow(),
            volume.source.clone(),
            volume.stream_options(options.stream),
            &volume.transfer,
        )
        .map_err(|e| SceneError::render(&name, e))?;
        let mut composite = StreamComposite {
            channels: opened.channels,
            applied: Vec::new(),
        };
        composite.apply(gpu.borrow(), &renderer, states, &name)?;
        // The tables reach the streamer's visibility at its next step.
        renderer.update(gpu.borrow());
        Ok(Self {
            gpu,
            drawn: Drawn::Stream {
                applied: volume.transfer,
                streamed: Box::new(volume),
                renderer,
                composite: Some(composite),
            },
            labels: Vec::new(),
            saved,
            notices: Vec::new(),
        })
    }

    /// The channels `chosen` of the store `source` names (at the frame `select` names)
    /// streamed together within `stream`'s budgets: the app's streamed composite, drawn away
    /// from the window (its channels' states are set per frame: [`Self::set_channels`]).
    pub fn of_store_channels(
        gpu: G,
        source: &VolumeSource,
        select: voxscope_volume::Selection,
        chosen: &[usize],
        stream: voxscope_stream::StreamOptions,
    ) -> Result<Self, SceneError> {
        let pyramid = voxscope_volume::ome_zarr::Pyramid::open_spec(
            source.spec(),
            select,
            voxscope_volume::remote::RemoteOptions::default(),
        )?;
        let options = DrawOptions {
            channels: crate::ChannelRequest {
                chosen: chosen.to_vec(),
                ..Default::default()
            },
            stream,
            ..DrawOptions::default()
        };
        Self::of_channels_of_store(gpu, pyramid, &options)
    }

    /// The channels of the store `pyramid` (of several) that `options` choose, streamed
    /// together as `options` draw them (the Python module's `render` of such a store).
    pub fn of_channels_of_store(
        gpu: G,
        pyramid: Pyramid,
        options: &DrawOptions,
    ) -> Result<Self, SceneError> {
        let saved = options.transfer.saved()?;
        let open = |request: &crate::TransferRequest| {
            StreamedChannels::open(pyramid, &options.channels, request)
        };
        Self::streamed_channels(open, options, saved, || Ok(gpu))
    }
}
