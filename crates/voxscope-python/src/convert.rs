//! `voxscope.convert()`: `voxscope convert` from Python. Any volume voxscope opens, or a numpy
//! array (z, y, x), written as a multiscale OME-Zarr image (0.4, or 0.5 sharded), with the
//! GIL released. An array is copied once into voxscope's layout before it is written.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::Path;

use voxscope_volume::Volume;
use voxscope_volume::ome_zarr::SlabSource;

use crate::arrays::{spacing_of, supported_array};
use crate::errors::LoadError;
use crate::keywords::{CONVERT, Given};
use crate::opened::spec_of;

/// convert(source, output, **options) -> list[tuple[int, int, int]]
///
/// Writes `source` (a path or URL voxscope opens, a `voxscope.Volume`, or a numpy array (z,
/// y, x) with `spacing=` in the same order) as the OME-Zarr image `output`, which must not
/// exist. Options are `voxscope convert`'s: `format` ("0.4" or "0.5"), `chunk`, `shard`,
/// `compression`, `labels`, `unit`, `tile`, `upsample`, `noise`, and for a path `raw`,
/// `spacing`, `channel`, `time`, `max_requests`. Returns each level's shape (z, y, x), finest first.
#[pyfunction]
#[pyo3(signature = (source, output, **options))]
pub fn convert(
    py: Python<'_>,
    source: &Bound<'_, PyAny>,
    output: &Bound<'_, PyAny>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<Vec<(usize, usize, usize)>> {
    let output = spec_of(output)?;
    let is_array = source.hasattr("__array__")? || source.hasattr("__array_interface__")?;
    let levels = if is_array {
        let options = match options {
            Some(options) => options.copy()?,
            None => PyDict::new(py),
        };
        let spacing = spacing_of(options.get_item("spacing")?.as_ref())?;
        let name: String = match options.get_item("name")? {
            Some(name) => name.extract()?,
            None => "array".to_owned(),
        };
        for key in ["spacing", "name"] {
            if options.contains(key)? {
                options.del_item(key)?;
            }
        }
        let given = Given::read(Some(&options), CONVERT, "convert")?;
        let options = given.convert_options()?;
        let volume = array_volume(source, &name, spacing)?;
        py.detach(|| {
            let source = SlabSource::from_volume(volume);
            voxscope_scene::convert(source, &name, Path::new(&output), &options, |_| {})
        })
    } else {
        let (spec, options) = path_source(source, options, &output)?;
        py.detach(|| {
            let source = SlabSource::open(&spec, &options.load_options())?;
            voxscope_scene::convert(source, &spec, Path::new(&output), &options, |_| {})
        })
    };
    let levels = levels.map_err(|e| LoadError::new_err(e.to_string()))?;
    Ok(levels.into_iter().map(|[x, y, z]| (z, y, x)).collect())
}

/// The path or URL `source` names (a Volume converts as it was opened: its `raw`, `spacing`,
/// channel and time) and the convert options `options` give for it; refused where it is
/// `output`.
fn path_source(
    source: &Bound<'_, PyAny>,
    options: Option<&Bound<'_, PyDict>>,
    output: &str,
) -> PyResult<(String, voxscope_scene::ConvertOptions)> {
    let given = Given::read(options, CONVERT, "convert")?;
    let (spec, given) = match source.cast::<crate::opened::Opened>() {
        Ok(volume) => (volume.get().spec.clone(), volume.get().given.with(&given)),
        Err(_) => (spec_of(source)?, given),
    };
    if Path::new(&spec) == Path::new(output) {
        return Err(PyValueError::new_err(format!(
            "{output}: the output is the input"
        )));
    }
    Ok((spec, given.convert_options()?))
}

/// A 3-D array (z, y, x) copied into a [`Volume`].
fn array_volume(source: &Bound<'_, PyAny>, name: &str, spacing: [f64; 3]) -> PyResult<Volume> {
    use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
    let array = supported_array(source)?;
    let shape = array.shape().to_vec();
    let [z, y, x] = shape[..] else {
        return Err(PyValueError::new_err(format!(
            "{name}: convert() writes one (z, y, x) volume; this array has shape {shape:?}"
        )));
    };
    macro_rules! typed {
        ($($t:ty),*) => {
            $(
                if let Ok(typed) = array.cast::<PyArrayDyn<$t>>() {
                    let values: Vec<$t> = typed.readonly().as_array().as_standard_layout().iter().copied().collect();
                    return Volume::new(name, "NumPy array", [x, y, z], spacing, <$t as voxscope_volume::Scalar>::wrap(values))
                        .map_err(|e| PyValueError::new_err(e.to_string()));
                }
            )*
        };
    }
    typed!(u8, i8, u16, i16, u32, i32, f32, f64);
    Err(PyValueError::new_err(format!(
        "{name}: the array's dtype is not one voxscope stores"
    )))
}

/// _convert_plan(source, output, parts, part_memory="512MiB", **options) -> str
///
/// `voxscope convert plan`: reads only `source`'s metadata (a path or URL voxscope opens),
/// writes the output's arrays and a plan of `parts` parts (each column slab within
/// `part_memory`) into `output`, and returns
/// `output`: what `convert.run_part(plan, i)` and `convert.finalize(plan)` take, on any
/// machine that shares the folder (a string, so Dask and Ray ship it as it is).
#[pyfunction]
#[pyo3(signature = (source, output, parts, part_memory = "512MiB", **options))]
pub fn _convert_plan(
    py: Python<'_>,
    source: &Bound<'_, PyAny>,
    output: &Bound<'_, PyAny>,
    parts: usize,
    part_memory: &str,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<String> {
    let output = spec_of(output)?;
    let part_memory = voxscope_scene::option_text::parse_bytes(part_memory)
        .map_err(|e| PyValueError::new_err(format!("part_memory={part_memory:?}: {e}")))?;
    let (spec, options) = path_source(source, options, &output)?;
    py.detach(|| {
        let source = SlabSource::open(&spec, &options.load_options())?;
        voxscope_scene::plan_conversion(
            source,
            &spec,
            Path::new(&output),
            &options,
            parts,
            Some(part_memory),
        )
        .map(|_| ())
    })
    .map_err(|e| LoadError::new_err(e.to_string()))?;
    // Absolute, so that a worker started elsewhere finds it.
    Ok(std::fs::canonicalize(&output)
        .map(|path| path.display().to_string())
        .unwrap_or(output))
}

/// _convert_run_part(plan, part) -> dict
///
/// `voxscope convert run PLAN --part I/N`: writes part `part` of the conversion `plan` (the
/// output folder) names, or returns at once where it has finished. Returns its marker's
/// figures: `part`, `parts`, `objects`, `bytes_in`, `bytes_out`, `seconds`,
/// `peak_memory_bytes` and `already_done`.
#[pyfunction]
pub fn _convert_run_part<'py>(
    py: Python<'py>,
    plan: &Bound<'py, PyAny>,
    part: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let output = spec_of(plan)?;
    let outcome = py
        .detach(|| voxscope_scene::run_part(Path::new(&output), part, None, None, |_| {}))
        .map_err(|e| LoadError::new_err(e.to_string()))?;
    let (marker, already_done) = match outcome {
        voxscope_scene::PartOutcome::Written(marker) => (marker, false),
        voxscope_scene::PartOutcome::AlreadyDone(marker) => (marker, true),
    };
    let figures = PyDict::new(py);
    figures.set_item("part", marker.part)?;
    figures.set_item("parts", marker.parts)?;
    figures.set_item("objects", marker.objects.len())?;
    figures.set_item("bytes_in", marker.bytes_in)?;
    figures.set_item("bytes_out", marker.bytes_out)?;
    figures.set_item("seconds", marker.seconds)?;
    figures.set_item("peak_memory_bytes", marker.peak_memory_bytes)?;
    figures.set_item("already_done", already_done)?;
    Ok(figures)
}

/// _convert_finalize(plan) -> list[tuple[int, int, int]]
///
/// `voxscope convert finalize PLAN`: checks every part, builds the coarsest levels and writes
/// the image's metadata, last. Returns each level's shape (z, y, x), finest first.
#[pyfunction]
pub fn _convert_finalize(
    py: Python<'_>,
    plan: &Bound<'_, PyAny>,
) -> PyResult<Vec<(usize, usize, usize)>> {
    let output = spec_of(plan)?;
    let levels = py
        .detach(|| voxscope_scene::finalize(Path::new(&output), |_| {}))
        .map_err(|e| LoadError::new_err(e.to_string()))?;
    Ok(levels.into_iter().map(|[x, y, z]| (z, y, x)).collect())
}
