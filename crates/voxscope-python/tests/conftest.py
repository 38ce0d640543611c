"""What the Python module's tests share: where the repository, `../shared/data` and the
command line's binary are, the servers the remote tests read from (a loopback HTTP server of
the tests' own; S3 at VOXSCOPE_TEST_S3, which .ci/run starts, else a moto_server on PATH),
PSNR, and a folder the tests' images are written to so that a person can look at them.

Run from the repository root after building the module (`maturin develop` or `pip install .`)
and the binary (`cargo build`): `WGPU_BACKEND=vulkan pytest crates/voxscope-python/tests`.
Nothing here skips: a missing binary, data folder, GPU or server fails the test that needs it.
"""

import functools
import http.server
import os
import socket
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

REPO = Path(__file__).resolve().parents[3]
SHARED = REPO.parent / "shared" / "data"
FIXTURES = REPO / "tests" / "data" / "ome-zarr"


def shared_data(name: str) -> Path:
    """A real volume of ../shared/data (beside the checkout, in CI too)."""
    path = SHARED / name
    assert path.exists(), f"{path} is missing: ../shared/data must be beside the checkout"
    return path


def cli_binary() -> Path:
    """The command line's binary: VOXSCOPE_CLI, else target/debug/voxscope (`cargo build`)."""
    path = Path(os.environ.get("VOXSCOPE_CLI") or REPO / "target" / "debug" / "voxscope")
    assert path.exists(), f"{path} is missing: build it (cargo build) or set VOXSCOPE_CLI"
    return path


def run_cli(*args, check: bool = True) -> subprocess.CompletedProcess:
    """Runs the command line's binary with `args`."""
    result = subprocess.run(
        [str(cli_binary()), *map(str, args)], capture_output=True, text=True, timeout=600
    )
    if check:
        assert result.returncode == 0, f"voxscope {args} failed:\n{result.stderr}"
    return result


def cli_render(raw: Path, shape_zyx, dtype: str, spacing_zyx, out: Path, *options) -> np.ndarray:
    """The command line's render of headerless voxels `raw` (C order (z, y, x)), as RGBA."""
    z, y, x = shape_zyx
    sz, sy, sx = spacing_zyx
    run_cli(
        "render", raw, "--raw", f"{x}x{y}x{z}:{dtype}", f"--spacing={sx},{sy},{sz}", "-o", out,
        *options,
    )
    return np.asarray(Image.open(out).convert("RGBA"))


RAW_TYPES = {
    "uint8": "u8", "int8": "i8", "uint16": "u16", "int16": "i16",
    "uint32": "u32", "int32": "i32", "float32": "f32", "float64": "f64",
}


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """PSNR in dB of two RGBA images (infinite when equal)."""
    assert a.shape == b.shape, f"{a.shape} != {b.shape}"
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    return float("inf") if mse == 0 else 10 * np.log10(255.0**2 / mse)


def lit(image: np.ndarray) -> float:
    """The share of pixels brighter than black."""
    return float((image[..., :3].max(axis=2) > 8).mean())


@pytest.fixture(scope="session")
def images() -> Path:
    """Where the tests write their pictures (looked at by a person): target/pytest-images."""
    folder = REPO / "target" / "pytest-images"
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def save(folder: Path, name: str, image: np.ndarray) -> None:
    Image.fromarray(np.ascontiguousarray(image)).save(folder / f"{name}.png")


@pytest.fixture(scope="session")
def head():
    """The small real T1 head (ITK's example) as voxscope reads it: (z, y, x) int16, spacing."""
    import voxscope

    volume = voxscope.open(shared_data("mri-head-128x128x62.nii.gz"))
    return volume.read(), volume.spacing


class _RangeHandler(http.server.SimpleHTTPRequestHandler):
    """Files with byte ranges (`Range: bytes=A-B`, `A-`, `-N`), as object stores serve them:
    a sharded store reads its chunks as ranges of a shard."""

    def log_message(self, *args):
        pass

    def do_GET(self):
        wanted = self.headers.get("Range")
        path = Path(self.translate_path(self.path))
        if not wanted or not path.is_file():
            return super().do_GET()
        data = path.read_bytes()
        first, _, last = wanted.removeprefix("bytes=").partition("-")
        if first == "":
            start, end = max(len(data) - int(last), 0), len(data) - 1
        else:
            start, end = int(first), min(int(last) if last else len(data) - 1, len(data) - 1)
        if start > end or start >= len(data):
            self.send_response(416)
            self.send_header("Content-Range", f"bytes */{len(data)}")
            self.end_headers()
            return
        self.send_response(206)
        self.send_header("Content-Range", f"bytes {start}-{end}/{len(data)}")
        self.send_header("Content-Length", str(end - start + 1))
        self.end_headers()
        self.wfile.write(data[start : end + 1])


@pytest.fixture(scope="session")
def http_fixtures():
    """A loopback HTTP server of tests/data/ome-zarr (with byte ranges), stopped after the
    session: its URL."""
    handler = functools.partial(_RangeHandler, directory=str(FIXTURES))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


@pytest.fixture(scope="session")
def s3_endpoint():
    """An S3 server on 127.0.0.1: VOXSCOPE_TEST_S3 (.ci/run starts moto), else a moto_server
    from PATH started here (stopped after); neither fails, and under CI=true the variable is
    required."""
    endpoint = os.environ.get("VOXSCOPE_TEST_S3")
    if endpoint:
        yield endpoint
        return
    assert os.environ.get("CI") != "true", "VOXSCOPE_TEST_S3 is not set under CI: .ci/run must start moto"
    probe = socket.socket()
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    try:
        process = subprocess.Popen(
            ["moto_server", "-H", "127.0.0.1", "-p", str(port)],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )
    except FileNotFoundError:
        pytest.fail("no S3 server: set VOXSCOPE_TEST_S3=http://HOST:PORT or install moto (pip install 'moto[server]')")
    try:
        for _ in range(100):
            try:
                socket.create_connection(("127.0.0.1", port), 1).close()
                break
            except OSError:
                time.sleep(0.1)
        else:
            pytest.fail("moto_server did not start")
        yield f"http://127.0.0.1:{port}"
    finally:
        process.terminate()
        process.wait(10)
