//! voxscope in Python (the `voxscope._voxscope` extension module; the package around it is
//! `python/voxscope`): numpy arrays and anything the command line opens, rendered on the GPU
//! into numpy images; a `Renderer` that keeps a volume resident for frame after frame;
//! `open()` for a file's or store's facts and levels; `convert()` to OME-Zarr; the command
//! line and the app (`python -m voxscope`, which `view()` starts in a child process).
//!
//! Every rendering keyword is the `render` option of the same name, parsed by the command
//! line's own option groups (`keywords.rs`); errors carry its one-line messages. The layers
//! below are the scene layer (`voxscope-scene`) and the renderers (`voxscope-render`); the
//! app (egui) is reached only through the command line, in another process.

mod arrays;
mod camera_keywords;
mod command_line;
mod convert;
mod drawn;
mod errors;
mod gpu;
mod keyword_values;
mod keywords;
mod opened;
mod renderer;

use pyo3::prelude::*;
use pyo3::types::PyDict;

/// open(source, **options) -> Volume
///
/// Opens a file (an Imaris file is read like a store), folder (DICOM series, slices,
/// OME-Zarr, N5, precomputed), a store's URL (http://, https://, s3://BUCKET/PATH),
/// `synthetic:KIND:SIZE` or `sample`, as the command line does, with the GIL released. Options: `raw` ("XxYxZ:TYPE[:le|:be]"), `spacing` ((sz,
/// sy, sx)), `channel`, `time`, `max_requests`. A store is opened by its metadata; a file is
/// read whole.
#[pyfunction]
#[pyo3(signature = (source, **options))]
fn open(
    py: Python<'_>,
    source: &Bound<'_, PyAny>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<opened::Opened> {
    opened::open_source(py, source, options)
}

/// device() -> str
///
/// The GPU voxscope draws on in this process (opened on first use; `WGPU_BACKEND` and
/// `WGPU_ADAPTER_NAME` choose it).
#[pyfunction]
fn device(py: Python<'_>) -> PyResult<String> {
    py.detach(gpu::device)
        .map(|context| context.describe())
        .map_err(|e| errors::RenderError::new_err(e.to_string()))
}

/// _voxels(data) -> numpy.ndarray
///
/// `data` as an array of a dtype voxscope stores, converted as `render()` converts it (what
/// `view()` writes for the app).
#[pyfunction]
fn _voxels<'py>(data: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    arrays::supported_array(data).map(Bound::into_any)
}

/// _command_line_words(**options) -> list[str]
///
/// The `render` options that rendering keywords stand for (`clip_box=((0, 1), (0, 1), (0,
/// 0.5))` is `--clip-box=0:0.5,0:1,0:1`): what `view()` hands the app.
#[pyfunction]
#[pyo3(signature = (**options))]
fn _command_line_words(options: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<String>> {
    let given = keywords::Given::read(options, keywords::RENDER, "view")?;
    given.draw_options()?;
    Ok(given.argv())
}

/// The extension module.
#[pymodule]
#[pyo3(name = "_voxscope")]
fn voxscope_module(module: &Bound<'_, PyModule>) -> PyResult<()> {
    module.add("__version__", env!("CARGO_PKG_VERSION"))?;
    module.add_function(wrap_pyfunction!(open, module)?)?;
    module.add_function(wrap_pyfunction!(renderer::render, module)?)?;
    module.add_function(wrap_pyfunction!(convert::convert, module)?)?;
    module.add_function(wrap_pyfunction!(convert::_convert_plan, module)?)?;
    module.add_function(wrap_pyfunction!(convert::_convert_run_part, module)?)?;
    module.add_function(wrap_pyfunction!(convert::_convert_finalize, module)?)?;
    module.add_function(wrap_pyfunction!(device, module)?)?;
    module.add_function(wrap_pyfunction!(command_line::run_command_line, module)?)?;
    module.add_function(wrap_pyfunction!(_voxels, module)?)?;
    module.add_function(wrap_pyfunction!(_command_line_words, module)?)?;
    module.add_class::<opened::Opened>()?;
    module.add_class::<renderer::Renderer>()?;
    errors::register(module)?;
    Ok(())
}
