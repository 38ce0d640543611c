//! Octrees ready to draw, for the tests of the octree crate and of every package above it.

use voxscope_octree::{BuildOptions, Octree, TransferFunction};
use voxscope_volume::{QuantizedVolume, Volume};

/// Quantizes, builds and colors `volume` with `transfer` (the robust window if `None`).
pub fn colored_octree(
    volume: &Volume,
    transfer: Option<TransferFunction>,
    options: BuildOptions,
) -> (Octree, TransferFunction) {
    let quantized = QuantizedVolume::new(volume);
    let mut octree = voxscope_octree::build(&quantized, options).expect("octree builds");
    let transfer = transfer.unwrap_or_else(|| TransferFunction::gray(quantized.robust_window()));
    voxscope_octree::recolor(&mut octree, &transfer);
    (octree, transfer)
}
