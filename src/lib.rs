//! voxscope: a volume inspector built on the flat-list sparse octree of Lukic, "Vulkan based
//! volume rendering using ray tracing", ray-cast by a wgpu compute shader.
//!
//! This crate is the top of the workspace: [`app`] (the window) and [`cli`] (commands without
//! one), and what both write movies with ([`movie_writer`]). The layers below are crates of their own, each depending only on the ones before it:
//! `voxscope_volume` (grids and loaders) → `voxscope_octree` (the flat list, its statistics
//! and colors) and `voxscope_stream` (pyramids of bricks, loaded and scheduled on the CPU) →
//! `voxscope_render` (wgpu device, ray casters, camera; no UI).

pub mod app;
pub mod cli;
pub mod movie_writer;
