//! The streaming renderer on the command line: its options (`--gpu-memory`, `--ram-cache`,
//! …), opening a pyramid (a procedural one, or any readable volume's, whose coarser levels are
//! computed in memory), and drawing one view until nothing visible is missing.

use std::sync::Arc;
use std::time::{Duration, Instant};

use clap::Args;

use super::{TransferArgs, VolumeArgs};
use crate::app::TransferPreset;
use voxscope_octree::{DataKind, TransferFunction};
use voxscope_render::{Camera, GpuContext, RenderSettings, RenderTarget, VolumeRenderer};
use voxscope_stream::{
    BrickSource, Downsampling, MemorySource, NoiseSource, StreamOptions, StreamStatus, ZarrSource,
    preview,
};
use voxscope_volume::ome_zarr::{self, Pyramid};
use voxscope_volume::{QuantizedVolume, ValueWindow, Volume, parse_dims};

/// The streaming renderer's budgets (`--renderer stream`, `bench --stream`).
#[derive(Debug, Clone, Args)]
pub struct StreamArgs {
    /// Streaming renderer: GPU memory for everything it holds (the brick atlas, page table and
    /// request buffers), e.g. 2GiB or 512MiB; bounded by the GPU's largest 3D texture.
    #[arg(long, value_name = "SIZE", default_value = "1GiB", value_parser = parse_bytes)]
    pub gpu_memory: u64,
    /// Streaming renderer: decoded bricks kept in RAM.
    #[arg(long, value_name = "SIZE", default_value = "2GiB", value_parser = parse_bytes)]
    pub ram_cache: u64,
    /// Streaming renderer: bricks uploaded to the GPU per frame at most, in bytes.
    #[arg(long, value_name = "SIZE", default_value = "8MiB", value_parser = parse_bytes)]
    pub upload_budget: u64,
    /// Streaming renderer: the pixel footprint is multiplied by this to pick each segment's
    /// level (1: no voxel larger than a pixel's footprint; 2: one level coarser; 0: always the
    /// max level).
    #[arg(long, value_name = "F", default_value_t = 1.0, value_parser = parse_lod_scale)]
    pub lod_scale: f32,
}

impl StreamArgs {
    /// The streamer's options (workers: the machine's cores less one).
    pub fn options(&self) -> StreamOptions {
        StreamOptions {
            gpu_memory: self.gpu_memory,
            ram_cache: self.ram_cache,
            upload_bytes_per_frame: self.upload_budget,
            lod_scale: self.lod_scale,
            ..StreamOptions::default()
        }
    }
}

/// `N`, or `N` with a binary unit: `K`/`KiB`, `M`/`MiB`, `G`/`GiB`, `T`/`TiB` (`2GiB`, `512M`).
pub fn parse_bytes(text: &str) -> Result<u64, String> {
    let trimmed = text.trim();
    let split = trimmed
        .find(|c: char| !c.is_ascii_digit() && c != '.')
        .unwrap_or(trimmed.len());
    let (number, unit) = trimmed.split_at(split);
    let shift = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 0,
        "k" | "kib" => 10,
        "m" | "mib" => 20,
        "g" | "gib" => 30,
        "t" | "tib" => 40,
        _ => {
            return Err(format!(
                "size '{text}' has an unknown unit (use K, M, G, T or KiB, MiB, GiB, TiB)"
            ));
        }
    };
    let value: f64 = number
        .parse()
        .ok()
        .filter(|v: &f64| v.is_finite() && *v > 0.0)
        .ok_or_else(|| format!("size '{text}' is not a positive number of bytes"))?;
    let bytes = value * (1u64 << shift) as f64;
    if bytes >= u64::MAX as f64 {
        return Err(format!("size '{text}' is too large"));
    }
    Ok(bytes as u64)
}

fn parse_lod_scale(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(v) if (0.0..=64.0).contains(&v) => Ok(v),
        _ => Err(format!("lod scale '{text}' is not a number from 0 to 64")),
    }
}

/// Loader threads for a URL's pyramid, at least: each waits on the network most of its time
/// (a region's requests are in flight together, up to `--max-requests`), not on a core.
pub const REMOTE_WORKERS: usize = 8;

/// A pyramid opened for streaming, and the transfer function to draw it with.
pub struct StreamPrepared {
    pub source: Arc<dyn BrickSource>,
    /// The Zarr pyramid the source reads, where it reads one (its remote counters).
    pub pyramid: Option<Arc<Pyramid>>,
    pub transfer: TransferFunction,
    /// The --tf file, whose opacity scale and mode apply too.
    pub saved: Option<TransferPreset>,
    /// How long opening took (reading a volume and computing its levels, or the preview).
    pub open_seconds: f64,
}

/// Bricks of the level read whole for the transfer function's defaults.
const PREVIEW_BRICKS: u64 = 64;

impl StreamPrepared {
    /// Opens what `volume_args` names as a pyramid: `synthetic:noise:SIZE` as procedural
    /// noise generated brick by brick (any size: 16384 is 8 TB of voxels), a Zarr store brick by
    /// brick from its own levels, anything else read into memory ([`Self::from_volume`]).
    pub fn new(volume_args: &VolumeArgs, transfer_args: &TransferArgs) -> Result<Self, String> {
        // A bad --tf file fails before the volume is read.
        transfer_args.saved()?;
        let started = Instant::now();
        let spec = volume_args.file.as_deref();
        match spec.and_then(|s| s.strip_prefix("synthetic:noise:")) {
            Some(size) if volume_args.raw.is_none() => {
                let dims = parse_dims(size)
                    .ok_or_else(|| format!("synthetic:noise:{size}: the size is not N or XxYxZ"))?;
                let name = format!("synthetic:noise:{size}");
                let source = Arc::new(NoiseSource::new(&name, dims)?);
                Self::finish(source, None, None, None, transfer_args, started)
            }
            _ if spec.is_some_and(ome_zarr::is_zarr_spec) && volume_args.raw.is_none() => {
                // Read region by region from the file's own levels (a folder's or a URL's),
                // never whole.
                let options = volume_args.load_options();
                let pyramid =
                    Pyramid::open_spec(spec.unwrap_or_default(), options.select, options.remote)
                        .map_err(|e| e.to_string())?;
                let window = pyramid.omero_window();
                let pyramid = Arc::new(pyramid);
                let source = ZarrSource::new(pyramid.clone())?;
                // The preview's and the pinned levels' chunks in one batch, not a chunk at a
                // time (a URL's round trips).
                source.warm_first_image(PREVIEW_BRICKS);
                Self::finish(
                    Arc::new(source),
                    None,
                    window,
                    Some(pyramid),
                    transfer_args,
                    started,
                )
            }
            _ => {
                let loaded = match spec {
                    Some(spec) => voxscope_volume::load(spec, &volume_args.load_options()),
                    None => voxscope_volume::sample(),
                }
                .map_err(|e| e.to_string())?;
                Self::from_volume(loaded, transfer_args, started)
            }
        }
    }

    /// A volume read whole already (since `started`), its coarser levels computed in memory
    /// (2× mean; max for label volumes): any loader's volume, of any size the RAM holds.
    pub fn from_volume(
        loaded: Volume,
        transfer_args: &TransferArgs,
        started: Instant,
    ) -> Result<Self, String> {
        let quantized = QuantizedVolume::new(&loaded);
        let kind = DataKind::of_volume(&loaded, &quantized);
        let how = match kind {
            DataKind::Labels(_) => Downsampling::Max,
            _ => Downsampling::Mean,
        };
        let source = MemorySource::from_levels(
            &loaded.name,
            quantized.levels,
            quantized.dims,
            quantized.quantization,
            loaded.spacing,
            how,
        )?;
        let window = loaded.default_window;
        Self::finish(
            Arc::new(source),
            Some(kind),
            window,
            None,
            transfer_args,
            started,
        )
    }

    /// The transfer function of `source` (its kind and window where known, else its preview's)
    /// and the rest of a prepared pyramid.
    fn finish(
        source: Arc<dyn BrickSource>,
        kind: Option<DataKind>,
        window: Option<ValueWindow>,
        pyramid: Option<Arc<Pyramid>>,
        transfer_args: &TransferArgs,
        started: Instant,
    ) -> Result<Self, String> {
        let saved = transfer_args.saved()?;
        let (preview, _) =
            preview(&*source, PREVIEW_BRICKS).map_err(|e| format!("{}: {e}", source.name()))?;
        let kind = kind.unwrap_or_else(|| DataKind::of(&preview, None, false));
        // A file's own window (OME-Zarr's omero) where it has one, else the percentiles.
        let window = window.unwrap_or_else(|| preview.robust_window());
        let transfer = transfer_args.transfer_function(&preview, kind, saved.as_ref(), window);
        Ok(Self {
            source,
            pyramid,
            transfer,
            saved,
            open_seconds: started.elapsed().as_secs_f64(),
        })
    }

    /// `options` for this source: a URL's pyramid gets at least [`REMOTE_WORKERS`] loaders.
    pub fn stream_options(&self, options: StreamOptions) -> StreamOptions {
        let remote = self
            .pyramid
            .as_ref()
            .is_some_and(|p| p.remote_stats().is_some());
        StreamOptions {
            workers: if remote {
                options.workers.max(REMOTE_WORKERS)
            } else {
                options.workers
            },
            ..options
        }
    }

    /// The octree depth of the pyramid (levels − 1): the max level's range.
    pub fn depth(&self) -> u32 {
        self.source.shape().depth()
    }
}

/// How a view's refinement ended.
pub struct Refinement {
    pub status: StreamStatus,
    /// Frames drawn.
    pub frames: u32,
    pub seconds: f64,
    /// Nothing visible was missing at the end (else `max_wait` ran out).
    pub complete: bool,
    /// Every update's error lines.
    pub errors: Vec<String>,
}

/// Draws `camera`'s view into `target` frame after frame (update, draw, wait for the GPU)
/// until nothing visible is missing or `max_wait` has passed.
pub fn refine(
    context: &GpuContext,
    renderer: &mut VolumeRenderer,
    target: &RenderTarget,
    camera: &Camera,
    settings: &RenderSettings,
    max_wait: Duration,
) -> Result<Refinement, String> {
    let started = Instant::now();
    let mut first_frame = None;
    let mut errors = Vec::new();
    for frames in 1.. {
        let status = renderer
            .update(context)
            .ok_or("refine needs the streaming renderer")?;
        errors.extend(status.errors.iter().cloned());
        let first = *first_frame.get_or_insert(status.frame);
        renderer.render(context, target, camera, settings);
        context.wait_idle().map_err(|e| e.to_string())?;
        let complete = status.complete && status.judged_frame.is_some_and(|f| f >= first);
        if complete || started.elapsed() >= max_wait {
            return Ok(Refinement {
                status,
                frames,
                seconds: started.elapsed().as_secs_f64(),
                complete,
                errors,
            });
        }
        if status.uploads == 0 && status.queued + status.loading > 0 {
            std::thread::sleep(Duration::from_millis(1));
        }
    }
    unreachable!("the loop returns")
}

/// `12 bricks missing (level 0: 10, level 1: 2)`.
pub fn describe_missing(status: &StreamStatus) -> String {
    let per_level: Vec<String> = status
        .counters
        .levels
        .iter()
        .enumerate()
        .filter(|(_, l)| l.requested > 0)
        .map(|(level, l)| format!("level {level}: {}", l.requested))
        .collect();
    format!(
        "{} bricks missing ({})",
        status.missing,
        if per_level.is_empty() {
            "none requested".to_owned()
        } else {
            per_level.join(", ")
        }
    )
}

#[cfg(test)]
mod tests {
    use super::parse_bytes;

    #[test]
    fn sizes_take_binary_units() {
        assert_eq!(parse_bytes("1024"), Ok(1024));
        assert_eq!(parse_bytes("2GiB"), Ok(2 << 30));
        assert_eq!(parse_bytes("512M"), Ok(512 << 20));
        assert_eq!(parse_bytes("1.5 KiB"), Ok(1536));
        for bad in ["", "GiB", "-1G", "3 parsecs", "0"] {
            assert!(parse_bytes(bad).is_err(), "{bad}");
        }
    }
}
