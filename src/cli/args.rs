//! Argument groups shared by the subcommands.

use clap::{Args, ValueEnum};

use crate::octree::{Colormap, OpacityMode, TransferFunction};
use crate::render::{RenderMode, RenderSettings, RendererKind};
use crate::volume::{LoadOptions, RawLayout, ValueWindow};

/// Which volume to open.
#[derive(Debug, Clone, Args)]
pub struct VolumeArgs {
    /// Volume file (.nii, .nii.gz, .nrrd, .nhdr, raw with --raw), a folder (DICOM series,
    /// slices, .zarr / .ome.zarr) or synthetic:KIND:SIZE
    /// (kinds: sphere, shells, noise, gradient; SIZE: N or XxYxZ). Default: the built-in
    /// sample head MRI.
    pub file: Option<String>,
    /// Read FILE as headerless voxels: XxYxZ:TYPE[:le|:be], TYPE one of u8 i8 u16 i16 u32 i32 f32 f64.
    #[arg(long, value_name = "LAYOUT", value_parser = RawLayout::parse)]
    pub raw: Option<RawLayout>,
    /// Voxel size SX,SY,SZ (overrides the file's).
    #[arg(long, value_name = "SX,SY,SZ", value_parser = parse_spacing)]
    pub spacing: Option<[f64; 3]>,
    /// The channel of a multi-channel OME-Zarr image (0 = the first).
    #[arg(long, default_value_t = 0)]
    pub channel: usize,
    /// The time point of a time-lapse OME-Zarr image (0 = the first).
    #[arg(long, default_value_t = 0)]
    pub time: usize,
}

impl VolumeArgs {
    /// The options for [`crate::volume::load`].
    pub fn load_options(&self) -> LoadOptions {
        LoadOptions {
            raw: self.raw,
            spacing: self.spacing,
            zarr: crate::volume::ome_zarr::PyramidOptions {
                channel: self.channel,
                time: self.time,
            },
        }
    }
}

/// The transfer function and rendering options.
#[derive(Debug, Clone, Args)]
pub struct TransferArgs {
    /// How opacity follows the value: alpha = gray value, or binary at --threshold.
    #[arg(long, value_enum, default_value_t = OpacityArg::Gray)]
    pub opacity: OpacityArg,
    /// Binary threshold on the windowed value, 0…1.
    #[arg(long, default_value_t = 0.3, value_parser = parse_unit)]
    pub threshold: f32,
    /// Value window LOW:HIGH in the data's own units (default: 0.5–99.5 percentiles).
    #[arg(long, value_name = "LOW:HIGH", allow_hyphen_values = true, value_parser = ValueWindow::parse)]
    pub window: Option<ValueWindow>,
    /// Colors of the windowed value: grays, viridis, inferno, magma, plasma or cividis.
    #[arg(long, default_value = "grays", value_parser = parse_colormap)]
    pub colormap: Colormap,
    /// Global opacity scale (below 1 makes dense volumes see-through).
    #[arg(long, default_value_t = 1.0)]
    pub density: f32,
    /// Direct volume rendering or maximum intensity projection.
    #[arg(long, value_enum, default_value_t = ModeArg::Dvr)]
    pub mode: ModeArg,
    /// Deepest octree level rays descend to (0 = root only; default: the voxels).
    #[arg(long)]
    pub level: Option<u32>,
    /// Also stop descending where a node projects to less than a pixel.
    #[arg(long)]
    pub pixel_lod: bool,
    /// Composite each node's alpha as is (the paper), without correcting for path length.
    #[arg(long)]
    pub no_opacity_correction: bool,
    /// Draw nodes visited per ray as a heat map instead of the volume.
    #[arg(long)]
    pub heatmap: bool,
    /// The dense renderer samples the nearest voxel instead of filtering trilinearly.
    #[arg(long)]
    pub nearest: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum OpacityArg {
    Gray,
    Binary,
}

/// Which renderer draws the volume.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RendererArg {
    /// The paper's octree (voxel leaves).
    Octree,
    /// One 3D texture at fixed steps (the peers' baseline).
    Dense,
    /// The octree down to bricks (default 32³), marched in a 3D texture atlas.
    Bricks,
}

impl From<RendererArg> for RendererKind {
    fn from(arg: RendererArg) -> Self {
        match arg {
            RendererArg::Octree => RendererKind::Octree,
            RendererArg::Dense => RendererKind::Dense,
            RendererArg::Bricks => RendererKind::Bricks,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ModeArg {
    Dvr,
    Mip,
}

impl TransferArgs {
    /// Every option at its default, as if none were given (clap's defaults, one source).
    pub fn defaults() -> Self {
        use clap::FromArgMatches;
        let command = Self::augment_args(clap::Command::new("defaults"));
        Self::from_arg_matches(&command.get_matches_from(["defaults"]))
            .expect("the defaults of TransferArgs parse")
    }

    /// The transfer function, with `default_window` where no --window was given.
    pub fn transfer_function(&self, default_window: ValueWindow) -> TransferFunction {
        TransferFunction {
            opacity: match self.opacity {
                OpacityArg::Gray => OpacityMode::Gray,
                OpacityArg::Binary => OpacityMode::Binary,
            },
            window: self.window.unwrap_or(default_window),
            threshold: self.threshold,
            colormap: self.colormap,
        }
    }

    /// Render settings for an octree of `depth`; the level is clamped to it.
    pub fn render_settings(&self, depth: u32) -> RenderSettings {
        RenderSettings {
            mode: match self.mode {
                ModeArg::Dvr => RenderMode::Dvr,
                ModeArg::Mip => RenderMode::Mip,
            },
            max_level: self.level.unwrap_or(depth).min(depth),
            pixel_lod: self.pixel_lod,
            opacity_correction: !self.no_opacity_correction,
            density: self.density,
            heatmap: self.heatmap,
            trilinear: !self.nearest,
        }
    }
}

pub(super) fn parse_spacing(text: &str) -> Result<[f64; 3], String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("spacing '{text}' is not SX,SY,SZ"))?;
    match values[..] {
        [x, y, z] if [x, y, z].iter().all(|v| v.is_finite() && *v > 0.0) => Ok([x, y, z]),
        _ => Err(format!("spacing '{text}' needs three positive numbers")),
    }
}

/// A brick side: a power of two from 4 to 32.
pub(super) fn parse_brick_size(text: &str) -> Result<usize, String> {
    match text.parse::<usize>() {
        Ok(n) if n.is_power_of_two() && (4..=32).contains(&n) => Ok(n),
        _ => Err(format!("brick size '{text}' is not 4, 8, 16 or 32")),
    }
}

fn parse_colormap(text: &str) -> Result<Colormap, String> {
    Colormap::from_name(text).ok_or_else(|| {
        let names: Vec<&str> = Colormap::ALL.iter().map(|c| c.name()).collect();
        format!("colormap '{text}' is not one of {}", names.join(", "))
    })
}

fn parse_unit(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(format!("'{text}' is not a number from 0 to 1")),
    }
}
