"""`voxscope.open` of a NIfTI file, a DICOM folder, OME-Zarr stores (a folder, the tests'
loopback HTTP server and S3), N5 containers, precomputed volumes and Imaris files, their facts and levels read
as numpy arrays (checked against the fixtures' expected.json or raw voxels); `convert` of an
array and of a file, read back."""

import http.client
import json
import os
from pathlib import Path
from urllib.parse import urlparse

import numpy as np
import pytest

import voxscope
from conftest import FIXTURES, run_cli, shared_data

EXPECTED = json.loads((FIXTURES / "expected.json").read_text())["fixtures"]
GOLDEN = 0x9E3779B97F4A7C15


def checksum(values: np.ndarray) -> int:
    """expected.json's position-weighted checksum: Σ value × (index + 1) × GOLDEN mod 2⁶⁴."""
    flat = values.ravel().astype(np.int64).view(np.uint64)
    weights = (np.arange(1, flat.size + 1, dtype=np.uint64) * np.uint64(GOLDEN))
    with np.errstate(over="ignore"):
        return int(np.sum(flat * weights, dtype=np.uint64))


def check_level(values: np.ndarray, expected: dict) -> None:
    assert list(values.shape) == expected["shape"][-3:]
    volume = expected["volumes"][0] if len(expected["volumes"]) == 1 else None
    if volume is not None:
        assert int(values.astype(np.int64).sum()) == volume["sum"]
        assert (values.min(), values.max()) == (volume["min"], volume["max"])
        assert checksum(values) == int(volume["checksum"])


def test_a_nifti_file_opens_with_its_facts_and_voxels():
    volume = voxscope.open(shared_data("mri-head-128x128x62.nii.gz"))
    assert volume.format == "NIfTI-1"
    # Reordered to RAS as voxscope draws it: x 128, y 62, z 128 (voxel 2 × 3 × 2 mm).
    assert volume.shape == (128, 62, 128)
    assert volume.spacing == (2.0, 3.0, 2.0) and volume.unit == "mm"
    assert volume.dtype == np.int16 and volume.levels == [volume.shape]
    assert volume.channels == ["channel 0"] and volume.time_points == 1
    voxels = volume.read()
    assert voxels.shape == volume.shape and voxels.dtype == np.int16
    assert (voxels.min(), voxels.max()) == (0, 255)
    assert voxels.flags.c_contiguous
    with pytest.raises(ValueError, match="no level 1"):
        volume.read(1)


def test_a_dicom_folder_opens_as_its_series():
    folder = shared_data("brain-pd-dicom")
    volume = voxscope.open(folder)
    facts = json.loads(run_cli("info", folder, "--json").stdout)["volume"]
    assert volume.format == "DICOM" == facts["format"]
    assert volume.shape == (20, 256, 256) == tuple(facts["dims"][::-1])
    assert volume.spacing == tuple(facts["spacing"][::-1])
    assert volume.dtype == np.int16
    voxels = volume.read()
    assert voxels.shape == (20, 256, 256)
    assert [voxels.min(), voxels.max()] == facts["value_range"]
    image = voxscope.render(volume, size=(64, 48))
    assert image.shape == (48, 64, 4) and image[..., :3].max() > 0


def test_an_imaris_file_opens_its_channels_levels_and_placement():
    volume = voxscope.open(DATA / "imaris" / "cells.ims", channel=1)
    assert volume.format == "Imaris"
    assert volume.levels == [(7, 9, 10), (4, 5, 5)]
    assert volume.spacing == (2.0, 0.5, 0.5) and volume.unit == "micrometer"
    assert volume.channels == ["GFP", "tdTomato"]
    expected = np.fromfile(DATA / "codecs" / "voxels.u16le", dtype="<u2").reshape(7, 9, 10)
    assert np.array_equal(volume.read(0), expected + 1000)


@pytest.mark.parametrize("fixture", ["head-v04-zstd.ome.zarr", "head-v05-sharded-blosc-zstd.ome.zarr", "nuclei-v04-blosc-lz4.ome.zarr"])
def test_an_ome_zarr_folder_opens_level_by_level(fixture):
    volume = voxscope.open(FIXTURES / fixture)
    expected = EXPECTED[fixture]["levels"]
    assert volume.format == "OME-Zarr"
    assert volume.levels == [tuple(level["shape"][-3:]) for level in expected]
    assert volume.dtype == np.dtype(expected[0]["dtype"])
    for level, facts in enumerate(expected):
        check_level(volume.read(level), facts)


def test_channels_and_time_points_of_a_store():
    volume = voxscope.open(FIXTURES / "tczyx-v04.ome.zarr")
    expected = EXPECTED["tczyx-v04.ome.zarr"]["levels"][0]
    assert volume.time_points == 2 and len(volume.channels) == 2
    for entry in expected["volumes"]:
        t, c = entry["index"]
        values = volume.read(0, channel=c, time=t)
        assert int(values.astype(np.int64).sum()) == entry["sum"]
        assert checksum(values) == int(entry["checksum"])
    picked = voxscope.open(FIXTURES / "tczyx-v04.ome.zarr", channel=1, time=1)
    assert picked.selected == (1, 1)


def test_an_ome_zarr_store_over_http_reads_as_its_folder(http_fixtures):
    for fixture in ["head-v05-sharded-blosc-zstd.ome.zarr", "nuclei-v04-blosc-lz4.ome.zarr"]:
        remote = voxscope.open(f"{http_fixtures}/{fixture}")
        local = voxscope.open(FIXTURES / fixture)
        assert remote.levels == local.levels and remote.dtype == local.dtype
        for level in range(len(local.levels)):
            assert np.array_equal(remote.read(level), local.read(level))
        assert np.array_equal(
            voxscope.render(remote, size=(64, 48)), voxscope.render(local, size=(64, 48))
        )


def s3_put(endpoint: str, path: str, body: bytes = b"") -> None:
    url = urlparse(endpoint)
    connection = http.client.HTTPConnection(url.hostname, url.port, timeout=30)
    connection.request("PUT", path, body=body)
    answer = connection.getresponse()
    answer.read()
    assert answer.status in (200, 201), f"PUT {path}: {answer.status}"


def test_an_ome_zarr_store_on_s3_reads_as_its_folder(s3_endpoint, monkeypatch):
    bucket = f"voxscope-python-{os.getpid()}"
    s3_put(s3_endpoint, f"/{bucket}")
    fixture = "head-v04-zstd.ome.zarr"
    root = FIXTURES / fixture
    for file in root.rglob("*"):
        if file.is_file():
            s3_put(s3_endpoint, f"/{bucket}/data/{fixture}/{file.relative_to(root).as_posix()}", file.read_bytes())
    for name, value in {
        "AWS_ENDPOINT_URL": s3_endpoint, "AWS_ACCESS_KEY_ID": "testing",
        "AWS_SECRET_ACCESS_KEY": "testing-secret", "AWS_REGION": "us-east-1",
        "AWS_SHARED_CREDENTIALS_FILE": "/nonexistent", "AWS_CONFIG_FILE": "/nonexistent",
    }.items():
        monkeypatch.setenv(name, value)
    remote = voxscope.open(f"s3://{bucket}/data/{fixture}")
    local = voxscope.open(root)
    assert remote.levels == local.levels
    for level in range(len(local.levels)):
        assert np.array_equal(remote.read(level), local.read(level))
    assert np.array_equal(
        voxscope.render(remote, size=(64, 48), renderer="stream"),
        voxscope.render(local, size=(64, 48), renderer="stream"),
    )
    with pytest.raises(voxscope.LoadError, match="missing.ome.zarr") as error:
        voxscope.open(f"s3://{bucket}/data/missing.ome.zarr")
    assert "testing-secret" not in str(error.value)


def test_convert_writes_an_array_and_a_file_as_ome_zarr(tmp_path, head):
    voxels, spacing = head
    levels = voxscope.convert(voxels, tmp_path / "head.ome.zarr", spacing=spacing, chunk=32)
    assert levels[0] == voxels.shape and len(levels) > 1
    back = voxscope.open(tmp_path / "head.ome.zarr")
    assert back.levels == levels and back.spacing == pytest.approx(spacing)
    assert np.array_equal(back.read(), voxels)
    # A file, as `voxscope convert` writes it: the same voxels, OME-Zarr 0.5 sharded.
    nifti = shared_data("mri-head-128x128x62.nii.gz")
    voxscope.convert(nifti, tmp_path / "v05.ome.zarr", format="0.5", chunk=32, shard=2)
    run_cli("convert", nifti, tmp_path / "cli.ome.zarr", "--format", "0.5", "--chunk", "32", "--shard", "2")
    ours, theirs = voxscope.open(tmp_path / "v05.ome.zarr"), voxscope.open(tmp_path / "cli.ome.zarr")
    assert ours.levels == theirs.levels
    for level in range(len(ours.levels)):
        assert np.array_equal(ours.read(level), theirs.read(level))
    with pytest.raises(voxscope.LoadError, match="exists"):
        voxscope.convert(voxels, tmp_path / "head.ome.zarr")
    # A Volume converts as it was opened: headerless voxels with their layout and spacing.
    raw = tmp_path / "head.raw"
    voxels.tofile(raw)
    z, y, x = voxels.shape
    opened = voxscope.open(raw, raw=f"{x}x{y}x{z}:i16", spacing=spacing)
    voxscope.convert(opened, tmp_path / "raw.ome.zarr")
    again = voxscope.open(tmp_path / "raw.ome.zarr")
    assert again.spacing == pytest.approx(spacing)
    assert np.array_equal(again.read(), voxels)


def test_python_m_voxscope_is_the_command_line(tmp_path):
    import subprocess
    import sys

    nifti = shared_data("mri-head-128x128x62.nii.gz")
    ours = subprocess.run([sys.executable, "-m", "voxscope", "info", str(nifti), "--json"], capture_output=True, text=True)
    theirs = run_cli("info", nifti, "--json")
    assert ours.returncode == 0, ours.stderr
    # The volume and the transfer function it opens with (the octree's part holds times).
    facts = lambda text: {k: json.loads(text)[k] for k in ("volume", "transfer")}
    assert facts(ours.stdout) == facts(theirs.stdout)
    failed = subprocess.run([sys.executable, "-m", "voxscope", "info", str(tmp_path / "none.nii")], capture_output=True, text=True)
    assert failed.returncode == 1
    assert failed.stderr.strip() == run_cli("info", tmp_path / "none.nii", check=False).stderr.strip()


DATA = FIXTURES.parent


@pytest.mark.parametrize(
    "store, kind, values",
    [
        ("n5/n5-viewer.n5", "N5", "codecs/voxels.u16le"),
        ("n5/edge-lz4.n5", "N5", "codecs/voxels.u16le"),
        ("precomputed/raw-u16", "precomputed", "codecs/voxels.u16le"),
        ("precomputed/sharded-cseg-u64", "precomputed", "precomputed/labels.u64le"),
        ("imaris/cells.ims", "Imaris", "codecs/voxels.u16le"),
    ],
)
def test_n5_precomputed_and_imaris_open_as_stores(store, kind, values):
    volume = voxscope.open(DATA / store)
    assert volume.format == kind
    assert volume.levels[0] == (7, 9, 10)
    dtype = "<u8" if values.endswith("u64le") else "<u2"
    expected = np.fromfile(DATA / values, dtype=dtype).reshape(7, 9, 10)
    assert np.array_equal(volume.read(0).astype(np.float64), expected.astype(np.float64))
    image = voxscope.render(volume, size=(64, 48))
    assert image.shape == (48, 64, 4) and image[..., :3].max() > 0
