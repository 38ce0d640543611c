//! Shared by voxscope-render's integration tests: the workspace's test modules they use, in
//! the root's tests/support (the root package's tests use them too): the CPU reference
//! renderer and the GPU helpers.
#![allow(dead_code, unused_imports)] // each test binary uses a different part

#[path = "../../../../tests/support/octrees.rs"]
pub mod octrees;
#[path = "../../../../tests/support/paths.rs"]
pub mod paths;
#[path = "../../../../tests/support/reference.rs"]
pub mod reference;
#[path = "../../../../tests/support/render.rs"]
pub mod render;

pub use octrees::colored_octree;
pub use paths::{image_dir, shared_data};
pub use render::{Prepared, draw, gpu, gpu_render};
