//! voxscope: a volume inspector built on the flat-list sparse octree of Lukic, "Vulkan based
//! volume rendering using ray tracing", ray-cast by a wgpu compute shader.
//!
//! The modules follow the data: [`volume`] (grids and loaders) → [`octree`] (the flat list,
//! its statistics and colors) → [`render`] (wgpu device, ray caster, camera) → [`app`] (the window) and
//! [`cli`] (commands without one). [`stream`] (pyramids of bricks, loaded and scheduled on the
//! CPU) sits between [`volume`] and [`render`], whose streaming renderer drives it.
//! Dependencies only point that way.

pub mod app;
pub mod cli;
pub mod octree;
pub mod progress;
pub mod render;
pub mod stream;
pub mod volume;
