//! Shared by voxscope-volume's integration tests: the workspace's test modules they use, in
//! the root's tests/support (the root package's tests use them too).
#![allow(dead_code, unused_imports)] // each test binary uses a different part

#[path = "../../../../tests/support/paths.rs"]
pub mod paths;
#[path = "../../../../tests/support/writers.rs"]
pub mod writers;

pub use paths::shared_data;
