//! DICOM series: the real brain series, one file of it, a folder with two series, and broken
//! files.

mod support;

use std::path::Path;

use voxscope_volume::{LoadOptions, VoxelType};

fn load(path: &Path) -> Result<voxscope_volume::Volume, String> {
    voxscope_volume::load(&path.display().to_string(), &LoadOptions::default())
        .map_err(|e| e.to_string())
}

fn has(volume: &voxscope_volume::Volume, key: &str, value: &str) -> bool {
    volume.metadata.iter().any(|(k, v)| k == key && v == value)
}

#[test]
fn the_real_series_opens_sorted_scaled_and_upright() {
    let dir = support::shared_data("brain-pd-dicom");
    let volume = load(&dir).unwrap();
    assert_eq!(volume.format, "DICOM");
    assert_eq!(volume.dims, [256, 256, 20]);
    assert_eq!(volume.voxel_type(), VoxelType::I16);
    let [sx, sy, sz] = volume.spacing;
    assert!(
        (sx - 0.859375).abs() < 1e-9 && (sy - 0.859375).abs() < 1e-9,
        "{:?}",
        volume.spacing
    );
    assert!(
        sz > 5.0 && sz < 8.0,
        "slice spacing from the positions: {sz}"
    );
    assert!(
        has(&volume, "modality", "MR") && has(&volume, "files", "20"),
        "{:?}",
        volume.metadata
    );
    assert_eq!(volume.orientation.describe(), "stored LPS, shown RAS");

    // One file of the series opens the whole series.
    let one = load(&dir.join("brain_007.dcm")).unwrap();
    assert_eq!(one.dims, volume.dims);
    assert_eq!(one.data.get(12345), volume.data.get(12345));
}

#[test]
fn a_folder_with_two_series_opens_the_larger_and_lists_the_other() {
    let source = support::shared_data("brain-pd-dicom");
    let dir = tempfile::tempdir().unwrap();
    let mut files: Vec<_> = std::fs::read_dir(&source)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    let header = dicom_object::OpenFileOptions::new()
        .read_until(dicom_dictionary_std::tags::PIXEL_DATA)
        .open_file(&files[0])
        .unwrap();
    let uid = header
        .element(dicom_dictionary_std::tags::SERIES_INSTANCE_UID)
        .unwrap()
        .to_str()
        .unwrap()
        .trim_end_matches('\0')
        .trim()
        .to_owned();
    let last = uid.chars().last().unwrap();
    let other = format!(
        "{}{}",
        &uid[..uid.len() - 1],
        if last == '9' { '8' } else { '9' }
    );
    for (index, file) in files.iter().enumerate() {
        let mut bytes = std::fs::read(file).unwrap();
        if index < 6 {
            // Same length, another series UID.
            let at = bytes
                .windows(uid.len())
                .position(|w| w == uid.as_bytes())
                .expect("the series UID is in the file");
            bytes[at..at + uid.len()].copy_from_slice(other.as_bytes());
        }
        std::fs::write(dir.path().join(file.file_name().unwrap()), bytes).unwrap();
    }
    let volume = load(dir.path()).unwrap();
    assert_eq!(volume.dims[2], 14);
    assert!(has(&volume, "files", "14"));
    assert!(
        volume.metadata.iter().any(|(k, v)| k == "other series 1"
            && v.contains(other.as_str())
            && v.contains("6 files")),
        "{:?}",
        volume.metadata
    );
}

#[test]
fn broken_dicom_files_fail_in_one_line_and_stay_untouched() {
    let source = support::shared_data("brain-pd-dicom/brain_001.dcm");
    let bytes = std::fs::read(&source).unwrap();
    let dir = tempfile::tempdir().unwrap();
    // Where the pixel data element (7FE0,0010) OW starts.
    let pixels = bytes
        .windows(6)
        .position(|w| w == [0xe0, 0x7f, 0x10, 0x00, b'O', b'W'])
        .expect("pixel data");
    // Rows (0028,0010) US: an 8-byte header and a 2-byte value.
    let rows = bytes
        .windows(6)
        .position(|w| w == [0x28, 0x00, 0x10, 0x00, b'U', b'S'])
        .expect("Rows");
    let cut_in_header =
        format!("cannot read the data set at byte {rows} (after element (0028,0004) at byte");
    let cut_in_value =
        format!("element (0028,0010) at byte {rows} declares 2 bytes, but only 1 remain");
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        // Cut between elements: the data set just ends, without the image's size.
        (
            "cut-header.dcm",
            bytes[..600].to_vec(),
            "no Rows (0028,0010)",
        ),
        // Cut inside an element's header, then inside its value: not "Could not read data set
        // token", but where, after which element, and why.
        (
            "cut-in-a-header.dcm",
            bytes[..rows + 7].to_vec(),
            &cut_in_header,
        ),
        (
            "cut-in-a-value.dcm",
            bytes[..rows + 9].to_vec(),
            &cut_in_value,
        ),
        (
            "cut-pixels.dcm",
            bytes[..pixels + 12 + 5000].to_vec(),
            "pixel data",
        ),
        (
            "preamble-only.dcm",
            bytes[..132].to_vec(),
            "the meta group ends early (byte 132)",
        ),
    ];
    for (name, content, expected) in cases {
        let folder = dir.path().join(name.trim_end_matches(".dcm"));
        std::fs::create_dir(&folder).unwrap();
        let path = folder.join(name);
        std::fs::write(&path, &content).unwrap();
        let started = std::time::Instant::now();
        let Err(error) = load(&path) else {
            panic!("{name} loaded");
        };
        assert!(started.elapsed().as_secs_f64() < 2.0);
        assert!(
            error.starts_with(&path.display().to_string()) && !error.contains('\n'),
            "{error}"
        );
        assert!(error.contains(expected), "{name}: {error}");
        // The file is named once, at the start.
        assert_eq!(error.matches(name).count(), 1, "{error}");
        assert_eq!(std::fs::read(&path).unwrap(), content);
    }
}

/// A file of the written multi-frame kind with an element claiming `length` bytes inserted
/// before Rows (0028,0010); returns the bytes and the inserted element's offset.
fn with_a_damaged_length(length: u32) -> (Vec<u8>, usize) {
    use support::writers::{dicom_bytes, dicom_native_pixels, dicom_object};
    let mut bytes = dicom_bytes(
        dicom_object(dicom_native_pixels(), dicom_core::VR::OW),
        "1.2.840.10008.1.2.1",
    );
    let rows = bytes
        .windows(6)
        .position(|w| w == [0x28, 0x00, 0x10, 0x00, b'U', b'S'])
        .expect("Rows");
    let mut element = vec![0x10, 0x00, 0x10, 0x00, b'U', b'T', 0, 0];
    element.extend(length.to_le_bytes());
    bytes.splice(rows..rows, element);
    (bytes, rows)
}

#[test]
fn a_damaged_element_length_is_refused_with_its_tag_and_offset() {
    let dir = tempfile::tempdir().unwrap();
    let (bytes, at) = with_a_damaged_length(0xffff_fff0);
    let path = dir.path().join("damaged.dcm");
    std::fs::write(&path, &bytes).unwrap();
    let started = std::time::Instant::now();
    let error = load(&path).unwrap_err();
    assert!(started.elapsed().as_secs_f64() < 1.0);
    let remaining = bytes.len() - at - 12;
    assert_eq!(
        error,
        format!(
            "{}: element (0010,0010) at byte {at} declares 4294967280 bytes, but only {remaining} remain",
            path.display()
        )
    );
}

#[test]
fn a_damaged_file_in_a_series_folder_is_skipped() {
    use support::writers::{dicom_bytes, dicom_native_pixels, dicom_object};
    let dir = tempfile::tempdir().unwrap();
    for (index, position) in [(1, "0"), (2, "2.5")] {
        let mut object = dicom_object(dicom_native_pixels(), dicom_core::VR::OW);
        object.put(dicom_core::DataElement::new(
            dicom_dictionary_std::tags::IMAGE_POSITION_PATIENT,
            dicom_core::VR::DS,
            dicom_core::dicom_value!(Strs, ["0", "0", position]),
        ));
        object.put(dicom_core::DataElement::new(
            dicom_dictionary_std::tags::IMAGE_ORIENTATION_PATIENT,
            dicom_core::VR::DS,
            dicom_core::dicom_value!(Strs, ["1", "0", "0", "0", "1", "0"]),
        ));
        object.put(dicom_core::DataElement::new(
            dicom_dictionary_std::tags::NUMBER_OF_FRAMES,
            dicom_core::VR::IS,
            dicom_core::dicom_value!(Str, "1"),
        ));
        let path = dir.path().join(format!("slice-{index}.dcm"));
        std::fs::write(path, dicom_bytes(object, "1.2.840.10008.1.2.1")).unwrap();
    }
    std::fs::write(
        dir.path().join("slice-3.dcm"),
        with_a_damaged_length(0x8000_0000).0,
    )
    .unwrap();
    let volume = load(dir.path()).unwrap();
    assert!(has(&volume, "files", "2"), "{:?}", volume.metadata);
    // Asked for by name, the damaged file is an error.
    let error = load(&dir.path().join("slice-3.dcm")).unwrap_err();
    assert!(error.contains("element (0010,0010) at byte"), "{error}");
}

mod written {
    //! DICOM files written here with dicom-object: multi-frame, RLE, and an unsupported syntax.

    use dicom_core::VR;

    use super::support::writers::{
        DICOM_COLUMNS as COLUMNS, DICOM_FRAMES as FRAMES, DICOM_ROWS as ROWS, dicom_bytes,
        dicom_native_pixels, dicom_object, dicom_pixel as pixel, dicom_rle_pixels,
    };

    fn write(object: dicom_object::InMemDicomObject, syntax: &str, path: &std::path::Path) {
        std::fs::write(path, dicom_bytes(object, syntax)).unwrap();
    }

    fn check(path: &std::path::Path) {
        let volume = super::load(path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(volume.dims, [COLUMNS as usize, ROWS as usize, FRAMES]);
        assert_eq!(volume.spacing, [0.25, 0.5, 2.5]);
        assert_eq!(
            (volume.value_scale.slope, volume.value_scale.intercept),
            (2.0, -1024.0)
        );
        for n in 0..FRAMES * (ROWS * COLUMNS) as usize {
            assert_eq!(
                volume.data.get(n),
                Some(pixel(n) as f64),
                "{} pixel {n}",
                path.display()
            );
        }
        assert!(super::has(&volume, "modality", "CT"));
    }

    #[test]
    fn multi_frame_files_uncompressed_and_rle() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("multi.dcm");
        write(
            dicom_object(dicom_native_pixels(), VR::OW),
            "1.2.840.10008.1.2.1",
            &path,
        );
        check(&path);

        let rle = dir.path().join("rle.dcm");
        write(
            dicom_object(dicom_rle_pixels(), VR::OB),
            "1.2.840.10008.1.2.5",
            &rle,
        );
        check(&rle);

        // JPEG baseline is named in the error.
        let jpeg = dir.path().join("jpeg.dcm");
        write(
            dicom_object(dicom_rle_pixels(), VR::OB),
            "1.2.840.10008.1.2.4.50",
            &jpeg,
        );
        let error = super::load(&jpeg).unwrap_err();
        assert!(
            error.contains("1.2.840.10008.1.2.4.50 (JPEG baseline/extended) is not supported")
                && !error.contains('\n'),
            "{error}"
        );
    }
}
