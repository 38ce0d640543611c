//! The real binary: `info`, `render`, `bench`, `ceilings`, and its exit codes on bad input.

mod support;

use std::process::{Command, Output};

use support::shared_data;

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
fn info_json_has_the_documented_keys_with_depth_plus_one_levels() {
    let path = shared_data("mri-head-256.nii.gz");
    let output = voxscope(&["info", "--json", path.to_str().unwrap()]);
    assert!(output.status.success(), "{}", stderr(&output));
    let json: serde_json::Value = serde_json::from_slice(&output.stdout).expect("one JSON object");
    let volume = &json["volume"];
    assert_eq!(volume["dims"], serde_json::json!([256, 256, 256]));
    assert_eq!(volume["voxel_type"], "u8");
    assert_eq!(volume["spacing"], serde_json::json!([1.0, 1.0, 1.0]));
    assert_eq!(volume["value_range"][0], 0.0);
    let octree = &json["octree"];
    assert_eq!(octree["depth"], 8);
    assert_eq!(octree["node_bytes"], 8);
    assert!(octree["build_seconds"].as_f64().unwrap() > 0.0);
    let levels = octree["levels"].as_array().unwrap();
    assert_eq!(levels.len(), 9);
    let total: u64 = levels.iter().map(|l| l["nodes"].as_u64().unwrap()).sum();
    assert_eq!(octree["total_nodes"].as_u64().unwrap(), total);
    for (i, level) in levels.iter().enumerate() {
        assert_eq!(level["level"], i);
        for key in ["nodes", "leaves", "transparent", "opaque", "bytes"] {
            assert!(level[key].is_u64(), "level {i} lacks {key}");
        }
        assert_eq!(
            level["bytes"].as_u64().unwrap(),
            8 * level["nodes"].as_u64().unwrap()
        );
    }
    assert_eq!(levels[0]["nodes"], 1);
}

#[test]
fn info_table_prints_volume_and_levels() {
    let output = voxscope(&["info", "synthetic:sphere:40x30x20"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let text = String::from_utf8(output.stdout).unwrap();
    for expected in [
        "40x30x20",
        "u8",
        "level",
        "transparent",
        "opaque",
        "total",
        "build",
    ] {
        assert!(text.contains(expected), "missing '{expected}' in:\n{text}");
    }
}

#[test]
fn render_writes_the_png_it_was_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("head.png");
    let path = shared_data("mri-head-128x128x62.nii.gz");
    let output = voxscope(&[
        "render",
        path.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--size",
        "160x120",
        "--opacity",
        "binary",
        "--threshold",
        "0.4",
        "--level",
        "5",
        "--azimuth",
        "-30",
        "--elevation",
        "15",
        "--distance",
        "2",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let image = image::open(&out).unwrap().to_rgba8();
    assert_eq!(image.dimensions(), (160, 120));
    assert!(
        support::reference::coverage(&image) > 0.05,
        "the head is visible"
    );
}

#[test]
fn render_without_a_file_draws_the_embedded_sample() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png");
    let output = voxscope(&["render", "-o", out.to_str().unwrap(), "--size", "64x48"]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(support::reference::coverage(&image::open(&out).unwrap().to_rgba8()) > 0.02);
}

#[test]
fn a_volume_longer_than_the_octree_renders_streamed_and_the_octree_says_its_limit() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("long.png");
    let spec = "synthetic:gradient:1100x40x36";
    // The default renderer and bricks stream it from memory at full resolution.
    for renderer in [None, Some("bricks")] {
        let mut args = vec![
            "render",
            spec,
            "-o",
            out.to_str().unwrap(),
            "--size",
            "96x64",
        ];
        args.extend(renderer.map(|r| ["--renderer", r]).into_iter().flatten());
        let output = voxscope(&args);
        let err = stderr(&output);
        assert!(output.status.success(), "{err}");
        assert!(
            err.contains("beyond the voxel octree's 1024 a side"),
            "{err}"
        );
        assert!(err.contains("stream renderer, level 11/11"), "{err}");
        // A thin rod across the image.
        assert!(support::reference::coverage(&image::open(&out).unwrap().to_rgba8()) > 0.01);
    }
    // The paper's octree keeps its limit and says so, in one line.
    let output = voxscope(&[
        "render",
        spec,
        "--renderer",
        "octree",
        "-o",
        out.to_str().unwrap(),
    ]);
    let err = stderr(&output);
    assert!(!output.status.success());
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("supports up to 1024 voxels per axis")
            && err.contains("--renderer bricks or stream"),
        "{err}"
    );
    // info describes the volume and says why there is no octree.
    let output = voxscope(&["info", spec]);
    assert!(output.status.success(), "{}", stderr(&output));
    let table = String::from_utf8_lossy(&output.stdout);
    assert!(table.contains("dimensions   1100x40x36"), "{table}");
    assert!(
        table.contains("octree       none: 1100x40x36 is beyond"),
        "{table}"
    );
}

#[test]
fn a_near_mip_beyond_the_budget_completes_at_the_budget_within_a_few_frames() {
    // A near MIP of the CT under 4 MiB asks for about 245 bricks where 25 fit. The coarser
    // bricks drawn in place of the asked ones hold most of the atlas; a cut that counted them
    // as free asked for slots they held, and the view ended only when it stopped progressing
    // (45 frames on lavapipe); one that counts them completes once its bricks are in (13).
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("near-mip.png");
    let near_mip = |budget: &str| {
        voxscope(&[
            "render",
            "synthetic:ct:256",
            "--renderer",
            "stream",
            "--mode",
            "mip",
            "--distance",
            "0.6",
            "--gpu-memory",
            budget,
            "--max-wait",
            "60",
            "--size",
            "256x192",
            "-o",
            out.to_str().unwrap(),
        ])
    };
    let output = near_mip("4MiB");
    let err = stderr(&output);
    assert!(output.status.success(), "{err}");
    assert!(err.contains("complete at the budget after"), "{err}");
    let frames: u32 = err
        .split("complete at the budget after ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|n| n.parse().ok())
        .expect("the frames it took");
    assert!(frames <= 25, "{frames} frames: {err}");
    assert!(support::reference::coverage(&image::open(&out).unwrap().to_rgba8()) > 0.2);
    // It names the budget that holds the view at full detail, and that budget does.
    let holds = err
        .split("a GPU budget of ")
        .nth(1)
        .and_then(|rest| rest.split(" holds it all").next())
        .expect("the budget that holds it");
    let suggested = holds.replace(' ', "");
    let output = near_mip(&suggested);
    let err = stderr(&output);
    assert!(output.status.success(), "{err}");
    assert!(
        err.contains("; complete after") && !err.contains("budget-limited"),
        "{suggested}: {err}"
    );
}

#[test]
fn bad_input_exits_non_zero_with_one_line_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty.nrrd");
    std::fs::write(&empty, b"").unwrap();
    let mystery = dir.path().join("mystery.bin");
    std::fs::write(&mystery, b"neither a header nor magic bytes").unwrap();
    let cases: Vec<(Vec<String>, &str)> = vec![
        // The command line can read it as raw voxels, and says how (the app does not).
        (
            vec!["info".into(), mystery.display().to_string()],
            "or raw voxels with --raw WxHxD:TYPE",
        ),
        (
            vec!["info".into(), empty.display().to_string()],
            "file is empty",
        ),
        (
            vec!["info".into(), dir.path().display().to_string()],
            // Every kind of folder that opens is named, not only slices.
            "is a folder without slice images (.tif, .tiff, .png), DICOM files or a Zarr store",
        ),
        (
            vec!["info".into(), "synthetic:sphere:0".into()],
            "zero extent",
        ),
        (
            vec![
                "render".into(),
                empty.display().to_string(),
                "-o".into(),
                dir.path().join("o.png").display().to_string(),
            ],
            "file is empty",
        ),
    ];
    for (args, problem) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let output = voxscope(&args);
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(1), "{args:?}: {message}");
        assert_eq!(
            message.trim_end().lines().count(),
            1,
            "{args:?}: one line, got {message}"
        );
        assert!(message.contains(problem), "{args:?}: {message}");
        assert!(!message.contains("panicked"));
    }
    // The input is never overwritten.
    let input = dir.path().join("in.png");
    std::fs::write(&input, b"not a volume").unwrap();
    let output = voxscope(&[
        "render",
        input.to_str().unwrap(),
        "-o",
        input.to_str().unwrap(),
    ]);
    assert_eq!(output.status.code(), Some(1));
    assert!(stderr(&output).contains("refusing to overwrite"));
    assert_eq!(std::fs::read(&input).unwrap(), b"not a volume");
}

#[test]
fn bench_stream_reports_its_orbits_paced_and_the_uploads_scattered() {
    // A frame rate below 1 (but 0) is refused, and it paces only the streaming bench.
    for (options, named) in [
        (&["--stream", "--orbit-fps", "0.001"][..], "frame rate"),
        (&["--orbit-fps", "30"][..], "--stream"),
    ] {
        let mut args = vec!["bench", "synthetic:sphere:32"];
        args.extend_from_slice(options);
        let output = voxscope(&args);
        assert!(!output.status.success(), "{options:?}");
        assert!(
            stderr(&output).contains(named),
            "{options:?}: {}",
            stderr(&output)
        );
    }
    let output = voxscope(&[
        "bench",
        "synthetic:sphere:64",
        "--stream",
        "--size",
        "64x48",
        "--frames",
        "3",
        "--orbit-fps",
        "2",
        "--gpu-memory",
        "64MiB",
        "--atlas-zero",
        "shader",
        "--json",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let json: serde_json::Value = serde_json::from_slice(&output.stdout).expect("one JSON object");
    for key in [
        "first_image_s",
        "first_image_parts",
        "stopped_view",
        "near_stopped_views",
        "decode",
        "resident",
    ] {
        assert!(!json[key].is_null(), "missing {key}");
    }
    assert_eq!(json["options"]["uploads"], "Scatter");
    // The first image's parts add up to no more than it; the renderer is made within the
    // open.
    let parts = &json["first_image_parts"];
    let part = |name: &str| parts[name].as_f64().expect("a part's seconds");
    let summed = part("open_s") + part("finish_s") + part("first_frame_s");
    assert!(
        summed > 0.0 && summed <= json["first_image_s"].as_f64().unwrap(),
        "{parts}"
    );
    assert!(
        part("renderer_s") > 0.0 && part("renderer_s") <= part("open_s"),
        "{parts}"
    );
    // Resident frames are timed once the loaders are idle.
    let rows = json["resident"]["rows"].as_array().expect("resident rows");
    // At full detail, then at the default pixel LOD: two modes by three cameras each.
    let lod_scales: Vec<f64> = rows
        .iter()
        .map(|r| r["lod_scale"].as_f64().unwrap())
        .collect();
    assert_eq!(lod_scales, [[0.0; 6], [1.0; 6]].concat(), "{lod_scales:?}");
    for row in rows {
        assert!(row["walked_levels"].as_u64().unwrap() <= 2, "{row}");
        assert_eq!(row["loaders_busy"], 0, "{row}");
        let halves = row["stream_gpu_halves_ms"].as_array().expect("two halves");
        assert!(
            halves.len() == 2 && halves.iter().all(|h| h.as_f64().unwrap() > 0.0),
            "{row}"
        );
        // Each renderer warmed up before it was timed (on lavapipe, one batch of frames).
        let warm_up = row["warm_up_s"].as_array().expect("two warm-ups");
        assert!(
            warm_up.len() == 2 && warm_up.iter().all(|s| s.as_f64().unwrap() > 0.0),
            "{row}"
        );
    }
    let near: Vec<(f64, &str)> = json["near_stopped_views"]
        .as_array()
        .expect("near views")
        .iter()
        .map(|view| {
            assert_eq!(view["complete"], true, "{view}");
            (
                view["distance"].as_f64().unwrap(),
                view["mode"].as_str().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        near,
        [
            (0.6, "dvr-gray"),
            (0.6, "mip"),
            (1.0, "dvr-gray"),
            (1.0, "mip")
        ]
    );
    // Asked to zero its atlas with a shader, a Vulkan device does (lavapipe too).
    let zeroed = if json["backend"] == "Vulkan" {
        "Shader"
    } else {
        "Wgpu"
    };
    assert_eq!(json["options"]["atlas_zero"], zeroed, "{}", json["options"]);
    let orbits = json["orbits"].as_array().expect("orbits");
    assert_eq!(orbits.len(), 2, "medium and near");
    let mut dispatches = 0;
    for orbit in orbits {
        assert_eq!(orbit["paced_fps"], 2.0, "{orbit}");
        assert!(orbit["wall_ms"]["median"].as_f64().unwrap() > 0.0);
        // The first frame: its update, then its encoding and the wait for the GPU.
        let first = &orbit["first_frame_ms"];
        let part = |name: &str| first[name].as_f64().expect(name);
        assert!(
            part("update") > 0.0 && part("wall") >= part("update") + part("wait"),
            "{first}"
        );
        // The renderer's teardown after the turn, timed apart from the next one's frames.
        assert!(orbit["teardown_ms"].as_f64().unwrap() > 0.0, "{orbit}");
        // Three frames at two a second: a turn of at least 1.5 s, however fast the frames.
        let turn = orbit["turn_seconds"].as_f64().unwrap();
        assert!(turn >= 1.45, "{turn} s");
        // lavapipe writes the atlas's texels from a shader: one dispatch a frame that uploads.
        let parts = &orbit["counters"]["upload_parts"];
        assert_eq!(parts["queue_bricks"], 0, "{parts}");
        assert_eq!(
            parts["ring_copies"].as_u64().unwrap(),
            2 * parts["scatter_dispatches"].as_u64().unwrap(),
            "{parts}"
        );
        dispatches += parts["scatter_dispatches"].as_u64().unwrap();
    }
    assert!(dispatches > 0, "the orbits uploaded through the dispatch");
    // Where the scatter's staging would leave the atlas too small for the always-resident
    // levels and a view, the ring copies instead (and says so).
    let tight = voxscope(&[
        "bench",
        "synthetic:sphere:256",
        "--stream",
        "--size",
        "32x24",
        "--frames",
        "1",
        "--gpu-memory",
        "1200KiB",
        "--json",
    ]);
    assert!(tight.status.success(), "{}", stderr(&tight));
    let tight: serde_json::Value = serde_json::from_slice(&tight.stdout).expect("one JSON object");
    assert_eq!(tight["options"]["uploads"], "Copies");
    assert_eq!(tight["gpu_bytes"]["upload_staging"], 0);
    // The staging the dispatch reads counts in the GPU budget.
    assert!(json["gpu_bytes"]["upload_staging"].as_u64().unwrap() > 0);
    let total: u64 = json["gpu_bytes"]
        .as_object()
        .unwrap()
        .values()
        .map(|v| v.as_u64().unwrap())
        .sum();
    assert!(total <= 64 << 20, "{total} bytes within 64 MiB");
}

#[test]
fn bench_runs_briefly_on_any_device_and_reports_every_case() {
    let output = voxscope(&[
        "bench",
        "synthetic:sphere:32",
        "--size",
        "48x32",
        "--frames",
        "3",
        "--json",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let json: serde_json::Value = serde_json::from_slice(&output.stdout).expect("one JSON object");
    for key in [
        "adapter",
        "backend",
        "timing",
        "size",
        "results",
        "build_seconds",
        "recolor_ms",
        "gpu_bytes",
    ] {
        assert!(!json[key].is_null(), "missing {key}");
    }
    let results = json["results"].as_array().unwrap();
    assert_eq!(
        results.len(),
        36,
        "3 renderers × 4 modes (gray, binary, MIP, gray shaded) × 3 cameras"
    );
    for renderer in ["octree", "dense", "bricks"] {
        assert_eq!(
            results.iter().filter(|r| r["renderer"] == renderer).count(),
            12,
            "{renderer}"
        );
    }
    for row in results {
        for key in [
            "renderer",
            "mode",
            "camera",
            "median_ms",
            "p95_ms",
            "wall_ms_per_frame",
            "fps",
            "rays_per_s",
            "nodes_per_ray_avg",
            "nodes_per_ray_max",
            "rays_in_volume",
        ] {
            assert!(!row[key].is_null(), "row lacks {key}: {row}");
        }
        assert!(row["rays_in_volume"].as_f64().unwrap() >= 1.0, "{row}");
        let median = row["median_ms"].as_f64().unwrap();
        assert!(median > 0.0 && median <= row["p95_ms"].as_f64().unwrap());
        assert!(row["nodes_per_ray_avg"].as_f64().unwrap() >= 1.0);
    }
    for (renderer, buffer) in [
        ("octree", "nodes"),
        ("dense", "texture"),
        ("bricks", "atlas"),
        ("target", "texture"),
    ] {
        assert!(
            json["gpu_bytes"][renderer][buffer].as_u64().unwrap() > 0,
            "{renderer} {buffer}"
        );
    }
}

#[test]
fn ceilings_checks_each_kernel_and_reports_every_figure() {
    // Every kernel's output is checked against what it must compute before its rate is
    // reported, so a success here means all seven ran right on this device.
    let output = voxscope(&["ceilings", "--quick", "--json"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let json: serde_json::Value = serde_json::from_slice(&output.stdout).expect("one JSON object");
    for key in [
        "memory_bytes_per_s",
        "filtered_samples_per_s",
        "filtered_f16_samples_per_s",
        "texture_latency_ns",
        "buffer_latency_ns",
        "fma_flops_per_s",
        "store_only_invocations_per_s",
    ] {
        let value = json[key].as_f64().unwrap_or(f64::NAN);
        assert!(value.is_finite() && value > 0.0, "{key}: {value}");
    }
    for kernel in [
        "stream",
        "filtered",
        "texture_chain",
        "buffer_chain",
        "fma_rate",
        "store_only",
    ] {
        assert!(
            json["median_ms"][kernel].as_f64().unwrap() > 0.0,
            "{kernel}"
        );
    }
    assert_eq!(json["sizes"]["stream_bytes"], 1 << 20);
}

/// Without `XDG_RUNTIME_DIR` (ssh, cron, containers) a successful render prints nothing that
/// looks like an error: Mesa's device-select layer printed libwayland's `error:
/// XDG_RUNTIME_DIR is invalid or not set` twice.
#[test]
fn a_render_without_a_runtime_dir_prints_no_foreign_error() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("sphere.png");
    for runtime_dir in [None, Some("/nonexistent/voxscope-runtime")] {
        let mut command = Command::new(env!("CARGO_BIN_EXE_voxscope"));
        command
            .args(["render", "synthetic:sphere:32", "--size", "64x48", "-o"])
            .arg(&out)
            .env_remove("NODEVICE_SELECT");
        match runtime_dir {
            None => command.env_remove("XDG_RUNTIME_DIR"),
            Some(dir) => command.env("XDG_RUNTIME_DIR", dir),
        };
        let output = command.output().expect("the binary runs");
        let text = stderr(&output);
        assert!(output.status.success(), "{runtime_dir:?}: {text}");
        assert!(
            !text.contains("error"),
            "{runtime_dir:?}: a successful render printed an error: {text}"
        );
        assert!(out.exists());
    }
}

/// While bricks are on their way and none arrive, `render` draws nothing (it drew frame after
/// frame of the same image: 254 in 31 s): level 0 of a store never answers, the coarser levels
/// do, and `--max-wait 3` ends the render with a frame drawn for each arrival, not one a
/// millisecond.
#[test]
fn render_draws_no_frame_while_nothing_arrives() {
    use support::fault_server::{FaultPlan, FaultServer};
    let dir = tempfile::tempdir().expect("temp dir");
    let store = dir.path().join("ct.ome.zarr");
    let store_arg = store.to_str().expect("UTF-8");
    let convert = voxscope(&[
        "convert",
        "synthetic:ct:200x160x120",
        store_arg,
        "--chunk",
        "32",
        "--format",
        "0.4",
    ]);
    assert!(convert.status.success(), "convert: {}", stderr(&convert));
    let level0_chunk = |path: &str| {
        path.split_once(".ome.zarr/").is_some_and(|(_, key)| {
            key.starts_with("0/") && !support::damage::is_metadata(std::path::Path::new(key))
        })
    };
    let server = FaultServer::start(
        dir.path(),
        FaultPlan {
            silent: Some(level0_chunk),
            ..FaultPlan::default()
        },
    );
    let png = dir.path().join("waiting.png");
    let output = voxscope(&[
        "render",
        &server.url("ct.ome.zarr"),
        "--renderer",
        "stream",
        "--lod-scale",
        "0",
        "--size",
        "160x120",
        "--max-wait",
        "3",
        "-o",
        png.to_str().expect("UTF-8"),
    ]);
    let text = stderr(&output);
    assert!(png.exists(), "{text}");
    assert_eq!(
        output.status.code(),
        Some(3),
        "still coarse is incomplete: {text}"
    );
    let frames: u32 = text
        .split_once("(--max-wait) and ")
        .and_then(|(_, rest)| rest.split_once(" frames"))
        .and_then(|(count, _)| count.parse().ok())
        .unwrap_or_else(|| panic!("no frame count: {text}"));
    eprintln!("{frames} frames drawn: {text}");
    assert!(
        (1..=24).contains(&frames),
        "{frames} frames drawn in 3 s of waiting for bricks that never came: {text}"
    );
}

/// A file that names no unit gets none: `probe` said "mm" for an uncalibrated volume.
#[test]
fn probe_names_no_unit_where_the_file_names_none() {
    let output = voxscope(&["probe", "synthetic:sphere:16", "--at", "1,2,3"]);
    let text = String::from_utf8_lossy(&output.stdout).into_owned();
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(
        text.contains("position   (1.000, 2.000, 3.000) from the first voxel"),
        "{text}"
    );
    assert!(!text.contains("mm"), "{text}");
    let json = voxscope(&["probe", "synthetic:sphere:16", "--at", "1,2,3", "--json"]);
    let json = String::from_utf8_lossy(&json.stdout).into_owned();
    assert!(json.contains("\"position_unit\":null"), "{json}");
    // NIfTI's standard unit is the millimetre.
    let head = shared_data("mri-head-128x128x62.nii.gz");
    let output = voxscope(&["probe", head.to_str().expect("UTF-8"), "--at", "1,2,3"]);
    let text = String::from_utf8_lossy(&output.stdout).into_owned();
    assert!(text.contains(") mm from the first voxel"), "{text}");
}

#[test]
fn a_reader_that_goes_away_ends_the_output_quietly() {
    // `voxscope info X | head -1`: the pipe closes before the table is written.
    let fixture =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/n5/n5-viewer.n5");
    for args in [vec!["info"], vec!["info", "--json"]] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_voxscope"))
            .args(&args)
            .arg(&fixture)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
}

#[test]
fn a_folder_of_stores_names_them_rather_than_a_store_being_written() {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    for (folder, first) in [
        ("ome-zarr", "'channels9-v05-sharded.ome.zarr'"),
        ("n5", "'bdv.n5'"),
        ("precomputed", "'cseg-u32'"),
    ] {
        let out = voxscope(&["info", data.join(folder).to_str().unwrap()]);
        assert!(!out.status.success());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(
            stderr.contains("is a folder of stores, not one"),
            "{stderr}"
        );
        assert!(stderr.contains(first), "{stderr}");
        assert!(!stderr.contains("still being written"), "{stderr}");
    }
}
