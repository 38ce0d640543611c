//! Shared by voxscope-octree's integration tests: the workspace's test modules they use, in
//! the root's tests/support (the root package's tests use them too).
#![allow(dead_code, unused_imports)] // each test binary uses a different part

#[path = "../../../../tests/support/octrees.rs"]
pub mod octrees;
#[path = "../../../../tests/support/paths.rs"]
pub mod paths;

pub use octrees::colored_octree;
pub use paths::shared_data;
