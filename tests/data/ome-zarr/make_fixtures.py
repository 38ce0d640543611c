"""Writes the OME-Zarr fixtures of tests/ome_zarr.rs with the reference implementation.

Run from the repository root, with ../shared/data beside it:

    python3 -m venv /tmp/zpy && /tmp/zpy/bin/pip install ome-zarr zarr numpy tifffile nibabel
    /tmp/zpy/bin/python tests/data/ome-zarr/make_fixtures.py

The pyramids are computed here (2x mean, the same rule as `voxscope convert`), so that the
content is exact and known; ome-zarr-py (`write_multiscale`) writes the metadata and zarr-python
the chunks. expected.json records, for every fixture, level and (t, c) volume, the shape and a
checksum of the voxels that the Rust tests compute the same way (see `checksum`).
"""

import json
import shutil
import sys
from pathlib import Path

import nibabel
import numcodecs
import numpy as np
import tifffile
import zarr
import zarr.codecs
import ome_zarr
import dask
from ome_zarr.format import FormatV04, FormatV05
from ome_zarr.writer import write_multiscale

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[2] / ".." / "shared" / "data"

# Cells3d (the nuclei TIFF's source) voxel size in micrometers, z, y, x (scikit-image docs).
NUCLEI_SPACING = (0.29, 0.26, 0.26)

MASK = (1 << 64) - 1
GOLDEN = 0x9E3779B97F4A7C15


def checksum(volume: np.ndarray) -> int:
    """sum over voxels i (C order of a z, y, x array: x fastest) of value_i * (i + 1) * GOLDEN,
    modulo 2^64, values as signed 64-bit integers (two's complement)."""
    flat = np.ascontiguousarray(volume).reshape(-1).astype(np.int64).view(np.uint64)
    index = np.arange(1, flat.size + 1, dtype=np.uint64)
    with np.errstate(over="ignore"):
        weights = index * np.uint64(GOLDEN)
        return int(np.sum(flat * weights, dtype=np.uint64)) & MASK


def mean_down(volume: np.ndarray) -> np.ndarray:
    """2x mean over the last three axes (z, y, x); an odd extent's last voxel is averaged with
    itself (edge replication), so the result has ceil(n / 2) voxels. Integer results round half
    up, as `voxscope convert` does."""
    pad = [(0, 0)] * (volume.ndim - 3) + [(0, n % 2) for n in volume.shape[-3:]]
    padded = np.pad(volume.astype(np.float64), pad, mode="edge")
    s = padded.shape
    blocks = padded.reshape(*s[:-3], s[-3] // 2, 2, s[-2] // 2, 2, s[-1] // 2, 2)
    mean = blocks.mean(axis=(-5, -3, -1))
    if np.issubdtype(volume.dtype, np.integer):
        mean = np.floor(mean + 0.5)
    return mean.astype(volume.dtype)


def pyramid(level0: np.ndarray, count: int) -> list:
    levels = [level0]
    for _ in range(count - 1):
        levels.append(mean_down(levels[-1]))
    return levels


def transforms(spacing, count, leading=()):
    """scale and translation per level for 2x mean levels: the center of a coarse voxel lies
    half a fine voxel further in."""
    result = []
    for level in range(count):
        factor = 2**level
        scale = [1.0] * len(leading) + [s * factor for s in spacing]
        shift = [0.0] * len(leading) + [s * (factor - 1) / 2 for s in spacing]
        result.append([{"type": "scale", "scale": scale}, {"type": "translation", "translation": shift}])
    return result


def nuclei() -> np.ndarray:
    """The nuclei stack, 4x mean in y and x, z 20..40, y and x 8..56: 20 x 48 x 48 (z, y, x), u16."""
    stack = tifffile.imread(DATA / "nuclei-60x256x256.tif")
    assert stack.shape == (60, 256, 256) and stack.dtype == np.uint16, stack.shape
    crop = stack[20:40].astype(np.float64)
    down = crop.reshape(20, 64, 4, 64, 4).mean(axis=(2, 4))
    return np.floor(down[:, 8:56, 8:56] + 0.5).astype(np.uint16)


def head() -> np.ndarray:
    """The small T1 head as stored (no reorientation), 2x mean: 31 x 64 x 64 (z, y, x), i16."""
    image = nibabel.load(DATA / "mri-head-128x128x62.nii.gz")
    stored = np.asarray(image.dataobj, dtype=np.int16)  # x, y, z
    assert stored.shape == (128, 128, 62), stored.shape
    zyx = np.ascontiguousarray(stored.T)
    return mean_down(zyx)


def record(expected, name, levels, axes):
    entry = {"axes": axes, "levels": []}
    for level in levels:
        volumes = []
        lead = level.shape[:-3]
        for index in np.ndindex(*lead):
            volume = level[index]
            volumes.append(
                {"index": list(index), "checksum": str(checksum(volume)), "sum": int(volume.astype(np.int64).sum()),
                 "min": int(volume.min()), "max": int(volume.max())}
            )
        entry["levels"].append({"shape": list(level.shape), "dtype": str(level.dtype), "volumes": volumes})
    expected[name] = entry


def fresh(name):
    path = HERE / name
    if path.exists():
        shutil.rmtree(path)
    return path


def main():
    expected = {}
    versions = {
        "ome-zarr": ome_zarr.__version__,
        "zarr": zarr.__version__,
        "numcodecs": numcodecs.__version__,
        "numpy": np.__version__,
        "dask": dask.__version__,
        "python": sys.version.split()[0],
    }

    # 1. OME-Zarr 0.4 (zarr v2), blosc lz4 with byte shuffle, z chunks that end in a partial one.
    name = "nuclei-v04-blosc-lz4.ome.zarr"
    levels = pyramid(nuclei(), 3)
    group = zarr.open_group(str(fresh(name)), mode="w", zarr_format=2)
    write_multiscale(
        levels, group, fmt=FormatV04(), axes=[
            {"name": "z", "type": "space", "unit": "micrometer"},
            {"name": "y", "type": "space", "unit": "micrometer"},
            {"name": "x", "type": "space", "unit": "micrometer"},
        ],
        coordinate_transformations=transforms((NUCLEI_SPACING[0], NUCLEI_SPACING[1] * 4, NUCLEI_SPACING[2] * 4), 3),
        storage_options={"chunks": (16, 32, 32), "compressor": numcodecs.Blosc(cname="lz4", clevel=5, shuffle=numcodecs.Blosc.SHUFFLE)},
        name="nuclei",
    )
    record(expected, name, levels, "zyx")

    # 2. OME-Zarr 0.4, zstd; background chunks (all zero) are not written: they read as the fill value.
    name = "head-v04-zstd.ome.zarr"
    levels = pyramid(head(), 3)
    group = zarr.open_group(str(fresh(name)), mode="w", zarr_format=2)
    write_multiscale(
        levels, group, fmt=FormatV04(), axes=[
            {"name": "z", "type": "space", "unit": "millimeter"},
            {"name": "y", "type": "space", "unit": "millimeter"},
            {"name": "x", "type": "space", "unit": "millimeter"},
        ],
        coordinate_transformations=transforms((6.0, 4.0, 4.0), 3),
        storage_options={"chunks": (16, 16, 16), "compressor": numcodecs.Zstd(level=3)},
        name="head",
    )
    record(expected, name, levels, "zyx")

    # 3. OME-Zarr 0.5 (zarr v3), shards of 32^3 holding 16^3 chunks, blosc zstd with bit shuffle.
    name = "head-v05-sharded-blosc-zstd.ome.zarr"
    group = zarr.open_group(str(fresh(name)), mode="w", zarr_format=3)
    write_multiscale(
        levels, group, fmt=FormatV05(), axes=[
            {"name": "z", "type": "space", "unit": "millimeter"},
            {"name": "y", "type": "space", "unit": "millimeter"},
            {"name": "x", "type": "space", "unit": "millimeter"},
        ],
        coordinate_transformations=transforms((6.0, 4.0, 4.0), 3),
        storage_options={"chunks": (16, 16, 16), "shards": (32, 32, 32),
                         "compressor": [zarr.codecs.BloscCodec(cname="zstd", clevel=5, shuffle="bitshuffle")]},
        name="head",
    )
    record(expected, name, levels, "zyx")

    # 4. tczyx: 2 time points x 2 channels (nuclei, head as u16), omero colors and windows.
    name = "tczyx-v04.ome.zarr"
    n = nuclei()[4:12, 16:32, 20:36]
    h = head()[12:20, 24:40, 24:40].astype(np.uint16)
    t0 = np.stack([n, h])
    t1 = np.stack([n[:, :, ::-1], h[:, ::-1, :]])
    level0 = np.ascontiguousarray(np.stack([t0, t1]))  # t, c, z, y, x
    levels = pyramid(level0, 2)
    group = zarr.open_group(str(fresh(name)), mode="w", zarr_format=2)
    write_multiscale(
        levels, group, fmt=FormatV04(), axes=[
            {"name": "t", "type": "time", "unit": "second"},
            {"name": "c", "type": "channel"},
            {"name": "z", "type": "space", "unit": "micrometer"},
            {"name": "y", "type": "space", "unit": "micrometer"},
            {"name": "x", "type": "space", "unit": "micrometer"},
        ],
        coordinate_transformations=transforms((0.5, 0.25, 0.25), 2, leading=(1, 1)),
        storage_options={"chunks": (1, 1, 8, 16, 16), "compressor": numcodecs.Blosc(cname="lz4", clevel=5, shuffle=numcodecs.Blosc.SHUFFLE)},
        name="two channels",
        metadata={"omero": {
            "name": "two channels",
            "version": "0.4",
            "channels": [
                {"label": "nuclei", "color": "00FF00", "active": True,
                 "window": {"min": 0, "max": 65535, "start": 2000, "end": 30000}},
                {"label": "head", "color": "FF00FF", "active": True,
                 "window": {"min": 0, "max": 255, "start": 10, "end": 200}},
            ],
            "rdefs": {"defaultT": 0, "defaultZ": 6, "model": "color"},
        }},
    )
    record(expected, name, levels, "tczyx")

    # 5. A plain zarr v2 array (no multiscales), u8, gzip, '.' as the chunk key separator.
    name = "plain-v2-gzip.zarr"
    plain = np.clip(head(), 0, 255).astype(np.uint8)
    array = zarr.create_array(str(fresh(name)), shape=plain.shape, chunks=(8, 32, 32), dtype="u1",
                              zarr_format=2, compressors=numcodecs.GZip(level=6), fill_value=0,
                              chunk_key_encoding={"name": "v2", "separator": "."})
    array[...] = plain
    record(expected, name, [plain], "zyx")

    # 6. A plain zarr v3 array without compression ('/' separator, the v3 default key encoding).
    name = "plain-v3-none.zarr"
    small = nuclei()[:6, :12, :20].astype(np.int32) - 1000
    array = zarr.create_array(str(fresh(name)), shape=small.shape, chunks=(4, 8, 8), dtype="i4",
                              zarr_format=3, compressors=None, fill_value=-7)
    array[...] = small
    record(expected, name, [small], "zyx")

    # 7. tzyx: 3 time points of the head (i16), each shifted 4 voxels further along x: a time
    #    series whose level 0 is several 32^3 bricks (the app's streamed prefetch test).
    name = "tzyx-head-v04.ome.zarr"
    frames = [np.roll(head(), 4 * t, axis=2) for t in range(3)]
    level0 = np.ascontiguousarray(np.stack(frames))  # t, z, y, x
    levels = pyramid(level0, 3)
    group = zarr.open_group(str(fresh(name)), mode="w", zarr_format=2)
    write_multiscale(
        levels, group, fmt=FormatV04(), axes=[
            {"name": "t", "type": "time", "unit": "second"},
            {"name": "z", "type": "space", "unit": "millimeter"},
            {"name": "y", "type": "space", "unit": "millimeter"},
            {"name": "x", "type": "space", "unit": "millimeter"},
        ],
        coordinate_transformations=transforms((6.0, 4.0, 4.0), 3, leading=(1,)),
        storage_options={"chunks": (1, 16, 16, 16), "compressor": numcodecs.Zstd(level=3)},
        name="moving head",
    )
    record(expected, name, levels, "tzyx")

    (HERE / "expected.json").write_text(json.dumps({"versions": versions, "fixtures": expected}, indent=1) + "\n")
    print(json.dumps(versions))


if __name__ == "__main__":
    main()
