"""Writes the N5 fixtures of crates/voxscope-volume/tests/n5.rs with the reference
implementations: tensorstore's `n5` driver and zarr-python 2's `N5Store`.

Run from the repository root:

    python3 -m venv /tmp/n5py && /tmp/n5py/bin/pip install tensorstore 'zarr<3' numpy lz4
    /tmp/n5py/bin/python tests/data/n5/make_fixtures.py

Every dataset holds the voxels of tests/data/codecs/voxels.u16le (10 x 9 x 7, x y z, u16)
in blocks of 6 x 5 x 4, so every dataset has blocks at its far edges:
- `tensorstore-<compression>.n5`: one dataset per compression tensorstore writes (raw, gzip,
  gzip with zlib, bzip2, xz, zstd, blosc); tensorstore writes edge blocks whole.
- `zarr2-<compression>.n5`: zarr-python 2's N5 store (gzip, bzip2, xz, blosc).
- `edge-raw.n5` and `edge-lz4.n5`: blocks written as Java's N5 writes them, here by this
  script (no Python N5 writer has them): edge blocks cut to the dataset's extent, and lz4 in
  lz4-java's LZ4Block framing (`lz4.block` for the LZ4 blocks, `xxhash` not needed: readers
  do not check the checksum, voxscope included).
- `n5-viewer.n5`: a group with n5-viewer's `scales` and `pixelResolution` over `s0` (the
  voxels) and `s1` (their 2 x 2 x 2 means, rounded down, in `s1.u16le`), written by
  tensorstore.
- `cosem.n5`: the same levels under cosem's `multiscales` with a `transform` per level.
- `bdv.n5`: the same levels as BigDataViewer lays them out (`setup0/timepoint0/s0`), with a
  second setup that holds the voxels plus 1000.

versions.json records the versions used.
"""

import json
import shutil
import struct
from importlib.metadata import version
from pathlib import Path

import lz4.block
import numpy as np
import tensorstore as ts
import zarr
import numcodecs
from zarr.n5 import N5Store

HERE = Path(__file__).resolve().parent
VOXELS = HERE.parent / "codecs" / "voxels.u16le"
DIMS = [10, 9, 7]  # x, y, z (N5's order)
BLOCK = [6, 5, 4]


def voxels() -> np.ndarray:
    """The voxels as (z, y, x), x fastest."""
    return np.fromfile(VOXELS, dtype="<u2").reshape(DIMS[::-1])


def halved(values: np.ndarray) -> np.ndarray:
    """2 x 2 x 2 means (edges padded by repetition), rounded down."""
    z, y, x = values.shape
    padded = np.pad(values.astype(np.float64), [(0, z % 2), (0, y % 2), (0, x % 2)], mode="edge")
    zz, yy, xx = padded.shape
    means = padded.reshape(zz // 2, 2, yy // 2, 2, xx // 2, 2).mean(axis=(1, 3, 5))
    return np.floor(means).astype("<u2")


def fresh(path: Path) -> Path:
    shutil.rmtree(path, ignore_errors=True)
    return path


def tensorstore_dataset(path: Path, compression: dict, values: np.ndarray, block=BLOCK):
    dims = list(values.shape[::-1])
    store = ts.open(
        {
            "driver": "n5",
            "kvstore": {"driver": "file", "path": str(path)},
            "metadata": {
                "dimensions": dims,
                "blockSize": block,
                "dataType": "uint16",
                "compression": compression,
            },
            "create": True,
            "delete_existing": True,
        }
    ).result()
    store[...] = values.T


def write_json(path: Path, value: dict) -> None:
    path.mkdir(parents=True, exist_ok=True)
    (path / "attributes.json").write_text(json.dumps(value))


def update_json(path: Path, extra: dict) -> None:
    document = json.loads((path / "attributes.json").read_text())
    document.update(extra)
    (path / "attributes.json").write_text(json.dumps(document))


def lz4_blocks(data: bytes) -> bytes:
    """lz4-java's LZ4BlockOutputStream framing, 64 KiB blocks, checksum 0."""
    out = bytearray()
    for at in range(0, len(data), 1 << 16):
        piece = data[at : at + (1 << 16)]
        compressed = lz4.block.compress(piece, store_size=False)
        out += b"LZ4Block" + bytes([0x20 | 5]) + struct.pack("<iii", len(compressed), len(piece), 0)
        out += compressed
    out += b"LZ4Block" + bytes([0x10]) + struct.pack("<iii", 0, 0, 0)
    return bytes(out)


def java_style(path: Path, compression: dict, compress) -> None:
    """Blocks as Java's N5 writes them: edge blocks cut to the dataset."""
    values = voxels()
    write_json(
        fresh(path),
        {"dimensions": DIMS, "blockSize": BLOCK, "dataType": "uint16", "compression": compression},
    )
    grid = [-(-d // b) for d, b in zip(DIMS, BLOCK)]
    for bx in range(grid[0]):
        for by in range(grid[1]):
            for bz in range(grid[2]):
                x0, y0, z0 = bx * BLOCK[0], by * BLOCK[1], bz * BLOCK[2]
                block = values[z0 : z0 + BLOCK[2], y0 : y0 + BLOCK[1], x0 : x0 + BLOCK[0]]
                extent = block.shape[::-1]
                header = struct.pack(">HH", 0, 3) + struct.pack(">III", *extent)
                payload = compress(block.astype(">u2").tobytes())
                target = path / str(bx) / str(by) / str(bz)
                target.parent.mkdir(parents=True, exist_ok=True)
                target.write_bytes(header + payload)


def main() -> None:
    values = voxels()
    fixtures = {}
    for name, compression in [
        ("raw", {"type": "raw"}),
        ("gzip", {"type": "gzip", "level": 6}),
        ("gzip-zlib", {"type": "gzip", "level": 6, "useZlib": True}),
        ("bzip2", {"type": "bzip2", "blockSize": 9}),
        ("xz", {"type": "xz", "preset": 6}),
        ("zstd", {"type": "zstd", "level": 3}),
        ("blosc", {"type": "blosc", "cname": "zstd", "clevel": 5, "shuffle": 2, "blocksize": 0}),
    ]:
        path = fresh(HERE / f"tensorstore-{name}.n5")
        tensorstore_dataset(path, compression, values)
        fixtures[path.name] = "n5 " + compression["type"] + (" zstd" if name == "blosc" else "")

    for name, compressor in [
        ("gzip", numcodecs.GZip(level=5)),
        ("bzip2", numcodecs.BZ2(level=9)),
        ("xz", numcodecs.LZMA(preset=6)),
        ("blosc", numcodecs.Blosc(cname="lz4", clevel=5, shuffle=numcodecs.Blosc.SHUFFLE)),
    ]:
        path = fresh(HERE / f"zarr2-{name}.n5")
        array = zarr.open_array(
            N5Store(str(path)), mode="w", shape=values.shape, chunks=BLOCK[::-1], dtype="<u2",
            compressor=compressor, fill_value=0,
        )
        array[...] = values
        kind = json.loads((path / "attributes.json").read_text())["compression"]["type"]
        fixtures[path.name] = "n5 " + kind + (" lz4" if name == "blosc" else "")

    java_style(HERE / "edge-raw.n5", {"type": "raw"}, lambda b: b)
    fixtures["edge-raw.n5"] = "n5 raw"
    java_style(HERE / "edge-lz4.n5", {"type": "lz4", "blockSize": 65536}, lz4_blocks)
    fixtures["edge-lz4.n5"] = "n5 lz4"

    coarse = halved(values)
    coarse.tofile(HERE / "s1.u16le")
    gzip = {"type": "gzip", "level": 6}

    viewer = fresh(HERE / "n5-viewer.n5")
    write_json(viewer, {
        "n5": "2.5.1",
        "scales": [[1, 1, 1], [2, 2, 2]],
        "pixelResolution": {"dimensions": [0.5, 0.5, 2.0], "unit": "um"},
    })
    tensorstore_dataset(viewer / "s0", gzip, values)
    tensorstore_dataset(viewer / "s1", gzip, coarse)
    update_json(viewer / "s1", {"downsamplingFactors": [2, 2, 2]})

    cosem = fresh(HERE / "cosem.n5")
    transform = lambda f: {
        "axes": ["z", "y", "x"],
        "ordering": "C",
        "scale": [2.0 * f, 0.5 * f, 0.5 * f],
        "translate": [10.0 + (f - 1), 20.0 + 0.25 * (f - 1), 30.0 + 0.25 * (f - 1)],
        "units": ["nm", "nm", "nm"],
    }
    write_json(cosem, {
        "n5": "2.5.1",
        "multiscales": [{
            "name": "cells",
            "datasets": [
                {"path": "s0", "transform": transform(1)},
                {"path": "s1", "transform": transform(2)},
            ],
        }],
    })
    tensorstore_dataset(cosem / "s0", gzip, values)
    tensorstore_dataset(cosem / "s1", gzip, coarse)
    update_json(cosem / "s0", {"transform": transform(1)})
    update_json(cosem / "s1", {"transform": transform(2)})

    bdv = fresh(HERE / "bdv.n5")
    write_json(bdv, {"n5": "2.2.0"})
    for setup, offset in [(0, 0), (1, 1000)]:
        group = bdv / f"setup{setup}"
        write_json(group, {"downsamplingFactors": [[1, 1, 1], [2, 2, 2]], "dataType": "uint16"})
        tensorstore_dataset(group / "timepoint0" / "s0", gzip, values + offset)
        tensorstore_dataset(group / "timepoint0" / "s1", gzip, halved(values + offset))
        update_json(group / "timepoint0" / "s1", {"downsamplingFactors": [2, 2, 2]})

    (HERE / "versions.json").write_text(json.dumps({
        "tensorstore": version("tensorstore"),
        "zarr": version("zarr"),
        "numcodecs": version("numcodecs"),
        "lz4": version("lz4"),
        "numpy": version("numpy"),
        "codecs": fixtures,
    }, indent=2) + "\n")


if __name__ == "__main__":
    main()
