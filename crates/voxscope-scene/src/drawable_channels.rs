//! The rules of a composite's channels, once for every front end: which channel numbers of
//! its file the composite's channels are, what is checked of the colors, windows and choice
//! asked for them, and each channel's state as it opens.

use voxscope_volume::Volume;

use super::CompositeChannel;
use crate::channels::file_channel_numbers;
use crate::{ChannelState, DrawOptions, SavedTransfer, SceneError};

/// Channels chosen (`--channels`) where nothing chooses among a file's channels (one volume
/// given, or files given as channels): refused with the way, never ignored.
pub(super) fn refuse_chosen(options: &DrawOptions) -> Result<(), SceneError> {
    if options.channels.chosen.is_empty() {
        return Ok(());
    }
    Err(SceneError::failed(
        "--channels chooses among the channels of one file of several; --channel N draws one, and --channels-from's files are the channels",
    ))
}

/// The file's channel numbers of the composite's `channels`, in order: each one's own where
/// they are channels of one file of several (or `alone`'s), else their places (files given
/// as channels, each its file's first).
pub(super) fn channel_numbers(channels: &[CompositeChannel], alone: Option<usize>) -> Vec<usize> {
    if let Some(alone) = alone {
        return vec![alone];
    }
    file_channel_numbers(channels.iter().map(CompositeChannel::volume))
        .unwrap_or_else(|| (0..channels.len()).collect())
}

/// Whether `channels` are channels of one file of several (not files given as channels).
pub(super) fn of_one_file(channels: &[CompositeChannel]) -> bool {
    file_channel_numbers(channels.iter().map(CompositeChannel::volume)).is_some()
}

/// Whether channel `index` of `volume`'s file (a channel chosen alone) has a color of its
/// own: from the request, else from the file (OME-Zarr `omero`, OME-XML). A file of several
/// channels checks the request against its channel count.
pub(super) fn colors_channel(
    request: &crate::ChannelRequest,
    volume: &Volume,
    index: usize,
) -> Result<bool, SceneError> {
    let count = volume.series.channel_count();
    request.check(count)?;
    let from_file = volume
        .series
        .channels
        .get(index)
        .is_some_and(|c| c.color.is_some());
    Ok(count > 1 && (request.colors.len() > index || from_file))
}

/// Each channel's state as `options` ask ([`ChannelState::opening_of`]); `alone` is the file
/// index of a single channel drawn alone.
pub(super) fn channel_states(
    channels: &[CompositeChannel],
    options: &DrawOptions,
    saved: Option<&SavedTransfer>,
    alone: Option<usize>,
) -> Result<Vec<ChannelState>, SceneError> {
    let request = &options.channels;
    check_channels(channels, options, alone)?;
    let transfer_request = options.transfer.request(saved);
    let numbers = channel_numbers(channels, alone);
    Ok(channels
        .iter()
        .zip(numbers)
        .map(|(c, number)| {
            ChannelState::opening_of(
                c.volume(),
                c.quantized(),
                c.kind,
                number,
                &transfer_request,
                request,
            )
        })
        .collect())
}

/// No color or window asked for a channel the file does not have (channels of one file, or
/// `alone`, the file index of a single channel drawn alone: the file's channels count; files
/// given as channels: theirs).
pub(super) fn check_channels(
    channels: &[CompositeChannel],
    options: &DrawOptions,
    alone: Option<usize>,
) -> Result<(), SceneError> {
    let count = if alone.is_some() || of_one_file(channels) {
        channels[0].volume().series.channel_count()
    } else {
        channels.len()
    };
    options.channels.check(count)
}
