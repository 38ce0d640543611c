//! Zarr stores in S3, on loopback only: an S3-compatible server (moto: `VOXSCOPE_TEST_S3`,
//! started by `.ci/run`, else a `moto_server` on PATH started here) holds a converted volume,
//! read and rendered through the real binary equal to its folder, signed and anonymous; the
//! S3 endpoint's variable is trimmed and checked before object_store sees it.

mod support;

use std::io::Write;
use std::net::TcpListener;
use std::path::Path;
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn voxscope(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_voxscope"));
    command.args(args);
    for (name, value) in env {
        command.env(name, value);
    }
    command.output().expect("the binary runs")
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// Panics (with the count of differing pixels, not the images) unless `a` and `b` are equal.
fn assert_same_image(a: &image::RgbaImage, b: &image::RgbaImage, what: &str) {
    assert_eq!(a.dimensions(), b.dimensions(), "{what}: sizes differ");
    let differing = a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count();
    assert_eq!(differing, 0, "{what}: {differing} pixels differ");
}

/// The one line of a failed command, checked for the URL and against `secret`.
fn one_line_error(out: &Output, url_shown: &str, secret: &str) -> String {
    assert!(!out.status.success(), "it should have failed");
    let text = stderr(out);
    let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "not one line: {text}");
    assert!(lines[0].contains(url_shown), "the URL is not named: {text}");
    assert!(!text.contains(secret), "a secret is shown: {text}");
    lines[0].to_owned()
}

/// The S3 endpoint to test against: `VOXSCOPE_TEST_S3` (set by `.ci/run`, which starts moto
/// on 127.0.0.1). Outside CI, a `moto_server` on PATH is started here; without either the
/// test fails with what to do (it never skips).
fn s3_endpoint() -> (String, Option<Moto>) {
    if let Ok(endpoint) = std::env::var("VOXSCOPE_TEST_S3") {
        return (endpoint, None);
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "VOXSCOPE_TEST_S3 is not set under CI: .ci/run must start the S3 server (moto) and export it"
    );
    let port = {
        let probe = TcpListener::bind("127.0.0.1:0").unwrap();
        probe.local_addr().unwrap().port()
    };
    let child = Command::new("moto_server")
        .args(["-H", "127.0.0.1", "-p", &port.to_string()])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap_or_else(|e| {
            panic!(
                "no S3 server: set VOXSCOPE_TEST_S3=http://HOST:PORT or install moto \
                 (pip install 'moto[server]'): {e}"
            )
        });
    let child = Moto(child);
    let started = Instant::now();
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(
            started.elapsed() < Duration::from_secs(30),
            "moto_server did not start"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    (format!("http://127.0.0.1:{port}"), Some(child))
}

/// A moto server this test started; stopped when dropped (also when the test fails).
struct Moto(std::process::Child);

impl Drop for Moto {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A raw request to the S3 server (moto accepts unsigned ones): bucket creation.
fn s3_request(endpoint: &str, method: &str, path: &str) -> String {
    let address = endpoint.trim_start_matches("http://");
    let mut stream = std::net::TcpStream::connect(address).expect("the S3 server answers");
    write!(
        stream,
        "{method} {path} HTTP/1.1\r\nHost: {address}\r\nContent-Length: 0\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut answer = String::new();
    std::io::Read::read_to_string(&mut stream, &mut answer).unwrap();
    answer
}

/// Uploads the files under `root` to `bucket` under `prefix`, readable by anyone if `public`.
fn upload(endpoint: &str, bucket: &str, root: &Path, prefix: &str, public: bool) {
    let acl = if public {
        "x-amz-acl: public-read\r\n"
    } else {
        ""
    };
    let mut files = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                files.push(path);
            }
        }
    }
    for file in files {
        let key = file
            .strip_prefix(root)
            .unwrap()
            .to_str()
            .unwrap()
            .replace('\\', "/");
        let body = std::fs::read(&file).unwrap();
        let address = endpoint.trim_start_matches("http://");
        let mut stream = std::net::TcpStream::connect(address).unwrap();
        write!(
            stream,
            "PUT /{bucket}/{prefix}/{key} HTTP/1.1\r\nHost: {address}\r\n{acl}Content-Length: {}\r\nConnection: close\r\n\r\n",
            body.len()
        )
        .unwrap();
        stream.write_all(&body).unwrap();
        let mut answer = String::new();
        std::io::Read::read_to_string(&mut stream, &mut answer).unwrap();
        assert!(
            answer.starts_with("HTTP/1.1 200"),
            "uploading {key}: {answer}"
        );
    }
}

#[test]
fn a_converted_volume_renders_from_s3_equal_to_its_folder() {
    let (endpoint, _moto) = s3_endpoint();
    let dir = tempfile::tempdir().unwrap();
    let converted = dir.path().join("shells.ome.zarr");
    let out = voxscope(
        &[
            "convert",
            "synthetic:shells:80",
            converted.to_str().unwrap(),
            "--format",
            "0.5",
            "--chunk",
            "16",
        ],
        &[],
    );
    assert!(out.status.success(), "convert: {}", stderr(&out));
    let bucket = format!("voxscope-{}", std::process::id());
    let answer = s3_request(&endpoint, "PUT", &format!("/{bucket}"));
    assert!(
        answer.starts_with("HTTP/1.1 200"),
        "creating the bucket: {answer}"
    );
    upload(
        &endpoint,
        &bucket,
        &converted,
        "data/shells.ome.zarr",
        false,
    );
    upload(
        &endpoint,
        &bucket,
        &converted,
        "public/shells.ome.zarr",
        true,
    );
    let url = format!("s3://{bucket}/data/shells.ome.zarr");
    let public_url = format!("s3://{bucket}/public/shells.ome.zarr");
    let secret = "wJalrXUtnFEMI-K7MDENG-voxscope-test";
    let signed = [
        ("AWS_ENDPOINT_URL", endpoint.as_str()),
        ("AWS_ACCESS_KEY_ID", "testing"),
        ("AWS_SECRET_ACCESS_KEY", secret),
        ("AWS_REGION", "us-east-1"),
        // No shared files of the machine's user.
        ("AWS_SHARED_CREDENTIALS_FILE", "/nonexistent"),
        ("AWS_CONFIG_FILE", "/nonexistent"),
    ];
    let anonymous = [
        ("AWS_ENDPOINT_URL", endpoint.as_str()),
        ("AWS_SHARED_CREDENTIALS_FILE", "/nonexistent"),
        ("AWS_CONFIG_FILE", "/nonexistent"),
    ];
    let local_png = dir.path().join("local.png");
    let out = voxscope(
        &[
            "render",
            converted.to_str().unwrap(),
            "--size",
            "160x120",
            "-o",
            local_png.to_str().unwrap(),
        ],
        &[],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let local = image::open(&local_png).unwrap().to_rgba8();
    assert!(support::reference::coverage(&local) > 0.02);
    for (what, url, env) in [
        ("signed", &url, &signed[..]),
        ("anonymous", &public_url, &anonymous[..]),
    ] {
        for renderer in ["octree", "stream"] {
            let png = dir.path().join(format!("s3-{what}-{renderer}.png"));
            let out = voxscope(
                &[
                    "render",
                    url,
                    "--renderer",
                    renderer,
                    "--size",
                    "160x120",
                    "-o",
                    png.to_str().unwrap(),
                ],
                env,
            );
            assert!(out.status.success(), "{what} {renderer}: {}", stderr(&out));
            assert!(!stderr(&out).contains(secret));
            let image = image::open(&png).unwrap().to_rgba8();
            if renderer == "octree" {
                assert_same_image(&image, &local, &format!("{what}: S3 against the folder"));
            } else {
                assert!(support::reference::coverage(&image) > 0.02, "{what}: empty");
            }
        }
    }
    let info = voxscope(&["info", "--json", &url], &signed);
    assert!(info.status.success(), "{}", stderr(&info));
    assert!(!String::from_utf8_lossy(&info.stdout).contains(secret));
    // Without credentials the private copy is refused, in one line that says so.
    let line = one_line_error(&voxscope(&["info", &url], &anonymous), &url, secret);
    assert!(line.contains("access denied (HTTP 403)"), "{line}");
    let missing = format!("s3://{bucket}/data/missing.ome.zarr");
    let line = one_line_error(&voxscope(&["info", &missing], &signed), &missing, secret);
    assert!(line.contains("is not a Zarr store"), "{line}");
    // A bucket that is not there is said so (not "not a Zarr store").
    let nowhere = format!("s3://voxscope-none-{}/cells.ome.zarr", std::process::id());
    let line = one_line_error(&voxscope(&["info", &nowhere], &signed), &nowhere, secret);
    assert!(
        line.contains(&format!(
            "the bucket 'voxscope-none-{}' does not exist",
            std::process::id()
        )),
        "{line}"
    );
}

/// `voxscope ARGS` with no S3 endpoint but what `env` gives (none of the machine's endpoint
/// variables, no shared files of its user) and `env`.
fn with_endpoint(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_voxscope"));
    command.args(args);
    for name in ["AWS_ENDPOINT_URL_S3", "AWS_ENDPOINT_URL", "AWS_ENDPOINT"] {
        command.env_remove(name);
    }
    command
        .env("AWS_SHARED_CREDENTIALS_FILE", "/nonexistent")
        .env("AWS_CONFIG_FILE", "/nonexistent");
    for (name, value) in env {
        command.env(name, value);
    }
    command.output().expect("the binary runs")
}

/// Issue 57: an S3 endpoint with whitespace around it (a CRLF env file's CR) made object_store
/// panic three times (an invalid request URI) and an endpoint's query went into every
/// request's path. Whitespace around it is trimmed, and the store read through it; one with
/// whitespace inside, a query, a fragment, another scheme or no host is one line naming where
/// it was given and what is wrong, never a panic.
#[test]
fn an_s3_endpoint_is_trimmed_and_a_bad_one_is_one_line_naming_its_variable() {
    let url = "s3://bucket/x.ome.zarr";
    let config = tempfile::NamedTempFile::new().expect("a file");
    std::fs::write(
        config.path(),
        "[default]\r\nendpoint_url = http://127.0.0.1:9/?region=x\r\n",
    )
    .expect("the config file");
    let config_path = config.path().to_str().expect("a UTF-8 path");
    for (variable, endpoint, problem) in [
        ("AWS_ENDPOINT_URL", "http://127.0.0.1:9/?x=1", "has a query"),
        (
            "AWS_ENDPOINT_URL",
            "http://127.0.0.1:9/#top",
            "has a fragment",
        ),
        (
            "AWS_ENDPOINT_URL",
            "http://127.0.0.1 :9",
            "holds a space inside",
        ),
        (
            "AWS_ENDPOINT_URL",
            "http://127.0.0.1:9/a\r\nb",
            "holds the character",
        ),
        (
            "AWS_ENDPOINT_URL",
            "ftp://127.0.0.1:9",
            "is not an http:// or https:// URL",
        ),
        (
            "AWS_ENDPOINT_URL",
            "127.0.0.1:9",
            "is not an http:// or https:// URL",
        ),
        ("AWS_ENDPOINT_URL", " http:// \r\n", "is not a valid URL"),
        (
            "AWS_ENDPOINT",
            "http://127.0.0.1:9/a b",
            "holds a space inside",
        ),
        (
            "AWS_ENDPOINT_URL_S3",
            "s3://bucket",
            "is not an http:// or https:// URL",
        ),
        ("AWS_CONFIG_FILE", config_path, "has a query"),
    ] {
        let out = with_endpoint(&["info", url], &[(variable, endpoint)]);
        let text = stderr(&out);
        assert!(
            !text.contains("panicked"),
            "{variable}={endpoint:?}: {text}"
        );
        let line = one_line_error(&out, url, "\u{0}");
        let source = if variable == "AWS_CONFIG_FILE" {
            format!("(endpoint_url of [default] in {config_path})")
        } else {
            format!("({variable})")
        };
        assert!(
            line.contains(&format!("its S3 endpoint {source} ")) && line.contains(problem),
            "{variable}={endpoint:?}: {line}"
        );
    }

    // Whitespace around a real server's endpoint is not part of it.
    let (endpoint, _moto) = s3_endpoint();
    let dir = tempfile::tempdir().unwrap();
    let converted = dir.path().join("shells.ome.zarr");
    let out = voxscope(
        &[
            "convert",
            "synthetic:shells:48",
            converted.to_str().unwrap(),
            "--chunk",
            "16",
        ],
        &[],
    );
    assert!(out.status.success(), "convert: {}", stderr(&out));
    let bucket = format!("voxscope-endpoint-{}", std::process::id());
    let answer = s3_request(&endpoint, "PUT", &format!("/{bucket}"));
    assert!(
        answer.starts_with("HTTP/1.1 200"),
        "creating the bucket: {answer}"
    );
    upload(&endpoint, &bucket, &converted, "shells.ome.zarr", false);
    let url = format!("s3://{bucket}/shells.ome.zarr");
    for padded in [
        format!("{endpoint} "),
        format!("{endpoint}\r\n"),
        format!(" \t{endpoint}/\r"),
    ] {
        let out = with_endpoint(
            &["info", "--json", &url],
            &[
                ("AWS_ENDPOINT_URL", padded.as_str()),
                ("AWS_ACCESS_KEY_ID", "testing"),
                ("AWS_SECRET_ACCESS_KEY", "testing-secret"),
                ("AWS_REGION", "us-east-1"),
            ],
        );
        let text = stderr(&out);
        assert!(out.status.success(), "{padded:?}: {text}");
        assert!(!text.contains("panicked"), "{padded:?}: {text}");
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
        let levels = json["pyramid"]["levels"].as_array().map_or(0, Vec::len);
        assert!(levels >= 1, "{padded:?}: {json}");
    }
}

#[test]
fn an_n5_container_renders_from_s3_equal_to_its_folder() {
    let (endpoint, _moto) = s3_endpoint();
    let dir = tempfile::tempdir().unwrap();
    let folder = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/n5/n5-viewer.n5");
    let bucket = format!("voxscope-n5-{}", std::process::id());
    let answer = s3_request(&endpoint, "PUT", &format!("/{bucket}"));
    assert!(
        answer.starts_with("HTTP/1.1 200"),
        "creating the bucket: {answer}"
    );
    upload(&endpoint, &bucket, &folder, "private/cells.n5", false);
    upload(&endpoint, &bucket, &folder, "public/cells.n5", true);
    let signed = [
        ("AWS_ENDPOINT_URL", endpoint.as_str()),
        ("AWS_ACCESS_KEY_ID", "testing"),
        ("AWS_SECRET_ACCESS_KEY", "testing-secret"),
        ("AWS_REGION", "us-east-1"),
        ("AWS_SHARED_CREDENTIALS_FILE", "/nonexistent"),
        ("AWS_CONFIG_FILE", "/nonexistent"),
    ];
    // Anonymous: what is missing (the Zarr documents looked for first) is denied, not absent.
    let anonymous = [
        ("AWS_ENDPOINT_URL", endpoint.as_str()),
        ("AWS_SHARED_CREDENTIALS_FILE", "/nonexistent"),
        ("AWS_CONFIG_FILE", "/nonexistent"),
    ];
    let render = |spec: &str, env: &[(&str, &str)], name: &str| {
        let png = dir.path().join(name);
        let out = voxscope(
            &[
                "render",
                spec,
                "--size",
                "96x72",
                "--window",
                "0:65535",
                "-o",
                png.to_str().unwrap(),
            ],
            env,
        );
        assert!(out.status.success(), "{spec}: {}", stderr(&out));
        image::open(&png).unwrap().to_rgba8()
    };
    let local = render(folder.to_str().unwrap(), &[], "local.png");
    assert!(support::reference::coverage(&local) > 0.02);
    for (what, path, env) in [
        ("signed", "private", &signed[..]),
        ("anonymous", "public", &anonymous[..]),
    ] {
        let url = format!("s3://{bucket}/{path}/cells.n5");
        let image = render(&url, env, &format!("{what}.png"));
        assert_same_image(&image, &local, &format!("{what}: S3 against the folder"));
        let info = voxscope(&["info", &url], env);
        let text = String::from_utf8_lossy(&info.stdout);
        assert!(
            text.contains("N5 2.5.1") && text.contains("n5 gzip"),
            "{what}: {text}"
        );
    }
}
