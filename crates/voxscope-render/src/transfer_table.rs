//! The transfer function on the GPU: its lookup table (one packed color per 16-bit value
//! level), shared by every renderer, and the level at which a MIP ray may stop.

use wgpu::util::DeviceExt;

use super::GpuContext;
use voxscope_octree::TransferFunction;
use voxscope_volume::Quantization;

/// A transfer function's lookup table in a storage buffer.
pub struct GpuTransferTable {
    pub buffer: wgpu::Buffer,
    quantization: Quantization,
    mip_saturation: u16,
    window_levels: f32,
}

/// The width of `transfer`'s value window in value levels of `quantization` (at least one
/// level): what the shading's gradient is measured against.
pub(crate) fn window_levels(quantization: Quantization, transfer: &TransferFunction) -> f32 {
    let width = ((transfer.window.high - transfer.window.low) / quantization.step).abs();
    if width.is_finite() {
        width.max(1.0) as f32
    } else {
        f32::MAX
    }
}

impl GpuTransferTable {
    /// The table of `transfer` for values quantized by `quantization`.
    pub fn new(
        context: &GpuContext,
        quantization: Quantization,
        transfer: &TransferFunction,
    ) -> Self {
        let buffer = context
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("voxscope::transfer_lookup_table"),
                contents: bytemuck::cast_slice(&transfer.lookup_table(quantization)),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            });
        Self {
            buffer,
            quantization,
            mip_saturation: transfer.saturation_level(quantization),
            window_levels: window_levels(quantization, transfer),
        }
    }

    /// Writes a new transfer function (whatever derives colors from it must be redone).
    pub fn write(&mut self, context: &GpuContext, transfer: &TransferFunction) {
        let table = transfer.lookup_table(self.quantization);
        context
            .queue
            .write_buffer(&self.buffer, 0, bytemuck::cast_slice(&table));
        self.mip_saturation = transfer.saturation_level(self.quantization);
        self.window_levels = window_levels(self.quantization, transfer);
    }

    /// The transfer window's width in value levels (at least 1): shading measures gradients
    /// in these widths.
    pub fn window_levels(&self) -> f32 {
        self.window_levels
    }

    /// The value level at which a MIP ray may stop (the top of the window).
    pub fn mip_saturation(&self) -> u16 {
        self.mip_saturation
    }

    /// Bytes on the GPU.
    pub fn size(&self) -> u64 {
        self.buffer.size()
    }
}
