"""Writes the neuroglancer precomputed fixtures of tests/precomputed.rs with tensorstore's
`neuroglancer_precomputed` driver (the reference implementation beside cloud-volume).

Run from the repository root:

    python3 -m venv /tmp/n5py && /tmp/n5py/bin/pip install tensorstore numpy
    /tmp/n5py/bin/python tests/data/precomputed/make_fixtures.py

Every volume is 10 x 9 x 7 voxels (x y z) at voxel offset (4, 2, 2) (even, so the second scale, at half of it, covers the first 2 x 2 x 2 voxels of the first), in chunks of 6 x 5 x 4, so
chunks at the far edges are cut (tensorstore writes them so, as cloud-volume does):
- `raw-u16`: the voxels of tests/data/codecs/voxels.u16le, and a second scale of their
  2 x 2 x 2 means (s1.u16le) at twice the resolution (4 x 4 x 40 nm, then 8 x 8 x 80).
- `raw-u16-gzip`: the same files gzip-compressed, named `*.gz` as cloud-volume writes them.
- `png-u8` and `jpeg-u8`: those voxels' high bytes (voxels.u8); the JPEG is lossy, and
  `jpeg-u8.expected.u8` is what tensorstore (libjpeg-turbo) decodes it to.
- `rgb-u8`: three channels (the high bytes, the low bytes, their sum), raw
  (`rgb.u8`, channel after channel).
- `cseg-u32` and `cseg-u64`: segmentations in compressed_segmentation blocks of 4 x 4 x 2
  (labels.u32le / labels.u64le: a few labels in slabs, the u64 ones above 2^32).
- `sharded-u16`: the raw-u16 voxels in a sharded scale (murmurhash3, gzip indexes and data).
- `sharded-cseg-u64`: the uint64 labels, compressed_segmentation, in a sharded scale of
  another layout (identity hash, 4 shards of 2 minishards, raw indexes and data).

versions.json records the versions used.
"""

import gzip
import json
import shutil
from importlib.metadata import version
from pathlib import Path

import numpy as np
import tensorstore as ts

HERE = Path(__file__).resolve().parent
VOXELS = HERE.parent / "codecs" / "voxels.u16le"
SIZE = [10, 9, 7]
OFFSET = [4, 2, 2]
CHUNK = [6, 5, 4]


def voxels() -> np.ndarray:
    """(z, y, x), x fastest."""
    return np.fromfile(VOXELS, dtype="<u2").reshape(SIZE[::-1])


def halved(values: np.ndarray) -> np.ndarray:
    z, y, x = values.shape
    padded = np.pad(values.astype(np.float64), [(0, z % 2), (0, y % 2), (0, x % 2)], mode="edge")
    zz, yy, xx = padded.shape
    means = padded.reshape(zz // 2, 2, yy // 2, 2, xx // 2, 2).mean(axis=(1, 3, 5))
    return np.floor(means).astype(values.dtype)


def create(path: Path, data_type: str, scales: list, channels=1, kind="image"):
    shutil.rmtree(path, ignore_errors=True)
    stores = []
    for i, scale in enumerate(scales):
        spec = {
            "driver": "neuroglancer_precomputed",
            "kvstore": {"driver": "file", "path": str(path)},
            "scale_metadata": scale,
            "create": True,
        }
        if i == 0:
            spec["multiscale_metadata"] = {"type": kind, "data_type": data_type, "num_channels": channels}
        else:
            spec["open"] = True
        stores.append(ts.open(spec).result())
    return stores


def scale(resolution, size=SIZE, offset=OFFSET, **extra):
    return {"size": size, "resolution": resolution, "chunk_size": CHUNK, "voxel_offset": offset,
            "encoding": "raw", **extra}


def write(store, values: np.ndarray):
    """`values` (z, y, x) or (c, z, y, x) into a store indexed x, y, z, channel."""
    if values.ndim == 3:
        values = values[np.newaxis]
    store[...] = np.transpose(values, (3, 2, 1, 0))


def main() -> None:
    values = voxels()
    coarse = halved(values)
    coarse.tofile(HERE / "s1.u16le")
    half = [(s + 1) // 2 for s in SIZE]
    half_offset = [o // 2 for o in OFFSET]

    fine, second = create(HERE / "raw-u16", "uint16", [
        scale([4, 4, 40]), scale([8, 8, 80], size=half, offset=half_offset)])
    write(fine, values)
    write(second, coarse)

    gz = HERE / "raw-u16-gzip"
    shutil.rmtree(gz, ignore_errors=True)
    shutil.copytree(HERE / "raw-u16", gz)
    for chunk in gz.glob("*/*-*_*-*_*-*"):
        chunk.with_name(chunk.name + ".gz").write_bytes(gzip.compress(chunk.read_bytes(), mtime=0))
        chunk.unlink()

    high = (values >> 8).astype(np.uint8)
    high.tofile(HERE / "voxels.u8")
    (png,) = create(HERE / "png-u8", "uint8", [scale([4, 4, 40], encoding="png")])
    write(png, high)
    (jpeg,) = create(HERE / "jpeg-u8", "uint8", [scale([4, 4, 40], encoding="jpeg", jpeg_quality=95)])
    write(jpeg, high)
    decoded = np.transpose(jpeg.read().result(), (3, 2, 1, 0))[0]
    decoded.astype(np.uint8).tofile(HERE / "jpeg-u8.expected.u8")

    rgb = np.stack([high, (values & 255).astype(np.uint8), (high + (values & 255)).astype(np.uint8)])
    rgb.tofile(HERE / "rgb.u8")
    (three,) = create(HERE / "rgb-u8", "uint8", [scale([4, 4, 40])], channels=3)
    write(three, rgb)

    z, y, x = np.indices(SIZE[::-1])
    labels = (1 + (x // 3) + 4 * (z // 2) + ((x + y) % 5 == 0) * 100).astype(np.uint32)
    labels.astype("<u4").tofile(HERE / "labels.u32le")
    block = {"encoding": "compressed_segmentation", "compressed_segmentation_block_size": [4, 4, 2]}
    (cseg,) = create(HERE / "cseg-u32", "uint32", [scale([4, 4, 40], **block)], kind="segmentation")
    write(cseg, labels)
    wide = labels.astype(np.uint64) * np.uint64(1 << 33) + np.uint64(7)
    wide.astype("<u8").tofile(HERE / "labels.u64le")
    (cseg64,) = create(HERE / "cseg-u64", "uint64", [scale([4, 4, 40], **block)], kind="segmentation")
    write(cseg64, wide)

    sharding = {"@type": "neuroglancer_uint64_sharded_v1", "preshift_bits": 1,
                "hash": "murmurhash3_x86_128", "minishard_bits": 1, "shard_bits": 1,
                "minishard_index_encoding": "gzip", "data_encoding": "gzip"}
    (sharded,) = create(HERE / "sharded-u16", "uint16", [scale([4, 4, 40], sharding=sharding)])
    write(sharded, values)
    identity = {"@type": "neuroglancer_uint64_sharded_v1", "preshift_bits": 0,
                "hash": "identity", "minishard_bits": 1, "shard_bits": 2,
                "minishard_index_encoding": "raw", "data_encoding": "raw"}
    (cseg_sharded,) = create(HERE / "sharded-cseg-u64", "uint64",
                             [scale([4, 4, 40], sharding=identity, **block)], kind="segmentation")
    write(cseg_sharded, wide)

    (HERE / "versions.json").write_text(json.dumps({
        "tensorstore": version("tensorstore"),
        "numpy": version("numpy"),
    }, indent=2) + "\n")


if __name__ == "__main__":
    main()
