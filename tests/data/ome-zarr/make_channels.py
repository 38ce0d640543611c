"""Writes the multi-channel OME-Zarr 0.5 fixture of the streamed composite's tests with the
reference implementation (ome-zarr-py's write_multiscale, zarr-python's chunks and shards).

Run from the repository root, with ../shared/data beside it:

    python3 -m venv /tmp/zpy && /tmp/zpy/bin/pip install ome-zarr zarr numpy tifffile
    /tmp/zpy/bin/python tests/data/ome-zarr/make_channels.py

channels9-v05-sharded.ome.zarr: nine channels (c, z, y, x = 9 x 8 x 40 x 40, u16) of the real
nuclei stack (../shared/data/nuclei-60x256x256.tif, 4x mean in y and x, z 22..30, y and x
12..52), channel c
shifted 3c voxels along x and scaled by 1 + c/4, so each channel differs; OME-Zarr 0.5 (zarr
v3), shards of 1 x 8 x 40 x 40 holding 1 x 8 x 20 x 20 chunks, blosc zstd; two levels (2x
mean in z, y, x). Its `omero` list marks channels 1, 3, 4 and 8 active (the channels an
image opens with), each with a name, color and window. The versions used are written to
channels9-versions.json beside it.
"""

import json
import shutil
from pathlib import Path

import numpy as np
import ome_zarr
import tifffile
import zarr
import zarr.codecs
from ome_zarr.format import FormatV05
from ome_zarr.writer import write_multiscale

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[2] / ".." / "shared" / "data"
NAME = "channels9-v05-sharded.ome.zarr"
ACTIVE = [False, True, False, True, True, False, False, False, True]
COLORS = ["00FF00", "FF00FF", "00FFFF", "FFFF00", "FF0000", "0000FF", "FF8000", "FFFFFF",
          "FF80FF"]


def nuclei() -> np.ndarray:
    stack = tifffile.imread(DATA / "nuclei-60x256x256.tif")
    assert stack.shape == (60, 256, 256) and stack.dtype == np.uint16, stack.shape
    down = stack[22:30].astype(np.float64).reshape(8, 64, 4, 64, 4).mean(axis=(2, 4))
    return down[:, 12:52, 12:52]


def mean_down(volume: np.ndarray) -> np.ndarray:
    """2x mean over z, y, x of a c, z, y, x array (even sizes), rounded half up."""
    c, z, y, x = volume.shape
    mean = volume.astype(np.float64).reshape(c, z // 2, 2, y // 2, 2, x // 2, 2).mean(axis=(2, 4, 6))
    return np.floor(mean + 0.5).astype(volume.dtype)


def main():
    base = nuclei()
    channels = []
    for c in range(9):
        shifted = np.roll(base, 3 * c, axis=2) * (1.0 + c / 4.0)
        channels.append(np.clip(np.floor(shifted + 0.5), 0, 65535).astype(np.uint16))
    level0 = np.ascontiguousarray(np.stack(channels))
    levels = [level0, mean_down(level0)]
    path = HERE / NAME
    if path.exists():
        shutil.rmtree(path)
    group = zarr.open_group(str(path), mode="w", zarr_format=3)
    spacing = (0.29, 1.04, 1.04)
    transforms = []
    for level in range(2):
        f = 2**level
        transforms.append([
            {"type": "scale", "scale": [1.0] + [s * f for s in spacing]},
            {"type": "translation", "translation": [0.0] + [s * (f - 1) / 2 for s in spacing]},
        ])
    omero_channels = []
    for c in range(9):
        high = int(level0[c].max())
        omero_channels.append({
            "label": f"ch{c}", "color": COLORS[c], "active": ACTIVE[c],
            "window": {"min": 0, "max": 65535, "start": high // 8, "end": high},
        })
    write_multiscale(
        levels, group, fmt=FormatV05(), axes=[
            {"name": "c", "type": "channel"},
            {"name": "z", "type": "space", "unit": "micrometer"},
            {"name": "y", "type": "space", "unit": "micrometer"},
            {"name": "x", "type": "space", "unit": "micrometer"},
        ],
        coordinate_transformations=transforms,
        storage_options={"chunks": (1, 8, 20, 20), "shards": (1, 8, 40, 40),
                         "compressor": [zarr.codecs.BloscCodec(cname="zstd", clevel=5, shuffle="bitshuffle")]},
        name="nine channels",
        metadata={"omero": {"name": "nine channels", "version": "0.5", "channels": omero_channels,
                            "rdefs": {"defaultT": 0, "defaultZ": 4, "model": "color"}}},
    )
    versions = {"ome-zarr": ome_zarr.__version__, "zarr": zarr.__version__,
                "numpy": np.__version__, "tifffile": tifffile.__version__}
    (HERE / "channels9-versions.json").write_text(json.dumps(versions, indent=2) + "\n")
    print(NAME, level0.shape, versions)


if __name__ == "__main__":
    main()
