//! The file formats voxscope reads, in one table: each format's name, file name endings, magic
//! bytes and loader. The registry's dispatch, the "unrecognized format" error, the Open
//! dialog's filter and the README's Formats table (checked by a test) all come from here, so
//! a format added to [`FORMATS`] is offered, recognized and documented everywhere at once.

use std::path::Path;

use super::error::Problem;
use super::{Selection, Volume};

/// One file format: how it is recognized and which loader reads it.
pub struct Format {
    /// The name users see (in errors, the dialog's filter, `info`).
    pub name: &'static str,
    /// File name endings, lower case with their dot (`.nii.gz`), matched against the end of
    /// the name.
    pub extensions: &'static [&'static str],
    /// Whether a folder of such files opens as one volume (a DICOM series), or
    /// the folder is the volume (a Zarr store).
    pub opens_folders: bool,
    /// The format's magic bytes: true when the first bytes of a file (up to [`SNIFF_BYTES`])
    /// are this format's. Consulted only when no extension matched.
    pub sniff: Option<fn(&[u8]) -> bool>,
    /// Reads the chosen frame of a file of this format (formats without channels or time
    /// points read their one frame and leave the check to the registry).
    load: fn(&Path, Selection) -> Result<Volume, Problem>,
}

impl Format {
    /// Reads frame `select` of `path` with this format's loader.
    pub(crate) fn load(&self, path: &Path, select: Selection) -> Result<Volume, Problem> {
        (self.load)(path, select)
    }

    /// Whether the lower-cased file name `name` ends with one of the format's extensions.
    pub fn matches_name(&self, name: &str) -> bool {
        self.extensions.iter().any(|ext| name.ends_with(ext))
    }
}

/// How many leading bytes of a file the magic-byte checks see.
pub const SNIFF_BYTES: usize = 4096;

/// Every format voxscope reads from a file, in the order the magic bytes are tried: the
/// strongest first (HDF5's 8-byte signature at byte 0; DICOM's `DICM` at byte 128 and MRC's
/// `MAP ` at byte 208 could occur inside another format's header fields; NIfTI's 4-byte header
/// size is the weakest, so last).
/// Extensions never overlap, so their order does not matter.
pub static FORMATS: [Format; 10] = [
    Format {
        name: "Imaris",
        extensions: &[".ims"],
        opens_folders: false,
        // HDF5's signature: an `.h5` of Imaris's layout opens; any other HDF5 file is named so.
        sniff: Some(super::ome_zarr::sniff_hdf5),
        // Read by the Zarr reader (ome_zarr/imaris).
        load: super::ome_zarr::load,
    },
    Format {
        name: "DICOM",
        extensions: &[".dcm"],
        opens_folders: true,
        sniff: Some(super::dicom::sniff),
        load: |path, _| super::dicom::load(path),
    },
    Format {
        name: "MRC",
        extensions: &[".mrc", ".map", ".rec", ".ccp4", ".mrcs", ".st", ".ali"],
        opens_folders: false,
        sniff: Some(super::mrc::sniff),
        load: |path, _| super::mrc::load(path),
    },
    Format {
        name: "NRRD",
        extensions: &[".nrrd", ".nhdr"],
        opens_folders: false,
        sniff: Some(super::nrrd::sniff),
        load: super::nrrd::load,
    },
    Format {
        name: "TIFF",
        extensions: &[".tif", ".tiff"],
        opens_folders: false,
        sniff: Some(super::tiff::sniff),
        load: super::tiff::load,
    },
    Format {
        name: "NIfTI-1",
        extensions: &[".nii", ".nii.gz", ".hdr"],
        opens_folders: false,
        sniff: Some(super::nifti::sniff),
        load: super::nifti::load,
    },
    Format {
        name: "OME-Zarr",
        extensions: &[".zarr"],
        opens_folders: true,
        sniff: None,
        load: super::ome_zarr::load,
    },
    Format {
        name: "N5",
        extensions: &[".n5"],
        opens_folders: true,
        sniff: None,
        // Read by the Zarr reader (ome_zarr/n5).
        load: super::ome_zarr::load,
    },
    Format {
        name: "precomputed",
        // A folder holding `info`, whatever its name.
        extensions: &[],
        opens_folders: true,
        sniff: None,
        // Read by the Zarr reader (ome_zarr/precomputed).
        load: super::ome_zarr::load,
    },
    Format {
        name: "VTK ImageData",
        extensions: &[".vti"],
        opens_folders: false,
        sniff: None,
        load: |path, _| super::vti::load(path),
    },
];

/// The format whose extension ends `file_name` (any case).
pub fn by_extension(file_name: &str) -> Option<&'static Format> {
    let name = file_name.to_lowercase();
    FORMATS.iter().find(|format| format.matches_name(&name))
}

/// The first format whose magic bytes `head` (a file's first bytes) carries.
pub fn by_magic(head: &[u8]) -> Option<&'static Format> {
    FORMATS
        .iter()
        .find(|format| format.sniff.is_some_and(|sniff| sniff(head)))
}

/// The extensions a file dialog offers, as dialogs want them: without the dot and only the
/// last component (`gz` for `.nii.gz`), each once.
pub fn dialog_extensions() -> Vec<&'static str> {
    let mut extensions: Vec<&'static str> = Vec::new();
    for format in &FORMATS {
        for extension in format.extensions {
            let last = extension.rsplit('.').next().unwrap_or(extension);
            if !extensions.contains(&last) {
                extensions.push(last);
            }
        }
    }
    extensions
}

/// The name of the dialog's filter: `Volumes (DICOM, MRC, …)`.
pub fn dialog_filter_name() -> String {
    let names: Vec<&str> = FORMATS.iter().map(|format| format.name).collect();
    format!("Volumes ({})", names.join(", "))
}

/// What the registry says when nothing recognized a file: every format with its extensions
/// (the registry marks it [`super::LoadErrorKind::Unrecognized`], where the command line adds
/// its `--raw`).
pub(crate) fn unrecognized_problem() -> Problem {
    let listed: Vec<String> = FORMATS
        .iter()
        .map(|format| {
            format!(
                "{} ({}{})",
                format.name,
                format.extensions.join(", "),
                if format.opens_folders {
                    ", or a folder"
                } else {
                    ""
                }
            )
        })
        .collect();
    format!("unrecognized format: expected {}", listed.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extensions_never_overlap_and_are_lower_case() {
        let all: Vec<&str> = FORMATS
            .iter()
            .flat_map(|f| f.extensions.iter().copied())
            .collect();
        for (i, a) in all.iter().enumerate() {
            assert!(a.starts_with('.') && *a == a.to_lowercase(), "{a}");
            for b in &all[i + 1..] {
                assert!(!a.ends_with(b) && !b.ends_with(a), "{a} and {b} overlap");
            }
        }
    }

    #[test]
    fn dialog_offers_every_extension_once() {
        let offered = dialog_extensions();
        for extension in FORMATS.iter().flat_map(|f| f.extensions) {
            let last = extension.rsplit('.').next().unwrap();
            assert!(offered.contains(&last), "{extension}");
        }
        let mut unique = offered.clone();
        unique.sort_unstable();
        unique.dedup();
        assert_eq!(unique.len(), offered.len());
        for wanted in ["hdr", "mrcs", "st", "ali", "gz", "nii"] {
            assert!(offered.contains(&wanted), "{wanted}");
        }
    }

    #[test]
    fn names_and_magic_pick_the_format() {
        assert_eq!(by_extension("Head.NII.GZ").map(|f| f.name), Some("NIfTI-1"));
        assert_eq!(by_extension("a.nhdr").map(|f| f.name), Some("NRRD"));
        assert!(by_extension("notes.txt").is_none());
        assert_eq!(by_magic(b"NRRD0004\n").map(|f| f.name), Some("NRRD"));
        assert_eq!(by_magic(b"II*\0....").map(|f| f.name), Some("TIFF"));
        let mut dicom = vec![0u8; 200];
        dicom[128..132].copy_from_slice(b"DICM");
        assert_eq!(by_magic(&dicom).map(|f| f.name), Some("DICOM"));
        assert!(by_magic(b"hello").is_none());
    }
}
