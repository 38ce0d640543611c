//! What a volume opens with: its window, its transfer function and, where the octree does not
//! fit the device, its renderer. One rule each, for the app, the command line and the Python
//! module alike.

use serde::{Deserialize, Serialize};
use voxscope_octree::{
    Colormap, DataKind, MAX_DEPTH, Node, Octree, OpacityMode, Preset, TransferFunction,
    default_transfer,
};
use voxscope_render::{GpuContext, RendererKind};
use voxscope_volume::{QuantizedVolume, ValueWindow, Volume};

/// The window the file gives `volume`: its selected channel's (OME metadata, ImageJ), else the
/// volume's own (OME-Zarr's omero). `None` where the file gives none.
pub fn file_window(volume: &Volume) -> Option<ValueWindow> {
    volume
        .series
        .channels
        .get(volume.series.selected.channel)
        .and_then(|channel| channel.window)
        .or(volume.default_window)
}

/// The window a volume opens with: `file_window` (see [`file_window`]) where the file gives
/// one, else the robust window of its values (0.5–99.5 percentiles).
pub fn default_window(
    file_window: Option<ValueWindow>,
    quantized: &QuantizedVolume,
) -> ValueWindow {
    file_window.unwrap_or_else(|| quantized.robust_window())
}

/// The transfer-function choices the app's panel edits and remembers between runs (the window
/// is the data's own and lives beside it). What a new volume opens with is not taken from
/// here: a curve in data units belongs to its data ([`TransferRequest::saved`] carries a
/// function the user pinned).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TransferChoice {
    pub opacity: OpacityMode,
    pub threshold: f32,
    pub colormap: Colormap,
}

impl TransferChoice {
    /// The transfer function of this choice over `window`.
    pub fn with_window(self, window: ValueWindow) -> TransferFunction {
        TransferFunction {
            opacity: self.opacity,
            window,
            threshold: self.threshold,
            colormap: self.colormap,
        }
    }
}

impl From<TransferFunction> for TransferChoice {
    fn from(transfer: TransferFunction) -> Self {
        Self {
            opacity: transfer.opacity,
            threshold: transfer.threshold,
            colormap: transfer.colormap,
        }
    }
}

/// What was asked of the transfer function a volume opens with, most binding first. Every part
/// is optional: without any, the volume opens with what fits its data, its kind's default (a CT
/// preset, labels) or alpha = gray over its default window. Nothing of the volume shown
/// before carries over unless asked here: the app asks `saved` with the function on screen
/// when the user pinned it ("Keep for the next volumes").
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TransferRequest {
    /// A whole transfer function (a saved file's, or the one the user pinned in the app):
    /// taken as it is.
    pub saved: Option<TransferFunction>,
    /// A preset, over the data's values.
    pub preset: Option<Preset>,
    /// An opacity mode over the default window (instead of the kind's default).
    pub opacity: Option<OpacityMode>,
    /// The binary threshold on the windowed value, 0…1 (0.3 where not given).
    pub threshold: Option<f32>,
    /// The colors (instead of the preset's or the default's).
    pub colormap: Option<Colormap>,
    /// The window (instead of the preset's or the default's).
    pub window: Option<ValueWindow>,
    /// The view is a maximum intensity projection: where no preset, colormap or opacity is
    /// asked for, the volume opens in grays over its default window (a CT preset's colors say
    /// what its opacity hides, which a projection does not); a label volume keeps its colors
    /// (its MIP draws the first label shown along each ray, in that label's color).
    pub mip: bool,
}

/// The binary threshold where none is asked for.
const DEFAULT_THRESHOLD: f32 = 0.3;

/// The transfer function a volume of `kind` with these `quantized` values opens with, as
/// `request` asks: its saved function, else its preset, else its opacity over
/// `default_window`, else the kind's default (CT: the soft-tissue preset, not for a maximum
/// intensity projection; labels: the labels colormap), else alpha = gray over
/// `default_window`. The request's window and colormap then override any of them.
pub fn opening_transfer(
    quantized: &QuantizedVolume,
    kind: DataKind,
    default_window: ValueWindow,
    request: &TransferRequest,
) -> TransferFunction {
    let colormap = request.colormap.unwrap_or(Colormap::Grays);
    let threshold = request.threshold.unwrap_or(DEFAULT_THRESHOLD);
    let over_window = |opacity| TransferFunction {
        opacity,
        window: default_window,
        threshold,
        colormap,
    };
    let mut transfer = if let Some(saved) = request.saved {
        saved
    } else if let Some(preset) = request.preset {
        preset.transfer(quantized, colormap)
    } else if let Some(opacity) = request.opacity {
        over_window(opacity)
    } else if let Some(transfer) =
        default_transfer(quantized, kind).filter(|_| !request.mip || kind.is_labels())
    {
        transfer
    } else {
        over_window(OpacityMode::Gray)
    };
    if let Some(window) = request.window {
        transfer.window = window;
    }
    if let Some(colormap) = request.colormap {
        transfer.colormap = colormap;
    }
    transfer
}

/// Whether a volume of `dims` is longer than the voxel octree holds (1024 voxels a side, depth
/// [`MAX_DEPTH`]): it is then drawn by the streaming renderer, from a pyramid in memory.
pub fn beyond_octree(dims: [usize; 3]) -> bool {
    dims.iter().any(|&d| d > 1 << MAX_DEPTH)
}

/// The renderer for `octree` drawn through `level` when none was asked for: the octree, or
/// bricks where its nodes through `level` exceed one of the device's storage buffers (`Err`
/// says so, with the bricks to use instead).
pub fn renderer_for_octree(
    context: &GpuContext,
    octree: &Octree,
    level: u32,
) -> Result<RendererKind, (RendererKind, String)> {
    let nodes = octree.nodes_through_level(level);
    let bytes = (nodes * std::mem::size_of::<Node>()) as u64;
    if bytes <= context.max_storage_bytes() {
        return Ok(RendererKind::Octree);
    }
    Err((
        RendererKind::Bricks,
        format!(
            "the octree through level {level} needs {} MiB of nodes but this GPU ({}) allows {} MiB per storage buffer",
            bytes.div_ceil(1 << 20),
            context.adapter_info.name,
            context.max_storage_bytes() >> 20
        ),
    ))
}
