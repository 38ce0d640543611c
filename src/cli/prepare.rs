//! The CPU half of every command: load, quantize, build the octree, color it.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use crate::app::TransferPreset;
use voxscope_octree::{BuildOptions, DataKind, Octree, TransferFunction};
use voxscope_render::{GpuContext, RendererKind};
use voxscope_volume::progress::Progress;
use voxscope_volume::{QuantizedVolume, Volume};

use super::{TransferArgs, VolumeArgs};

/// A volume ready to draw: its octree colored by a transfer function.
pub struct Prepared {
    pub volume: Volume,
    pub quantized: QuantizedVolume,
    pub octree: Octree,
    pub transfer: TransferFunction,
    /// The transfer function file of --tf, whose opacity scale and mode apply too.
    pub saved: Option<TransferPreset>,
    pub recolor_time: Duration,
}

impl Prepared {
    /// Loads and prepares what `volume_args` and `transfer_args` name.
    pub fn new(volume_args: &VolumeArgs, transfer_args: &TransferArgs) -> Result<Self, String> {
        // A bad --tf file fails before the volume is read.
        transfer_args.saved()?;
        Self::from_volume(volume_args.load()?, transfer_args)
    }

    /// Prepares `volume`, loaded already (a channel of a composite that has only one).
    pub fn from_volume(volume: Volume, transfer_args: &TransferArgs) -> Result<Self, String> {
        let saved = transfer_args.saved()?;
        let quantized = QuantizedVolume::new(&volume);
        let mut octree = build_reporting_progress(&quantized).map_err(|e| {
            // The paper's octree keeps its limit; the streamed bricks have none.
            let hint = if beyond_octree(volume.dims) {
                " (render draws it with --renderer bricks or stream, bench with --stream)"
            } else {
                ""
            };
            format!("{}: {e}{hint}", volume.name)
        })?;
        let kind = DataKind::of_volume(&volume, &quantized);
        // A file's own window (OME-Zarr's omero) where it has one, else the percentiles.
        let window = volume
            .default_window
            .unwrap_or_else(|| quantized.robust_window());
        let transfer = transfer_args.transfer_function(&quantized, kind, saved.as_ref(), window);
        let recolor_time = voxscope_octree::recolor(&mut octree, &transfer);
        Ok(Self {
            volume,
            quantized,
            octree,
            transfer,
            saved,
            recolor_time,
        })
    }
}

/// Builds the octree; a build still running after a second prints its progress to stderr
/// once a second (`building octree: 42 %`), so large volumes do not look hung.
fn build_reporting_progress(
    quantized: &QuantizedVolume,
) -> Result<Octree, voxscope_octree::BuildError> {
    let progress = Arc::new(Progress::new());
    let finished = Arc::new(AtomicBool::new(false));
    let reporter = {
        let (progress, finished) = (Arc::clone(&progress), Arc::clone(&finished));
        std::thread::spawn(move || {
            let mut reported = false;
            let mut waited = Duration::ZERO;
            while !finished.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(50));
                waited += Duration::from_millis(50);
                if waited >= Duration::from_secs(1) {
                    waited = Duration::ZERO;
                    let (stage, fraction) = progress.get();
                    eprint!("\r{stage}: {:3.0} %", fraction * 100.0);
                    reported = true;
                }
            }
            if reported {
                eprintln!("\rbuilding octree: done ");
            }
        })
    };
    let result =
        voxscope_octree::build_with_progress(quantized, BuildOptions::default(), &progress);
    finished.store(true, Ordering::Relaxed);
    let _ = reporter.join();
    result
}

/// Whether a volume of `dims` is longer than the voxel octree holds (1024 voxels a side, depth
/// [`voxscope_octree::MAX_DEPTH`]): `render` then draws it with the streaming renderer from memory
/// unless `octree` or `dense` is asked for.
pub(super) fn beyond_octree(dims: [usize; 3]) -> bool {
    dims.iter().any(|&d| d > 1 << voxscope_octree::MAX_DEPTH)
}

/// The renderer for `render` and `slice` when none was asked for, as the app chooses: the
/// octree, or bricks (said on stderr, before `then`) where the octree's nodes through
/// `level` exceed one of the device's storage buffers.
pub(super) fn default_renderer(
    context: &GpuContext,
    octree: &Octree,
    level: u32,
    then: &str,
) -> RendererKind {
    let nodes = octree.nodes_through_level(level);
    let bytes = (nodes * std::mem::size_of::<voxscope_octree::Node>()) as u64;
    if bytes <= context.max_storage_bytes() {
        return RendererKind::Octree;
    }
    eprintln!(
        "the octree through level {level} needs {} MiB of nodes but this GPU ({}) allows {} MiB per storage buffer; {then} with bricks",
        bytes.div_ceil(1 << 20),
        context.adapter_info.name,
        context.max_storage_bytes() >> 20
    );
    RendererKind::Bricks
}
