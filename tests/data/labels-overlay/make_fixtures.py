"""Writes the label-overlay fixture with the reference implementation (ome-zarr-py).

Run from the repository root:

    python3 -m venv /tmp/fixture-venv
    /tmp/fixture-venv/bin/pip install zarr==3.1.6 numcodecs==0.16.6 ome-zarr==0.18.0 numpy
    /tmp/fixture-venv/bin/python tests/data/labels-overlay/make_fixtures.py

`cells-v04.ome.zarr`: an OME-Zarr 0.4 image of 24 x 20 x 16 voxels (x y z, u16, a smooth
blob) written by `ome_zarr.writer.write_image`, with a `labels/` group of two label images
written by `write_labels`:
- `cells` (u8): label 1 a box, 2 a ball, 3 a small box; `image-label` colors 1 red, 2 green,
  3 blue (all opaque);
- `regions` (u16): label 5 a slab, 9 another; no colors (the labels palette applies).
`cells-v05.ome.zarr`: the same image and label images as OME-Zarr 0.5 (Zarr v3; `labels` and
`image-label` under `attributes.ome` of `zarr.json`).
`cells-channels-v05.ome.zarr`: two channels (c z y x: the blob, and a ramp along x) as
OME-Zarr 0.5 with `omero` colors (green, magenta) and windows, and the `cells` label image.
`cells.nii`: the `cells` label image as NIfTI-1 (written by hand, no orientation codes), and
`wrong-grid.nii`: a label volume of 12 x 10 x 8 voxels (not the image's grid).
expected.json records the versions, the labels' voxel counts and a few voxels' values.
"""

import json
import shutil
import struct
import sys
from pathlib import Path

import numpy as np
import ome_zarr
import zarr
from ome_zarr.format import FormatV04, FormatV05
from ome_zarr.writer import write_image, write_labels, write_multiscale

HERE = Path(__file__).resolve().parent
SHAPE = (16, 20, 24)  # z, y, x
COLORS = {1: [255, 0, 0, 255], 2: [0, 255, 0, 255], 3: [0, 0, 255, 255]}


def image_voxels() -> np.ndarray:
    z, y, x = np.indices(SHAPE).astype(np.float64)
    r2 = ((x - 11.5) / 9) ** 2 + ((y - 9.5) / 8) ** 2 + ((z - 7.5) / 6) ** 2
    return np.round(100 + 900 * np.exp(-2 * r2)).astype(np.uint16)


def cells_voxels() -> np.ndarray:
    z, y, x = np.indices(SHAPE)
    cells = np.zeros(SHAPE, dtype=np.uint8)
    cells[(x >= 3) & (x < 9) & (y >= 4) & (y < 10) & (z >= 3) & (z < 9)] = 1
    cells[(x - 16) ** 2 + (y - 12) ** 2 + (z - 9) ** 2 <= 16] = 2
    cells[(x >= 10) & (x < 14) & (y >= 14) & (y < 18) & (z >= 10) & (z < 14)] = 3
    return cells


def regions_voxels() -> np.ndarray:
    z, y, x = np.indices(SHAPE)
    regions = np.zeros(SHAPE, dtype=np.uint16)
    regions[(x >= 18) & (z < 8)] = 5
    regions[(y < 4) & (x < 12)] = 9
    return regions


def write_nifti(path: Path, data_zyx: np.ndarray) -> None:
    """A NIfTI-1 single file (.nii) of u8 voxels, x fastest, 1 mm voxels, no orientation."""
    nz, ny, nx = data_zyx.shape
    header = bytearray(348)
    struct.pack_into("<i", header, 0, 348)
    struct.pack_into("<8h", header, 40, 3, nx, ny, nz, 1, 1, 1, 1)
    struct.pack_into("<h", header, 70, 2)  # datatype: unsigned char
    struct.pack_into("<h", header, 72, 8)  # bitpix
    struct.pack_into("<8f", header, 76, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0)
    struct.pack_into("<f", header, 108, 352.0)  # vox_offset
    struct.pack_into("<f", header, 112, 1.0)  # scl_slope
    header[344:348] = b"n+1\0"
    path.write_bytes(bytes(header) + b"\0\0\0\0" + data_zyx.astype(np.uint8).tobytes(order="C"))


def main() -> None:
    path = HERE / "cells-v04.ome.zarr"
    shutil.rmtree(path, ignore_errors=True)
    fmt = FormatV04()
    root = zarr.open_group(str(path), mode="w", zarr_format=2)
    image = image_voxels()
    write_image(image, root, scale_factors=[], axes="zyx", fmt=fmt)
    cells = cells_voxels()
    colors = [{"label-value": v, "rgba": rgba} for v, rgba in COLORS.items()]
    write_labels(cells, root, "cells", scale_factors=[], axes="zyx", fmt=fmt, label_metadata={"colors": colors})
    regions = regions_voxels()
    write_labels(regions, root, "regions", scale_factors=[], axes="zyx", fmt=fmt)
    path = HERE / "cells-v05.ome.zarr"
    shutil.rmtree(path, ignore_errors=True)
    fmt = FormatV05()
    root = zarr.open_group(str(path), mode="w", zarr_format=3)
    write_image(image, root, scale_factors=[], axes="zyx", fmt=fmt)
    write_labels(cells, root, "cells", scale_factors=[], axes="zyx", fmt=fmt, label_metadata={"colors": colors})
    write_labels(regions, root, "regions", scale_factors=[], axes="zyx", fmt=fmt)
    path = HERE / "cells-channels-v05.ome.zarr"
    shutil.rmtree(path, ignore_errors=True)
    root = zarr.open_group(str(path), mode="w", zarr_format=3)
    ramp = np.broadcast_to(np.arange(SHAPE[2], dtype=np.uint16) * 40 + 50, SHAPE)
    omero = {
        "channels": [
            {"label": "blob", "color": "00FF00", "active": True,
             "window": {"min": 0, "max": 1000, "start": 100, "end": 1000}},
            {"label": "ramp", "color": "FF00FF", "active": True,
             "window": {"min": 0, "max": 1000, "start": 50, "end": 1000}},
        ]
    }
    write_multiscale([np.stack([image, ramp])], root, axes="czyx", fmt=fmt, name="two channels",
                     metadata={"omero": omero})
    write_labels(cells, root, "cells", scale_factors=[], axes="zyx", fmt=fmt, label_metadata={"colors": colors})
    write_nifti(HERE / "cells.nii", cells)
    write_nifti(HERE / "wrong-grid.nii", cells[::2, ::2, ::2])
    counts = {
        name: {str(int(v)): int((data == v).sum()) for v in np.unique(data)}
        for name, data in [("cells", cells), ("regions", regions)]
    }
    probes = [[5, 6, 5], [16, 12, 9], [0, 0, 0], [20, 10, 2]]  # x, y, z
    voxels = [
        {
            "at": p,
            "image": int(image[p[2], p[1], p[0]]),
            "cells": int(cells[p[2], p[1], p[0]]),
            "regions": int(regions[p[2], p[1], p[0]]),
        }
        for p in probes
    ]
    versions = {
        "ome-zarr": ome_zarr.__version__,
        "zarr": zarr.__version__,
        "numpy": np.__version__,
        "python": sys.version.split()[0],
    }
    expected = {"versions": versions, "colors": {str(k): v for k, v in COLORS.items()}, "counts": counts, "voxels": voxels}
    (HERE / "expected.json").write_text(json.dumps(expected, indent=1) + "\n")


if __name__ == "__main__":
    main()
