"""Writes the thin-chunk fixtures (issue 54) with the reference implementation.

Run from the repository root, with ../shared/data beside it:

    python3 -m venv /tmp/thinvenv && /tmp/thinvenv/bin/pip install ome-zarr zarr numpy tifffile nibabel
    /tmp/thinvenv/bin/python tests/data/thin-chunks/make_fixtures.py

The same voxels three times: the small T1 head (40 of its 62 planes, 96 x 96 of its 128 x 128 rows and columns, as u16) in one-plane
chunks (OME-Zarr 0.4), in one-plane inner chunks of 16-plane shards (OME-Zarr 0.5), and in 64³
chunks (OME-Zarr 0.4, the reference). The pyramid's levels are computed here (2x mean, as
`voxscope convert` and ../ome-zarr/make_fixtures.py do), ome-zarr-py writes the metadata and
zarr-python the chunks. versions.json records the versions and each level's shape and checksum.
"""

import json
import shutil
import sys
from pathlib import Path

import dask
import nibabel
import numcodecs
import numpy as np
import ome_zarr
import zarr
import zarr.codecs
from ome_zarr.format import FormatV04, FormatV05
from ome_zarr.writer import write_multiscale

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "ome-zarr"))
from make_fixtures import DATA, checksum, pyramid, transforms  # noqa: E402


def fresh(name):
    path = HERE / name
    if path.exists():
        shutil.rmtree(path)
    return path

AXES = [{"name": n, "type": "space", "unit": "millimeter"} for n in "zyx"]
LEVELS = 3


def head40() -> np.ndarray:
    """The small T1 head as stored (no reorientation), planes 11..51, rows and columns 16..112:
    40 x 96 x 96 (z, y, x), u16."""
    image = nibabel.load(DATA / "mri-head-128x128x62.nii.gz")
    stored = np.asarray(image.dataobj, dtype=np.int16)  # x, y, z
    assert stored.shape == (128, 128, 62), stored.shape
    return np.ascontiguousarray(stored.T[11:51, 16:112, 16:112]).astype(np.uint16)


def write(name, levels, fmt, zarr_format, storage):
    group = zarr.open_group(str(fresh(name)), mode="w", zarr_format=zarr_format)
    write_multiscale(levels, group, fmt=fmt, axes=AXES,
                     coordinate_transformations=transforms((3.0, 2.0, 2.0), len(levels)),
                     storage_options=storage, name="head")


def main():
    levels = pyramid(head40(), LEVELS)
    zstd = numcodecs.Blosc(cname="zstd", clevel=9, shuffle=numcodecs.Blosc.BITSHUFFLE)
    # Storage options per level: a chunk (and shard) never beyond the level, as a writer of
    # one-plane acquisition chunks leaves them (1 x Y x X of the level).
    plane = [{"chunks": (1,) + level.shape[1:], "compressor": zstd} for level in levels]
    write("thin-v04.ome.zarr", levels, FormatV04(), 2, plane)
    sharded = [{"chunks": (1,) + level.shape[1:], "shards": (16,) + level.shape[1:],
                "compressor": [zarr.codecs.BloscCodec(cname="zstd", clevel=9, shuffle="bitshuffle")]} for level in levels]
    write("thin-v05-sharded.ome.zarr", levels, FormatV05(), 3, sharded)
    write("cubic64-v04.ome.zarr", levels, FormatV04(), 2, {"chunks": (64, 64, 64), "compressor": zstd})
    record = {
        "versions": {"ome-zarr": ome_zarr.__version__, "zarr": zarr.__version__,
                     "numcodecs": numcodecs.__version__, "numpy": np.__version__,
                     "dask": dask.__version__, "python": sys.version.split()[0]},
        "levels": [{"shape": list(l.shape), "checksum": str(checksum(l))} for l in levels],
    }
    (HERE / "versions.json").write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
