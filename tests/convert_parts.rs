//! `convert` in parts (plan, run, finalize), each step its own process as a scheduler runs it:
//! the parts in any order, one killed half way and run again, write the same bytes as the
//! one-process `convert`; a part's number comes from Slurm's or Kubernetes' variables; a
//! missing part, another plan's marker and an input changed since the plan are one-line
//! errors that write nothing over finished work.

mod support;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use support::cli::voxscope;

/// A 770x650x130 u16 volume: smooth waves and a little noise (so chunks compress unevenly).
const DIMS: [usize; 3] = [770, 650, 130];
const LAYOUT: &str = "770x650x130:u16";

fn write_raw(path: &Path) {
    let mut bytes = Vec::with_capacity(DIMS.iter().product::<usize>() * 2);
    let mut seed = 12345u32;
    for z in 0..DIMS[2] {
        for y in 0..DIMS[1] {
            for x in 0..DIMS[0] {
                seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let wave =
                    (x as f64 / 17.0).sin() + (y as f64 / 23.0).cos() + (z as f64 / 7.0).sin();
                let value = 3000.0 + 900.0 * wave + f64::from(seed >> 28);
                bytes.extend_from_slice(&(value as u16).to_le_bytes());
            }
        }
    }
    std::fs::write(path, bytes).unwrap();
}

fn ok(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn error(out: &Output) -> String {
    assert!(!out.status.success(), "it succeeded");
    let stderr = String::from_utf8_lossy(&out.stderr).trim().to_owned();
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    stderr
}

/// Every file under `root` but the plan's folder, by relative path, with its bytes.
fn files(root: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<PathBuf, Vec<u8>>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.file_name().is_some_and(|n| n == ".voxscope") {
                continue;
            }
            if path.is_dir() {
                walk(root, &path, out);
            } else {
                let bytes = std::fs::read(&path).unwrap();
                out.insert(path.strip_prefix(root).unwrap().to_path_buf(), bytes);
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(root, root, &mut out);
    out
}

fn assert_same_files(expected: &Path, got: &Path) {
    let (a, b) = (files(expected), files(got));
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "the same files"
    );
    for (path, bytes) in &a {
        assert!(bytes == &b[path], "{} differs", path.display());
    }
}

fn s(path: &Path) -> &str {
    path.to_str().unwrap()
}

fn plan(raw: &Path, out: &Path, parts: usize, format: &[&str]) -> String {
    let parts = parts.to_string();
    let mut args = vec![
        "convert",
        "plan",
        s(raw),
        s(out),
        "--raw",
        LAYOUT,
        "--parts",
        &parts,
    ];
    args.extend_from_slice(format);
    ok(&voxscope(&args))
}

fn run_part(out: &Path, part: &str) -> Output {
    voxscope(&["convert", "run", s(out), "--part", part])
}

/// 0.5 sharded, small chunks: four parts of 512² columns, levels 0 and 1 in the parts and the
/// rest built by finalize.
const SHARDED: [&str; 8] = [
    "--format",
    "0.5",
    "--chunk",
    "32",
    "--shard",
    "2",
    "--compression",
    "gzip",
];

#[test]
fn parts_in_any_order_one_killed_write_the_one_process_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("waves.raw");
    write_raw(&raw);
    let whole = dir.path().join("whole.ome.zarr");
    let mut args = vec!["convert", s(&raw), s(&whole), "--raw", LAYOUT];
    args.extend_from_slice(&SHARDED);
    ok(&voxscope(&args));

    let parted = dir.path().join("parts.ome.zarr");
    assert_eq!(
        plan(&raw, &parted, 4, &SHARDED).trim(),
        "4",
        "plan prints N"
    );
    let plan_text = std::fs::read_to_string(parted.join(".voxscope/plan.json")).unwrap();
    assert!(plan_text.contains("\"column_levels\": 2"), "{plan_text}");
    // No image before finalize: the group's metadata is written last.
    assert!(!parted.join("zarr.json").exists());

    // Part 2 killed once it has written some of its shards, then the others in another
    // order, then part 2 again.
    let mut child = Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(["convert", "run", s(&parted), "--part", "2/4"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    let written = |dir: &Path| {
        std::fs::read_dir(dir.join("0/c"))
            .map(|entries| entries.count())
            .unwrap_or(0)
    };
    while written(&parted) == 0 && started.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        written(&parted) > 0,
        "part 2 wrote shards before it was killed"
    );
    assert!(
        !parted.join(".voxscope/parts/2.json").exists(),
        "part 2 was killed before it finished"
    );
    for part in ["3/4", "0/4", "2/4", "1/4"] {
        let stdout = ok(&run_part(&parted, part));
        assert!(stdout.contains("objects"), "{stdout}");
    }
    // A finished part returns at once.
    let again = ok(&run_part(&parted, "1/4"));
    assert!(again.contains("had finished"), "{again}");
    let marker = std::fs::read_to_string(parted.join(".voxscope/parts/1.json")).unwrap();
    for field in [
        "\"objects\"",
        "\"bytes_in\"",
        "\"bytes_out\"",
        "\"seconds\"",
        "\"peak_memory_bytes\"",
    ] {
        assert!(marker.contains(field), "{field} in {marker}");
    }
    let finalized = ok(&voxscope(&["convert", "finalize", s(&parted)]));
    assert!(finalized.contains("6 levels"), "{finalized}");
    assert_same_files(&whole, &parted);

    // Slurm's array variables and Kubernetes' completion index name the part.
    let slurm = dir.path().join("slurm.ome.zarr");
    plan(&raw, &slurm, 2, &SHARDED);
    for task in ["1", "0"] {
        let out = Command::new(env!("CARGO_BIN_EXE_voxscope"))
            .args(["convert", "run", s(&slurm)])
            .env("SLURM_ARRAY_TASK_ID", task)
            .env("SLURM_ARRAY_TASK_MIN", "1")
            .output()
            .unwrap();
        ok(&out);
    }
    let k8s = dir.path().join("k8s.ome.zarr");
    plan(&raw, &k8s, 3, &SHARDED);
    for index in ["0", "1", "2"] {
        let out = Command::new(env!("CARGO_BIN_EXE_voxscope"))
            .args(["convert", "run", s(&k8s)])
            .env("JOB_COMPLETION_INDEX", index)
            .output()
            .unwrap();
        ok(&out);
    }
    for out in [&slurm, &k8s] {
        ok(&voxscope(&["convert", "finalize", s(out)]));
        assert_same_files(&whole, out);
    }
}

#[test]
fn unsharded_parts_write_the_one_process_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("waves.raw");
    write_raw(&raw);
    let format = ["--format", "0.4", "--chunk", "64"];
    let whole = dir.path().join("whole.ome.zarr");
    let mut args = vec!["convert", s(&raw), s(&whole), "--raw", LAYOUT];
    args.extend_from_slice(&format);
    ok(&voxscope(&args));
    let parted = dir.path().join("parts.ome.zarr");
    plan(&raw, &parted, 3, &format);
    for part in ["1/3", "2/3", "0/3"] {
        ok(&run_part(&parted, part));
    }
    ok(&voxscope(&["convert", "finalize", s(&parted)]));
    assert_same_files(&whole, &parted);

    // A part killed while writing an edge chunk (x 768..770 of part 1's column) left it
    // truncated: run again, it writes the chunk whole, not over what it would read back.
    let edge = parted.join("0/0/0/12");
    let bytes = std::fs::read(&edge).unwrap();
    std::fs::write(&edge, &bytes[..bytes.len() / 3]).unwrap();
    std::fs::remove_file(parted.join(".voxscope/parts/1.json")).unwrap();
    ok(&run_part(&parted, "1/3"));
    ok(&voxscope(&["convert", "finalize", s(&parted)]));
    assert_same_files(&whole, &parted);
}

#[test]
fn narrow_columns_and_finalize_in_rounds_write_the_one_process_bytes() {
    // --part-memory 1MiB: columns of one 256² tile each, only level 0 in the parts, and
    // finalize builds the rest in rounds of columns (level 1 in four of 512², then the others
    // from level 1 whole).
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("waves.raw");
    write_raw(&raw);
    let format = ["--format", "0.5", "--chunk", "32", "--shard", "2"];
    let whole = dir.path().join("whole.ome.zarr");
    let mut args = vec!["convert", s(&raw), s(&whole), "--raw", LAYOUT];
    args.extend_from_slice(&format);
    ok(&voxscope(&args));
    let parted = dir.path().join("parts.ome.zarr");
    let mut args = vec!["convert", "plan", s(&raw), s(&parted), "--raw", LAYOUT];
    args.extend_from_slice(&["--parts", "5", "--part-memory", "1MiB"]);
    args.extend_from_slice(&format);
    ok(&voxscope(&args));
    let plan_text = std::fs::read_to_string(parted.join(".voxscope/plan.json")).unwrap();
    assert!(plan_text.contains("\"column_levels\": 1"), "{plan_text}");
    for part in ["4/5", "1/5", "3/5", "0/5", "2/5"] {
        ok(&run_part(&parted, part));
    }
    let out = voxscope(&["convert", "finalize", s(&parted)]);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    ok(&out);
    assert!(
        stderr.contains("building levels 1 to 1 from level 0 (770x650x130) in 4 columns"),
        "{stderr}"
    );
    assert_same_files(&whole, &parted);
}

#[test]
fn a_missing_part_another_plan_and_a_changed_input_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("waves.raw");
    write_raw(&raw);
    let first = dir.path().join("first.ome.zarr");
    plan(&raw, &first, 3, &SHARDED);
    ok(&run_part(&first, "0/3"));
    ok(&run_part(&first, "2/3"));

    // finalize with part 1 missing: it names the part and the command, and writes no image.
    let message = error(&voxscope(&["convert", "finalize", s(&first)]));
    assert!(
        message.contains("part 1 of 3 not finished") && message.contains("--part 1/3"),
        "{message}"
    );
    assert!(!first.join("zarr.json").exists());

    // The part count must be the plan's.
    let message = error(&run_part(&first, "1/4"));
    assert!(message.contains("the plan has 3 parts, not 4"), "{message}");

    // Another plan's marker (a plan of other options into another folder).
    let second = dir.path().join("second.ome.zarr");
    plan(&raw, &second, 3, &["--format", "0.5", "--chunk", "64"]);
    std::fs::create_dir_all(second.join(".voxscope/parts")).unwrap();
    std::fs::copy(
        first.join(".voxscope/parts/0.json"),
        second.join(".voxscope/parts/0.json"),
    )
    .unwrap();
    let message = error(&run_part(&second, "0/3"));
    assert!(message.contains("another plan"), "{message}");
    assert!(!second.join("0/c").exists(), "nothing written");

    // The input changed between plan and run: refused before anything is written.
    let before = files(&first);
    let mut bytes = std::fs::read(&raw).unwrap();
    bytes[1000] ^= 0xff;
    std::thread::sleep(Duration::from_millis(20));
    std::fs::write(&raw, &bytes).unwrap();
    let message = error(&run_part(&first, "1/3"));
    assert!(message.contains("changed since the plan"), "{message}");
    assert!(
        before == files(&first),
        "nothing written over finished work"
    );

    // An edited plan (columns that would share shards) is refused.
    let plan_path = first.join(".voxscope/plan.json");
    let text = std::fs::read_to_string(&plan_path).unwrap();
    std::fs::write(&plan_path, text.replacen("512", "384", 1)).unwrap();
    let message = error(&run_part(&first, "1/3"));
    assert!(message.contains("not a plan convert made"), "{message}");

    // No plan at all.
    let message = error(&run_part(dir.path(), "0/1"));
    assert!(message.contains("no conversion plan"), "{message}");
}

#[test]
fn a_file_read_whole_is_not_cut_into_parts() {
    let dir = tempfile::tempdir().unwrap();
    let nrrd = dir.path().join("small.nrrd");
    let mut text =
        b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 8 8 8\nencoding: gzip\n\n".to_vec();
    let mut encoder = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    std::io::Write::write_all(&mut encoder, &[7u8; 512]).unwrap();
    text.extend(encoder.finish().unwrap());
    std::fs::write(&nrrd, text).unwrap();
    let out = dir.path().join("out.ome.zarr");
    let message = error(&voxscope(&[
        "convert",
        "plan",
        s(&nrrd),
        s(&out),
        "--parts",
        "2",
    ]));
    assert!(
        message.contains("read whole, not by region") && message.contains("one process"),
        "{message}"
    );
    // One part is the one-process conversion.
    ok(&voxscope(&[
        "convert",
        "plan",
        s(&nrrd),
        s(&out),
        "--parts",
        "1",
    ]));
    ok(&run_part(&out, "0/1"));
    ok(&voxscope(&["convert", "finalize", s(&out)]));
}
