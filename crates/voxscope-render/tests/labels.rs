//! Label volumes (segmentations, atlases: values that name, not measure) in every renderer, on
//! the software Vulkan device: sampled at the nearest voxel whatever the trilinear setting
//! (against the CPU references' nearest-neighbour march and exact octree), MIP drawing the first
//! visible label, coarser levels reduced by the mode (never a label the volume lacks), the
//! octree's and the bricks' coarse colors never a mix of two labels', slices nearest. GPU tests
//! fail when no adapter is found.

mod support;

use std::collections::HashSet;
use std::time::{Duration, Instant};

use image::RgbaImage;
use support::reference::{MarchVolume, psnr, reference_march, reference_render};
use support::{colored_octree, gpu, image_dir};
use voxscope_octree::{BuildOptions, LEAF, Octree, TransferFunction, labels_transfer};
use voxscope_render::{
    Camera, GpuContext, RenderMode, RenderSettings, RenderTarget, RendererKind, RendererOptions,
    Shading, SliceConvention, SliceFrame, SliceSettings, SliceView, VolumeRenderer, read_buffer,
    read_image,
};
use voxscope_volume::{LoadOptions, QuantizedVolume, Volume};

const SIZE: (u32, u32) = (120, 100);

/// The synthetic segmentation: thirteen labels, two thin sheets.
fn labels_volume() -> Volume {
    voxscope_volume::load("synthetic:labels:48x40x36", &LoadOptions::default())
        .expect("synthetic labels")
}

/// The volume, its quantized values, its label octree colored by the labels transfer function.
struct Labels {
    volume: Volume,
    quantized: QuantizedVolume,
    octree: Octree,
    transfer: TransferFunction,
}

fn prepare() -> Labels {
    prepare_volume(labels_volume())
}

fn prepare_volume(volume: Volume) -> Labels {
    let quantized = QuantizedVolume::new(&volume);
    let transfer = labels_transfer(&quantized);
    let options = BuildOptions {
        labels: true,
        ..BuildOptions::default()
    };
    let (octree, transfer) = colored_octree(&volume, Some(transfer), options);
    assert!(octree.labels);
    Labels {
        volume,
        quantized,
        octree,
        transfer,
    }
}

impl Labels {
    fn renderer(&self, context: &GpuContext, options: RendererOptions) -> VolumeRenderer {
        VolumeRenderer::new(
            context,
            options,
            &self.octree,
            &self.quantized,
            self.volume.spacing,
            self.octree.depth,
            &self.transfer,
        )
        .expect("upload")
    }

    /// The RGB of every label the volume holds under the transfer function, opaque ones only.
    fn palette(&self) -> HashSet<[u8; 3]> {
        let table = self.transfer.lookup_table(self.quantized.quantization);
        self.quantized
            .levels
            .iter()
            .map(|&level| table[level as usize])
            .filter(|color| color >> 24 != 0)
            .map(|color| {
                let [r, g, b, _] = voxscope_octree::unpack_rgba(color);
                [r, g, b]
            })
            .collect()
    }
}

fn camera() -> Camera {
    Camera {
        azimuth_deg: 35.0,
        elevation_deg: 20.0,
        distance: 1.6,
        ..Camera::default()
    }
}

/// Full detail, unshaded, trilinear filtering asked for (a label volume must ignore it).
fn settings(depth: u32, mode: RenderMode) -> RenderSettings {
    RenderSettings {
        mode,
        trilinear: true,
        ..RenderSettings::full_detail(depth)
    }
}

fn draw(
    context: &GpuContext,
    renderer: &mut VolumeRenderer,
    settings: &RenderSettings,
) -> RgbaImage {
    draw_at(context, renderer, settings, &camera(), SIZE)
}

fn draw_at(
    context: &GpuContext,
    renderer: &mut VolumeRenderer,
    settings: &RenderSettings,
    camera: &Camera,
    size: (u32, u32),
) -> RgbaImage {
    let target = RenderTarget::new(context, size.0, size.1);
    // The streaming renderer refines until nothing visible is missing; the others draw once.
    let started = Instant::now();
    let mut first = None;
    loop {
        let status = renderer.update(context);
        renderer.render(context, &target, camera, settings);
        context.wait_idle().expect("GPU");
        let Some(status) = status else { break };
        let first = *first.get_or_insert(status.frame);
        if status.complete && status.judged_frame.is_some_and(|judged| judged >= first) {
            break;
        }
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "the stream never completed: {status:?}"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    read_image(context, &target).expect("readback")
}

/// Pixels whose color differs from `b`'s by more than 2 in some channel, as a fraction.
fn differing(a: &RgbaImage, b: &RgbaImage) -> f64 {
    let count = a
        .pixels()
        .zip(b.pixels())
        .filter(|(p, q)| (0..3).any(|c| p.0[c].abs_diff(q.0[c]) > 2))
        .count();
    count as f64 / a.pixels().len() as f64
}

/// Lit pixels whose color is no label's (a blend, or a label the volume lacks).
fn foreign_pixels(image: &RgbaImage, palette: &HashSet<[u8; 3]>) -> usize {
    image
        .pixels()
        .map(|p| [p.0[0], p.0[1], p.0[2]])
        .filter(|rgb| *rgb != [0, 0, 0] && !palette.contains(rgb))
        .count()
}

fn save(image: &RgbaImage, name: &str) {
    image
        .save(image_dir().join(format!("labels-{name}.png")))
        .expect("save");
}

fn kinds() -> [(&'static str, RendererOptions); 5] {
    [
        ("dense", RendererKind::Dense.into()),
        (
            "bricks8",
            RendererOptions {
                kind: RendererKind::Bricks,
                brick_size: 8,
                ..RendererOptions::default()
            },
        ),
        ("bricks32", RendererKind::Bricks.into()),
        ("stream", RendererKind::Stream.into()),
        ("octree", RendererKind::Octree.into()),
    ]
}

#[test]
fn every_renderer_draws_labels_as_the_nearest_neighbour_reference_dvr_and_mip() {
    let context = gpu();
    let labels = prepare();
    let palette = labels.palette();
    let depth = labels.octree.depth;
    let nearest = MarchVolume::new(&labels.quantized).into_labels();
    let interpolated = MarchVolume::new(&labels.quantized);
    for mode in [RenderMode::Dvr, RenderMode::Mip] {
        let settings = settings(depth, mode);
        let marched = reference_march(
            &nearest,
            labels.volume.spacing,
            &labels.transfer,
            &camera(),
            &settings,
            SIZE.0,
            SIZE.1,
        );
        let exact = reference_render(
            &labels.octree,
            labels.volume.spacing,
            &labels.transfer,
            &camera(),
            &settings,
            SIZE.0,
            SIZE.1,
        );
        save(&marched, &format!("{mode:?}-reference"));
        // What interpolating the labels draws: the fault this guards against, far from both.
        let blended = reference_march(
            &interpolated,
            labels.volume.spacing,
            &labels.transfer,
            &camera(),
            &settings,
            SIZE.0,
            SIZE.1,
        );
        save(&blended, &format!("{mode:?}-interpolated"));
        let blended_off = differing(&blended, &marched);
        assert!(
            blended_off > 0.02,
            "{mode:?}: interpolation must look different ({blended_off:.4})"
        );
        assert_eq!(foreign_pixels(&marched, &palette), 0, "{mode:?}");
        for (name, options) in kinds() {
            let mut renderer = labels.renderer(&context, options);
            let image = draw(&context, &mut renderer, &settings);
            save(&image, &format!("{mode:?}-{name}"));
            // Every renderer meets a label's voxel where the ray enters it, as the octree's
            // exact boxes do (the sampling ones walk the voxels crossed between samples).
            let reference = &exact;
            let off = differing(&image, reference);
            eprintln!(
                "{mode:?} {name}: {:.3} % of pixels differ from the nearest-neighbour reference ({:.1} dB); interpolation {:.3} %",
                100.0 * off,
                psnr(&image, reference),
                100.0 * blended_off
            );
            assert!(
                off < 0.004,
                "{mode:?} {name}: {:.3} % of pixels differ from the reference",
                100.0 * off
            );
            assert_eq!(
                foreign_pixels(&image, &palette),
                0,
                "{mode:?} {name}: a color that is no label's"
            );
        }
    }
}

#[test]
fn coarser_levels_keep_each_blocks_most_frequent_label() {
    let context = gpu();
    let labels = prepare();
    let palette = labels.palette();
    let depth = labels.octree.depth;
    for max_level in [depth - 1, depth - 2] {
        let settings = RenderSettings {
            max_level,
            opacity_correction: false,
            ..settings(depth, RenderMode::Dvr)
        };
        let mut images = Vec::new();
        for (name, options) in [
            ("dense", RendererKind::Dense.into()),
            (
                "bricks8",
                RendererOptions {
                    kind: RendererKind::Bricks,
                    brick_size: 8,
                    ..RendererOptions::default()
                },
            ),
            ("stream", RendererKind::Stream.into()),
        ] {
            let mut renderer = labels.renderer(&context, options);
            let image = draw(&context, &mut renderer, &settings);
            save(&image, &format!("level{max_level}-{name}"));
            // A mean of labels 1 and 12 is 6 or 7, another organ's color: the mode never is.
            assert_eq!(
                foreign_pixels(&image, &palette),
                0,
                "level {max_level} {name}: a color that is no label's"
            );
            images.push((name, image));
        }
        let (_, dense) = &images[0];
        for (name, image) in &images[1..] {
            let off = differing(dense, image);
            assert!(
                off < 0.004,
                "level {max_level}: {name} differs from dense in {:.3} % of pixels",
                100.0 * off
            );
        }
    }
}

#[test]
fn the_octree_and_the_bricks_color_coarse_nodes_by_a_label_never_a_mix() {
    let context = gpu();
    let labels = prepare();
    let palette = labels.palette();
    let depth = labels.octree.depth;
    // The octree's GPU recolor follows the CPU's rule (the children's most shown color) bit for
    // bit, and draws as the exact reference does at a level of nodes.
    let mut renderer = labels.renderer(&context, RendererKind::Octree.into());
    let mut encoder = context.device.create_command_encoder(&Default::default());
    renderer
        .set_transfer(&context, &mut encoder, &labels.transfer, None)
        .expect("recolor");
    context.queue.submit([encoder.finish()]);
    let settings = RenderSettings {
        max_level: depth - 2,
        ..settings(depth, RenderMode::Dvr)
    };
    let image = draw(&context, &mut renderer, &settings);
    let reference = reference_render(
        &labels.octree,
        labels.volume.spacing,
        &labels.transfer,
        &camera(),
        &settings,
        SIZE.0,
        SIZE.1,
    );
    save(&image, "octree-level-nodes");
    let db = psnr(&image, &reference);
    assert!(db >= 40.0, "octree level {}: {db:.1} dB", depth - 2);
    for (index, node) in labels.octree.nodes.iter().enumerate() {
        let [r, g, b, a] = voxscope_octree::unpack_rgba(node.color);
        if a > 0 {
            assert!(
                palette.contains(&[r, g, b]),
                "node {index}'s color {:?} is no label's",
                [r, g, b]
            );
        }
    }

    // The bricks' nodes at the brick level: a label its voxels show (a majority vote).
    let layout = voxscope_octree::BrickLayout::new(&labels.octree, &labels.quantized, 8, 2048)
        .expect("layout");
    let bricks = voxscope_render::GpuBricks::upload(
        &context,
        &layout,
        &labels.quantized,
        labels.volume.spacing,
        depth,
        &labels.transfer,
    )
    .expect("bricks");
    let mut encoder = context.device.create_command_encoder(&Default::default());
    context
        .brick_recolor()
        .encode(&context, &mut encoder, &bricks, None);
    context.queue.submit([encoder.finish()]);
    use voxscope_render::OctreeOnGpu;
    let bytes = read_buffer(&context, bricks.nodes(), bricks.nodes().size()).expect("readback");
    let nodes: &[voxscope_octree::Node] = bytemuck::cast_slice(&bytes);
    let table = labels.transfer.lookup_table(labels.quantized.quantization);
    let dims = labels.volume.dims;
    let level = layout.brick_level as usize;
    let mut checked = 0;
    let range = layout.level_starts[level]..layout.level_starts[level + 1];
    for (index, (node, gpu_node)) in layout.nodes[range.clone()]
        .iter()
        .zip(&nodes[range.clone()])
        .enumerate()
    {
        let index = range.start + index;
        if node.first_child == LEAF || node.first_child & voxscope_octree::BRICK_FLAG == 0 {
            continue;
        }
        let origin =
            layout.brick_origins[(node.first_child & !voxscope_octree::BRICK_FLAG) as usize];
        let mut shown = std::collections::HashMap::new();
        for z in origin[2]..(origin[2] + 8).min(dims[2]) {
            for y in origin[1]..(origin[1] + 8).min(dims[1]) {
                for x in origin[0]..(origin[0] + 8).min(dims[0]) {
                    let color =
                        table[labels.quantized.levels[x + dims[0] * (y + dims[1] * z)] as usize];
                    if color >> 24 != 0 {
                        *shown.entry(color & 0x00ff_ffff).or_insert(0usize) += 1;
                    }
                }
            }
        }
        let got = gpu_node.color;
        if shown.is_empty() {
            assert_eq!(got >> 24, 0, "brick node {index}: nothing visible");
            continue;
        }
        assert!(
            shown.contains_key(&(got & 0x00ff_ffff)),
            "brick node {index}: {got:08x} is none of its voxels' labels"
        );
        let total: usize = shown.values().sum();
        if let Some((&majority, _)) = shown.iter().find(|(_, n)| 2 * **n > total) {
            assert_eq!(got & 0x00ff_ffff, majority, "brick node {index}");
        }
        checked += 1;
    }
    assert!(checked > 10, "only {checked} bricks checked");
}

#[test]
fn slices_of_labels_show_the_nearest_voxel_even_when_asked_to_interpolate() {
    let context = gpu();
    let labels = prepare();
    let dims = labels.volume.dims;
    for (name, options) in [
        ("dense", RendererKind::Dense.into()),
        ("bricks", RendererKind::Bricks.into()),
        ("octree", RendererKind::Octree.into()),
    ] {
        let renderer: VolumeRenderer = labels.renderer(&context, options);
        let slice = |nearest: bool| {
            let view = SliceView {
                zoom: 3.0,
                ..SliceView::new(2, dims[2] / 2 + 3)
            };
            let frame = SliceFrame::axis_aligned(
                &view,
                SliceConvention::Image,
                dims,
                labels.volume.spacing,
                [160, 140],
            );
            let target = RenderTarget::new(&context, 160, 140);
            renderer.render_slice(
                &context,
                &target,
                &SliceSettings {
                    frame,
                    window: labels.transfer.window,
                    // Grays: the labels colormap alone would force nearest slices before.
                    colormap: voxscope_octree::Colormap::Grays,
                    nearest,
                },
            );
            read_image(&context, &target).expect("readback")
        };
        let linear = slice(false);
        save(&linear, &format!("slice-{name}"));
        assert_eq!(linear, slice(true), "{name}: a label slice interpolated");
    }
}

/// The mean absolute Laplacian of an image's luminance (4-neighbour, inner pixels): how far
/// pixels stand from their neighbours' mean. Speckle raises it; flat faces keep it low.
fn mean_abs_laplacian(image: &RgbaImage) -> f64 {
    let luma = |x: u32, y: u32| {
        let p = image.get_pixel(x, y).0;
        0.299 * p[0] as f64 + 0.587 * p[1] as f64 + 0.114 * p[2] as f64
    };
    let (w, h) = image.dimensions();
    let mut sum = 0.0;
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let around = luma(x - 1, y) + luma(x + 1, y) + luma(x, y - 1) + luma(x, y + 1);
            sum += (4.0 * luma(x, y) - around).abs();
        }
    }
    sum / ((w - 2) * (h - 2)) as f64
}

/// Categorical data is never dithered: zoomed in on a label volume, every renderer draws flat
/// faces as the octree's voxel cubes do, lit by the face entered (it drew each face as noise
/// with bricks and dense, 7.5× the octree's Laplacian: the per-pixel jitter and the gradient of
/// nearest-sampled labels), shaded and unshaded, and only the labels' own colors unshaded.
#[test]
fn zoomed_in_labels_draw_flat_faces_in_every_renderer() {
    let context = gpu();
    let volume = voxscope_volume::load("synthetic:labels:64", &LoadOptions::default())
        .expect("synthetic labels");
    let labels = prepare_volume(volume);
    let palette = labels.palette();
    let depth = labels.octree.depth;
    let near = Camera {
        distance: 0.8,
        ..Camera::default()
    };
    let whole = Camera::default();
    let size = (480, 360);
    // Zoomed in, the faces; from afar, unshaded, the boundaries between labels.
    for (lit, shading, camera) in [
        ("near-shaded", Shading::default(), near),
        ("near-unshaded", Shading::OFF, near),
        ("whole-shaded", Shading::default(), whole),
        ("whole-unshaded", Shading::OFF, whole),
    ] {
        let settings = RenderSettings {
            shading,
            ..RenderSettings::full_detail(depth)
        };
        let mut octree = labels.renderer(&context, RendererKind::Octree.into());
        let exact = draw_at(&context, &mut octree, &settings, &camera, size);
        save(&exact, &format!("{lit}-octree"));
        let floor = mean_abs_laplacian(&exact);
        eprintln!("{lit} octree: mean |Laplacian| {floor:.2}");
        for (name, options) in kinds() {
            if name == "octree" {
                continue;
            }
            let mut renderer = labels.renderer(&context, options);
            let image = draw_at(&context, &mut renderer, &settings, &camera, size);
            save(&image, &format!("{lit}-{name}"));
            let laplacian = mean_abs_laplacian(&image);
            eprintln!(
                "{lit} {name}: mean |Laplacian| {laplacian:.2}, the octree's {floor:.2} ({:.2}×)",
                laplacian / floor
            );
            assert!(
                laplacian < 1.5 * floor + 0.5,
                "{lit} {name}: speckle, mean |Laplacian| {laplacian:.2} against the octree's {floor:.2}"
            );
            if !shading.enabled {
                assert_eq!(
                    foreign_pixels(&image, &palette),
                    0,
                    "{lit} {name}: a color that is no label's"
                );
            }
        }
    }
}

/// Zoomed in so that a voxel is some 100 pixels, every renderer meets the labels' voxel cubes
/// where the exact octree reference does: the plate fixture's field is `(x + y + z) % 4`
/// (label 0 transparent), stairs of one-voxel steps. Sampled one voxel apart, bricks and dense
/// met each label up to a step late and drew the stairs a voxel off (22 % of the pixels
/// differed); they walk the voxels crossed between samples now.
#[test]
fn zoomed_in_one_voxel_stairs_match_the_exact_reference_in_every_renderer() {
    let context = gpu();
    let volume = voxscope_volume::load(
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/plates/plate-v04.ome.zarr"
        ),
        &LoadOptions::default(),
    )
    .expect("plate");
    let labels = prepare_volume(volume);
    let depth = labels.octree.depth;
    let near = Camera {
        distance: 1.2,
        ..Camera::default()
    };
    let size = (480, 360);
    let settings = RenderSettings::full_detail(depth);
    let exact = reference_render(
        &labels.octree,
        labels.volume.spacing,
        &labels.transfer,
        &near,
        &settings,
        size.0,
        size.1,
    );
    save(&exact, "stairs-reference");
    for (name, options) in kinds() {
        let mut renderer = labels.renderer(&context, options);
        let image = draw_at(&context, &mut renderer, &settings, &near, size);
        save(&image, &format!("stairs-{name}"));
        let off = differing(&image, &exact);
        eprintln!(
            "{name}: {:.3} % of pixels differ from the exact reference",
            100.0 * off
        );
        assert!(off < 0.005, "{name}: {:.3} % of pixels differ", 100.0 * off);
    }
}
