//! The GPU's own ceilings, measured the way the ray casters use it (`shaders/ceilings.wgsl`):
//! memory bandwidth, filtered 3D texture samples per second, the latency of a texture fetch or a
//! storage-buffer read that waits on the previous one, the FMA rate, and how fast invocations
//! that only store a result run (a frame's fixed cost). A renderer's time set
//! against these says what bounds it (docs/benchmarks.md).
//!
//! Every kernel's output is checked after it is timed, so a kernel that did not run, or ran
//! wrong, cannot report a rate.

use std::time::{Duration, Instant};

use wgpu::util::DeviceExt;

use super::gpu_data::CeilingParams;
use super::level_texture::LevelTexture;
use super::pipeline::{
    atlas_entry, atlas_sampler_entry, clamped_sampler, compute_pipelines, numbered_bind_group,
    storage_entry, uniform_entry,
};
use super::{GpuContext, GpuTimer, RenderError, read_buffer, time_passes, timing_name};

/// How much work each measurement does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CeilingSizes {
    /// Bytes the bandwidth kernel reads (it writes as many).
    pub stream_bytes: u64,
    /// Invocations of the sample-rate, FMA and store-only kernels.
    pub invocations: u32,
    /// Filtered samples per invocation.
    pub samples: u32,
    /// FMA rounds per invocation (each 8 × vec4).
    pub fma_rounds: u32,
    /// Dependent fetches per invocation of the latency kernels (one warp of 32 runs them).
    pub chain_fetches: u32,
    /// Timed passes per kernel; the median is reported.
    pub repeats: u32,
}

impl CeilingSizes {
    /// For a real GPU: 256 MiB streamed, 268 M samples, 69 GFLOP, 16 384 fetches per chain.
    pub const FULL: Self = Self {
        stream_bytes: 256 << 20,
        invocations: 1 << 20,
        samples: 256,
        fma_rounds: 1024,
        chain_fetches: 16384,
        repeats: 20,
    };
    /// For a software device (tests, CI): the same kernels, a few thousandth of the work.
    pub const QUICK: Self = Self {
        stream_bytes: 1 << 20,
        invocations: 4096,
        samples: 16,
        fma_rounds: 16,
        chain_fetches: 64,
        repeats: 3,
    };
}

/// What the GPU did, each figure from the median pass.
#[derive(Debug, Clone, PartialEq)]
pub struct Ceilings {
    /// `gpu-timestamps`, or `wall-clock-with-device-wait` where the device has no timestamps.
    pub timing: &'static str,
    /// The work done: as asked, the streamed bytes held to what the device can bind.
    pub sizes: CeilingSizes,
    /// Bytes read plus bytes written per second, by a copy between two storage buffers.
    pub memory_bytes_per_s: f64,
    /// Trilinear samples per second from a 64³ 8-bit 3D texture (the renderers' format), each
    /// invocation walking its own line one texel per sample, as a ray does.
    pub filtered_samples_per_s: f64,
    /// The same from a 16-bit float texture (volumes whose value levels pass 255).
    pub filtered_f16_samples_per_s: f64,
    /// Nanoseconds from one filtered sample to the next when each position waits on the
    /// previous sample (the texture is cache-resident).
    pub texture_latency_ns: f64,
    /// Nanoseconds from one storage-buffer read to the next when each index is the previous
    /// read's value (16 KiB, cache-resident).
    pub buffer_latency_ns: f64,
    /// Floating-point operations per second (an FMA counts two).
    pub fma_flops_per_s: f64,
    /// Invocations per second of a kernel whose invocations only store one value each.
    pub store_only_invocations_per_s: f64,
    /// Median milliseconds of each kernel, by name.
    pub median_ms: [(&'static str, f64); KERNELS.len()],
}

/// Side of the cubic texture the sample kernels read.
const TEXTURE_SIDE: usize = 64;
/// Its every texel's value level: not zero, so a kernel that read nothing cannot pass.
const TEXTURE_LEVEL: u16 = 77;
/// The same for the 16-bit float texture (above 255, so it gets that format; exact in f16).
const TEXTURE_LEVEL_F16: u16 = 300;
/// Entries of the index chain: 16 KiB.
const CHAIN_LENGTH: u32 = 4096;
/// The chain steps by this (odd, so one cycle through all entries; 4 KiB apart, a new cache line
/// each read).
const CHAIN_STRIDE: u32 = 1031;
/// Invocations of the latency kernels: one warp.
const CHAIN_INVOCATIONS: u32 = 32;
const FMA_SCALE: f32 = 0.999;
const FMA_OFFSET: f32 = 0.001;
/// Keep in sync with `WORKGROUP` in `ceilings.wgsl`.
const WORKGROUP: u32 = 256;
/// Most workgroups of the grid-stride bandwidth kernel.
const STREAM_WORKGROUPS: u32 = 8192;
/// Untimed passes before any timing, until this has passed: a GPU idle before starts slow.
const WARMUP_TIME: Duration = Duration::from_millis(200);

/// Each measurement's name and the entry point of `ceilings.wgsl` it runs (`filtered_f16` runs
/// `filtered` on a 16-bit float texture, the format of volumes whose levels pass 255).
const KERNELS: [(&str, &str); 7] = [
    ("stream", "stream"),
    ("filtered", "filtered"),
    ("filtered_f16", "filtered"),
    ("texture_chain", "texture_chain"),
    ("buffer_chain", "buffer_chain"),
    ("fma_rate", "fma_rate"),
    ("store_only", "store_only"),
];

/// The index in [`KERNELS`] of the measurement called `name`.
fn kernel_index(name: &str) -> usize {
    KERNELS
        .iter()
        .position(|&(kernel, _)| kernel == name)
        .expect("a measurement of KERNELS")
}

/// Runs every measurement with `sizes` and checks each kernel's output.
pub fn measure_ceilings(
    context: &GpuContext,
    sizes: CeilingSizes,
) -> Result<Ceilings, RenderError> {
    let kit = Kit::new(context, sizes)?;
    let timer = GpuTimer::new(context, sizes.repeats);
    let warming = Instant::now();
    while warming.elapsed() < WARMUP_TIME {
        kit.time(context, kernel_index("filtered"), None, 3)?;
    }
    let mut median_ms = [("", 0.0); KERNELS.len()];
    for (kernel, (name, _)) in KERNELS.iter().enumerate() {
        kit.time(context, kernel, None, 2)?;
        let mut times = kit.time(context, kernel, timer.as_ref(), sizes.repeats)?;
        times.sort_by(f64::total_cmp);
        median_ms[kernel] = (*name, times[times.len() / 2]);
        kit.check(context, kernel)?;
    }
    let seconds = |name: &str| median_ms[kernel_index(name)].1 * 1e-3;
    let samples = sizes.invocations as f64 * sizes.samples as f64;
    let flops = sizes.invocations as f64 * sizes.fma_rounds as f64 * 8.0 * 4.0 * 2.0;
    Ok(Ceilings {
        timing: timing_name(timer.as_ref()),
        sizes: CeilingSizes {
            stream_bytes: kit.stream_bytes(),
            ..sizes
        },
        memory_bytes_per_s: 2.0 * kit.stream_bytes() as f64 / seconds("stream"),
        filtered_samples_per_s: samples / seconds("filtered"),
        filtered_f16_samples_per_s: samples / seconds("filtered_f16"),
        texture_latency_ns: seconds("texture_chain") * 1e9 / sizes.chain_fetches as f64,
        buffer_latency_ns: seconds("buffer_chain") * 1e9 / sizes.chain_fetches as f64,
        fma_flops_per_s: flops / seconds("fma_rate"),
        store_only_invocations_per_s: sizes.invocations as f64 / seconds("store_only"),
        median_ms,
    })
}

/// The pipelines, their buffers and what each kernel's pass dispatches.
struct Kit {
    sizes: CeilingSizes,
    elements: u32,
    pipelines: Vec<wgpu::ComputePipeline>,
    /// One bind group per kernel (their parameters differ).
    bind_groups: Vec<wgpu::BindGroup>,
    /// Texel value × this = value level, of the 8-bit and the 16-bit texture.
    texel_scales: [f32; 2],
    destination: wgpu::Buffer,
    results: wgpu::Buffer,
}

impl Kit {
    fn new(context: &GpuContext, sizes: CeilingSizes) -> Result<Self, RenderError> {
        let device = &context.device;
        let stream_bytes = sizes.stream_bytes.min(context.max_storage_bytes()) / 16 * 16;
        let elements = u32::try_from(stream_bytes / 16).map_err(|_| {
            RenderError::Invalid("the bandwidth kernel streams at most 64 GiB".into())
        })?;
        if elements == 0 || sizes.repeats == 0 {
            return Err(RenderError::Invalid(
                "ceilings need a positive stream size and repeat count".into(),
            ));
        }
        let (pipelines, layout) = compute_pipelines(
            context,
            "ceilings",
            super::shaders::CEILINGS,
            &KERNELS.map(|(_, entry_point)| entry_point),
            &[
                uniform_entry(0, false),
                storage_entry(1, true),
                storage_entry(2, false),
                atlas_entry(3),
                atlas_sampler_entry(4),
                storage_entry(5, true),
                storage_entry(6, false),
            ],
        );
        let pattern: Vec<u32> = (0..elements * 4).map(stream_word).collect();
        let source = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("voxscope::ceilings_source"),
            contents: bytemuck::cast_slice(&pattern),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let destination = poisoned_buffer(device, "ceilings_destination", elements as u64 * 4);
        let results_len = sizes.invocations.max(CHAIN_INVOCATIONS);
        let results = poisoned_buffer(device, "ceilings_results", results_len as u64);
        let chain: Vec<u32> = (0..CHAIN_LENGTH)
            .map(|i| (i + CHAIN_STRIDE) % CHAIN_LENGTH)
            .collect();
        let chain = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("voxscope::ceilings_chain"),
            contents: bytemuck::cast_slice(&chain),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let texels = TEXTURE_SIDE.pow(3);
        let byte_texture = LevelTexture::upload(
            context,
            "ceilings_texture",
            [TEXTURE_SIDE; 3],
            &vec![TEXTURE_LEVEL; texels],
        )?;
        let half_texture = LevelTexture::upload(
            context,
            "ceilings_texture_f16",
            [TEXTURE_SIDE; 3],
            &vec![TEXTURE_LEVEL_F16; texels],
        )?;
        let sampler = clamped_sampler(
            device,
            wgpu::FilterMode::Linear,
            "voxscope::ceilings_sampler",
        );
        let bind_groups = (0..KERNELS.len())
            .map(|kernel| {
                let (iterations, invocations) = Self::work(sizes, kernel);
                let texture = if KERNELS[kernel].0 == "filtered_f16" {
                    &half_texture
                } else {
                    &byte_texture
                };
                let params = CeilingParams {
                    elements,
                    iterations,
                    invocations,
                    chain_length: CHAIN_LENGTH,
                    fma_scale: FMA_SCALE,
                    fma_offset: FMA_OFFSET,
                    _padding: [0; 2],
                };
                let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("voxscope::ceilings_params"),
                    contents: bytemuck::bytes_of(&params),
                    usage: wgpu::BufferUsages::UNIFORM,
                });
                numbered_bind_group(
                    device,
                    "voxscope::ceilings_bind_group",
                    &layout,
                    &[
                        params.as_entire_binding(),
                        source.as_entire_binding(),
                        destination.as_entire_binding(),
                        wgpu::BindingResource::TextureView(&texture.view),
                        wgpu::BindingResource::Sampler(&sampler),
                        chain.as_entire_binding(),
                        results.as_entire_binding(),
                    ],
                )
            })
            .collect();
        Ok(Self {
            sizes,
            elements,
            pipelines,
            bind_groups,
            texel_scales: [byte_texture.scale, half_texture.scale],
            destination,
            results,
        })
    }

    fn stream_bytes(&self) -> u64 {
        self.elements as u64 * 16
    }

    /// Iterations per invocation and invocations of `kernel` (0 for the stream kernel, which
    /// loops over its elements).
    fn work(sizes: CeilingSizes, kernel: usize) -> (u32, u32) {
        match KERNELS[kernel].0 {
            "stream" => (0, 0),
            "filtered" | "filtered_f16" => (sizes.samples, sizes.invocations),
            "fma_rate" => (sizes.fma_rounds, sizes.invocations),
            "store_only" => (0, sizes.invocations),
            _ => (sizes.chain_fetches, CHAIN_INVOCATIONS),
        }
    }

    fn workgroups(&self, kernel: usize) -> u32 {
        match Self::work(self.sizes, kernel) {
            (_, 0) => self.elements.div_ceil(WORKGROUP).min(STREAM_WORKGROUPS),
            (_, invocations) => invocations.div_ceil(WORKGROUP),
        }
    }

    /// Runs `kernel` `passes` times; milliseconds of each (GPU time with `timer`, else wall time
    /// with a device wait per pass).
    fn time(
        &self,
        context: &GpuContext,
        kernel: usize,
        timer: Option<&GpuTimer>,
        passes: u32,
    ) -> Result<Vec<f64>, RenderError> {
        let submit = |_, writes| {
            let mut encoder =
                context
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("voxscope::ceilings"),
                    });
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("voxscope::ceilings_pass"),
                    timestamp_writes: writes,
                });
                pass.set_pipeline(&self.pipelines[kernel]);
                pass.set_bind_group(0, &self.bind_groups[kernel], &[]);
                pass.dispatch_workgroups(self.workgroups(kernel), 1, 1);
            }
            context.queue.submit([encoder.finish()]);
        };
        time_passes(context, timer, passes, submit)
    }

    /// Checks what `kernel` wrote against what it must have computed.
    fn check(&self, context: &GpuContext, kernel: usize) -> Result<(), RenderError> {
        let name = KERNELS[kernel].0;
        let wrong =
            |detail: String| RenderError::Invalid(format!("ceilings: the {name} kernel {detail}"));
        if name == "stream" {
            let bytes = self.stream_bytes();
            let copied = read_buffer(context, &self.destination, bytes)?;
            let copied: &[u32] = bytemuck::cast_slice(&copied);
            let mismatch = (0u32..)
                .zip(copied)
                .position(|(word, &got)| got != stream_word(word));
            return match mismatch {
                None => Ok(()),
                Some(word) => Err(wrong(format!("copied word {word} wrong"))),
            };
        }
        let (iterations, invocations) = Self::work(self.sizes, kernel);
        let bytes = read_buffer(context, &self.results, invocations as u64 * 4)?;
        let results: &[f32] = bytemuck::cast_slice(&bytes);
        let [byte_scale, half_scale] = self.texel_scales;
        let texel = TEXTURE_LEVEL as f32 / byte_scale;
        // `fma_rate`'s result depends only on the invocation's low three bits.
        let fma_totals: Vec<f32> = if name == "fma_rate" {
            (0..8)
                .map(|low| expected_fma_total(low, iterations))
                .collect()
        } else {
            Vec::new()
        };
        for (invocation, &got) in results.iter().enumerate() {
            let expected = match name {
                "filtered" => iterations as f32 * texel,
                "filtered_f16" => iterations as f32 * TEXTURE_LEVEL_F16 as f32 / half_scale,
                "texture_chain" => texel,
                "store_only" => invocation as f32,
                "buffer_chain" => {
                    let start = invocation as u64 % CHAIN_LENGTH as u64;
                    ((start + iterations as u64 * CHAIN_STRIDE as u64) % CHAIN_LENGTH as u64) as f32
                }
                _ => fma_totals[invocation % 8],
            };
            let close = (got - expected).abs() <= 1e-3 * expected.abs().max(1.0);
            if !close {
                return Err(wrong(format!(
                    "gave {got} for invocation {invocation}, expected {expected}"
                )));
            }
        }
        Ok(())
    }
}

/// Word `index` of the streamed data: a hash, so a shifted or partial copy shows.
fn stream_word(index: u32) -> u32 {
    index.wrapping_mul(2_654_435_761)
}

/// What `fma_rate` writes for `invocation`: its 32 lanes after `rounds` FMAs, summed.
fn expected_fma_total(invocation: u32, rounds: u32) -> f32 {
    let first = (invocation & 7) as f32;
    let mut total = 0.0;
    for lane in 0..32 {
        let mut a = first + lane as f32;
        for _ in 0..rounds {
            a = a.mul_add(FMA_SCALE, FMA_OFFSET);
        }
        total += a;
    }
    total
}

/// A buffer of `words` 32-bit words, all bits set (a NaN as f32), that a kernel writes.
fn poisoned_buffer(device: &wgpu::Device, label: &str, words: u64) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(&format!("voxscope::{label}")),
        contents: &vec![0xff; words as usize * 4],
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    })
}
