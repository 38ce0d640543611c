//! Channels and time points: which 3-D frame of a multi-channel or time-lapse file a loader
//! reads ([`Selection`]), and what the file holds besides it ([`Series`]), so that `info` can
//! list the channels and the app can offer the others.

use std::sync::Arc;

use super::ValueWindow;
use super::error::Problem;
use super::ome_zarr::{Bioformats2raw, Plate};

/// Which 3-D frame of a multi-channel, time-lapse file is read (both default to 0). Every
/// loader honours it; a file without such axes has one channel and one time point.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Selection {
    /// The channel index (OME-Zarr's `c` axis, a TIFF hyperstack's channels, NIfTI's
    /// dim\[5\], a NRRD list/vector/color axis).
    pub channel: usize,
    /// The time point index (OME-Zarr's `t`, TIFF frames, NIfTI's dim\[4\], a NRRD time axis).
    pub time: usize,
}

impl Selection {
    /// The one-line problem when this selection lies outside `channels` × `time_points`
    /// (the loader adds the file's name).
    pub(crate) fn check(self, channels: usize, time_points: usize) -> Result<(), Problem> {
        if self.channel >= channels {
            return Err(format!(
                "channel {} does not exist (the image has {channels})",
                self.channel
            ));
        }
        if self.time >= time_points {
            return Err(format!(
                "time point {} does not exist (the image has {time_points})",
                self.time
            ));
        }
        Ok(())
    }
}

/// What the file says about one channel, where it says anything.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ChannelInfo {
    /// Its name (OME-XML `Channel Name`, OME-Zarr `omero` label, ImageJ `Labels`).
    pub name: Option<String>,
    /// Its display color as RGB (OME-XML `Color`, `omero` color).
    pub color: Option<[u8; 3]>,
    /// The display window the file advises, in the data's units.
    pub window: Option<ValueWindow>,
    /// The file says not to show it when the image opens (OME-Zarr `omero` `active: false`).
    pub inactive: bool,
}

/// The channels and time points of the file a [`super::Volume`] came from, and which frame
/// the volume holds.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// One entry per channel of the file (at least one).
    pub channels: Vec<ChannelInfo>,
    /// Time points in the file (at least one).
    pub time_points: usize,
    /// The frame the volume holds.
    pub selected: Selection,
    /// The container the image is one of (an HCS plate's field, a bioformats2raw root's
    /// series), where it was opened through the container's root.
    pub container: Option<Arc<Container>>,
}

/// A store holding several images, opened at its root: an HCS plate (OME-Zarr `plate`, each
/// well's fields an image) or a bioformats2raw root of several series.
#[derive(Debug, Clone, PartialEq)]
pub enum Container {
    Plate(Plate),
    Series(Bioformats2raw),
}

impl Container {
    /// Each image's path below the root, in the container's order: `ROW/COLUMN/FIELD` for a
    /// plate's fields, the series' groups for a bioformats2raw root.
    pub fn images(&self) -> Vec<String> {
        match self {
            Self::Plate(plate) => plate
                .wells
                .iter()
                .flat_map(|(well, fields)| fields.iter().map(move |f| format!("{well}/{f}")))
                .collect(),
            Self::Series(found) => found.series.iter().map(|s| s.path.clone()).collect(),
        }
    }

    /// The path below the root of the image open.
    pub fn opened(&self) -> String {
        match self {
            Self::Plate(plate) => plate.field.clone(),
            Self::Series(found) => found
                .series
                .get(found.opened)
                .map(|s| s.path.clone())
                .unwrap_or_default(),
        }
    }

    /// The same container with `image` (one of [`Self::images`]) open instead; `None` where
    /// it holds no such image.
    pub fn with_opened(&self, image: &str) -> Option<Self> {
        if !self.images().iter().any(|i| i == image) {
            return None;
        }
        Some(match self {
            Self::Plate(plate) => Self::Plate(Plate {
                field: image.to_owned(),
                ..plate.clone()
            }),
            Self::Series(found) => Self::Series(Bioformats2raw {
                opened: found.series.iter().position(|s| s.path == image)?,
                chosen: true,
                ..found.clone()
            }),
        })
    }
}

impl Default for Series {
    /// A plain 3-D file: one unnamed channel, one time point.
    fn default() -> Self {
        Self::plain(1, 1, Selection::default())
    }
}

impl Series {
    /// `channels` unnamed channels and `time_points` time points, frame `selected` held.
    pub fn plain(channels: usize, time_points: usize, selected: Selection) -> Self {
        Self {
            channels: vec![ChannelInfo::default(); channels.max(1)],
            time_points: time_points.max(1),
            selected,
            container: None,
        }
    }

    /// Channels in the file.
    pub fn channel_count(&self) -> usize {
        self.channels.len()
    }

    /// The channels an image of several opens with: every one where there are at most
    /// `most` (those the file marks inactive open hidden); of more, those it does not mark
    /// inactive, in order, at most `most`, else (all are) the first ones.
    pub fn opening_channels(&self, most: usize) -> Vec<usize> {
        if self.channels.len() <= most {
            return (0..self.channels.len()).collect();
        }
        let active: Vec<usize> = (0..self.channels.len())
            .filter(|&c| !self.channels[c].inactive)
            .take(most)
            .collect();
        if active.is_empty() {
            (0..self.channels.len().min(most)).collect()
        } else {
            active
        }
    }

    /// Whether the file holds more than the one frame read.
    pub fn is_multi_frame(&self) -> bool {
        self.channels.len() > 1 || self.time_points > 1
    }
}

/// `RRGGBB` (OME-Zarr `omero`, a CLI color) as RGB.
pub(crate) fn parse_hex_color(text: &str) -> Option<[u8; 3]> {
    let hex = text.trim().trim_start_matches('#');
    if hex.len() != 6 || !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    let byte = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).ok();
    Some([byte(0)?, byte(2)?, byte(4)?])
}

/// OME-XML's `Color`: a signed 32-bit RGBA integer (`-16776961` is opaque red).
pub(crate) fn parse_ome_color(text: &str) -> Option<[u8; 3]> {
    let value = text.trim().parse::<i64>().ok()?;
    let rgba = u32::try_from(value & 0xffff_ffff).ok()?;
    let [r, g, b, _] = rgba.to_be_bytes();
    Some([r, g, b])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn selections_out_of_range_name_the_axis_and_its_extent() {
        let pick = |channel, time| Selection { channel, time };
        assert!(pick(1, 2).check(2, 3).is_ok());
        assert_eq!(
            pick(2, 0).check(2, 3).unwrap_err(),
            "channel 2 does not exist (the image has 2)"
        );
        assert_eq!(
            pick(0, 3).check(2, 3).unwrap_err(),
            "time point 3 does not exist (the image has 3)"
        );
    }

    #[test]
    fn colors_parse_from_hex_and_ome_integers() {
        assert_eq!(parse_hex_color("00FF00"), Some([0, 255, 0]));
        assert_eq!(parse_hex_color("#ff00ff"), Some([255, 0, 255]));
        assert_eq!(parse_hex_color("green"), None);
        assert_eq!(parse_ome_color("-16776961"), Some([255, 0, 0]));
        assert_eq!(parse_ome_color("16711935"), Some([0, 255, 0]));
        assert_eq!(parse_ome_color("x"), None);
    }

    #[test]
    fn a_file_of_more_channels_than_are_drawn_opens_its_active_ones_and_a_smaller_one_all() {
        let series = |inactive: &[bool]| Series {
            channels: inactive
                .iter()
                .map(|&inactive| ChannelInfo {
                    inactive,
                    ..ChannelInfo::default()
                })
                .collect(),
            time_points: 1,
            selected: Selection::default(),
            container: None,
        };
        // Of 4 (at most 8 drawn): all, the inactive one hidden by the composite's state.
        assert_eq!(
            series(&[false, true, false, false]).opening_channels(8),
            [0, 1, 2, 3]
        );
        // Of 10: the active ones, at most 8.
        let mut ten = [true; 10];
        ten[2] = false;
        ten[7] = false;
        assert_eq!(series(&ten).opening_channels(8), [2, 7]);
        assert_eq!(
            series(&[false; 10]).opening_channels(8),
            (0..8).collect::<Vec<_>>()
        );
        // None active: the first ones.
        assert_eq!(
            series(&[true; 10]).opening_channels(8),
            (0..8).collect::<Vec<_>>()
        );
    }
}
