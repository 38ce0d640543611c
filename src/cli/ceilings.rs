//! `voxscope ceilings`: what the GPU itself can do (memory bandwidth, filtered samples, fetch
//! latencies, FMA rate, store-only invocations), to set the renderers' times against.

use clap::Args;
use serde_json::json;

use voxscope_render::{CeilingSizes, GpuContext, measure_ceilings};

#[derive(Debug, Args)]
pub struct CeilingsArgs {
    /// A few thousandth of the work: for software devices and tests.
    #[arg(long)]
    pub quick: bool,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &CeilingsArgs) -> Result<(), String> {
    let context = GpuContext::new_headless().map_err(|e| e.to_string())?;
    let sizes = if args.quick {
        CeilingSizes::QUICK
    } else {
        CeilingSizes::FULL
    };
    let ceilings = measure_ceilings(&context, sizes).map_err(|e| e.to_string())?;
    let sizes = ceilings.sizes;
    let median_ms: serde_json::Map<String, serde_json::Value> = ceilings
        .median_ms
        .iter()
        .map(|&(kernel, ms)| (kernel.to_owned(), ms.into()))
        .collect();
    if args.json {
        let report = json!({
            "adapter": context.adapter_info.name,
            "backend": format!("{:?}", context.adapter_info.backend),
            "driver": format!("{} {}", context.adapter_info.driver, context.adapter_info.driver_info),
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
        });
        println!("{report}");
        return Ok(());
    }
    println!(
        "{}, {}, median of {} passes",
        context.describe(),
        ceilings.timing,
        sizes.repeats
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
        println!("{label:<36}{value:9.2} {unit}");
    }
    Ok(())
}
