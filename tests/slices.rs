//! GPU slices (`VolumeRenderer::encode_slice`) against the voxels they show: every pixel of a
//! nearest slice at one pixel per voxel is the color of its voxel's value, from every source
//! (dense texture, bricks, octree), for several volumes, axes and indices; reoriented files put
//! the patient's right on the screen's left; value levels above 2048 stay exact; linear slices
//! equal a CPU trilinear reference; the app's zoomed frames draw the voxel their pixel maps to.
//! And `voxscope slice`, the command.

mod support;

use std::path::Path;
use std::process::{Command, Output};

use support::writers::{NiftiSpec, NrrdSpec, encode, nifti_bytes, write_nrrd};
use support::{colored_octree, gpu, image_dir, shared_data};
use voxscope_octree::{BuildOptions, Colormap};
use voxscope_render::{
    GpuContext, RenderTarget, RendererKind, RendererOptions, SliceConvention, SliceFrame,
    SliceSettings, SliceView, VolumeRenderer, read_image,
};
use voxscope_volume::{
    self, Endian, LoadOptions, NrrdEncoding, Orientation, QuantizedVolume, ValueWindow, Volume,
    VoxelData,
};

fn load(spec: &str) -> Volume {
    voxscope_volume::load(spec, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// The renderers a slice can read from: each kind, and bricks small enough to have many.
fn sources() -> [RendererOptions; 4] {
    [
        RendererKind::Dense.into(),
        RendererKind::Octree.into(),
        RendererKind::Bricks.into(),
        RendererOptions {
            kind: RendererKind::Bricks,
            brick_size: 4,
            ..Default::default()
        },
    ]
}

fn source_name(options: RendererOptions) -> String {
    format!("{}{}", options.kind.name(), options.brick_size)
}

/// `volume` uploaded for `options` (colored with its robust gray transfer function: slices do
/// not use it), with its quantized levels.
fn renderer(
    context: &GpuContext,
    volume: &Volume,
    options: RendererOptions,
) -> (VolumeRenderer, QuantizedVolume) {
    let quantized = QuantizedVolume::new(volume);
    let (octree, transfer) = colored_octree(volume, None, BuildOptions::default());
    let renderer = VolumeRenderer::new(
        context,
        options,
        &octree,
        &quantized,
        volume.spacing,
        octree.depth,
        &transfer,
    )
    .unwrap_or_else(|e| panic!("{}: {e}", volume.name));
    (renderer, quantized)
}

/// Draws one slice of `size` pixels and reads it back.
fn draw(
    context: &GpuContext,
    renderer: &VolumeRenderer,
    settings: &SliceSettings,
    size: [u32; 2],
) -> image::RgbaImage {
    let target = RenderTarget::new(context, size[0], size[1]);
    renderer.render_slice(context, &target, settings);
    read_image(context, &target).expect("readback")
}

/// The color a slice gives value level `level`: the value's place in the window through the
/// colormap, opaque.
fn color_of(quantized: &QuantizedVolume, settings: &SliceSettings, level: u16) -> [u8; 4] {
    let value = quantized.quantization.value(level);
    let [r, g, b] = settings
        .colormap
        .rgb_of(value, settings.window.normalize(value));
    [r, g, b, 255]
}

/// The voxel at pixel (column, row) of a one-pixel-per-voxel slice, written out per view from
/// the conventions' definitions (not from `SliceFrame`).
fn voxel_of_pixel(
    convention: SliceConvention,
    axis: usize,
    index: usize,
    dims: [usize; 3],
    column: usize,
    row: usize,
) -> [usize; 3] {
    let [x, y, z] = dims;
    match (convention, axis) {
        // Patient's right (+x) on the left, anterior (+y) and superior (+z) up.
        (SliceConvention::Radiological, 2) => [x - 1 - column, y - 1 - row, index],
        (SliceConvention::Radiological, 1) => [x - 1 - column, index, z - 1 - row],
        (SliceConvention::Radiological, _) => [index, y - 1 - column, z - 1 - row],
        // The first voxel top-left across z; +z up in the side views, as in the 3D view.
        (SliceConvention::Image, 2) => [column, row, index],
        (SliceConvention::Image, 1) => [column, index, z - 1 - row],
        (SliceConvention::Image, _) => [index, column, z - 1 - row],
    }
}

/// Checks every pixel of a nearest slice at one pixel per voxel against its voxel's color;
/// `stored` says what level the source holds for a voxel's level. Returns the slice.
#[allow(clippy::too_many_arguments)]
fn check_voxel_grid_slice(
    context: &GpuContext,
    name: &str,
    renderer: &VolumeRenderer,
    quantized: &QuantizedVolume,
    convention: SliceConvention,
    axis: usize,
    index: usize,
    window: ValueWindow,
    colormap: Colormap,
    stored: impl Fn(u16) -> u16,
) -> image::RgbaImage {
    let dims = quantized.dims;
    let (frame, size) = SliceFrame::voxel_grid(convention, axis, index, dims);
    let settings = SliceSettings {
        frame,
        window,
        colormap,
        nearest: true,
    };
    let image = draw(context, renderer, &settings, size);
    assert_eq!([image.width(), image.height()], size, "{name}");
    let mut wrong = Vec::new();
    for row in 0..size[1] as usize {
        for column in 0..size[0] as usize {
            let [x, y, z] = voxel_of_pixel(convention, axis, index, dims, column, row);
            let level = quantized.levels[x + dims[0] * (y + dims[1] * z)];
            let expected = color_of(quantized, &settings, stored(level));
            let got = image.get_pixel(column as u32, row as u32).0;
            if got != expected {
                wrong.push(format!(
                    "pixel ({column}, {row}) = voxel ({x}, {y}, {z}) level {level}: {got:?}, expected {expected:?}"
                ));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "{name}: {} of {} pixels differ, first: {}",
        wrong.len(),
        size[0] * size[1],
        wrong[..wrong.len().min(3)].join("; ")
    );
    image
}

#[test]
fn nearest_slices_equal_the_voxels_from_every_source() {
    let context = gpu();
    // u8 with uniform regions (collapsed leaves, leaves above the brick level), u16 shells,
    // f32 noise (65 536 levels), and the real anisotropic head (2×2×3 mm, i16), all non-cubic.
    let volumes = [
        load("synthetic:sphere:40x33x21"),
        load("synthetic:shells:36x30x28"),
        load("synthetic:noise:37x26x19"),
        load(shared_data("mri-head-128x128x62.nii.gz").to_str().unwrap()),
    ];
    let colormaps = [Colormap::Grays, Colormap::Viridis, Colormap::Inferno];
    let mut checked = 0;
    for (v, volume) in volumes.iter().enumerate() {
        for options in sources() {
            let (renderer, quantized) = renderer(&context, volume, options);
            assert!(renderer.exact_slices());
            let window = quantized.robust_window();
            for convention in [SliceConvention::Radiological, SliceConvention::Image] {
                for axis in 0..3 {
                    let side = volume.dims[axis];
                    for index in [0, side / 2, side - 1] {
                        let name = format!(
                            "{} {} {convention:?} axis {axis} index {index}",
                            volume.name,
                            source_name(options)
                        );
                        let image = check_voxel_grid_slice(
                            &context,
                            &name,
                            &renderer,
                            &quantized,
                            convention,
                            axis,
                            index,
                            window,
                            colormaps[(v + axis) % colormaps.len()],
                            exact_or_half(&context, &quantized),
                        );
                        let worth_a_look = index == side / 2
                            && convention == SliceConvention::Radiological
                            && options.kind == RendererKind::Octree;
                        if worth_a_look {
                            let file = format!(
                                "slice-{}-{}-axis{axis}.png",
                                Path::new(&volume.name)
                                    .file_name()
                                    .unwrap()
                                    .to_string_lossy()
                                    .replace(':', "-"),
                                source_name(options)
                            );
                            image.save(image_dir().join(file)).unwrap();
                        }
                        checked += 1;
                    }
                }
            }
        }
    }
    assert_eq!(checked, 4 * 4 * 2 * 3 * 3);
}

/// The level a dense texture or brick atlas gives back for `level`: itself, unless the device
/// lacks 16-bit normalized textures and the volume's levels pass 255 (then a half float).
fn exact_or_half(context: &GpuContext, quantized: &QuantizedVolume) -> impl Fn(u16) -> u16 {
    let exact = context.has_norm16_textures || quantized.levels.iter().all(|&l| l <= 255);
    move |level| {
        if exact {
            level
        } else {
            half::f16::from_f32(level as f32).to_f32().round() as u16
        }
    }
}

/// A CT-like volume: Hounsfield units from −1024 to 3071 (4096 levels), every voxel a different
/// level from its neighbours, so a level rounded by one shows.
fn ct_volume() -> Volume {
    let dims = [29, 23, 17];
    let mut values = Vec::with_capacity(dims.iter().product());
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let mixed = (x * 7919 + y * 104_729 + z * 1_299_709) % 4096;
                values.push(mixed as i16 - 1024);
            }
        }
    }
    // Make sure both ends of the range are present.
    values[0] = -1024;
    values[1] = 3071;
    Volume::new(
        "ct-like",
        "test",
        dims,
        [0.7, 0.7, 1.25],
        VoxelData::I16(values),
    )
    .unwrap()
}

#[test]
fn levels_above_2048_stay_exact() {
    let context = gpu();
    assert!(
        context.has_norm16_textures,
        "this device ({}) has no 16-bit normalized textures: dense and bricks slices of CT round levels above 2048",
        context.describe()
    );
    let volume = ct_volume();
    let quantized = QuantizedVolume::new(&volume);
    assert_eq!(quantized.quantization.step, 1.0, "one level per HU");
    assert!(quantized.levels.iter().any(|&l| l > 2048 && l % 2 == 1));
    // A window one gray per HU (2500…2755), and the labels colormap (a color per value mod 20):
    // either shows a level off by one.
    let narrow = ValueWindow {
        low: 2500.0,
        high: 2755.0,
    };
    let full = ValueWindow {
        low: -1024.0,
        high: 3071.0,
    };
    for options in sources() {
        let (renderer, quantized) = renderer(&context, &volume, options);
        for (window, colormap) in [(narrow, Colormap::Grays), (full, Colormap::Labels)] {
            for axis in 0..3 {
                let name = format!("CT {} {colormap:?} axis {axis}", source_name(options));
                check_voxel_grid_slice(
                    &context,
                    &name,
                    &renderer,
                    &quantized,
                    SliceConvention::Radiological,
                    axis,
                    volume.dims[axis] / 3,
                    window,
                    colormap,
                    |level| level,
                );
            }
        }
    }
}

/// A volume whose value is its voxel's linear index in the file as stored, `dims` < 256 voxels.
fn indexed_payload(dims: [usize; 3]) -> Vec<u8> {
    let values: Vec<i16> = (0..dims.iter().product::<usize>() as i16).collect();
    encode(&values, Endian::Little)
}

/// Writes the two reoriented test files: FreeSurfer's LIA as a NIfTI sform, and DICOM's LPS
/// as NRRD space directions; both 6×5×4 stored voxels of values 0…119 (the stored index).
fn write_reoriented(dir: &Path) -> [(std::path::PathBuf, &'static str); 2] {
    let dims = [6, 5, 4];
    let lia = dir.join("lia.nii");
    let spec = NiftiSpec {
        dims,
        datatype: 4,
        spacing: [1.0, 2.0, 3.0],
        slope: 1.0,
        intercept: 0.0,
        // Stored x runs to the left, y inferior, z anterior.
        sform: Some([
            [-1.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 3.0, 0.0],
            [0.0, -2.0, 0.0, 0.0],
        ]),
        endian: Endian::Little,
    };
    std::fs::write(&lia, nifti_bytes(&spec, &indexed_payload(dims))).unwrap();
    let lps = dir.join("lps.nrrd");
    let spec = NrrdSpec {
        type_name: "short",
        sizes: &dims,
        encoding: NrrdEncoding::Raw,
        endian: Endian::Little,
        extra: &[
            "space: left-posterior-superior",
            "space directions: (0.8,0,0) (0,0.8,0) (0,0,2.5)",
        ],
    };
    write_nrrd(&lps, &spec, &indexed_payload(dims), "");
    [(lia, "LIA"), (lps, "LPS")]
}

/// The stored voxel at pixel (column, row) of the radiological view across displayed `axis`
/// at displayed `index`, from what each letter of the stored orientation means, with
/// `stored_dims` the file's own grid. Right on the screen's left, anterior and superior up.
fn stored_voxel_at(
    stored: &str,
    stored_dims: [usize; 3],
    axis: usize,
    index: usize,
    column: usize,
    row: usize,
) -> [usize; 3] {
    // The patient direction each screen step goes toward, and the slice's own direction.
    // Axial: right is toward L, down toward P, index counts toward S; coronal: right L, down
    // I, index A; sagittal: right P, down I, index R.
    let (toward_right, toward_down, toward_index) = match axis {
        2 => ('L', 'P', 'S'),
        1 => ('L', 'I', 'A'),
        _ => ('P', 'I', 'R'),
    };
    let opposite = |letter: char| match letter {
        'L' => 'R',
        'R' => 'L',
        'P' => 'A',
        'A' => 'P',
        'I' => 'S',
        _ => 'I',
    };
    let mut voxel = [usize::MAX; 3];
    for (stored_axis, letter) in stored.chars().enumerate() {
        let last = stored_dims[stored_axis] - 1;
        for (toward, step) in [
            (toward_right, column),
            (toward_down, row),
            (toward_index, index),
        ] {
            if letter == toward {
                voxel[stored_axis] = step;
            } else if letter == opposite(toward) {
                voxel[stored_axis] = last - step;
            }
        }
    }
    assert!(
        voxel.iter().all(|&v| v != usize::MAX),
        "{stored}: axis {axis}"
    );
    voxel
}

#[test]
fn reoriented_files_put_the_patients_right_on_the_left_and_anterior_and_superior_up() {
    let context = gpu();
    let dir = tempfile::tempdir().unwrap();
    let stored_dims = [6, 5, 4];
    for (path, stored) in write_reoriented(dir.path()) {
        let volume = load(path.to_str().unwrap());
        assert_eq!(
            volume.orientation,
            Orientation::Reoriented {
                stored: stored.into()
            }
        );
        let convention = SliceConvention::of_volume(&volume);
        assert_eq!(convention, SliceConvention::Radiological);
        // Window 0…255 in grays: a pixel's gray is its voxel's value, the stored index.
        let window = ValueWindow {
            low: 0.0,
            high: 255.0,
        };
        for options in sources() {
            let (renderer, _) = renderer(&context, &volume, options);
            for axis in 0..3 {
                for index in 0..volume.dims[axis] {
                    let (frame, size) =
                        SliceFrame::voxel_grid(convention, axis, index, volume.dims);
                    let settings = SliceSettings {
                        frame,
                        window,
                        colormap: Colormap::Grays,
                        nearest: true,
                    };
                    let image = draw(&context, &renderer, &settings, size);
                    for row in 0..size[1] as usize {
                        for column in 0..size[0] as usize {
                            let [x, y, z] =
                                stored_voxel_at(stored, stored_dims, axis, index, column, row);
                            let expected = x + 6 * (y + 5 * z);
                            let gray = image.get_pixel(column as u32, row as u32).0[0];
                            assert_eq!(
                                gray as usize,
                                expected,
                                "{stored} {} axis {axis} index {index} pixel ({column}, {row})",
                                source_name(options)
                            );
                        }
                    }
                }
            }
        }
    }
}

/// Trilinear interpolation of the levels between voxel centers around voxel-space `p`,
/// clamped to the volume's edge (the definition, in f64).
fn trilinear(quantized: &QuantizedVolume, p: [f64; 3]) -> f64 {
    let dims = quantized.dims;
    let q = p.map(|c| c - 0.5);
    let base = q.map(f64::floor);
    let f: [f64; 3] = std::array::from_fn(|a| q[a] - base[a]);
    let level = |offset: [usize; 3]| {
        let voxel: [usize; 3] = std::array::from_fn(|a| {
            (base[a] as i64 + offset[a] as i64).clamp(0, dims[a] as i64 - 1) as usize
        });
        quantized.levels[voxel[0] + dims[0] * (voxel[1] + dims[1] * voxel[2])] as f64
    };
    let mut sum = 0.0;
    for corner in 0..8 {
        let offset = [corner & 1, (corner >> 1) & 1, corner >> 2];
        let weight: f64 = (0..3)
            .map(|a| if offset[a] == 1 { f[a] } else { 1.0 - f[a] })
            .product();
        sum += weight * level(offset);
    }
    sum
}

/// A zoomed, panned view of an anisotropic volume in the app's frame, as the app draws it.
fn app_frame(volume: &Volume, axis: usize, size: [u32; 2]) -> SliceFrame {
    let view = SliceView {
        axis,
        index: volume.dims[axis] * 2 / 5,
        zoom: 2.3,
        pan: [17.0, -9.0],
    };
    SliceFrame::axis_aligned(
        &view,
        SliceConvention::of_volume(volume),
        volume.dims,
        volume.spacing,
        size,
    )
}

#[test]
fn linear_slices_equal_trilinear_interpolation_and_agree_across_sources() {
    let context = gpu();
    let volume = load("synthetic:noise:37x26x19");
    let volume = Volume {
        spacing: [0.9, 1.4, 2.2],
        ..volume
    };
    let size = [97, 71];
    let mut first: Vec<image::RgbaImage> = Vec::new();
    for options in sources() {
        let (renderer, quantized) = renderer(&context, &volume, options);
        let window = quantized.robust_window();
        for axis in 0..3 {
            let frame = app_frame(&volume, axis, size);
            let settings = SliceSettings {
                frame,
                window,
                colormap: Colormap::Grays,
                nearest: false,
            };
            let image = draw(&context, &renderer, &settings, size);
            let mut inside = 0;
            for row in 0..size[1] {
                for column in 0..size[0] {
                    let got = image.get_pixel(column, row).0;
                    let pixel = [column as f64 + 0.5, row as f64 + 0.5];
                    let p = frame.point_at(pixel);
                    // f32 on the GPU: a point within a hair of the volume's faces may fall on
                    // either side.
                    let near_face = (0..3)
                        .any(|a| p[a].abs() < 1e-3 || (p[a] - volume.dims[a] as f64).abs() < 1e-3);
                    if near_face {
                        continue;
                    }
                    if frame.voxel_at(pixel, volume.dims).is_none() {
                        assert_eq!(got[3], 0, "outside the volume: transparent");
                        continue;
                    }
                    inside += 1;
                    let level = trilinear(&quantized, p);
                    // f32 on the GPU, f64 here: levels up to 65 535 carry f32 rounding of a few
                    // hundredths, so a level that close to .5 may round either way.
                    let candidates = if (level.fract() - 0.5).abs() < 0.05 {
                        vec![level.floor(), level.ceil()]
                    } else {
                        vec![level.round()]
                    };
                    assert!(
                        candidates
                            .iter()
                            .any(|&l| color_of(&quantized, &settings, l as u16) == got),
                        "{} axis {axis} pixel ({column}, {row}) at {p:?}: level {level}, got {got:?}",
                        source_name(options)
                    );
                }
            }
            assert!(inside > 500, "axis {axis}: the view shows the volume");
            match first.get(axis) {
                None => {
                    image
                        .save(image_dir().join(format!("slice-linear-axis{axis}.png")))
                        .unwrap();
                    first.push(image);
                }
                Some(reference) => assert!(
                    *reference == image,
                    "{} axis {axis}: linear slices differ between sources",
                    source_name(options)
                ),
            }
        }
    }
}

#[test]
fn the_app_frame_draws_the_voxel_each_pixel_maps_to_and_nothing_outside() {
    // What the cursor and probe read (SliceFrame::voxel_at) is what the slice shows there.
    let context = gpu();
    let volume = load(shared_data("mri-head-128x128x62.nii.gz").to_str().unwrap());
    assert_eq!(
        volume.spacing,
        [2.0, 3.0, 2.0],
        "anisotropic, RAS-reordered"
    );
    for (size, zoom) in [([160, 120], 0.8), ([90, 140], 1.0), ([128, 96], 3.7)] {
        for options in sources() {
            let (renderer, quantized) = renderer(&context, &volume, options);
            let window = quantized.robust_window();
            for axis in 0..3 {
                let view = SliceView {
                    axis,
                    index: volume.dims[axis] / 2,
                    zoom,
                    // Fractional, so that pixel centers do not line up on voxel faces.
                    pan: [5.3, 3.7],
                };
                let convention = SliceConvention::of_volume(&volume);
                let frame =
                    SliceFrame::axis_aligned(&view, convention, volume.dims, volume.spacing, size);
                let settings = SliceSettings {
                    frame,
                    window,
                    colormap: Colormap::Magma,
                    nearest: true,
                };
                let image = draw(&context, &renderer, &settings, size);
                let (mut inside, mut outside, mut on_edges) = (0, 0, 0);
                for row in 0..size[1] {
                    for column in 0..size[0] {
                        let pixel = [column as f64 + 0.5, row as f64 + 0.5];
                        let p = frame.point_at(pixel);
                        // f32 on the GPU: a point within a hair of a voxel face may fall on
                        // either side.
                        if p.iter().any(|c| (c - c.round()).abs() < 1e-3) {
                            on_edges += 1;
                            continue;
                        }
                        let got = image.get_pixel(column, row).0;
                        match frame.voxel_at(pixel, volume.dims) {
                            Some([x, y, z]) => {
                                inside += 1;
                                let level =
                                    quantized.levels[x + volume.dims[0] * (y + volume.dims[1] * z)];
                                assert_eq!(
                                    got,
                                    color_of(&quantized, &settings, level),
                                    "{} axis {axis} {size:?} pixel ({column}, {row})",
                                    source_name(options)
                                );
                            }
                            None => {
                                outside += 1;
                                assert_eq!(got, [0; 4], "outside: transparent black");
                            }
                        }
                    }
                }
                assert!(
                    inside > 1000,
                    "{size:?} axis {axis}: {inside} pixels inside"
                );
                assert!(
                    on_edges < inside / 20,
                    "{size:?} zoom {zoom} axis {axis}: {on_edges} pixels on voxel faces, e.g. {:?}",
                    frame.point_at([0.5, 0.5])
                );
                if zoom < 1.0 {
                    assert!(outside > 0, "a view larger than the slice has a margin");
                }
                if options.kind == RendererKind::Octree && size == [160, 120] {
                    image
                        .save(image_dir().join(format!("slice-app-frame-axis{axis}.png")))
                        .unwrap();
                }
            }
        }
    }
}

#[test]
fn slices_with_different_windows_in_one_encoder_keep_their_own_colors() {
    // A new window makes a new color table, so a slice recorded before it keeps its colors.
    let context = gpu();
    let volume = load("synthetic:shells:30x24x20");
    let (renderer, quantized) = renderer(&context, &volume, RendererKind::Dense.into());
    let (frame, size) = SliceFrame::voxel_grid(SliceConvention::Image, 2, 10, volume.dims);
    let settings = [
        SliceSettings {
            frame,
            window: quantized.robust_window(),
            colormap: Colormap::Grays,
            nearest: true,
        },
        SliceSettings {
            frame,
            window: ValueWindow {
                low: 0.0,
                high: 300.0,
            },
            colormap: Colormap::Viridis,
            nearest: true,
        },
    ];
    let alone: Vec<image::RgbaImage> = settings
        .iter()
        .map(|s| draw(&context, &renderer, s, size))
        .collect();
    assert_ne!(alone[0], alone[1]);
    let targets = [0, 1].map(|_| RenderTarget::new(&context, size[0], size[1]));
    let mut encoder = context.device.create_command_encoder(&Default::default());
    for (target, settings) in targets.iter().zip(&settings) {
        renderer.encode_slice(&context, &mut encoder, target, settings);
    }
    context.queue.submit([encoder.finish()]);
    for (i, target) in targets.iter().enumerate() {
        let image = read_image(&context, target).unwrap();
        assert!(image == alone[i], "slice {i} recorded with the other");
    }
    // Views alternating between their windows reuse their tables; at most four are kept.
    let table_bytes = |renderer: &VolumeRenderer| {
        renderer
            .gpu_bytes()
            .iter()
            .find(|(name, _)| *name == "slice_colors")
            .map_or(0, |(_, bytes)| *bytes)
    };
    let one_table = 65_536 * 4;
    assert_eq!(table_bytes(&renderer), 2 * one_table);
    for settings in settings.iter().cycle().take(10) {
        draw(&context, &renderer, settings, size);
    }
    assert_eq!(table_bytes(&renderer), 2 * one_table, "alternating windows");
    for high in [100.0, 200.0, 400.0, 800.0, 1600.0] {
        let settings = SliceSettings {
            window: ValueWindow { low: 0.0, high },
            ..settings[0]
        };
        draw(&context, &renderer, &settings, size);
    }
    assert_eq!(
        table_bytes(&renderer),
        4 * one_table,
        "the last four windows"
    );
}

#[test]
fn the_slice_pipeline_is_built_once_per_device_and_a_cut_octree_says_so() {
    let context = gpu();
    let volume = load("synthetic:sphere:24");
    let quantized = QuantizedVolume::new(&volume);
    let (octree, transfer) = colored_octree(&volume, None, BuildOptions::default());
    let (frame, size) = SliceFrame::voxel_grid(SliceConvention::Image, 2, 12, volume.dims);
    let settings = SliceSettings {
        frame,
        window: quantized.robust_window(),
        colormap: Colormap::Grays,
        nearest: true,
    };
    let mut built = None;
    for kind in RendererKind::ALL {
        let renderer = VolumeRenderer::new(
            &context,
            kind,
            &octree,
            &quantized,
            volume.spacing,
            octree.depth,
            &transfer,
        )
        .unwrap();
        let before = context.pipelines_built();
        draw(&context, &renderer, &settings, size);
        let after = context.pipelines_built();
        match built {
            None => {
                assert_eq!(after, before + 1, "the first slice builds one pipeline");
                built = Some(after);
            }
            Some(_) => assert_eq!(after, before, "{}: built again", kind.name()),
        }
    }
    // The octree uploaded only down to level 2 of 5: the slice shows each level-2 node's middle
    // value, and says it is not exact.
    let cut = VolumeRenderer::new(
        &context,
        RendererKind::Octree,
        &octree,
        &quantized,
        volume.spacing,
        2,
        &transfer,
    )
    .unwrap();
    assert!(!cut.exact_slices());
    let image = draw(&context, &cut, &settings, size);
    let cell = 1usize << (octree.depth - 2);
    let [dx, dy, _] = volume.dims;
    for row in 0..size[1] as usize {
        for column in 0..size[0] as usize {
            // The level-2 cell of this pixel's voxel: the range of its voxels' levels.
            let (x0, y0, z0) = (column / cell * cell, row / cell * cell, 12 / cell * cell);
            let mut range = [u16::MAX, 0];
            for z in z0..(z0 + cell).min(volume.dims[2]) {
                for y in y0..(y0 + cell).min(dy) {
                    for x in x0..(x0 + cell).min(dx) {
                        let level = quantized.levels[x + dx * (y + dy * z)];
                        range = [range[0].min(level), range[1].max(level)];
                    }
                }
            }
            let middle = ((range[0] as u32 + range[1] as u32) / 2) as u16;
            assert_eq!(
                image.get_pixel(column as u32, row as u32).0,
                color_of(&quantized, &settings, middle),
                "pixel ({column}, {row})"
            );
        }
    }
}

fn voxscope(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

#[test]
fn slice_command_writes_the_displayed_voxels_one_pixel_each() {
    let dir = tempfile::tempdir().unwrap();
    let [(lia, _), _] = write_reoriented(dir.path());
    let volume = load(lia.to_str().unwrap());
    // RAS-reordered: 6 (x) × 4 (y, from stored z) × 5 (z, from stored y).
    assert_eq!(volume.dims, [6, 4, 5]);
    for (axis_name, axis) in [("x", 0), ("y", 1), ("z", 2)] {
        for renderer in ["octree", "dense", "bricks"] {
            let out = dir.path().join(format!("lia-{axis_name}-{renderer}.png"));
            let mut args = vec![
                "slice",
                lia.to_str().unwrap(),
                "--axis",
                axis_name,
                "--window",
                "0:255",
                "--renderer",
                renderer,
                "-o",
                out.to_str().unwrap(),
            ];
            if renderer == "dense" {
                args.push("--linear");
            }
            let output = voxscope(&args);
            assert!(output.status.success(), "{}", stderr(&output));
            let image = image::open(&out).unwrap().to_rgba8();
            let index = volume.dims[axis] / 2;
            let [(right, _), (down, _)] = SliceConvention::Radiological.screen_axes(axis);
            assert_eq!(
                [image.width() as usize, image.height() as usize],
                [volume.dims[right], volume.dims[down]]
            );
            for (column, row, pixel) in image.enumerate_pixels() {
                let [x, y, z] = voxel_of_pixel(
                    SliceConvention::Radiological,
                    axis,
                    index,
                    volume.dims,
                    column as usize,
                    row as usize,
                );
                let value = volume.value(x, y, z).unwrap();
                assert_eq!(
                    pixel.0,
                    [value as u8, value as u8, value as u8, 255],
                    "{axis_name} {renderer} pixel ({column}, {row})"
                );
            }
        }
    }
    // --index counts in the displayed order; the default is the middle.
    let out = dir.path().join("first.png");
    let output = voxscope(&[
        "slice",
        lia.to_str().unwrap(),
        "--axis",
        "z",
        "--index",
        "0",
        "--colormap",
        "viridis",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("axial slice 0 of 5"),
        "{}",
        stderr(&output)
    );
    assert!(
        stderr(&output).contains("R left, A up"),
        "{}",
        stderr(&output)
    );
}

#[test]
fn slice_command_of_a_real_head_matches_the_gpu_api_and_shows_the_head() {
    let dir = tempfile::tempdir().unwrap();
    let path = shared_data("mni152-t1-197x233x189.nii.gz");
    let out = dir.path().join("axial.png");
    let output = voxscope(&[
        "slice",
        path.to_str().unwrap(),
        "--axis",
        "z",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let image = image::open(&out).unwrap().to_rgba8();
    image
        .save(image_dir().join("slice-cli-mni-axial.png"))
        .unwrap();
    assert_eq!([image.width(), image.height()], [197, 233]);
    // The brain fills the middle; the corners are air.
    let gray = |x: u32, y: u32| image.get_pixel(x, y).0[0];
    assert!(gray(98, 116) > 60, "the center is brain");
    assert!(
        gray(2, 2) < 10 && gray(194, 230) < 10,
        "the corners are air"
    );
    let bright = image.pixels().filter(|p| p.0[0] > 60).count();
    assert!(bright > 197 * 233 / 5, "{bright} bright pixels");
    // And it is the slice the library draws.
    let context = gpu();
    let volume = load(path.to_str().unwrap());
    let (renderer, quantized) = renderer(&context, &volume, RendererKind::Octree.into());
    let window = quantized.robust_window();
    let library = check_voxel_grid_slice(
        &context,
        "mni axial",
        &renderer,
        &quantized,
        SliceConvention::Radiological,
        2,
        volume.dims[2] / 2,
        window,
        Colormap::Grays,
        |level| level,
    );
    assert!(library == image, "the command and the library differ");
}

#[test]
fn slice_command_errors_are_one_line_and_name_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s.png");
    let out = out.to_str().unwrap();
    let cases: [(&[&str], &str); 5] = [
        (
            &[
                "slice",
                "synthetic:sphere:40x30x20",
                "--axis",
                "z",
                "--index",
                "20",
                "-o",
                out,
            ],
            "--index 20 is outside the z axis, which has 20 voxels (0 to 19)",
        ),
        (
            &[
                "slice",
                "synthetic:sphere:40x30x20",
                "--axis",
                "x",
                "--index",
                "99",
                "-o",
                out,
            ],
            "outside the x axis, which has 40 voxels",
        ),
        (
            &["slice", "synthetic:sphere:16", "--axis", "z", "-o", "s.jpg"],
            "the output must be a .png file",
        ),
        (
            &["slice", "no-such-file.nii", "--axis", "y", "-o", out],
            "no-such-file.nii",
        ),
        (
            &["slice", "synthetic:sphere:16", "--axis", "w", "-o", out],
            "invalid value 'w'",
        ),
    ];
    for (args, expected) in cases {
        let output = voxscope(args);
        assert!(!output.status.success(), "{args:?} succeeded");
        let text = stderr(&output);
        assert!(text.contains(expected), "{args:?}: {text}");
        if expected.starts_with("invalid value") {
            continue; // clap's usage error, several lines with a hint
        }
        assert_eq!(text.trim_end().lines().count(), 1, "{args:?}: {text}");
        assert!(text.starts_with("error: "), "{text}");
    }
    assert!(!Path::new(out).exists(), "nothing written on error");
}

#[test]
fn image_stacks_show_their_pages_as_stored_and_patient_files_radiologically() {
    let conventions = [
        ("nuclei-60x256x256.tif", SliceConvention::Image),
        ("mri-head-256.nii.gz", SliceConvention::Radiological),
        ("brain-pd-dicom", SliceConvention::Radiological),
    ];
    for (name, expected) in conventions {
        let volume = load(shared_data(name).to_str().unwrap());
        assert_eq!(SliceConvention::of_volume(&volume), expected, "{name}");
    }
    assert_eq!(
        SliceConvention::of_volume(&load("synthetic:sphere:8")),
        SliceConvention::Image
    );
    // A TIFF page as the file holds it: row 0 at the top, column 0 on the left.
    let dir = tempfile::tempdir().unwrap();
    let path = shared_data("nuclei-60x256x256.tif");
    let out = dir.path().join("page.png");
    let output = voxscope(&[
        "slice",
        path.to_str().unwrap(),
        "--axis",
        "z",
        "--index",
        "17",
        "--window",
        "0:65535",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("z slice 17 of 60"),
        "{}",
        stderr(&output)
    );
    let image = image::open(&out).unwrap().to_rgba8();
    let volume = load(path.to_str().unwrap());
    assert_eq!([image.width(), image.height()], [256, 256]);
    for (column, row, pixel) in image.enumerate_pixels() {
        let value = volume.value(column as usize, row as usize, 17).unwrap();
        let gray = (value / 65535.0 * 255.0).round() as u8;
        assert_eq!(pixel.0, [gray, gray, gray, 255], "pixel ({column}, {row})");
    }
}
