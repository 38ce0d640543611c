//! The CPU half of every command: load, quantize, build the octree, color it.

use std::time::Duration;

use crate::octree::{self, BuildOptions, Octree, TransferFunction};
use crate::volume::{self, QuantizedVolume, Volume};

use super::{TransferArgs, VolumeArgs};

/// A volume ready to draw: its octree colored by a transfer function.
pub struct Prepared {
    pub volume: Volume,
    pub quantized: QuantizedVolume,
    pub octree: Octree,
    pub transfer: TransferFunction,
    pub recolor_time: Duration,
}

impl Prepared {
    /// Loads and prepares what `volume_args` and `transfer_args` name.
    pub fn new(volume_args: &VolumeArgs, transfer_args: &TransferArgs) -> Result<Self, String> {
        let volume = match &volume_args.file {
            Some(spec) => volume::load(spec, &volume_args.load_options()),
            None => volume::sample(),
        }
        .map_err(|e| e.to_string())?;
        let quantized = QuantizedVolume::new(&volume);
        let mut octree = octree::build(&quantized, BuildOptions::default())
            .map_err(|e| format!("{}: {e}", volume.name))?;
        let transfer = transfer_args.transfer_function(quantized.robust_window());
        let recolor_time = octree::recolor(&mut octree, &transfer);
        Ok(Self {
            volume,
            quantized,
            octree,
            transfer,
            recolor_time,
        })
    }
}
