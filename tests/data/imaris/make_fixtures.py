"""Writes the Imaris fixtures of tests/imaris.rs with h5py (libhdf5) in the layout Imaris,
ImarisConvert and ImarisWriter write (Imaris 5.5: `DataSet/ResolutionLevel L/TimePoint T/
Channel C/Data`, text attributes stored as arrays of one-character strings, `DataSetInfo`
with the extent, unit and channel colors), and hdf5plugin for the LZ4 filter (id 32004, the
one ImarisWriter uses).

Run from the repository root:

    python3 -m venv /tmp/h5 && /tmp/h5/bin/pip install h5py hdf5plugin numpy
    /tmp/h5/bin/python tests/data/imaris/make_fixtures.py

Every image holds the voxels of tests/data/codecs/voxels.u16le (10 x 9 x 7, x y z):
- `cells.ims`: uint16, two channels (the voxels; the voxels plus 1000) named, colored and
  windowed, two resolution levels (the second the 2 x 2 x 2 means of tests/data/n5/s1.u16le),
  deflate with shuffle in chunks of 6 x 5 x 4 and `Data` padded to whole chunks as Imaris
  pads it; voxels of 0.5 x 0.5 x 2 um from (30, 20, 10) um; histograms and a thumbnail.
- `lz4-time.ims`: uint8 (the voxels modulo 256), LZ4, two time points (the second 255
  minus the first), `Data` not padded, written with libver 'latest' (superblock 3, the
  newer chunk indexes).
- `contiguous-be.ims`: big-endian float32 (the voxels times 0.5), unchunked, without
  `DataSetInfo` (voxels of 1 from 0).
- `plain.h5`: an HDF5 file that is not an Imaris file.

versions.json records the versions used.
"""

import json
from importlib.metadata import version
from pathlib import Path

import h5py
import hdf5plugin
import numpy as np

HERE = Path(__file__).resolve().parent
VOXELS = HERE.parent / "codecs" / "voxels.u16le"
COARSE = HERE.parent / "n5" / "s1.u16le"
DIMS = (7, 9, 10)  # z, y, x


def text(node, name: str, value) -> None:
    """An attribute as Imaris writes text: an array of one-character strings."""
    data = str(value).encode("ascii")
    node.attrs.create(name, np.frombuffer(data, dtype="S1"), dtype="S1")


def padded(values: np.ndarray, chunk) -> np.ndarray:
    shape = [-(-n // c) * c for n, c in zip(values.shape, chunk)]
    out = np.zeros(shape, dtype=values.dtype)
    out[: values.shape[0], : values.shape[1], : values.shape[2]] = values
    return out


def root(f: h5py.File) -> None:
    text(f, "DataSetDirectoryName", "DataSet")
    text(f, "DataSetInfoDirectoryName", "DataSetInfo")
    text(f, "ImarisDataSet", "ImarisDataSet")
    text(f, "ImarisVersion", "5.5.0")
    text(f, "ThumbnailDirectoryName", "Thumbnail")
    f.attrs.create("NumberOfDataSets", np.array([1], dtype=np.uint32))


def level(f, r: int, t: int, c: int, values: np.ndarray, pad_to=None, **options) -> None:
    group = f.require_group(f"DataSet/ResolutionLevel {r}/TimePoint {t}/Channel {c}")
    data = padded(values, pad_to) if pad_to else values
    group.create_dataset("Data", data=data, **options)
    z, y, x = values.shape
    text(group, "ImageSizeX", x)
    text(group, "ImageSizeY", y)
    text(group, "ImageSizeZ", z)
    low, high = float(values.min()), float(values.max())
    text(group, "HistogramMin", f"{low:.3f}")
    text(group, "HistogramMax", f"{high:.3f}")
    histogram, _ = np.histogram(values, bins=256, range=(low, max(high, low + 1)))
    group.create_dataset("Histogram", data=histogram.astype(np.uint64))


def info(f, extent_min, spacing, channels) -> None:
    image = f.require_group("DataSetInfo/Image")
    z, y, x = DIMS
    for name, value in [("X", x), ("Y", y), ("Z", z), ("Unit", "um"), ("Noc", len(channels)),
                        ("Name", "cells"), ("Description", "voxscope test fixture")]:
        text(image, name, value)
    for axis, (low, step, n) in enumerate(zip(extent_min, spacing, (x, y, z))):
        text(image, f"ExtMin{axis}", f"{low:.3f}")
        text(image, f"ExtMax{axis}", f"{low + step * n:.3f}")
    for c, (name, color, window) in enumerate(channels):
        group = f.require_group(f"DataSetInfo/Channel {c}")
        text(group, "Name", name)
        text(group, "Color", color)
        text(group, "ColorMode", "BaseColor")
        text(group, "ColorOpacity", "1.000")
        text(group, "ColorRange", window)
    time = f.require_group("DataSetInfo/TimeInfo")
    text(time, "DatasetTimePoints", 1)
    text(time, "FileTimePoints", 1)
    text(time, "TimePoint1", "2026-12-07 12:00:00.000")


def main() -> None:
    voxels = np.fromfile(VOXELS, dtype="<u2").reshape(DIMS)
    coarse = np.fromfile(COARSE, dtype="<u2").reshape((4, 5, 5))
    chunk = (4, 5, 6)

    with h5py.File(HERE / "cells.ims", "w") as f:
        root(f)
        gzip = dict(chunks=chunk, compression="gzip", compression_opts=2, shuffle=True)
        for c, offset in [(0, 0), (1, 1000)]:
            level(f, 0, 0, c, voxels + offset, pad_to=chunk, **gzip)
            level(f, 1, 0, c, coarse + offset, pad_to=chunk, **gzip)
        info(f, (30.0, 20.0, 10.0), (0.5, 0.5, 2.0), [
            ("GFP", "0.000 1.000 0.000", "0.000 300.000"),
            ("tdTomato", "1.000 0.000 1.000", "1000.000 1300.000"),
        ])
        thumbnail = f.require_group("Thumbnail")
        thumbnail.create_dataset("Data", data=np.zeros((16, 64), dtype=np.uint8))

    with h5py.File(HERE / "lz4-time.ims", "w", libver="latest") as f:
        root(f)
        first = (voxels % 256).astype(np.uint8)
        for t, values in [(0, first), (1, 255 - first)]:
            level(f, 0, t, 0, values, chunks=chunk, **hdf5plugin.LZ4())
        info(f, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), [("DAPI", "0.000 0.000 1.000", "0 255")])

    with h5py.File(HERE / "contiguous-be.ims", "w") as f:
        root(f)
        level(f, 0, 0, 0, (voxels * 0.5).astype(">f4"))

    with h5py.File(HERE / "plain.h5", "w") as f:
        f.create_dataset("volume", data=voxels)

    (HERE / "versions.json").write_text(json.dumps({
        "h5py": version("h5py"),
        "hdf5": h5py.version.hdf5_version,
        "hdf5plugin": version("hdf5plugin"),
        "numpy": version("numpy"),
    }, indent=2) + "\n")


if __name__ == "__main__":
    main()
