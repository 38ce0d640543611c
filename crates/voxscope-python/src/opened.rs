//! `voxscope.open()`: anything the command line opens (a file, a folder, an OME-Zarr store
//! on disk or behind an `http(s)://` or `s3://` URL, `synthetic:KIND:SIZE`, `sample`), as a
//! `Volume` that says its shape, dtype, spacing, levels, channels and time points and reads a
//! level as a numpy array. A store is opened by its metadata alone and read level by level; a
//! file is read whole (the frame asked for), as the command line reads it.

use std::sync::Arc;

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use voxscope_render::GpuContext;
use voxscope_render::RendererKind;
use voxscope_scene::{
    Channel, ChannelChoice, DrawOptions, Drawable, OpenOptions, StreamedVolume, VolumeSource,
};
use voxscope_volume::ome_zarr::{Pyramid, PyramidOptions, VOLUME_VOXEL_BUDGET, is_zarr_spec};
use voxscope_volume::{Volume as LoadedVolume, VoxelType};

use crate::arrays::{numpy_dtype, to_numpy};
use crate::drawn::{Drawn, Notice, notice_of};
use crate::errors::{Failure, LoadError, load_error};
use crate::keywords::{Given, OPEN};

/// What was opened: a store read level by level, or a file's frame read whole.
enum Content {
    Store(Arc<Pyramid>),
    File(Arc<LoadedVolume>),
}

/// A volume opened from a path or URL (`voxscope.open`): its facts, its levels read as numpy
/// arrays, and what `render`, `Renderer` and `view` draw.
#[pyclass(name = "Volume", module = "voxscope", frozen)]
pub struct Opened {
    /// The path, URL or spec it was opened from.
    pub spec: String,
    /// The keywords it was opened with (`raw`, `spacing`, `channel`, `time`, `max_requests`).
    pub given: Given,
    args: OpenOptions,
    content: Content,
}

impl Opened {
    /// Opens `spec` with `given` (open's keywords), the GIL released while reading.
    pub fn open(py: Python<'_>, spec: String, given: Given) -> PyResult<Self> {
        let args = given.open_options(&spec)?;
        let store = args.raw.is_none() && is_zarr_spec(&spec);
        let content = py.detach(|| -> Result<Content, voxscope_volume::LoadError> {
            let options = args.load_options();
            if store {
                Ok(Content::Store(Arc::new(Pyramid::open_spec(
                    &spec,
                    options.select,
                    options.remote,
                )?)))
            } else {
                let source = VolumeSource::from_spec(&spec);
                match source.load_with(&options) {
                    Ok(volume) => Ok(Content::File(Arc::new(volume))),
                    Err(voxscope_scene::SceneError::Load(error)) => Err(error),
                    Err(other) => Err(voxscope_volume::LoadError::new(&spec, other.to_string())),
                }
            }
        });
        Ok(Self {
            spec,
            given,
            args,
            content: content.map_err(load_error)?,
        })
    }

    /// The same source with channel and time point `select` (re-opened where they differ).
    pub fn reselected(
        &self,
        py: Python<'_>,
        channel: Option<usize>,
        time: Option<usize>,
    ) -> PyResult<Option<Self>> {
        let current = self.selection();
        let wanted_channel = channel.unwrap_or(current.channel);
        let wanted_time = time.unwrap_or(current.time);
        let channel_changes = channel.is_some()
            && !matches!(self.args.channel, Some(ChannelChoice::Index(c)) if c == wanted_channel);
        if !channel_changes && wanted_time == current.time {
            return Ok(None);
        }
        let mut given = self.given.clone();
        given
            .words
            .retain(|(name, _)| *name != "channel" && *name != "time");
        if channel.is_some() || self.args.channel.is_some() {
            given
                .words
                .push(("channel", vec![format!("--channel={wanted_channel}")]));
        }
        given
            .words
            .push(("time", vec![format!("--time={wanted_time}")]));
        Self::open(py, self.spec.clone(), given).map(Some)
    }

    /// The frame this volume reads.
    fn selection(&self) -> PyramidOptions {
        match &self.content {
            Content::Store(pyramid) => pyramid.selected,
            Content::File(volume) => volume.series.selected,
        }
    }

    /// Channels of the file.
    fn channel_count(&self) -> usize {
        match &self.content {
            Content::Store(pyramid) => pyramid.channels,
            Content::File(volume) => volume.series.channel_count(),
        }
    }

    /// What `render` would draw of it with `options`, made on `context`: streamed (asked
    /// for, or a store larger than 512³ without another renderer asked for, as the app
    /// streams it), the composite of its channels (none chosen, 2 to 8 of them), or the
    /// frame in memory (a store's finest level within 512³).
    pub fn drawn(
        &self,
        context: &Arc<GpuContext>,
        options: &DrawOptions,
    ) -> Result<(Drawn, Notice), Failure> {
        let (mut drawn, notice) = self.drawn_volume(context, options)?;
        drawn.open_labels(&self.args, options)?;
        Ok((drawn, notice))
    }

    /// [`Self::drawn`] without its label overlays.
    fn drawn_volume(
        &self,
        context: &Arc<GpuContext>,
        options: &DrawOptions,
    ) -> Result<(Drawn, Notice), Failure> {
        let source = VolumeSource::from_spec(&self.spec);
        let large_store = match &self.content {
            Content::Store(pyramid) => pyramid.levels[0].voxel_count() > VOLUME_VOXEL_BUDGET as u64,
            Content::File(_) => false,
        };
        let streams = options.renderer == Some(RendererKind::Stream)
            || (large_store && options.renderer.is_none());
        let composite =
            self.channel_count() > 1 && !matches!(self.args.channel, Some(ChannelChoice::Index(_)));
        if let (true, true, Content::Store(pyramid)) = (streams, composite, &self.content) {
            // A store's channels stream together.
            let drawn =
                Drawable::of_channels_of_store(Arc::clone(context), (**pyramid).clone(), options)?;
            return Ok((drawn, None));
        }
        if streams {
            let saved = options.transfer.saved()?;
            // The renderer is made while a store's first chunks are on their way.
            let opened = StreamedVolume::open_with_renderer(
                &source,
                &self.args.load_options(),
                &options.transfer.request(saved.as_ref()),
                options.stream,
                || Ok(Arc::clone(context)),
            )?;
            return Ok((Drawable::streamed(opened, saved), None));
        }
        let channels: Vec<Channel> = if composite {
            let chosen = &options.channels.chosen;
            let volumes = self.args.chosen_channels(chosen)?.unwrap_or_default();
            volumes.iter().map(Channel::of_volume).collect()
        } else {
            match &self.content {
                Content::File(volume) => vec![Channel::of_volume(volume)],
                Content::Store(_) => vec![Channel::of_volume(&self.args.load()?)],
            }
        };
        let drawn = Drawable::of_channels(Arc::clone(context), &source, channels, options)?;
        let notice = notice_of(&drawn);
        Ok((drawn, notice))
    }
}

/// A numpy dtype name of a stored type.
fn dtype_name(voxel_type: VoxelType) -> &'static str {
    match voxel_type {
        VoxelType::U8 => "uint8",
        VoxelType::I8 => "int8",
        VoxelType::U16 => "uint16",
        VoxelType::I16 => "int16",
        VoxelType::U32 => "uint32",
        VoxelType::I32 => "int32",
        VoxelType::F32 => "float32",
        VoxelType::F64 => "float64",
    }
}

/// (z, y, x) of x, y, z.
fn zyx<T: Copy>(xyz: [T; 3]) -> (T, T, T) {
    (xyz[2], xyz[1], xyz[0])
}

#[pymethods]
impl Opened {
    /// The path, URL or spec it was opened from, as given to `open()`.
    #[getter]
    fn source(&self) -> String {
        self.spec.clone()
    }

    /// The command line's words for the keywords it was opened with (`--raw=…`,
    /// `--spacing=…`, `--channel=…`, `--time=…`).
    #[getter]
    fn options(&self) -> Vec<String> {
        self.given.argv()
    }

    /// The path, URL or spec it was opened from.
    #[getter]
    fn name(&self) -> String {
        match &self.content {
            Content::Store(pyramid) => pyramid.source.clone(),
            Content::File(volume) => volume.name.clone(),
        }
    }

    /// The format: `NIfTI-1`, `DICOM`, `OME-Zarr`, `TIFF`, …
    #[getter]
    fn format(&self) -> &'static str {
        match &self.content {
            Content::Store(pyramid) => pyramid.format,
            Content::File(volume) => volume.format,
        }
    }

    /// Voxels along (z, y, x) at full resolution (level 0).
    #[getter]
    fn shape(&self) -> (usize, usize, usize) {
        match &self.content {
            Content::Store(pyramid) => zyx(pyramid.levels[0].dims),
            Content::File(volume) => zyx(volume.dims),
        }
    }

    /// The numpy dtype that `read()` returns: the stored type, or float where the file scales
    /// its values (NIfTI `scl_slope`, DICOM rescale) to the data's units.
    #[getter]
    fn dtype<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let name = match &self.content {
            Content::Store(pyramid) => dtype_name(pyramid.voxel_type),
            Content::File(volume) => numpy_dtype(volume),
        };
        py.import("numpy")?.getattr("dtype")?.call1((name,))
    }

    /// Voxel size along (z, y, x) at level 0, in `unit`s.
    #[getter]
    fn spacing(&self) -> (f64, f64, f64) {
        match &self.content {
            Content::Store(pyramid) => zyx(pyramid.levels[0].spacing),
            Content::File(volume) => zyx(volume.spacing),
        }
    }

    /// The unit of `spacing` (the file's, else `mm`).
    #[getter]
    fn unit(&self) -> String {
        match &self.content {
            Content::Store(pyramid) => pyramid.units[0].clone().unwrap_or_else(|| "mm".into()),
            Content::File(volume) => volume.spatial_unit().unwrap_or_default().to_owned(),
        }
    }

    /// The shape (z, y, x) of each level, finest first: an OME-Zarr store's pyramid; one
    /// level for a file, which is read whole.
    #[getter]
    fn levels(&self) -> Vec<(usize, usize, usize)> {
        match &self.content {
            Content::Store(pyramid) => pyramid.levels.iter().map(|l| zyx(l.dims)).collect(),
            Content::File(volume) => vec![zyx(volume.dims)],
        }
    }

    /// The channels' names (the file's, else `channel N`).
    #[getter]
    fn channels(&self) -> Vec<String> {
        let series = match &self.content {
            Content::Store(pyramid) => pyramid.series(),
            Content::File(volume) => volume.series.clone(),
        };
        series
            .channels
            .iter()
            .enumerate()
            .map(|(i, c)| c.name.clone().unwrap_or_else(|| format!("channel {i}")))
            .collect()
    }

    /// Time points in the file.
    #[getter]
    fn time_points(&self) -> usize {
        match &self.content {
            Content::Store(pyramid) => pyramid.time_points,
            Content::File(volume) => volume.series.time_points,
        }
    }

    /// The channel and time point `read()` and the renderers read unless told: `(channel,
    /// time)`.
    #[getter]
    fn selected(&self) -> (usize, usize) {
        let selected = self.selection();
        (selected.channel, selected.time)
    }

    /// Reads level `level` (0: full resolution) of `channel` at `time` (default: the ones
    /// opened) as a numpy array (z, y, x) in the data's units, with the GIL released. A
    /// level larger than 2³² voxels is refused; a file has level 0 alone.
    #[pyo3(signature = (level = 0, *, channel = None, time = None))]
    fn read<'py>(
        &self,
        py: Python<'py>,
        level: usize,
        channel: Option<usize>,
        time: Option<usize>,
    ) -> PyResult<Bound<'py, PyAny>> {
        if let Some(other) = self.reselected(py, channel, time)? {
            return other.read(py, level, None, None);
        }
        let volume = match &self.content {
            Content::Store(pyramid) => {
                if level >= pyramid.levels.len() {
                    return Err(PyValueError::new_err(format!(
                        "{}: no level {level} (it has {}: 0 to {})",
                        pyramid.source,
                        pyramid.levels.len(),
                        pyramid.levels.len() - 1
                    )));
                }
                let pyramid = Arc::clone(pyramid);
                Arc::new(
                    py.detach(|| pyramid.level_volume(level))
                        .map_err(load_error)?,
                )
            }
            Content::File(volume) => {
                if level > 0 {
                    return Err(PyValueError::new_err(format!(
                        "{}: no level {level}: a file has level 0 alone (OME-Zarr stores have levels)",
                        volume.name
                    )));
                }
                Arc::clone(volume)
            }
        };
        to_numpy(py, &volume)
    }

    fn __repr__(&self) -> String {
        let (z, y, x) = self.shape();
        let (sz, sy, sx) = self.spacing();
        let dtype = match &self.content {
            Content::Store(pyramid) => dtype_name(pyramid.voxel_type),
            Content::File(volume) => numpy_dtype(volume),
        };
        format!(
            "<voxscope.Volume {:?}: {} shape (z, y, x) = ({z}, {y}, {x}), {dtype}, spacing ({sz}, {sy}, {sx}) {}, {} levels, {} channels, {} time points>",
            self.name(),
            self.format(),
            self.unit(),
            self.levels().len(),
            self.channel_count(),
            self.time_points()
        )
    }
}

/// `voxscope.open(source, **options)`.
pub fn open_source(
    py: Python<'_>,
    source: &Bound<'_, PyAny>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<Opened> {
    let spec = spec_of(source)?;
    let given = Given::read(options, OPEN, "open")?;
    Opened::open(py, spec, given)
}

/// A path, `os.PathLike` or URL as text.
pub fn spec_of(source: &Bound<'_, PyAny>) -> PyResult<String> {
    let py = source.py();
    let text = py
        .import("os")?
        .call_method1("fspath", PyTuple::new(py, [source])?)
        .map_err(|_| {
            PyTypeError::new_err(format!(
                "{} is not a path, URL or volume",
                source
                    .get_type()
                    .name()
                    .map(|n| n.to_string())
                    .unwrap_or_default()
            ))
        })?;
    text.extract::<String>()
        .map_err(|_| LoadError::new_err("paths are read as text (a bytes path was given)"))
}
