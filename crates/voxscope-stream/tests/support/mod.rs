//! Shared by voxscope-stream's integration tests: the workspace's test modules they use, in
//! the root's tests/support (the root package's tests use them too): the fault-injecting
//! HTTP server, the plain file server and the damaged-store generator.
#![allow(dead_code, unused_imports)] // each test binary uses a different part

#[path = "../../../../tests/support/damage.rs"]
pub mod damage;
#[path = "../../../../tests/support/fault_server.rs"]
pub mod fault_server;
#[path = "../../../../tests/support/http_server.rs"]
pub mod http_server;
pub mod rays;
