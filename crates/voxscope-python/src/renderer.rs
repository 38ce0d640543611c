//! `voxscope.Renderer` and `voxscope.render`: a volume kept on the GPU (device, pipelines and
//! voxels resident) and drawn frame after frame into numpy images. A frame costs what the GPU
//! costs plus the keywords' parsing (camera keywords alone are read as numbers, over the
//! options parsed when the Renderer was made); a changed transfer function is a GPU recolor,
//! a changed size a new target; nothing is uploaded again. The GIL is released while
//! loading, uploading, drawing and reading back.

use std::sync::{Mutex, MutexGuard};

use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use voxscope_render::{RenderTarget, read_image};
use voxscope_scene::{DrawOptions, Drawable, SavedTransfer, VolumeSource};

use crate::arrays::{ArrayOptions, quantize, spacing_of, supported_array};
use crate::camera_keywords::CameraKeywords;
use crate::drawn::{CompleteNotice, Drawn, Frame, Notice, draw_complete, notice_of};
use crate::errors::{RenderError, VoxscopeError, gpu_error};
use crate::gpu::device;
use crate::keywords::{Given, OPEN, RENDER, STRUCTURAL};
use crate::opened::{Opened, spec_of};

/// Keywords about the input rather than the drawing: an array's (`spacing`, `channel_axis`,
/// `channel`, `time`, `name`), or a path's (`open()`'s).
const ARRAY_INPUT: [&str; 5] = ["spacing", "channel_axis", "channel", "time", "name"];

/// A volume resident on the GPU, drawn frame after frame.
#[pyclass(name = "Renderer", module = "voxscope", frozen)]
pub struct Renderer {
    resident: Mutex<Resident>,
}

/// What a Renderer holds: the device, the volume uploaded, the keywords it was made with
/// (and their options, parsed), what its transfer function follows now, and the target of
/// the last frame.
struct Resident {
    drawn: Drawn,
    base: Given,
    base_options: DrawOptions,
    /// The words of `base`'s transfer keywords (what a frame of camera keywords alone has).
    base_words: Vec<String>,
    /// The transfer keywords' words last applied, and their `tf` file as read then.
    applied: Option<(Vec<String>, Option<SavedTransfer>)>,
    target: Option<RenderTarget>,
    /// The GPU budget's limit last said (`render()` says it again only once it changes).
    budget_said: Option<String>,
    /// The last frame drawn (its camera and settings: what `read()` draws the labels with).
    last_frame: Option<Frame>,
}

/// A frame's keywords: camera keywords alone, as numbers (a camera sweep's; no words), or
/// any, as words.
struct FrameKeywords {
    /// The camera keywords, where the frame gives nothing else.
    camera: Option<CameraKeywords>,
    given: Given,
}

impl Resident {
    /// The frame of the Renderer's keywords with `frame`'s on top, applied: the transfer
    /// function and channels where their keywords changed, a target of the frame's size.
    fn prepare(&mut self, frame: &FrameKeywords) -> Result<Frame, PyErr> {
        // Camera keywords alone over the Renderer's own transfer function, applied already:
        // its options with the camera moved, nothing merged, read or compared but the words
        // applied (a camera sweep's frame costs microseconds in Python).
        if let Some(camera) = frame.camera
            && self
                .applied
                .as_ref()
                .is_some_and(|(applied, _)| *applied == self.base_words)
        {
            let mut prepared = Frame::of(&self.drawn, &self.base_options);
            prepared.camera = camera.over(prepared.camera);
            self.fit_target(prepared.size);
            return Ok(prepared);
        }
        let (options, words) = match frame.camera {
            // Camera keywords are no transfer keywords: the Renderer's own words.
            Some(camera) => {
                let mut options = self.base_options.clone();
                options.camera = camera.over(options.camera);
                (options, self.base_words.clone())
            }
            None => {
                let merged = self.base.with(&frame.given);
                (merged.draw_options()?, merged.transfer_words())
            }
        };
        if self
            .applied
            .as_ref()
            .is_none_or(|(applied, _)| *applied != words)
        {
            let saved = options
                .transfer
                .saved()
                .map_err(crate::errors::Failure::from)?;
            self.drawn
                .apply_transfer(&options, saved)
                .map_err(crate::errors::Failure::from)?;
            self.applied = Some((words, saved));
        }
        let prepared = Frame::of(&self.drawn, &options);
        self.fit_target(prepared.size);
        Ok(prepared)
    }

    /// Makes the target `size` pixels, unless the last one is.
    fn fit_target(&mut self, (width, height): (u32, u32)) {
        let fits = self
            .target
            .as_ref()
            .is_some_and(|t| t.width == width && t.height == height);
        if !fits {
            self.target = Some(RenderTarget::new(self.drawn.context(), width, height));
        }
    }

    /// The last frame's pixels, read back (waits for the GPU).
    fn read(&self) -> Result<(u32, u32, Vec<u8>), PyErr> {
        let target = self
            .target
            .as_ref()
            .ok_or_else(|| VoxscopeError::new_err("nothing drawn yet: call render() or draw()"))?;
        let image = read_image(self.drawn.context(), target)
            .map_err(|e| gpu_error(&self.drawn.name(), e))?;
        Ok((image.width(), image.height(), image.into_raw()))
    }

    /// [`Self::read`], with the label overlays (`labels=`) drawn over it as `frame` draws.
    fn read_with_labels(&mut self, frame: &Frame) -> Result<(u32, u32, Vec<u8>), PyErr> {
        let (width, height, pixels) = self.read()?;
        if self.drawn.labels().is_empty() {
            return Ok((width, height, pixels));
        }
        let mut image = image::RgbaImage::from_raw(width, height, pixels)
            .ok_or_else(|| VoxscopeError::new_err("the frame read back has another size"))?;
        self.drawn
            .draw_labels_over(&mut image, None, &frame.camera, &frame.settings)
            .map_err(crate::errors::Failure::from)?;
        Ok((width, height, image.into_raw()))
    }
}

/// An image (height, width, 4) uint8 RGBA from its pixels.
fn image_array(
    py: Python<'_>,
    (width, height, pixels): (u32, u32, Vec<u8>),
) -> PyResult<Bound<'_, PyAny>> {
    use numpy::PyArrayMethods;
    numpy::PyArray1::from_vec(py, pixels)
        .reshape([height as usize, width as usize, 4])
        .map(Bound::into_any)
}

impl Renderer {
    fn lock(&self) -> MutexGuard<'_, Resident> {
        self.resident
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Makes the renderer of `data` (an array, a `Volume`, a path or URL) with `options`.
    fn make(
        py: Python<'_>,
        data: &Bound<'_, PyAny>,
        options: Option<&Bound<'_, PyDict>>,
        function: &str,
    ) -> PyResult<Self> {
        let all = match options {
            Some(options) => options.copy()?,
            None => PyDict::new(py),
        };
        let input = PyDict::new(py);
        let is_array = data.hasattr("__array__")? || data.hasattr("__array_interface__")?;
        let input_keys: Vec<&str> = if is_array {
            ARRAY_INPUT.to_vec()
        } else if data.is_instance_of::<Opened>() {
            vec!["channel", "time"]
        } else {
            OPEN.iter().map(|k| k.name).collect()
        };
        for key in input_keys {
            if let Some(value) = all.get_item(key)? {
                input.set_item(key, value)?;
                all.del_item(key)?;
            }
        }
        let base = Given::read(Some(&all), RENDER, function)?;
        let options = base.draw_options()?;
        let context = py
            .detach(device)
            .map_err(|e| RenderError::new_err(e.to_string()))?;
        let (drawn, notice) = if is_array {
            let array = supported_array(data)?;
            let array_options = ArrayOptions {
                spacing: spacing_of(input.get_item("spacing")?.as_ref())?,
                channel_axis: input
                    .get_item("channel_axis")?
                    .map(|v| v.extract())
                    .transpose()?,
                channel: input
                    .get_item("channel")?
                    .map(|v| v.extract())
                    .transpose()?,
                time: input
                    .get_item("time")?
                    .map(|v| v.extract())
                    .transpose()?
                    .unwrap_or(0),
                name: input
                    .get_item("name")?
                    .map(|v| v.extract())
                    .transpose()?
                    .unwrap_or_else(|| "array".to_owned()),
            };
            let channels = quantize(&array, &array_options)?;
            let source = VolumeSource::Spec(array_options.name.clone());
            let drawn: Drawn = py
                .detach(|| -> Result<Drawn, voxscope_scene::SceneError> {
                    let mut drawn = Drawable::of_channels(context, &source, channels, &options)?;
                    // Label files on the array's grid.
                    drawn.open_labels(&voxscope_scene::OpenOptions::default(), &options)?;
                    Ok(drawn)
                })
                .map_err(crate::errors::Failure::from)?;
            let notice = notice_of(&drawn);
            (drawn, notice)
        } else {
            let opened_here;
            let opened: &Opened = if let Ok(volume) = data.cast::<Opened>() {
                let volume = volume.get();
                let channel = input
                    .get_item("channel")?
                    .map(|v| v.extract())
                    .transpose()?;
                let time = input.get_item("time")?.map(|v| v.extract()).transpose()?;
                match volume.reselected(py, channel, time)? {
                    Some(other) => {
                        opened_here = other;
                        &opened_here
                    }
                    None => volume,
                }
            } else {
                let spec = spec_of(data)?;
                let given = Given::read(Some(&input), OPEN, function)?;
                opened_here = Opened::open(py, spec, given)?;
                &opened_here
            };
            py.detach(|| opened.drawn(&context, &options))?
        };
        if let Some(notice) = notice {
            warn(py, &notice)?;
        }
        Ok(Self {
            resident: Mutex::new(Resident {
                drawn,
                base_words: base.transfer_words(),
                base,
                base_options: options,
                applied: None,
                target: None,
                budget_said: None,
                last_frame: None,
            }),
        })
    }

    /// A frame's keywords: the drawing ones but those fixed when the Renderer was made;
    /// camera keywords alone as numbers.
    fn frame_keywords(
        options: Option<&Bound<'_, PyDict>>,
        function: &str,
    ) -> PyResult<FrameKeywords> {
        if let Some(camera) = CameraKeywords::read(options) {
            return Ok(FrameKeywords {
                camera: Some(camera),
                given: Given::default(),
            });
        }
        let given = Given::read(options, RENDER, function)?;
        if let Some(name) = given.any_of(&STRUCTURAL) {
            return Err(PyTypeError::new_err(format!(
                "{name}= is chosen when the Renderer is made (it decides what is uploaded): make another Renderer"
            )));
        }
        Ok(FrameKeywords {
            camera: CameraKeywords::of_given(&given),
            given,
        })
    }
}

/// Issues a Python warning (`UserWarning`) with `message`.
fn warn(py: Python<'_>, message: &str) -> PyResult<()> {
    py.import("warnings")?.call_method1(
        "warn",
        (message, py.get_type::<pyo3::exceptions::PyUserWarning>(), 2),
    )?;
    Ok(())
}

#[pymethods]
impl Renderer {
    /// Renderer(data, **options)
    ///
    /// Uploads `data` to the GPU once for frame after frame. `data`: a numpy array (z, y, x)
    /// (channels and time as leading axes), a `voxscope.Volume`, or a path or URL. Options:
    /// every keyword of `render()`; `renderer`, `brick_size`, `gpu_memory`, `ram_cache`,
    /// `upload_budget`, `lod_scale`, `uploads`, `labels`, `labels_opacity` and `labels_hide`
    /// are fixed here, the rest are each frame's defaults.
    #[new]
    #[pyo3(signature = (data, **options))]
    fn new(
        py: Python<'_>,
        data: &Bound<'_, PyAny>,
        options: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        Self::make(py, data, options, "Renderer")
    }

    /// render(**options) -> numpy.ndarray
    ///
    /// Draws one frame with the Renderer's keywords and these on top (camera, transfer
    /// function, mode, level, shading, clipping, size, …) and returns it as a (height,
    /// width, 4) uint8 RGBA array. The streaming renderer draws until nothing visible is
    /// missing (at most `max_wait` seconds; a warning says what stayed coarse, and where the
    /// GPU budget limits the view: once, until a frame's limit differs).
    #[pyo3(signature = (**options))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let frame = Self::frame_keywords(options, "render")?;
        let (pixels, notice) = py.detach(|| -> PyResult<_> {
            let mut resident = self.lock();
            let prepared = resident.prepare(&frame)?;
            let Resident { drawn, target, .. } = &mut *resident;
            let target = target.as_ref().expect("prepare made the frame's target");
            let CompleteNotice { mut lines, budget } = draw_complete(drawn, target, &prepared)?;
            // A view the budget limits as the last one did is not said again.
            let limit = budget.as_ref().map(|(_, limit)| limit.clone());
            if limit != resident.budget_said {
                lines.extend(budget.map(|(line, _)| line));
                resident.budget_said = limit;
            }
            let notice: Notice = (!lines.is_empty()).then(|| lines.join("; "));
            let pixels = resident.read_with_labels(&prepared)?;
            resident.last_frame = Some(prepared);
            Ok((pixels, notice))
        })?;
        if let Some(notice) = notice {
            warn(py, &notice)?;
        }
        image_array(py, pixels)
    }

    /// draw(**options) -> None
    ///
    /// Records and submits one frame like `render()` without waiting for it or reading it
    /// back: frames issued back to back, then `finish()` (the GPU-bound rate) or `read()`.
    /// The streaming renderer takes one step (what earlier frames asked for streams in).
    #[pyo3(signature = (**options))]
    fn draw(&self, py: Python<'_>, options: Option<&Bound<'_, PyDict>>) -> PyResult<()> {
        let frame = Self::frame_keywords(options, "draw")?;
        py.detach(|| -> PyResult<()> {
            let mut resident = self.lock();
            let prepared = resident.prepare(&frame)?;
            let Resident { drawn, target, .. } = &mut *resident;
            let target = target.as_ref().expect("prepare made the frame's target");
            drawn.draw(target, &prepared.camera, &prepared.settings);
            resident.last_frame = Some(prepared);
            Ok(())
        })
    }

    /// finish() -> None
    ///
    /// Waits until the GPU has finished every frame submitted.
    fn finish(&self, py: Python<'_>) -> PyResult<()> {
        py.detach(|| {
            let resident = self.lock();
            resident
                .drawn
                .context()
                .wait_idle()
                .map_err(|e| gpu_error(&resident.drawn.name(), e))
        })
    }

    /// read() -> numpy.ndarray
    ///
    /// The last frame drawn, as `render()` returns it (waits for the GPU).
    fn read<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let pixels = py.detach(|| {
            let mut resident = self.lock();
            match resident.last_frame.take() {
                Some(frame) => {
                    let pixels = resident.read_with_labels(&frame);
                    resident.last_frame = Some(frame);
                    pixels
                }
                None => resident.read(),
            }
        })?;
        image_array(py, pixels)
    }

    /// The renderer drawing it: `octree`, `dense`, `bricks`, `stream` or `composite`.
    #[getter]
    fn kind(&self) -> &'static str {
        self.lock().drawn.renderer().kind().name()
    }

    /// What is drawn: the file's, URL's or array's name.
    #[getter]
    fn name(&self) -> String {
        self.lock().drawn.name()
    }

    /// The deepest level (`level=` of full detail): the octree's or the pyramid's depth.
    #[getter]
    fn depth(&self) -> u32 {
        self.lock().drawn.depth()
    }

    /// Bytes it holds on the GPU, by buffer or texture.
    #[getter]
    fn gpu_bytes(&self) -> Vec<(String, u64)> {
        self.lock()
            .drawn
            .renderer()
            .gpu_bytes()
            .into_iter()
            .map(|(name, bytes)| (name.to_owned(), bytes))
            .collect()
    }

    /// The GPU it draws on (`NVIDIA H200 (Vulkan)`).
    #[getter]
    fn device(&self) -> String {
        self.lock().drawn.context().describe()
    }

    fn __repr__(&self) -> String {
        let resident = self.lock();
        format!(
            "<voxscope.Renderer of {:?}: {} renderer on {}>",
            resident.drawn.name(),
            resident.drawn.renderer().kind().name(),
            resident.drawn.context().describe()
        )
    }
}

/// render(data, **options) -> numpy.ndarray
///
/// Draws `data` once and returns the image (height, width, 4) uint8 RGBA; what `voxscope
/// render` draws of the same voxels with the same options (a fresh `Renderer`'s first frame).
#[pyfunction]
#[pyo3(signature = (data, **options))]
pub fn render<'py>(
    py: Python<'py>,
    data: &Bound<'py, PyAny>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let renderer = Renderer::make(py, data, options, "render")?;
    renderer.render(py, None)
}
