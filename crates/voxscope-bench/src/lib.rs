//! voxscope's benchmarks: programs that measure, not tests. What to measure is a plain
//! [`BenchOptions`] (the command line's `bench` flags map into it, as its render flags map into
//! the scene layer's `DrawOptions`); each benchmark returns its report, and the command line
//! prints it.
//!
//! - [`renderers`]: the in-memory renderers (octree, dense, bricks) and composites of channels,
//!   GPU time per frame from the paper's three camera distances in each transfer mode, with
//!   the work per ray, transfer edits and GPU memory.
//! - [`stream`]: the streaming renderer: the first image after open, stopped views until
//!   complete, orbits while detail streams in, the loaders' decode rate ([`decode`]), and the
//!   frames once resident against the bricks renderer ([`resident`]); the process's memory by
//!   phase ([`memory`]).
//! - [`ceilings`]: what the GPU itself can do, to set the renderers' times against.
//!
//! Errors are a [`BenchError`]; the command line words them as one line.

pub mod ceilings;
pub mod decode;
mod edits;
mod error;
mod frames;
pub mod memory;
mod options;
mod orbit;
pub mod renderers;
pub mod resident;
mod resident_channels;
mod stats;
pub mod stream;

pub use error::BenchError;
pub use options::{BenchOptions, MAX_WAIT};
pub use renderers::{BenchResult, BenchVolume, Report};
pub use stats::percentile;
