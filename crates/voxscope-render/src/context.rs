//! The wgpu device: created headless here (CLI, tests, benchmarks), or handed over by the app.

use super::RendererKind;
use super::pipeline_cache::PipelineCache;

/// Why rendering could not start or go on; each displays as one line. Callers branch on the
/// variant: a volume that does not fit one renderer may fit another.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RenderError {
    /// What the renderer needs is more than this device allows or has room for (a storage
    /// buffer, a 3D texture's side, memory).
    #[error("{0}")]
    DoesNotFit(String),
    /// There is no device: no adapter was found, or it refused a device.
    #[error("{0}")]
    NoDevice(String),
    /// The device failed while working: a wait or a readback did not complete (a lost
    /// device, a dropped mapping).
    #[error("{0}")]
    DeviceLost(String),
    /// What was asked makes no sense here (a pixel outside the image, channels of different
    /// grids, a recolor of an octree only partly on the GPU).
    #[error("{0}")]
    Invalid(String),
}

/// A device, its queue and what it can do, decided once; and the pipelines built with it,
/// each once ([`PipelineCache`]).
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter_info: wgpu::AdapterInfo,
    /// The limits the device was created with: the adapter's own, not wgpu's defaults.
    pub limits: wgpu::Limits,
    /// Whether GPU timestamp queries can time passes.
    pub has_timestamps: bool,
    /// Whether 16-bit normalized textures (`R16Unorm`) can be sampled: value levels above
    /// 255 are then stored exactly (`LevelTexture`), else as 16-bit floats.
    pub has_norm16_textures: bool,
    /// The streaming atlas's texel formats a compute shader can write here: uploads are
    /// scattered into the atlas by a dispatch where its format is one of them.
    pub(crate) atlas_storage_formats: Vec<wgpu::TextureFormat>,
    pub(crate) pipelines: PipelineCache,
}

impl GpuContext {
    /// The features voxscope asks for when the adapter has them: timestamp queries (GPU time
    /// per pass), 16-bit normalized textures (exact value levels above 255) and the adapter's
    /// own format features (a shader writing the streaming atlas's 8- and 16-bit texels).
    pub fn wanted_features(adapter_features: wgpu::Features) -> wgpu::Features {
        adapter_features
            & (wgpu::Features::TIMESTAMP_QUERY
                | wgpu::Features::TEXTURE_FORMAT_16BIT_NORM
                | wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES)
    }

    /// What voxscope asks of `adapter`: all of its limits (large storage buffers and 3D
    /// textures, not wgpu's portable defaults) and the [`Self::wanted_features`] it has.
    /// The app hands this to egui-wgpu so its device can run the ray caster too.
    pub fn device_descriptor(adapter: &wgpu::Adapter) -> wgpu::DeviceDescriptor<'static> {
        wgpu::DeviceDescriptor {
            label: Some("voxscope::device"),
            required_features: Self::wanted_features(adapter.features()),
            required_limits: adapter.limits(),
            ..Default::default()
        }
    }

    /// Opens the best adapter without a window. `WGPU_BACKEND` (e.g. `vulkan`) and
    /// `WGPU_ADAPTER_NAME` select one, as everywhere in wgpu.
    pub fn new_headless() -> Result<Self, RenderError> {
        Self::from_adapter(&Self::headless_adapter()?)
    }

    /// The adapter [`Self::new_headless`] opens: tests share one and open a device per test.
    pub fn headless_adapter() -> Result<wgpu::Adapter, RenderError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let options = wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::from_env()
                .unwrap_or(wgpu::PowerPreference::HighPerformance),
            ..Default::default()
        };
        // The adapter keeps what it needs of the instance alive.
        pollster::block_on(instance.request_adapter(&options)).map_err(|e| {
            RenderError::NoDevice(format!(
                "no GPU adapter found ({e}); for a software device install mesa-vulkan-drivers and set WGPU_BACKEND=vulkan"
            ))
        })
    }

    /// A new device of `adapter`, asked for what voxscope wants ([`Self::device_descriptor`]).
    pub fn from_adapter(adapter: &wgpu::Adapter) -> Result<Self, RenderError> {
        let descriptor = Self::device_descriptor(adapter);
        let (device, queue) = pollster::block_on(adapter.request_device(&descriptor))
            .map_err(|e| RenderError::NoDevice(format!("the GPU refused a device: {e}")))?;
        Ok(Self::from_device(device, queue, adapter))
    }

    /// Wraps a device of `adapter` created elsewhere (the app's, from egui-wgpu).
    pub fn from_device(device: wgpu::Device, queue: wgpu::Queue, adapter: &wgpu::Adapter) -> Self {
        let limits = device.limits();
        let features = device.features();
        let atlas_storage_formats =
            if features.contains(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES) {
                let writable = |format: wgpu::TextureFormat| {
                    let supported = adapter.get_texture_format_features(format);
                    supported
                        .flags
                        .contains(wgpu::TextureFormatFeatureFlags::STORAGE_WRITE_ONLY)
                        && supported
                            .allowed_usages
                            .contains(wgpu::TextureUsages::STORAGE_BINDING)
                        && format.required_features().difference(features).is_empty()
                };
                super::atlas_scatter::FORMATS
                    .into_iter()
                    .filter(|&format| writable(format))
                    .collect()
            } else {
                Vec::new()
            };
        Self {
            device,
            queue,
            adapter_info: adapter.get_info(),
            limits,
            has_timestamps: features.contains(wgpu::Features::TIMESTAMP_QUERY),
            has_norm16_textures: features.contains(wgpu::Features::TEXTURE_FORMAT_16BIT_NORM),
            atlas_storage_formats,
            pipelines: PipelineCache::default(),
        }
    }

    /// Waits until the GPU has finished everything submitted.
    pub fn wait_idle(&self) -> Result<(), RenderError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| RenderError::DeviceLost(format!("GPU wait failed: {e}")))
    }

    /// Largest buffer a shader can bind as storage, in bytes.
    pub fn max_storage_bytes(&self) -> u64 {
        self.limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
    }

    /// The side of the square tiles an image of `size` pixels is drawn in on this device,
    /// where it exceeds what one render target may be (the largest 2D texture, storage buffer
    /// or buffer, with the readback's rows padded); `None` where one target holds it. A tile
    /// is a [`crate::RenderTarget::tile`] of the whole image.
    pub fn tile_side(&self, size: [u32; 2]) -> Option<u32> {
        let limits = &self.limits;
        let fits = |width: u32, height: u32| {
            let row_bytes = (width as u64 * 4).div_ceil(256) * 256;
            width <= limits.max_texture_dimension_2d
                && height <= limits.max_texture_dimension_2d
                && width as u64 * height as u64 * 4 <= self.max_storage_bytes()
                && row_bytes * height as u64 <= limits.max_buffer_size
        };
        if fits(size[0], size[1]) {
            return None;
        }
        let mut side = (limits.max_texture_dimension_2d.min(4096) / 16 * 16).max(16);
        while side > 16 && !fits(side, side) {
            side /= 2;
        }
        Some(side)
    }

    /// `NVIDIA H100 80GB HBM3 (Vulkan)`.
    pub fn describe(&self) -> String {
        format!(
            "{} ({:?})",
            self.adapter_info.name, self.adapter_info.backend
        )
    }
}

/// A headless [`GpuContext`] being made on a thread of its own ([`Self::begin`]) while the
/// caller reads its volume: the driver's start (a fraction of a second, longer from a cold
/// disk) and the reading overlap. [`Self::finish`] waits for it; dropped unfinished (the
/// volume could not be read), it still waits, so that no driver is left starting while the
/// process ends: an error found before the GPU is needed is told once the device has started.
#[must_use = "the context is made for finish(); dropped, it is waited for and thrown away"]
pub struct HeadlessStart(Option<std::thread::JoinHandle<Result<GpuContext, RenderError>>>);

impl HeadlessStart {
    /// Starts making the context; where no thread can be made, [`Self::finish`] makes it.
    pub fn begin() -> Self {
        Self::begin_for(None)
    }

    /// [`Self::begin`], then, on the same thread, the pipelines of `kind`'s renderer
    /// ([`GpuContext::build_pipelines`]): their compile overlaps the reading too.
    pub fn begin_for(kind: Option<RendererKind>) -> Self {
        let thread = std::thread::Builder::new()
            .name("voxscope-gpu-start".into())
            .spawn(move || {
                let context = GpuContext::new_headless()?;
                if let Some(kind) = kind {
                    context.build_pipelines(kind);
                }
                Ok(context)
            })
            .ok();
        Self(thread)
    }

    /// The context, made as [`GpuContext::new_headless`] makes it.
    pub fn finish(mut self) -> Result<GpuContext, RenderError> {
        match self.0.take() {
            Some(thread) => thread.join().unwrap_or_else(|_| {
                Err(RenderError::NoDevice(
                    "the GPU's start failed (its thread panicked)".into(),
                ))
            }),
            None => GpuContext::new_headless(),
        }
    }
}

impl Drop for HeadlessStart {
    fn drop(&mut self) {
        if let Some(thread) = self.0.take() {
            let _ = thread.join();
        }
    }
}
