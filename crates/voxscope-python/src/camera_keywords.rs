//! A frame's camera keywords as numbers: what a camera sweep gives `Renderer.draw()` and
//! `Renderer.render()` frame after frame (`azimuth=` alone, or with `elevation=`,
//! `distance=`, `fov=`). Read straight from the call's keywords, they skip the words every
//! other keyword is written as and read back from ([`crate::keywords`]), and a frame of them
//! alone over the Renderer's own transfer function needs no merge with its keywords.

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyFloat, PyInt, PyString};
use voxscope_render::Camera;

use crate::keywords::Given;

/// The camera keywords a frame gives, each where given.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CameraKeywords {
    azimuth: Option<f64>,
    elevation: Option<f64>,
    distance: Option<f64>,
    fov: Option<f64>,
}

impl CameraKeywords {
    /// The call's keywords where they are camera keywords alone (or none), each a Python
    /// `float` or `int` (not a subclass: not `bool`, not a numpy scalar) or `None` (not
    /// given, as [`Given::read`] takes it); else `None`: read them as words. The numbers
    /// are those the words would give: Python's `str()` of a float reads back as the same
    /// float, and an int converts to the nearest one either way (one too large for a float
    /// is left to the words).
    pub fn read(kwargs: Option<&Bound<'_, PyDict>>) -> Option<Self> {
        let mut keywords = Self::default();
        for (key, value) in kwargs.into_iter().flatten() {
            let key = key.cast::<PyString>().ok()?.to_cow().ok()?;
            let slot = keywords.slot(&key)?;
            if value.is_none() {
                continue;
            }
            *slot = Some(if let Ok(float) = value.cast_exact::<PyFloat>() {
                float.value()
            } else if value.is_exact_instance_of::<PyInt>() {
                value.extract::<f64>().ok()?
            } else {
                return None;
            });
        }
        Some(keywords)
    }

    /// `given`'s keywords where they are camera keywords alone (or none), each one number
    /// (`--azimuth=150`); else `None`.
    pub fn of_given(given: &Given) -> Option<Self> {
        let mut keywords = Self::default();
        for (name, words) in &given.words {
            let slot = keywords.slot(name)?;
            let [word] = &words[..] else { return None };
            let (_, text) = word.split_once('=')?;
            *slot = Some(text.parse().ok()?);
        }
        Some(keywords)
    }

    /// `camera` with these keywords set.
    pub fn over(&self, camera: Camera) -> Camera {
        Camera {
            azimuth_deg: self.azimuth.unwrap_or(camera.azimuth_deg),
            elevation_deg: self.elevation.unwrap_or(camera.elevation_deg),
            distance: self.distance.unwrap_or(camera.distance),
            fov_y_deg: self.fov.unwrap_or(camera.fov_y_deg),
            ..camera
        }
    }

    /// Where keyword `name`'s number goes; `None` for any other keyword.
    fn slot(&mut self, name: &str) -> Option<&mut Option<f64>> {
        match name {
            "azimuth" => Some(&mut self.azimuth),
            "elevation" => Some(&mut self.elevation),
            "distance" => Some(&mut self.distance),
            "fov" => Some(&mut self.fov),
            _ => None,
        }
    }
}
