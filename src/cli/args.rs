//! Argument groups shared by the subcommands.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use voxscope_scene::option_text::{
    parse_colormap, parse_max_requests, parse_preset, parse_shininess, parse_spacing, parse_unit,
};

use voxscope_octree::{Clip, ClipPlane, Colormap, OpacityCurve, OpacityMode, Preset};
use voxscope_render::{RenderMode, RendererKind, Shading};
pub use voxscope_scene::ChannelChoice;
use voxscope_scene::{OpenOptions, SavedTransfer, SceneError, TransferOptions};
use voxscope_volume::{LoadError, LoadErrorKind, LoadOptions, RawLayout, ValueWindow};

/// Which volume to open.
#[derive(Debug, Clone, Args)]
pub struct VolumeArgs {
    /// Volume file (.nii, .nii.gz, .nrrd, .nhdr, raw with --raw), a folder (DICOM series,
    /// slices, .zarr / .ome.zarr), a Zarr store's URL (http://, https://, s3://BUCKET/PATH)
    /// or synthetic:KIND:SIZE (kinds: sphere, shells, noise, gradient, ct, labels; SIZE: N or
    /// XxYxZ). Default: the built-in sample head MRI.
    pub file: Option<String>,
    /// Read FILE as headerless voxels: XxYxZ:TYPE[:le|:be], TYPE one of u8 i8 u16 i16 u32 i32 f32 f64.
    #[arg(long, value_name = "LAYOUT", value_parser = RawLayout::parse)]
    pub raw: Option<RawLayout>,
    /// Voxel size SX,SY,SZ (overrides the file's).
    #[arg(long, value_name = "SX,SY,SZ", value_parser = parse_spacing)]
    pub spacing: Option<[f64; 3]>,
    /// The channel of a multi-channel image (0 = the first), or `all`: OME-Zarr, OME-TIFF,
    /// ImageJ hyperstacks, NIfTI (dim 5), NRRD (a list, vector or color axis). `render`,
    /// `bench`, `info` and `probe` show all channels of a multi-channel file unless one is
    /// chosen; other commands read channel 0.
    #[arg(long, value_name = "N|all", value_parser = ChannelChoice::parse)]
    pub channel: Option<ChannelChoice>,
    /// Files opened together as the channels of one volume (same dimensions), instead of FILE.
    #[arg(
        long,
        value_name = "A,B,…",
        value_delimiter = ',',
        conflicts_with = "file"
    )]
    pub channels_from: Option<Vec<String>>,
    /// The time point of a time series (0 = the first): OME-Zarr, OME-TIFF, ImageJ
    /// hyperstacks, 4-D NIfTI and NRRD.
    #[arg(long, default_value_t = 0)]
    pub time: usize,
    /// A URL's store: requests in flight at once, at most (1 to 1024).
    #[arg(long, value_name = "N", default_value_t = voxscope_volume::remote::DEFAULT_MAX_REQUESTS, value_parser = parse_max_requests)]
    pub max_requests: usize,
    /// The field of an HCS plate (OME-Zarr `plate`) to open, as ROW/COLUMN/FIELD (`B/3/0`);
    /// default: the first well's first field (`info` lists them all).
    #[arg(long, value_name = "ROW/COLUMN/FIELD", value_parser = parse_field)]
    pub field: Option<String>,
    /// The series of a bioformats2raw container to open (0, 1, …); default: the first
    /// (`info` lists them all).
    #[arg(long, value_name = "N", conflicts_with = "field")]
    pub series: Option<u32>,
}

/// `--field ROW/COLUMN/FIELD`: three path components inside the plate.
fn parse_field(text: &str) -> Result<String, String> {
    let parts: Vec<&str> = text.trim().trim_matches('/').split('/').collect();
    let valid = |part: &&str| {
        !part.is_empty()
            && *part != "."
            && *part != ".."
            && part
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    };
    if parts.len() == 3 && parts.iter().all(valid) {
        Ok(parts.join("/"))
    } else {
        Err(format!("'{text}' is not ROW/COLUMN/FIELD (e.g. B/3/0)"))
    }
}

/// FILE's series `series` (a bioformats2raw container's group of that number).
pub fn series_file(file: &str, series: u32) -> String {
    format!("{}/{series}", file.trim_end_matches('/'))
}

/// A load error as the command line says it: a file no format recognized can still be read
/// as raw voxels here, and the message says how (the app, which has no `--raw`, does not).
pub fn load_error_text(error: &LoadError) -> String {
    match error.kind {
        LoadErrorKind::Unrecognized => format!("{error}, or raw voxels with --raw WxHxD:TYPE"),
        _ => error.to_string(),
    }
}

/// A scene error as the command line says it: a load error with [`load_error_text`]'s
/// advice; a volume beyond the octree with the renderers that draw it.
pub fn scene_error_text(error: &SceneError) -> String {
    match error {
        SceneError::Load(load) => load_error_text(load),
        SceneError::BeyondOctree(text) => format!(
            "{text} (render draws it with --renderer bricks or stream, bench with --stream)"
        ),
        _ => error.to_string(),
    }
}

impl VolumeArgs {
    /// FILE with `--field`'s field path appended (the field of a plate is an image group
    /// inside it); an error for `--field` without FILE.
    pub fn apply_field(&mut self) -> Result<(), String> {
        let Some(field) = self.field.take() else {
            return Ok(());
        };
        match &mut self.file {
            Some(file) => {
                *file = format!("{}/{field}", file.trim_end_matches('/'));
                Ok(())
            }
            None => Err(format!("--field {field} needs a plate to open")),
        }
    }

    /// FILE with `--series`'s series group appended (a bioformats2raw container's series `N`
    /// is its group `N`; one it lacks is named with the container's count when opened); an
    /// error for `--series` without FILE.
    pub fn apply_series(&mut self) -> Result<(), String> {
        let Some(series) = self.series.take() else {
            return Ok(());
        };
        match &mut self.file {
            Some(file) => {
                *file = series_file(file, series);
                Ok(())
            }
            None => Err(format!(
                "--series {series} needs a bioformats2raw container to open"
            )),
        }
    }

    /// What to open, as the scene layer takes it (`--field` and `--series` applied already).
    pub fn open_options(&self) -> OpenOptions {
        OpenOptions {
            source: self.file.clone(),
            raw: self.raw,
            spacing: self.spacing,
            channel: self.channel,
            channels_from: self.channels_from.clone(),
            time: self.time,
            max_requests: self.max_requests,
        }
    }

    /// Reads FILE (the channel and time point chosen), or the built-in sample without one.
    pub fn load(&self) -> Result<voxscope_volume::Volume, String> {
        self.open_options().load().map_err(|e| scene_error_text(&e))
    }

    /// FILE, or the built-in sample without one, as the scene layer opens it.
    pub fn source(&self) -> voxscope_scene::VolumeSource {
        self.open_options().volume_source()
    }

    /// The options for [`voxscope_volume::load`].
    pub fn load_options(&self) -> LoadOptions {
        self.open_options().load_options()
    }
}

impl VolumeArgs {
    /// The channels to composite, when these options ask for a composite or leave it to the
    /// file (`--channel` not a number): every channel of FILE at `--time`, or the
    /// `--channels-from` files. `None` when one channel was chosen.
    pub fn composite_channels(&self) -> Result<Option<Vec<voxscope_volume::Volume>>, String> {
        self.open_options()
            .composite_channels()
            .map_err(|e| scene_error_text(&e))
    }

    /// Whether these options leave the channels to the file (`--channel` not a number): a file
    /// of several channels is then their composite.
    pub fn wants_composite(&self) -> bool {
        self.open_options().wants_composite()
    }
}

/// The transfer function and rendering options.
#[derive(Debug, Clone, Args)]
pub struct TransferArgs {
    /// How opacity follows the value: alpha = gray value, or binary at --threshold. Without
    /// it (or --opacity-points, --preset, --tf), the data decides: CT opens with the
    /// ct-soft-tissue preset, label volumes with the labels colormap, the rest with gray.
    #[arg(long, value_enum, conflicts_with_all = ["opacity_points", "preset", "tf"])]
    pub opacity: Option<OpacityArg>,
    /// A piecewise-linear opacity curve V:A,V:A,… (value in data units, opacity 0…1, sorted
    /// by value; linear in between, flat outside).
    #[arg(long, value_name = "V:A,…", allow_hyphen_values = true, value_parser = OpacityCurve::parse, conflicts_with_all = ["preset", "tf"])]
    pub opacity_points: Option<OpacityCurve>,
    /// A volume-rendering preset: ct-soft-tissue, ct-bone, ct-vessels, ct-lung, ct-skin
    /// (Hounsfield units) or ramp (60th to 99.5th percentile).
    #[arg(long, value_name = "NAME", value_parser = parse_preset, conflicts_with = "tf")]
    pub preset: Option<Preset>,
    /// A transfer function saved by the app (File > Save transfer function…, RON): its
    /// curve, window and colormap, and its opacity scale and mode unless given here.
    #[arg(long, value_name = "FILE.ron")]
    pub tf: Option<PathBuf>,
    /// Binary threshold on the windowed value, 0…1.
    #[arg(long, default_value_t = 0.3, value_parser = parse_unit)]
    pub threshold: f32,
    /// Value window LOW:HIGH in the data's own units (default: 0.5–99.5 percentiles).
    #[arg(long, value_name = "LOW:HIGH", allow_hyphen_values = true, value_parser = ValueWindow::parse)]
    pub window: Option<ValueWindow>,
    /// Colors of the windowed value: grays, viridis, inferno, magma, plasma, cividis or
    /// labels (default: grays; labels for label volumes).
    #[arg(long, value_parser = parse_colormap)]
    pub colormap: Option<Colormap>,
    /// Global opacity scale (below 1 makes dense volumes see-through; default 1).
    #[arg(long)]
    pub density: Option<f32>,
    /// Direct volume rendering or maximum intensity projection (default: dvr).
    #[arg(long, value_enum)]
    pub mode: Option<ModeArg>,
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
    /// Shade DVR with a headlight (Blinn-Phong on the volume's gradient; the octree's voxel
    /// faces): the default.
    #[arg(long, overrides_with = "no_shading")]
    pub shading: bool,
    /// Draw the transfer function's colors unshaded (the paper's picture).
    #[arg(long, overrides_with = "shading")]
    pub no_shading: bool,
    /// Shading: the share of the color that does not depend on the surface's direction, 0…1
    /// (default 0.1).
    #[arg(long, value_parser = parse_unit)]
    pub ambient: Option<f32>,
    /// Shading: the share that follows the angle between surface and light, 0…1 (default 0.9).
    #[arg(long, value_parser = parse_unit)]
    pub diffuse: Option<f32>,
    /// Shading: the white highlight's strength, 0…1 (default 0.2).
    #[arg(long, value_parser = parse_unit)]
    pub specular: Option<f32>,
    /// Shading: the highlight's exponent, 1…128 (default 10; larger is sharper).
    #[arg(long, value_parser = parse_shininess)]
    pub shininess: Option<f32>,
}

/// Clipping: a crop box and one clip plane, in normalized volume coordinates (0…1 along each
/// axis of the displayed volume). A group of its own so that every command that draws (and the
/// app's command line) can take it.
#[derive(Debug, Clone, Default, Args)]
pub struct ClipArgs {
    /// Crop box: the fractions of each axis that stay drawn, X0:X1,Y0:Y1,Z0:Z1 (each 0…1,
    /// low below high).
    #[arg(long, value_name = "X0:X1,Y0:Y1,Z0:Z1", value_parser = Clip::parse_box)]
    pub clip_box: Option<[[f32; 2]; 3]>,
    /// Clip plane NX,NY,NZ,D in normalized volume coordinates: the side where
    /// NX·x + NY·y + NZ·z ≥ D stays drawn (`--clip-plane=-1,0,0,-0.5` keeps x ≤ 0.5).
    #[arg(long, value_name = "NX,NY,NZ,D", allow_hyphen_values = true, value_parser = Clip::parse_plane)]
    pub clip_plane: Option<ClipPlane>,
}

impl ClipArgs {
    /// The clip these options describe ([`Clip::NONE`] without them).
    pub fn clip(&self) -> Clip {
        Clip {
            bounds: self.clip_box,
            plane: self.clip_plane,
        }
    }
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
    /// A pyramid of 32³ bricks streamed into a fixed GPU budget (--gpu-memory, --ram-cache):
    /// volumes of any size.
    Stream,
}

impl From<RendererArg> for RendererKind {
    fn from(arg: RendererArg) -> Self {
        match arg {
            RendererArg::Octree => RendererKind::Octree,
            RendererArg::Dense => RendererKind::Dense,
            RendererArg::Bricks => RendererKind::Bricks,
            RendererArg::Stream => RendererKind::Stream,
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

    /// What these options ask of the transfer function and the render settings, as the scene
    /// layer takes it: --shading / --no-shading (on unless the last of them is
    /// --no-shading) with the parameters given, else [`Shading::default`]'s.
    pub fn options(&self) -> TransferOptions {
        let opacity = match (self.opacity_points, self.opacity) {
            (Some(curve), _) => Some(OpacityMode::Points(curve)),
            (None, Some(OpacityArg::Gray)) => Some(OpacityMode::Gray),
            (None, Some(OpacityArg::Binary)) => Some(OpacityMode::Binary),
            (None, None) => None,
        };
        let defaults = Shading::default();
        TransferOptions {
            opacity,
            preset: self.preset,
            tf: self.tf.clone(),
            threshold: self.threshold,
            window: self.window,
            colormap: self.colormap,
            density: self.density,
            mode: self.mode.map(|mode| match mode {
                ModeArg::Dvr => RenderMode::Dvr,
                ModeArg::Mip => RenderMode::Mip,
            }),
            level: self.level,
            pixel_lod: self.pixel_lod,
            opacity_correction: !self.no_opacity_correction,
            heatmap: self.heatmap,
            trilinear: !self.nearest,
            shading: Shading {
                enabled: !self.no_shading,
                ambient: self.ambient.unwrap_or(defaults.ambient),
                diffuse: self.diffuse.unwrap_or(defaults.diffuse),
                specular: self.specular.unwrap_or(defaults.specular),
                shininess: self.shininess.unwrap_or(defaults.shininess),
            },
            saved: None,
        }
    }

    /// The saved transfer function of --tf, if given.
    pub fn saved(&self) -> Result<Option<SavedTransfer>, String> {
        self.options().saved().map_err(|e| e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;

    /// A command of just these groups, as `render` and `bench` flatten them.
    #[derive(Debug, Parser)]
    struct Both {
        #[command(flatten)]
        transfer: TransferArgs,
        #[command(flatten)]
        clip: ClipArgs,
    }

    fn parse(args: &[&str]) -> Result<Both, clap::Error> {
        Both::try_parse_from(std::iter::once("test").chain(args.iter().copied()))
    }

    #[test]
    fn shading_is_on_unless_the_last_word_is_no_shading() {
        let shading = |args: &[&str]| parse(args).expect("parses").transfer.options().shading;
        assert_eq!(shading(&[]), Shading::default());
        assert!(shading(&[]).enabled);
        assert!(!shading(&["--no-shading"]).enabled);
        assert!(shading(&["--no-shading", "--shading"]).enabled);
        assert!(!shading(&["--shading", "--no-shading"]).enabled);
        let custom = shading(&[
            "--ambient",
            "0.3",
            "--diffuse",
            "0.6",
            "--specular",
            "0",
            "--shininess",
            "40",
        ]);
        assert_eq!(
            [
                custom.ambient,
                custom.diffuse,
                custom.specular,
                custom.shininess
            ],
            [0.3, 0.6, 0.0, 40.0]
        );
        for bad in [
            &["--ambient", "2"][..],
            &["--shininess", "0"],
            &["--specular", "x"],
        ] {
            assert!(parse(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn clip_options_make_a_clip_and_refuse_nonsense() {
        let clip = |args: &[&str]| parse(args).expect("parses").clip.clip();
        assert_eq!(clip(&[]), Clip::NONE);
        let both = clip(&["--clip-box", "0:0.5,0.25:1,0:1", "--clip-plane=-1,0,0,-0.4"]);
        assert_eq!(both.bounds, Some([[0.0, 0.5], [0.25, 1.0], [0.0, 1.0]]));
        let plane = both.plane.expect("a plane");
        assert_eq!((plane.normal, plane.distance), ([-1.0, 0.0, 0.0], -0.4));
        for bad in [
            &["--clip-box", "0:1,0:1"][..],
            &["--clip-box", "0.5:0.2,0:1,0:1"],
            &["--clip-plane", "0,0,0,1"],
        ] {
            assert!(parse(bad).is_err(), "{bad:?}");
        }
    }
}
