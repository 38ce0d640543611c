//! The CPU half of every command, through the scene layer: load, quantize, build the octree,
//! choose the transfer function ([`voxscope_scene::opening_transfer`]) and color it.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use voxscope_octree::{self as octree, TransferFunction};
use voxscope_render::{GpuContext, RendererKind};
use voxscope_scene::{
    Progress, SavedTransfer, VolumeData, VolumeSource, opening_transfer, renderer_for_octree,
};
use voxscope_volume::Volume;

use super::{TransferArgs, VolumeArgs};

/// A volume ready to draw: its data (quantized, octree, histogram) with its octree colored by
/// the transfer function the options ask for.
pub struct Prepared {
    pub data: VolumeData,
    pub transfer: TransferFunction,
    /// The transfer function file of --tf, whose opacity scale and mode apply too.
    pub saved: Option<SavedTransfer>,
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
        let transfer_options = transfer_args.options();
        let saved = transfer_options.saved().map_err(|e| e.to_string())?;
        let source = VolumeSource::from_spec(&volume.name);
        let mut data = reporting_progress(|progress| {
            VolumeData::prepare(&source, volume, Instant::now(), progress)
        })
        // The paper's octree keeps its limit; the streamed bricks have none.
        .map_err(|e| super::args::scene_error_text(&e))?;
        let transfer = opening_transfer(
            &data.quantized,
            data.kind,
            data.default_window,
            &transfer_options.request(saved.as_ref()),
        );
        let recolor_time = octree::recolor(&mut data.octree, &transfer);
        Ok(Self {
            data,
            transfer,
            saved,
            recolor_time,
        })
    }
}

/// Runs `work`; while it still runs after a second, prints its progress to stderr once a
/// second (`building octree: 42 %`), so large volumes do not look hung.
pub(super) fn reporting_progress<T, E>(
    work: impl FnOnce(&Progress) -> Result<T, E>,
) -> Result<T, E> {
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
                let (stage, fraction) = progress.get();
                // Nothing to say outside a stage (the volume is still read, or the GPU
                // works after the build): only a stage's second counts.
                if stage.is_empty() {
                    if reported {
                        eprintln!("\rbuilding octree: done ");
                        reported = false;
                    }
                    waited = Duration::ZERO;
                    continue;
                }
                if waited >= Duration::from_secs(1) {
                    waited = Duration::ZERO;
                    eprint!("\r{stage}: {:3.0} %", fraction * 100.0);
                    reported = true;
                }
            }
            if reported {
                eprintln!("\rbuilding octree: done ");
            }
        })
    };
    let result = work(&progress);
    finished.store(true, Ordering::Relaxed);
    let _ = reporter.join();
    result
}

/// The renderer for `render` and `slice` when none was asked for, as the app chooses: the
/// octree, or bricks (said on stderr, before `then`) where the octree's nodes through
/// `level` exceed one of the device's storage buffers.
pub(super) fn default_renderer(
    context: &GpuContext,
    octree: &octree::Octree,
    level: u32,
    then: &str,
) -> RendererKind {
    renderer_for_octree(context, octree, level).unwrap_or_else(|(kind, reason)| {
        eprintln!("{reason}; {then} with bricks");
        kind
    })
}
