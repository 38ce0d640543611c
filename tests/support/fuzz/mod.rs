//! The fuzzer shared by `examples/fuzz.rs` (long campaigns) and
//! `crates/voxscope-octree/tests/fuzz.rs` (a fixed few
//! thousand cases in CI): seeds of every format, structure-aware mutations, and the oracle
//! that runs each case in-process under a counting allocator.
//!
//! A case is fully determined by (campaign seed, format, case number): the same numbers give
//! the same files anywhere, so a failure is reproduced with `--format F --case N --seed S`.
//! Every failure ever found is kept under `tests/data/fuzz/` and run by
//! `crates/voxscope-octree/tests/fuzz.rs`.
#![allow(dead_code)] // the example and the test use different parts

pub mod alloc;
pub mod mutate;
pub mod oracle;
pub mod rng;
pub mod seeds;
#[path = "../writers.rs"]
pub mod writers;

use std::path::{Path, PathBuf};

use rng::Rng;
use seeds::{Role, Seed};

/// The formats fuzzed, one per loader of the format table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Kind {
    Nifti,
    Nrrd,
    Tiff,
    Dicom,
    Vti,
    Mrc,
}

impl Kind {
    /// Every format, in report order.
    pub const ALL: [Kind; 6] = [
        Kind::Nifti,
        Kind::Nrrd,
        Kind::Tiff,
        Kind::Dicom,
        Kind::Vti,
        Kind::Mrc,
    ];

    /// The name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Nifti => "nifti",
            Kind::Nrrd => "nrrd",
            Kind::Tiff => "tiff",
            Kind::Dicom => "dicom",
            Kind::Vti => "vti",
            Kind::Mrc => "mrc",
        }
    }

    /// The format of a name given on the command line.
    pub fn from_name(name: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The format of a file, by its extension (the format table's).
    pub fn of_file_name(name: &str) -> Option<Kind> {
        let format = voxscope_volume::format::by_extension(name)?;
        Some(match format.name {
            "NIfTI-1" => Kind::Nifti,
            "NRRD" => Kind::Nrrd,
            "TIFF" => Kind::Tiff,
            "DICOM" => Kind::Dicom,
            "VTK ImageData" => Kind::Vti,
            "MRC" => Kind::Mrc,
            _ => return None,
        })
    }
}

/// One mutated input: the files of a seed, one or more of them changed.
#[derive(Debug, Clone)]
pub struct Case {
    pub kind: Kind,
    pub seed_name: String,
    pub index: u64,
    /// File name and bytes, written into an empty folder.
    pub files: Vec<(String, Vec<u8>)>,
    /// A file name of `files`, or `.` for the folder.
    pub open: String,
    /// What was changed, one line per mutation.
    pub mutations: Vec<String>,
}

/// Case `index` of `kind` in the campaign `campaign_seed`: seed `index % seeds`, then one to
/// three mutations, each of one file of the seed (the main file more often than data files).
pub fn make_case(seeds: &[&Seed], kind: Kind, campaign_seed: u64, index: u64) -> Case {
    make_case_from(
        seeds[(index % seeds.len() as u64) as usize],
        kind,
        campaign_seed,
        index,
    )
}

/// Case `index` of the campaign `campaign_seed` made from `seed` (what [`make_case`] makes
/// when it picks that seed): the mutations depend on the campaign, format and number only.
pub fn make_case_from(seed: &Seed, kind: Kind, campaign_seed: u64, index: u64) -> Case {
    let mut rng = Rng::for_case(campaign_seed, kind.name(), index);
    let mut files: Vec<(String, Vec<u8>)> = seed
        .files
        .iter()
        .map(|f| (f.name.clone(), f.bytes.clone()))
        .collect();
    let count = match rng.below(20) {
        0..=11 => 1,
        12..=16 => 2,
        _ => 3,
    };
    let mut mutations = Vec::new();
    for _ in 0..count {
        let main: Vec<usize> = (0..files.len())
            .filter(|&i| seed.files[i].role == Role::Main)
            .collect();
        let which = if main.len() < files.len() && rng.percent(25) {
            rng.below(files.len())
        } else {
            *rng.pick(&main)
        };
        let role = seed.files[which].role;
        mutations.push(format!("{}:", files[which].0));
        mutate::mutate(kind, role, &mut files[which].1, &mut rng, &mut mutations);
    }
    Case {
        kind,
        seed_name: seed.name.clone(),
        index,
        files,
        open: seed.open.clone(),
        mutations,
    }
}

/// A fingerprint of a case's files (FNV-1a over names and bytes): a recipe in
/// `tests/data/fuzz/real-data.txt` records it, so a change to the mutations that would make
/// the recipe produce another file is noticed instead of testing something else.
pub fn fingerprint(case: &Case) -> u64 {
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    for (name, bytes) in &case.files {
        for byte in name.bytes().chain([0]).chain(bytes.iter().copied()) {
            hash = (hash ^ byte as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    hash
}

/// A failure found in a case made from a real file of `../shared/data`, kept as how to make
/// it again (the files are too large to keep): one line of `real-data.txt`,
/// `FORMAT SEED_FILE CAMPAIGN_SEED CASE FINGERPRINT`.
#[derive(Debug, Clone, PartialEq)]
pub struct Recipe {
    pub kind: Kind,
    /// Relative to `../shared/data`.
    pub seed_file: String,
    pub campaign_seed: u64,
    pub index: u64,
    pub fingerprint: u64,
}

impl Recipe {
    /// Parses one line (`#` comments and blank lines give `None`).
    pub fn parse(line: &str) -> Option<Result<Self, String>> {
        let line = line.split('#').next().unwrap_or_default().trim();
        if line.is_empty() || line.starts_with('#') {
            return None;
        }
        let fields: Vec<&str> = line.split_whitespace().collect();
        let parsed = (|| {
            let [kind, seed_file, campaign_seed, index, fingerprint] = fields[..] else {
                return None;
            };
            Some(Self {
                kind: Kind::from_name(kind)?,
                seed_file: seed_file.to_owned(),
                campaign_seed: campaign_seed.parse().ok()?,
                index: index.parse().ok()?,
                fingerprint: u64::from_str_radix(fingerprint, 16).ok()?,
            })
        })();
        Some(parsed.ok_or_else(|| format!("not a recipe: {line}")))
    }

    /// The line [`Recipe::parse`] reads.
    pub fn line(&self) -> String {
        format!(
            "{} {} {} {} {:016x}",
            self.kind.name(),
            self.seed_file,
            self.campaign_seed,
            self.index,
            self.fingerprint
        )
    }
}

/// Writes the case's files into `dir` (emptied first) and returns what to open and the
/// inputs to check unchanged.
pub fn write_case(case: &Case, dir: &Path) -> std::io::Result<(PathBuf, Box<oracle::Inputs>)> {
    if dir.exists() {
        std::fs::remove_dir_all(dir)?;
    }
    std::fs::create_dir_all(dir)?;
    let mut inputs = Vec::new();
    for (name, bytes) in &case.files {
        let path = dir.join(name);
        std::fs::write(&path, bytes)?;
        inputs.push((path, bytes.clone()));
    }
    let target = if case.open == "." {
        dir.to_path_buf()
    } else {
        dir.join(&case.open)
    };
    Ok((target, inputs.into_boxed_slice()))
}

/// Runs `case` in `dir` under `limits`.
pub fn run_case(case: &Case, dir: &Path, limits: &oracle::Limits) -> oracle::Outcome {
    let (target, inputs) = write_case(case, dir).expect("the work folder is writable");
    oracle::check(&target, &inputs, limits)
}

/// Saves a case as a regression folder: its files and `OPEN` naming what is opened (what
/// `crates/voxscope-octree/tests/fuzz.rs` reads back from `tests/data/fuzz/`).
pub fn save_case(case: &Case, folder: &Path, note: &str) -> std::io::Result<()> {
    std::fs::create_dir_all(folder)?;
    for (name, bytes) in &case.files {
        std::fs::write(folder.join(name), bytes)?;
    }
    std::fs::write(folder.join("OPEN"), format!("{}\n", case.open))?;
    let mut about = format!(
        "format {}, seed '{}', case {}\n{note}\nmutations:\n",
        case.kind.name(),
        case.seed_name,
        case.index
    );
    for line in &case.mutations {
        about.push_str(&format!("  {line}\n"));
    }
    std::fs::write(folder.join("ABOUT"), about)
}

/// A saved regression folder's target and inputs (every file but `OPEN` and `ABOUT`).
pub fn load_saved(folder: &Path) -> std::io::Result<(PathBuf, Box<oracle::Inputs>)> {
    let open = std::fs::read_to_string(folder.join("OPEN"))?;
    let open = open.trim();
    let mut inputs = Vec::new();
    for entry in std::fs::read_dir(folder)? {
        let path = entry?.path();
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
        if matches!(name.as_deref(), Some("OPEN") | Some("ABOUT")) {
            continue;
        }
        let bytes = std::fs::read(&path)?;
        inputs.push((path, bytes));
    }
    inputs.sort();
    let target = if open == "." {
        folder.to_path_buf()
    } else {
        folder.join(open)
    };
    Ok((target, inputs.into_boxed_slice()))
}
