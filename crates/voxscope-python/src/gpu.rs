//! The process's GPU: one device, opened on first use and shared by every `render()` call and
//! `Renderer` (its pipelines are built once, whatever the number of volumes).

use std::sync::{Arc, Mutex};

use voxscope_render::{GpuContext, RenderError};

static DEVICE: Mutex<Option<Arc<GpuContext>>> = Mutex::new(None);

/// The shared device, opened now if this is the first use (`WGPU_BACKEND` and
/// `WGPU_ADAPTER_NAME` choose, as for the command line). A failure is tried again next time.
pub fn device() -> Result<Arc<GpuContext>, RenderError> {
    let mut device = DEVICE
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    if let Some(context) = device.as_ref() {
        return Ok(Arc::clone(context));
    }
    let context = Arc::new(GpuContext::new_headless()?);
    *device = Some(Arc::clone(&context));
    Ok(context)
}
