//! The streamed composite (`shaders/stream_composite.wgsl`): channels of one grid streamed
//! together through one atlas and page table draw, once the view is complete at full detail,
//! what the in-memory composite of the same voxels draws (DVR, shaded and not, and MIP); a hidden channel's
//! bricks are never read; hiding or recoloring a channel draws the next frame without reading
//! anything; the probe finds the in-memory composite's point.

mod support;

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use image::RgbaImage;
use support::gpu;
use support::reference::psnr;
use voxscope_octree::TransferFunction;
use voxscope_render::{
    Camera, ChannelLayer, CompositeVolume, GpuContext, ProbeRequest, RenderMode, RenderSettings,
    RenderTarget, Renderer, Shading, VolumeRenderer, probe_pixel, read_image,
};
use voxscope_stream::{
    AtlasZero, BrickData, BrickError, BrickId, BrickSource, ChannelSources, Downsampling,
    MemorySource, PyramidShape, StreamOptions, StreamStatus, UploadPath,
};
use voxscope_volume::{LoadOptions, Quantization, QuantizedVolume, ValueWindow};

const SIZE: (u32, u32) = (96, 72);

/// Four channels on one 64³ grid (8 bricks of level 0 each, and coarser levels), colors dim
/// enough that their sum rarely saturates.
fn channels() -> Vec<(QuantizedVolume, TransferFunction, [f32; 3])> {
    let specs = [
        ("synthetic:sphere:64", [0.0, 1.0, 0.0]),
        ("synthetic:shells:64", [1.0, 0.0, 1.0]),
        ("synthetic:noise:64", [0.0, 1.0, 1.0]),
        ("synthetic:gradient:64", [1.0, 1.0, 0.0]),
    ];
    specs
        .iter()
        .map(|(spec, color)| {
            let volume = voxscope_volume::load(spec, &LoadOptions::default()).expect(spec);
            let quantized = QuantizedVolume::new(&volume);
            let window = quantized.robust_window();
            (
                quantized,
                TransferFunction::gray(window),
                color.map(|c: f32| c * 0.45),
            )
        })
        .collect()
}

fn layers(channels: &[(QuantizedVolume, TransferFunction, [f32; 3])]) -> Vec<ChannelLayer<'_>> {
    channels
        .iter()
        .map(|(quantized, transfer, color)| ChannelLayer {
            quantized,
            transfer,
            color: *color,
        })
        .collect()
}

/// A source that counts the bricks read (to show what a hidden channel costs).
struct Counted {
    inner: MemorySource,
    reads: AtomicU64,
}

impl BrickSource for Counted {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn shape(&self) -> &PyramidShape {
        self.inner.shape()
    }
    fn spacing(&self) -> [f64; 3] {
        self.inner.spacing()
    }
    fn quantization(&self) -> Quantization {
        self.inner.quantization()
    }
    fn max_value_level(&self) -> u16 {
        self.inner.max_value_level()
    }
    fn read_brick(&self, id: BrickId) -> Result<BrickData, BrickError> {
        self.reads.fetch_add(1, Ordering::Relaxed);
        self.inner.read_brick(id)
    }
}

/// The channels as one streamed pyramid, and each channel's counted source.
fn streamed(
    channels: &[(QuantizedVolume, TransferFunction, [f32; 3])],
) -> (Arc<ChannelSources>, Vec<Arc<Counted>>) {
    let counted: Vec<Arc<Counted>> = channels
        .iter()
        .enumerate()
        .map(|(c, (quantized, _, _))| {
            let inner = MemorySource::new(
                &format!("channel {c}"),
                quantized,
                [1.0; 3],
                Downsampling::Mean,
            )
            .expect("pyramid");
            Arc::new(Counted {
                inner,
                reads: AtomicU64::new(0),
            })
        })
        .collect();
    let sources = counted
        .iter()
        .map(|c| Arc::clone(c) as Arc<dyn BrickSource>)
        .collect();
    let pyramid = ChannelSources::new("four channels", sources).expect("one grid");
    (Arc::new(pyramid), counted)
}

fn options() -> StreamOptions {
    StreamOptions {
        gpu_memory: 64 << 20,
        ram_cache: 64 << 20,
        upload_bytes_per_frame: 8 << 20,
        uploads: UploadPath::Scatter,
        atlas_zero: AtlasZero::Auto,
        workers: 2,
        // Level 0 wherever the view is, as the in-memory composite draws.
        lod_scale: 0.0,
        prefetch: false,
        level_walk: true,
        retry_after: Duration::from_secs(3600),
    }
}

fn camera() -> Camera {
    Camera {
        azimuth_deg: 35.0,
        elevation_deg: 25.0,
        distance: 2.2,
        ..Camera::default()
    }
}

fn settings(mode: RenderMode, density: f32) -> RenderSettings {
    RenderSettings {
        mode,
        density,
        ..RenderSettings::full_detail(u32::MAX)
    }
}

/// Draws frame after frame until the streamer says nothing visible is missing.
fn refine(
    context: &GpuContext,
    renderer: &mut VolumeRenderer,
    settings: &RenderSettings,
) -> (RgbaImage, StreamStatus) {
    let target = RenderTarget::new(context, SIZE.0, SIZE.1);
    let started = Instant::now();
    let mut first = None;
    loop {
        let status = renderer.update(context).expect("a streaming renderer");
        let first = *first.get_or_insert(status.frame);
        renderer.render(context, &target, &camera(), settings);
        context.wait_idle().expect("GPU");
        if status.complete && status.judged_frame.is_some_and(|judged| judged >= first) {
            return (read_image(context, &target).expect("readback"), status);
        }
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "not complete: {status:?}"
        );
        if status.uploads == 0 {
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

/// The in-memory composite's image of `layers`, those `shown` marks drawn.
fn in_memory(
    context: &GpuContext,
    layers: &[ChannelLayer<'_>],
    shown: &[bool],
    settings: &RenderSettings,
) -> RgbaImage {
    let volume = CompositeVolume::upload(context, layers, [1.0; 3]).expect("upload");
    volume.set_shown_layers(context, layers, shown);
    let target = RenderTarget::new(context, SIZE.0, SIZE.1);
    volume.render(context, &target, &camera(), settings);
    read_image(context, &target).expect("readback")
}

fn save(image: &RgbaImage, name: &str) {
    image
        .save(support::image_dir().join(format!("stream-composite-{name}.png")))
        .expect("save");
}

fn lit(image: &RgbaImage) -> f64 {
    support::reference::coverage(image)
}

#[test]
fn the_streamed_composite_draws_the_in_memory_composite_of_the_same_voxels() {
    let context = gpu();
    let channels = channels();
    let layers = layers(&channels);
    let shown = [true; 4];
    let (pyramid, _) = streamed(&channels);
    let first = TransferFunction::gray(ValueWindow {
        low: 0.0,
        high: 1.0,
    });
    let mut renderer =
        VolumeRenderer::new_stream(&context, pyramid, options(), &first).expect("renderer");
    assert_eq!(renderer.renderer().channel_count(), 4);
    renderer
        .renderer()
        .set_channels(&context, &layers, &shown)
        .expect("four layers");
    let cases = [
        (RenderMode::Dvr, 0.3, Shading::OFF, "dvr"),
        (RenderMode::Dvr, 0.3, Shading::default(), "dvr-shaded"),
        (RenderMode::Mip, 1.0, Shading::OFF, "mip"),
    ];
    for (mode, density, shading, name) in cases {
        let settings = RenderSettings {
            shading,
            ..settings(mode, density)
        };
        let (streamed, status) = refine(&context, &mut renderer, &settings);
        let expected = in_memory(&context, &layers, &shown, &settings);
        save(&streamed, name);
        save(&expected, &format!("{name}-in-memory"));
        assert!(lit(&streamed) > 0.2, "{name}: the composite shows");
        let db = psnr(&streamed, &expected);
        // (The in-memory composite holds 16-bit floats: exact up to level 2048, so the two
        // differ by that rounding, not by what is drawn.)
        assert!(
            db > 40.0,
            "{name}: {db:.1} dB from the in-memory composite ({status:?})"
        );
    }
}

#[test]
fn a_hidden_channel_is_never_read_and_hiding_or_recoloring_reads_nothing() {
    let context = gpu();
    let channels = channels();
    let layers = layers(&channels);
    let (pyramid, counted) = streamed(&channels);
    let pinned_per_channel = pyramid
        .shape()
        .levels
        .iter()
        .filter(|l| l.brick_count() == 1)
        .count() as u64;
    let mut renderer =
        VolumeRenderer::new_stream(&context, pyramid, options(), &channels[0].1).expect("renderer");
    // Channel 2 (the noise, visible everywhere) hidden from the start.
    let shown = [true, true, false, true];
    renderer
        .renderer()
        .set_channels(&context, &layers, &shown)
        .expect("four layers");
    let dvr = settings(RenderMode::Dvr, 0.3);
    let (image, _) = refine(&context, &mut renderer, &dvr);
    let reads: Vec<u64> = counted
        .iter()
        .map(|c| c.reads.load(Ordering::Relaxed))
        .collect();
    assert_eq!(
        reads[2], pinned_per_channel,
        "the hidden channel's always-resident bricks alone are read: {reads:?}"
    );
    assert!(
        reads[1] > pinned_per_channel,
        "shown ones stream: {reads:?}"
    );
    assert!(psnr(&image, &in_memory(&context, &layers, &shown, &dvr)) > 40.0);

    // Hiding channel 1 and recoloring channel 3: the next frame draws it, nothing read.
    let loads_before = renderer.update(&context).expect("streams").counters.loads;
    let shown = [true, false, false, true];
    let mut recolored = layers.clone();
    recolored[3].color = [0.45, 0.0, 0.0];
    renderer
        .renderer()
        .set_channels(&context, &recolored, &shown)
        .expect("four layers");
    let target = RenderTarget::new(&context, SIZE.0, SIZE.1);
    let status = renderer.update(&context).expect("streams");
    renderer.render(&context, &target, &camera(), &dvr);
    let next = read_image(&context, &target).expect("readback");
    save(&next, "recolored");
    let expected = in_memory(&context, &recolored, &shown, &dvr);
    assert!(psnr(&next, &expected) > 40.0, "the next frame shows it");
    assert_eq!(status.counters.loads, loads_before, "nothing loaded");
    assert_eq!(
        counted
            .iter()
            .map(|c| c.reads.load(Ordering::Relaxed))
            .collect::<Vec<_>>(),
        reads,
        "nothing read"
    );
}

/// The probes of `renderer` over a 12×9 grid of pixels, as `settings` draw.
fn probes(
    context: &GpuContext,
    renderer: &VolumeRenderer,
    settings: &RenderSettings,
) -> Vec<Option<[f32; 3]>> {
    (0..9)
        .flat_map(|row| (0..12).map(move |column| [column * 8 + 3, row * 8 + 3]))
        .map(|pixel| {
            let request = ProbeRequest {
                size: [SIZE.0, SIZE.1],
                pixel,
                camera: &camera(),
                settings,
            };
            probe_pixel(context, renderer, &request)
                .expect("probe")
                .map(|hit| hit.point)
        })
        .collect()
}

#[test]
fn the_streamed_composite_probes_where_the_in_memory_composite_does() {
    // DVR: where the composite's opacity reaches half; MIP: the maximum of the channel drawn
    // brightest. The two march the same lattice of samples (level 0 resident), so their
    // points agree but where a sample's 16-bit float rounding in memory tips a comparison.
    let context = gpu();
    let channels = channels();
    let layers = layers(&channels);
    let shown = [true, true, false, true];
    let (pyramid, _) = streamed(&channels);
    let mut renderer =
        VolumeRenderer::new_stream(&context, pyramid, options(), &channels[0].1).expect("renderer");
    renderer
        .renderer()
        .set_channels(&context, &layers, &shown)
        .expect("four layers");
    let memory = VolumeRenderer::new_composite(&context, &layers, [1.0; 3]).expect("composite");
    memory
        .renderer()
        .set_channels(&context, &layers, &shown)
        .expect("four layers");
    for (mode, density) in [(RenderMode::Dvr, 0.3), (RenderMode::Mip, 1.0)] {
        let settings = settings(mode, density);
        refine(&context, &mut renderer, &settings);
        let streamed = probes(&context, &renderer, &settings);
        let expected = probes(&context, &memory, &settings);
        let (mut found, mut near) = (0, 0);
        for (got, want) in streamed.iter().zip(&expected) {
            match (got, want) {
                (Some(got), Some(want)) => {
                    found += 1;
                    let distance = (0..3)
                        .map(|a| (got[a] - want[a]).powi(2))
                        .sum::<f32>()
                        .sqrt();
                    near += usize::from(distance <= 0.01);
                }
                (None, None) => {}
                _ => panic!("{mode:?}: streamed {got:?}, in memory {want:?}"),
            }
        }
        eprintln!("{mode:?}: {near} of {found} probes at the in-memory composite's point");
        assert!(found >= 40, "{mode:?}: {found} probes hit");
        assert!(
            near * 10 >= found * 9,
            "{mode:?}: {near} of {found} probes agree"
        );
    }
    // Hiding every channel leaves nothing to probe.
    renderer
        .renderer()
        .set_channels(&context, &layers, &[false; 4])
        .expect("four layers");
    let dvr = settings(RenderMode::Dvr, 0.3);
    assert!(
        probes(&context, &renderer, &dvr)
            .iter()
            .all(Option::is_none)
    );
}
