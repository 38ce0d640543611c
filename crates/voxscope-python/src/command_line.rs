//! The command line inside the module: `python -m voxscope ARGS` is `voxscope ARGS` (render,
//! info, convert, …; without a command the app), and `view()` starts the app this way in a
//! child process, so the wheel needs no separate binary.

use pyo3::prelude::*;

use crate::errors::VoxscopeError;

/// run_command_line(argv: list[str]) -> int
///
/// Runs `voxscope` with `argv` (the program's name first) in this process, the GIL released:
/// the app's window blocks until it closes. Returns the exit status (0, or 3 for a render
/// whose image is incomplete: bricks could not be read). A failure raises VoxscopeError with
/// the command line's one-line message; `--help`, `--version` and usage errors print and exit
/// the process.
#[cfg(feature = "app")]
#[pyfunction]
pub fn run_command_line(py: Python<'_>, argv: Vec<String>) -> PyResult<u8> {
    py.detach(|| voxscope::cli::run_from(argv))
        .map_err(VoxscopeError::new_err)
}

/// run_command_line(argv: list[str]) -> int
///
/// This build of the module has no command line or app (built without the `app` feature,
/// which `pip install .` turns on): raises VoxscopeError saying so.
#[cfg(not(feature = "app"))]
#[pyfunction]
pub fn run_command_line(argv: Vec<String>) -> PyResult<u8> {
    let _ = argv;
    Err(VoxscopeError::new_err(
        "this build of the voxscope module has no command line or app: build it with the `app` feature (as `pip install .` does)",
    ))
}
