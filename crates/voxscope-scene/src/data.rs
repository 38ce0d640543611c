//! A loaded volume's CPU side: its description, quantized values, octree and histogram, what
//! every renderer and panel is made from.

use std::sync::Arc;
use std::time::Instant;

use voxscope_octree::{self as octree, BuildOptions, DataKind, Octree};
use voxscope_stream::MemorySource;
use voxscope_volume::progress::Progress;
use voxscope_volume::{QuantizedVolume, ValueWindow, Volume, format_value};

use crate::{SceneError, VolumeSource, default_window, file_window};

/// A loaded volume's CPU side: what every renderer is made from, shared with jobs.
pub struct VolumeData {
    pub source: VolumeSource,
    /// The volume's description; its voxels are dropped once quantized.
    pub volume: Volume,
    pub quantized: QuantizedVolume,
    pub octree: Octree,
    /// The window the volume opened with ([`default_window`]).
    pub default_window: ValueWindow,
    /// Histogram of the values in [`HISTOGRAM_BINS`] bins over the value range.
    pub histogram: Vec<u64>,
    /// CT, labels, or other: what the presets and defaults follow.
    pub kind: DataKind,
    pub load_seconds: f64,
    /// The full-resolution pyramid of a volume in memory longer than the voxel octree holds
    /// (1024 voxels a side): the streaming renderer draws it, and `volume`, `quantized` and
    /// `octree` are its finest level within [`crate::PANEL_LEVEL_VOXELS`], as for a large
    /// OME-Zarr store.
    pub pyramid: Option<Arc<MemorySource>>,
}

/// Bins of the histogram the transfer panel draws.
pub const HISTOGRAM_BINS: usize = 256;

impl VolumeData {
    /// Quantizes `volume`, builds its octree (colored later) and histogram: what the panels
    /// and every renderer read. `started` is when its reading began. Its voxels are dropped
    /// once quantized.
    pub fn prepare(
        source: &VolumeSource,
        mut volume: Volume,
        started: Instant,
        progress: &Progress,
    ) -> Result<Self, SceneError> {
        progress.begin("quantizing");
        let quantized = QuantizedVolume::new(&volume);
        volume.data = volume.data.emptied();
        Self::from_quantized(source, volume, quantized, started, progress)
    }

    /// [`Self::prepare`] of values quantized already ([`QuantizedVolume::of_values`]: the
    /// Python module's arrays, read in place); `volume` describes them (its voxels may be
    /// empty, of their stored type).
    pub fn from_quantized(
        source: &VolumeSource,
        volume: Volume,
        quantized: QuantizedVolume,
        started: Instant,
        progress: &Progress,
    ) -> Result<Self, SceneError> {
        progress.check()?;
        let kind = DataKind::of_volume(&volume, &quantized);
        // A label volume's octree colors its inner nodes by their children's most shown label,
        // and every renderer made of it samples the nearest voxel.
        let options = BuildOptions {
            labels: kind.is_labels(),
            ..BuildOptions::default()
        };
        let octree = octree::build_with_progress(&quantized, options, progress)
            .map_err(|e| SceneError::from_build(&volume.name, e))?;
        let default_window = default_window(file_window(&volume), &quantized);
        let histogram = display_histogram(&quantized);
        Ok(Self {
            source: source.clone(),
            volume,
            quantized,
            octree,
            default_window,
            histogram,
            kind,
            load_seconds: started.elapsed().as_secs_f64(),
            pyramid: None,
        })
    }

    /// The value of `voxel` in the data's units, from the quantized levels the GPU holds
    /// (exact for integer data spanning up to 65 536 values; within half a level step, a
    /// 65 535th of the range, otherwise).
    pub fn value_at(&self, voxel: [usize; 3]) -> Option<f64> {
        let [x, y, z] = voxel;
        let dims = self.quantized.dims;
        if x >= dims[0] || y >= dims[1] || z >= dims[2] {
            return None;
        }
        let level = *self.quantized.levels.get(x + dims[0] * (y + dims[1] * z))?;
        Some(self.quantized.quantization.value(level))
    }

    /// What a status bar says of `voxel`: its indices, position and value.
    pub fn describe_voxel(&self, voxel: [usize; 3]) -> Option<String> {
        Some(format!(
            "{} · value {}",
            self.describe_place(voxel)?,
            self.describe_value(voxel)?
        ))
    }

    /// Where `voxel` is: its indices and position (`voxel (i, j, k) · (x, y, z) mm`).
    pub fn describe_place(&self, voxel: [usize; 3]) -> Option<String> {
        self.value_at(voxel)?;
        let spacing = self.volume.spacing;
        let [i, j, k] = voxel;
        let position = self.volume.with_unit(format!(
            "({:.1}, {:.1}, {:.1})",
            i as f64 * spacing[0],
            j as f64 * spacing[1],
            k as f64 * spacing[2],
        ));
        Some(format!("voxel ({i}, {j}, {k}) · {position}"))
    }

    /// The value at `voxel` in its units (`HU` for a CT).
    pub fn describe_value(&self, voxel: [usize; 3]) -> Option<String> {
        let value = self.value_at(voxel)?;
        let value_unit = if self.kind == DataKind::Ct { " HU" } else { "" };
        Some(format!("{}{value_unit}", format_value(value)))
    }

    /// Bytes it holds in memory: the value levels and the octree's nodes.
    pub fn cpu_bytes(&self) -> u64 {
        (self.quantized.levels.len() * 2 + self.octree.nodes.len() * 8) as u64
    }

    /// The value at the center of histogram bin `bin`'s left edge.
    pub fn bin_value(&self, bin: f64) -> f64 {
        let [low, high] = self.quantized.value_range;
        low + (high - low) * bin / HISTOGRAM_BINS as f64
    }
}

fn display_histogram(quantized: &QuantizedVolume) -> Vec<u64> {
    let [low, high] = quantized.value_range;
    let span = (high - low).max(f64::MIN_POSITIVE);
    let mut bins = vec![0u64; HISTOGRAM_BINS];
    for (level, &count) in quantized.histogram.counts.iter().enumerate() {
        if count > 0 {
            let value = quantized.quantization.value(level as u16);
            let bin = ((value - low) / span * HISTOGRAM_BINS as f64) as usize;
            bins[bin.min(HISTOGRAM_BINS - 1)] += count;
        }
    }
    bins
}
