//! Shared by the integration tests: paths to real data, the CPU reference renderer, file
//! writers for loader tests, and GPU helpers. The crates' own tests (crates/*/tests) name the
//! modules here that stand on their crate alone with `#[path]`, in their own tests/support.
#![allow(dead_code, unused_imports)] // each test binary uses a different part

pub mod app_harness;
pub mod cli;
pub mod damage;
pub mod fault_server;
pub mod http_server;
pub mod labels;
pub mod octrees;
pub mod paths;
pub mod reference;
pub mod render;
pub mod writers;

pub use octrees::colored_octree;
pub use paths::{image_dir, shared_data};
pub use render::{Prepared, draw, gpu, gpu_render};
