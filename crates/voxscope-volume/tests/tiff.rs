//! Multi-page TIFF stacks: every sample type, ImageJ and OME-TIFF spacing, the real nuclei
//! stack, and broken files (one-line errors, no panic, the file untouched).

mod support;

use std::path::Path;

use tiff::encoder::{TiffEncoder, colortype};
use voxscope_volume::{LoadOptions, VoxelType};

/// Writes `pages` pages of `width`×`height`, voxel (x, y, z) = `value(x, y, z)`.
fn write_stack<C: colortype::ColorType>(
    path: &Path,
    dims: [u32; 3],
    description: Option<&str>,
    resolution: Option<f64>,
    value: impl Fn(u32, u32, u32) -> C::Inner,
) where
    [C::Inner]: tiff::encoder::TiffValue,
{
    let bytes = support::writers::tiff_stack::<C>(
        dims,
        description,
        resolution,
        tiff::encoder::Compression::Uncompressed,
        value,
    );
    std::fs::write(path, bytes).expect("write");
}

fn load(path: &Path) -> Result<voxscope_volume::Volume, String> {
    voxscope_volume::load(&path.display().to_string(), &LoadOptions::default())
        .map_err(|e| e.to_string())
}

#[test]
fn every_sample_type_reads_back_voxel_for_voxel() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [7u32, 5, 4];
    // Values 0…99, inside every type's range.
    let at = |x: u32, y: u32, z: u32| ((x + 7 * (y + 5 * z)) % 100) as f64;
    macro_rules! case {
        ($color:ty, $convert:expr, $type:expr) => {{
            let path = dir.path().join(format!("{}.tif", $type.name()));
            write_stack::<$color>(&path, dims, None, None, |x, y, z| $convert(at(x, y, z)));
            let volume = load(&path).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(volume.format, "TIFF");
            assert_eq!(volume.dims, [7, 5, 4]);
            assert_eq!(volume.voxel_type(), $type);
            for (index, expected) in (0..140).map(|i| (i, (i % 100) as f64)) {
                assert_eq!(
                    volume.data.get(index),
                    Some(expected),
                    "{} voxel {index}",
                    $type.name()
                );
            }
        }};
    }
    case!(colortype::Gray8, |v: f64| v as u8, VoxelType::U8);
    case!(colortype::GrayI8, |v: f64| v as i8, VoxelType::I8);
    case!(colortype::Gray16, |v: f64| v as u16, VoxelType::U16);
    case!(colortype::GrayI16, |v: f64| v as i16, VoxelType::I16);
    case!(colortype::Gray32, |v: f64| v as u32, VoxelType::U32);
    case!(colortype::GrayI32, |v: f64| v as i32, VoxelType::I32);
    case!(colortype::Gray32Float, |v: f64| v as f32, VoxelType::F32);
    case!(colortype::Gray64Float, |v: f64| v, VoxelType::F64);
}

#[test]
fn imagej_and_ome_metadata_give_the_spacing() {
    let dir = tempfile::tempdir().unwrap();
    let imagej = dir.path().join("imagej.tif");
    write_stack::<colortype::Gray16>(
        &imagej,
        [8, 6, 3],
        Some("ImageJ=1.54f\nimages=3\nslices=3\nunit=micron\nspacing=0.29\nloop=false\n"),
        Some(1.0 / 0.26),
        |x, _, _| x as u16,
    );
    let volume = load(&imagej).unwrap();
    let [sx, sy, sz] = volume.spacing;
    assert!(
        (sx - 0.26).abs() < 1e-3 && (sy - 0.26).abs() < 1e-3 && (sz - 0.29).abs() < 1e-9,
        "{:?}",
        volume.spacing
    );
    assert!(volume.metadata.contains(&("unit".into(), "micron".into())));
    assert!(
        volume
            .metadata
            .contains(&("spacing from".into(), "ImageJ".into()))
    );

    let ome = dir.path().join("stack.ome.tif");
    let xml = r#"<?xml version="1.0"?><OME><Image><Pixels DimensionOrder="XYZCT" SizeX="8" SizeY="6" SizeZ="3" SizeC="1" SizeT="1" PhysicalSizeX="0.5" PhysicalSizeY="0.5" PhysicalSizeZ="2.0" PhysicalSizeXUnit="um" Type="uint8"/></Image></OME>"#;
    write_stack::<colortype::Gray8>(&ome, [8, 6, 3], Some(xml), None, |_, y, _| y as u8);
    let volume = load(&ome).unwrap();
    assert_eq!(volume.spacing, [0.5, 0.5, 2.0]);
    assert!(volume.metadata.contains(&("unit".into(), "um".into())));

    let hyperstack = dir.path().join("hyper.tif");
    write_stack::<colortype::Gray8>(
        &hyperstack,
        [4, 4, 4],
        Some("ImageJ=1.54f\nimages=4\nchannels=2\nslices=2\n"),
        None,
        |_, _, _| 1,
    );
    // Pages c0z0, c1z0, c0z1, c1z1 (XYCZT): channel 0 is pages 1 and 3.
    let volume = load(&hyperstack).unwrap();
    assert_eq!(volume.dims, [4, 4, 2]);
    assert_eq!(volume.series.channel_count(), 2);
    let beyond = voxscope_volume::load(
        &hyperstack.display().to_string(),
        &LoadOptions {
            select: voxscope_volume::Selection {
                channel: 2,
                time: 0,
            },
            ..LoadOptions::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(
        beyond.ends_with("hyper.tif: channel 2 does not exist (the image has 2)"),
        "{beyond}"
    );
}

#[test]
fn the_real_nuclei_stack_opens() {
    let path = support::shared_data("nuclei-60x256x256.tif");
    let volume = load(&path).unwrap();
    assert_eq!(volume.dims, [256, 256, 60]);
    assert_eq!(volume.voxel_type(), VoxelType::U16);
    assert!(volume.metadata.contains(&("pages".into(), "60".into())));
    let quantized = voxscope_volume::QuantizedVolume::new(&volume);
    assert_eq!(quantized.value_range, [0.0, 65535.0]);
}

#[test]
fn broken_stacks_fail_in_one_line_and_stay_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.tif");
    write_stack::<colortype::Gray16>(&good, [16, 16, 4], None, None, |x, y, z| (x + y + z) as u16);
    let bytes = std::fs::read(&good).unwrap();

    let mut cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("truncated.tif", bytes[..bytes.len() / 2].to_vec(), ""),
        ("header-only.tif", bytes[..8].to_vec(), ""),
        (
            "garbage.tif",
            b"II*\0 this is not really a tiff at all".to_vec(),
            "",
        ),
    ];
    // A second stack whose pages differ in size.
    let mixed = dir.path().join("mixed-src.tif");
    {
        let file = std::fs::File::create(&mixed).unwrap();
        let mut encoder = TiffEncoder::new(file).unwrap();
        encoder
            .write_image::<colortype::Gray8>(4, 4, &[0; 16])
            .unwrap();
        encoder
            .write_image::<colortype::Gray8>(5, 4, &[0; 20])
            .unwrap();
    }
    cases.push((
        "mixed.tif",
        std::fs::read(&mixed).unwrap(),
        "page 2 is 5x4 but page 1 is 4x4",
    ));
    // RGB pages are three channels (tests/channels.rs); CMYK is no set of channels.
    let cmyk = dir.path().join("cmyk-src.tif");
    {
        let file = std::fs::File::create(&cmyk).unwrap();
        let mut encoder = TiffEncoder::new(file).unwrap();
        encoder
            .write_image::<colortype::CMYK8>(4, 4, &[0; 64])
            .unwrap();
    }
    cases.push((
        "cmyk.tif",
        std::fs::read(&cmyk).unwrap(),
        "page 1 is CMYK, 8 bits per sample; only grayscale pages",
    ));

    for (name, content, expected) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, &content).unwrap();
        let started = std::time::Instant::now();
        let error = load(&path).expect_err(name);
        assert!(started.elapsed().as_secs_f64() < 1.0, "{name}");
        assert!(error.starts_with(&path.display().to_string()), "{error}");
        assert!(!error.contains('\n'), "{error}");
        assert!(error.contains(expected), "{name}: {error}");
        assert_eq!(std::fs::read(&path).unwrap(), content, "{name} untouched");
    }
}

#[test]
fn a_folder_of_slices_opens_in_the_order_of_the_numbers_in_their_names() {
    let dir = tempfile::tempdir().unwrap();
    // 12 PNG slices: lexicographic order would put slice_10 before slice_2.
    for z in 1..=12u16 {
        let image = image::ImageBuffer::<image::Luma<u16>, _>::from_fn(6, 4, |x, _| {
            image::Luma([z * 100 + x as u16])
        });
        image
            .save(dir.path().join(format!("slice_{z}.png")))
            .unwrap();
    }
    std::fs::write(dir.path().join("notes.txt"), "not a slice").unwrap();
    let volume = load(dir.path()).unwrap();
    assert_eq!(volume.format, "slices");
    assert_eq!(volume.dims, [6, 4, 12]);
    assert_eq!(volume.voxel_type(), VoxelType::U16);
    for z in 0..12usize {
        for x in 0..6usize {
            assert_eq!(
                volume.data.get(x + 6 * 4 * z),
                Some(((z + 1) * 100 + x) as f64)
            );
        }
    }
    assert!(
        volume
            .metadata
            .contains(&("first, last".into(), "slice_1.png, slice_12.png".into()))
    );

    // TIFF slices, 8-bit, with ImageJ spacing on the first.
    let tiffs = tempfile::tempdir().unwrap();
    for z in 0..3u32 {
        let description = (z == 0).then_some("ImageJ=1.54f\nunit=micron\nspacing=2.5\n");
        write_stack::<colortype::Gray8>(
            &tiffs.path().join(format!("z{z:03}.tif")),
            [5, 5, 1],
            description,
            Some(2.0),
            move |x, _, _| (x + 10 * z) as u8,
        );
    }
    let volume = load(tiffs.path()).unwrap();
    assert_eq!(volume.dims, [5, 5, 3]);
    assert_eq!(volume.data.get(2 + 25 * 2), Some(22.0));
    assert_eq!(volume.spacing, [0.5, 0.5, 2.5]);

    // Mismatched and colored slices fail in one line naming the slice.
    let bad = tempfile::tempdir().unwrap();
    image::GrayImage::new(4, 4)
        .save(bad.path().join("a1.png"))
        .unwrap();
    image::GrayImage::new(5, 4)
        .save(bad.path().join("a2.png"))
        .unwrap();
    let error = load(bad.path()).unwrap_err();
    assert!(
        error.contains("a2.png is 5x4 but the first is 4x4") && !error.contains('\n'),
        "{error}"
    );
    let rgb = tempfile::tempdir().unwrap();
    image::RgbImage::new(4, 4)
        .save(rgb.path().join("c1.png"))
        .unwrap();
    let error = load(rgb.path()).unwrap_err();
    assert!(error.contains("only grayscale PNG slices"), "{error}");
    let empty = tempfile::tempdir().unwrap();
    let error = load(empty.path()).unwrap_err();
    assert!(error.contains("without slice images"), "{error}");
}

/// A one-pixel TIFF page with `bits` as its BitsPerSample list (one value per sample), the
/// list stored after the directory, photometric BlackIsZero.
fn many_samples(bits: &[u16]) -> Vec<u8> {
    let samples = bits.len() as u32;
    let entries: u16 = 9;
    let directory_end = 8 + 2 + 12 * entries as u32 + 4;
    let bits_at = directory_end;
    let strip_at = bits_at + 2 * samples;
    let strip_bytes: u32 = bits.iter().map(|&b| b as u32 / 8).sum();
    let mut file = b"II*\0".to_vec();
    file.extend(8u32.to_le_bytes());
    file.extend(entries.to_le_bytes());
    let mut entry = |tag: u16, kind: u16, count: u32, value: u32| {
        file.extend(tag.to_le_bytes());
        file.extend(kind.to_le_bytes());
        file.extend(count.to_le_bytes());
        file.extend(value.to_le_bytes());
    };
    entry(256, 3, 1, 1); // ImageWidth
    entry(257, 3, 1, 1); // ImageLength
    // BitsPerSample: one value fits in the entry, more are stored after the directory.
    let inline = if samples == 1 {
        bits[0] as u32
    } else {
        bits_at
    };
    entry(258, 3, samples, inline);
    entry(259, 3, 1, 1); // no compression
    entry(262, 3, 1, 1); // BlackIsZero
    entry(273, 4, 1, strip_at); // StripOffsets
    entry(277, 3, 1, samples); // SamplesPerPixel
    entry(278, 3, 1, 1); // RowsPerStrip
    entry(279, 4, 1, strip_bytes); // StripByteCounts
    file.extend(0u32.to_le_bytes());
    for b in bits {
        file.extend(b.to_le_bytes());
    }
    file.extend(vec![0u8; strip_bytes as usize]);
    file
}

#[test]
fn long_tag_lists_are_shortened_and_color_types_named_in_words() {
    let dir = tempfile::tempdir().unwrap();
    let mut bits = vec![8u16; 49000];
    bits.extend(vec![16u16; 49000]);
    std::fs::write(
        dir.path().join("four-samples.tif"),
        many_samples(&[16, 16, 16, 16]),
    )
    .unwrap();
    let path = dir.path().join("mixed-bits.tif");
    std::fs::write(&path, many_samples(&bits)).unwrap();
    let error = load(&path).unwrap_err();
    assert!(error.len() < 400, "{} characters: {error}", error.len());
    assert!(!error.contains('{') && !error.contains('\n'), "{error}");
    // Samples of one width are channels, one read at a time.
    let four = load(&dir.path().join("four-samples.tif")).unwrap();
    assert_eq!(four.series.channel_count(), 4);
}

#[test]
fn library_errors_say_what_pointed_where() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = support::writers::tiff_stack::<colortype::Gray16>(
        [16, 16, 4],
        None,
        None,
        tiff::encoder::Compression::Uncompressed,
        |x, y, z| (x + y + z) as u16,
    );
    // Cut inside the pixel data: the file ends early (not "failed to fill whole buffer").
    let cut = dir.path().join("cut.tif");
    std::fs::write(&cut, &bytes[..bytes.len() - 300]).unwrap();
    let error = load(&cut).unwrap_err();
    assert!(error.contains("the file ends early"), "{error}");
    // The first page's directory offset far beyond the file (not "Invalid argument").
    let mut far = bytes.clone();
    far[4..8].copy_from_slice(&0xffff_fff0u32.to_le_bytes());
    let path = dir.path().join("far.tif");
    std::fs::write(&path, &far).unwrap();
    let error = load(&path).unwrap_err();
    assert!(
        !error.contains("Invalid argument") && !error.contains("failed to fill"),
        "{error}"
    );
    // A page claiming 30000x30000 pixels in a small file (not "decoder limits exceeded").
    let mut huge = many_samples(&[8]);
    let entry = |index: usize| 8 + 2 + 12 * index + 8;
    huge[entry(0)..entry(0) + 4].copy_from_slice(&30000u32.to_le_bytes());
    huge[entry(1)..entry(1) + 4].copy_from_slice(&30000u32.to_le_bytes());
    huge[entry(7)..entry(7) + 4].copy_from_slice(&30000u32.to_le_bytes());
    huge[entry(8)..entry(8) + 4].copy_from_slice(&900_000_000u32.to_le_bytes());
    let path = dir.path().join("huge.tif");
    std::fs::write(&path, &huge).unwrap();
    let started = std::time::Instant::now();
    let error = load(&path).unwrap_err();
    assert!(started.elapsed().as_secs_f64() < 1.0);
    assert!(
        error.contains("cannot decode page 1: the page would decode to more than")
            && error.contains("more than a file of this size can hold"),
        "{error}"
    );
}
