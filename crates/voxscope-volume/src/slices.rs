//! A folder of 2-D slices (TIFF or PNG), one per z, sorted by the number in their names
//! (`slice_2.png` before `slice_10.png`), as microscopes and segmentation tools export them.

use std::path::{Path, PathBuf};

use super::error::{Problem, printable};
use super::io::{MAX_DEFLATE_RATIO, io_reason};
use super::{MAX_VOXELS, Volume, VoxelData};

/// Files of these extensions are slices.
const SLICE_EXTENSIONS: [&str; 3] = ["tif", "tiff", "png"];

/// What a folder that holds no volume lacks: every kind of folder that opens (the last tried,
/// slices, named first).
pub(super) fn no_volume_in_folder() -> Problem {
    format!(
        "is a folder without slice images ({}), DICOM files or a Zarr store (.zgroup, .zarray \
         or zarr.json), N5 container (attributes.json) or precomputed volume (info); open a \
         volume file, a folder of slices or of one DICOM series, or a store's folder",
        SLICE_EXTENSIONS.map(|e| format!(".{e}")).join(", ")
    )
}

/// Reads the slices of `dir` in name-number order into one volume.
pub(super) fn load(dir: &Path) -> Result<Volume, Problem> {
    let files = slice_files(dir)?;
    if files.is_empty() {
        return Err(no_volume_in_folder());
    }
    let mut stack: Option<(VoxelData, [usize; 2], Volume)> = None;
    for (index, file) in files.iter().enumerate() {
        let slice = read_slice(file).map_err(|p| format!("slice {}: {p}", file.display()))?;
        if slice.dims[2] != 1 {
            return Err(format!(
                "slice {} has {} pages; a folder of slices needs one page per file",
                file.display(),
                slice.dims[2]
            ));
        }
        let size = [slice.dims[0], slice.dims[1]];
        match &mut stack {
            None => {
                let data = slice.data.clone();
                stack = Some((data, size, slice));
            }
            Some((data, first_size, first)) => {
                if size != *first_size {
                    return Err(format!(
                        "slice {} is {}x{} but the first is {}x{}",
                        file.display(),
                        size[0],
                        size[1],
                        first_size[0],
                        first_size[1]
                    ));
                }
                if (index + 1).saturating_mul(size[0] * size[1]) > MAX_VOXELS {
                    return Err(format!("more than {MAX_VOXELS} voxels"));
                }
                let slice_type = slice.voxel_type();
                data.append(slice.data).map_err(|_| {
                    format!(
                        "slice {} holds {} values but the first holds {}",
                        file.display(),
                        slice_type.name(),
                        first.voxel_type().name()
                    )
                })?;
            }
        }
    }
    let (data, [width, height], first) = stack.expect("at least one slice");
    let mut volume = Volume::new(
        dir.display().to_string(),
        "slices",
        [width, height, files.len()],
        first.spacing,
        data,
    )
    .map_err(|e| e.problem)?;
    volume.metadata = vec![
        ("slices".to_owned(), files.len().to_string()),
        (
            "first, last".to_owned(),
            format!(
                "{}, {}",
                printable(&file_name(&files[0])),
                printable(&file_name(&files[files.len() - 1]))
            ),
        ),
    ];
    volume
        .metadata
        .extend(first.metadata.into_iter().filter(|(key, _)| key != "pages"));
    Ok(volume)
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// The slice files of `dir`, sorted by the last number in the name, then by name.
pub(super) fn slice_files(dir: &Path) -> Result<Vec<PathBuf>, Problem> {
    let entries = std::fs::read_dir(dir).map_err(|e| format!("cannot list: {}", io_reason(&e)))?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .map(|entry| entry.path())
        .filter(|path| {
            path.is_file()
                && path.extension().is_some_and(|ext| {
                    SLICE_EXTENSIONS.contains(&ext.to_string_lossy().to_lowercase().as_str())
                })
        })
        .collect();
    files.sort_by_key(|path| {
        let name = file_name(path);
        (last_number(&name), name)
    });
    Ok(files)
}

/// The last run of digits in `name`, or `None` (sorted first).
fn last_number(name: &str) -> Option<u64> {
    let stem = name.rsplit_once('.').map_or(name, |(stem, _)| stem);
    let end = stem.rfind(|c: char| c.is_ascii_digit())? + 1;
    let start = stem[..end]
        .rfind(|c: char| !c.is_ascii_digit())
        .map_or(0, |i| i + 1);
    stem[start..end].parse().ok()
}

/// One slice as a volume of depth 1 (TIFF through the stack reader, PNG through `image`).
pub(super) fn read_slice(path: &Path) -> Result<Volume, Problem> {
    let is_png = path
        .extension()
        .is_some_and(|e| e.to_string_lossy().eq_ignore_ascii_case("png"));
    if !is_png {
        let slice = super::tiff::load(path, super::Selection::default())?;
        if slice.series.is_multi_frame() {
            return Err(format!(
                "holds {} channels and {} time points; a folder of slices needs one grayscale image each",
                slice.series.channel_count(),
                slice.series.time_points
            ));
        }
        return Ok(slice);
    }
    let file_bytes = std::fs::metadata(path)
        .map_err(|e| format!("cannot open: {}", io_reason(&e)))?
        .len();
    let mut reader = image::ImageReader::open(path)
        .map_err(|e| format!("cannot open: {}", io_reason(&e)))?
        .with_guessed_format()
        .map_err(|e| format!("cannot read: {}", io_reason(&e)))?;
    // A PNG is deflated: a larger claim is refused before allocating.
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(file_bytes.saturating_mul(MAX_DEFLATE_RATIO).min(1 << 31));
    reader.limits(limits);
    let image = reader
        .decode()
        .map_err(|e| format!("not a readable PNG: {e}"))?;
    let (width, height) = (image.width() as usize, image.height() as usize);
    let data = match image {
        image::DynamicImage::ImageLuma8(buffer) => VoxelData::U8(buffer.into_raw()),
        image::DynamicImage::ImageLuma16(buffer) => VoxelData::U16(buffer.into_raw()),
        other => {
            return Err(format!(
                "has {} channels of {} bits; only grayscale PNG slices (8 or 16 bit) are supported",
                other.color().channel_count(),
                other.color().bits_per_pixel() / other.color().channel_count().max(1) as u16
            ));
        }
    };
    Volume::new(
        path.display().to_string(),
        "PNG",
        [width, height, 1],
        [1.0; 3],
        data,
    )
    .map_err(|e| e.problem)
}

#[cfg(test)]
mod tests {
    use super::last_number;

    #[test]
    fn names_sort_by_their_last_number() {
        assert_eq!(last_number("slice_10.png"), Some(10));
        assert_eq!(last_number("scan2_z0007.tif"), Some(7));
        assert_eq!(last_number("plain.png"), None);
    }
}
