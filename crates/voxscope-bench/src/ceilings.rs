//! The GPU's own ceilings (`voxscope ceilings`): memory bandwidth, filtered samples, fetch
//! latencies, FMA rate and store-only invocations, to set the renderers' times against; as a
//! JSON object or a table.

use serde_json::json;
use voxscope_render::{CeilingSizes, Ceilings, GpuContext, measure_ceilings};

use crate::error::BenchError;

/// What [`measure`] found, and on which device.
pub struct CeilingsReport {
    adapter: wgpu::AdapterInfo,
    /// The device in words, as the table's first line names it.
    device: String,
    ceilings: Ceilings,
}

/// Measures the ceilings of the headless device with `sizes` of work (each kernel's output
/// checked before its rate is reported).
pub fn measure(sizes: CeilingSizes) -> Result<CeilingsReport, BenchError> {
    let context = GpuContext::new_headless()?;
    let ceilings = measure_ceilings(&context, sizes)?;
    Ok(CeilingsReport {
        adapter: context.adapter_info.clone(),
        device: context.describe(),
        ceilings,
    })
}

impl CeilingsReport {
    /// The report as one JSON object: the device, every figure, each kernel's median and the
    /// work done.
    pub fn json(&self) -> serde_json::Value {
        let (adapter, ceilings) = (&self.adapter, &self.ceilings);
        let sizes = ceilings.sizes;
        let median_ms: serde_json::Map<String, serde_json::Value> = ceilings
            .median_ms
            .iter()
            .map(|&(kernel, ms)| (kernel.to_owned(), ms.into()))
            .collect();
        json!({
            "adapter": adapter.name,
            "backend": format!("{:?}", adapter.backend),
            "driver": format!("{} {}", adapter.driver, adapter.driver_info),
            "timing": ceilings.timing,
            "repeats": sizes.repeats,
            "memory_bytes_per_s": ceilings.memory_bytes_per_s,
            "filtered_samples_per_s": ceilings.filtered_samples_per_s,
            "filtered_f16_samples_per_s": ceilings.filtered_f16_samples_per_s,
            "texture_latency_ns": ceilings.texture_latency_ns,
            "buffer_latency_ns": ceilings.buffer_latency_ns,
            "fma_flops_per_s": ceilings.fma_flops_per_s,
            "store_only_invocations_per_s": ceilings.store_only_invocations_per_s,
            "median_ms": median_ms,
            "sizes": {
                "stream_bytes": sizes.stream_bytes,
                "invocations": sizes.invocations,
                "samples": sizes.samples,
                "fma_rounds": sizes.fma_rounds,
                "chain_fetches": sizes.chain_fetches,
            },
        })
    }

    /// The report as a table: the device, then a line a figure (each ended by a newline).
    pub fn table(&self) -> String {
        let ceilings = &self.ceilings;
        let mut table = format!(
            "{}, {}, median of {} passes\n",
            self.device, ceilings.timing, ceilings.sizes.repeats
        );
        let rows = [
            (
                "memory bandwidth (read + write)",
                ceilings.memory_bytes_per_s * 1e-9,
                "GB/s",
            ),
            (
                "filtered 3D samples (8-bit)",
                ceilings.filtered_samples_per_s * 1e-9,
                "G/s",
            ),
            (
                "filtered 3D samples (16-bit float)",
                ceilings.filtered_f16_samples_per_s * 1e-9,
                "G/s",
            ),
            (
                "dependent texture sample latency",
                ceilings.texture_latency_ns,
                "ns",
            ),
            (
                "dependent storage read latency",
                ceilings.buffer_latency_ns,
                "ns",
            ),
            ("FMA rate", ceilings.fma_flops_per_s * 1e-12, "TFLOP/s"),
            (
                "store-only invocations",
                ceilings.store_only_invocations_per_s * 1e-9,
                "G/s",
            ),
        ];
        for (label, value, unit) in rows {
            table += &format!("{label:<36}{value:9.2} {unit}\n");
        }
        table
    }
}
