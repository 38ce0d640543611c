"""Writes a large Imaris file for the streaming benchmark (docs/benchmarks.md "Imaris"), in the
layout Imaris writes, with h5py: the confocal nuclei (../shared/data/nuclei-60x256x256.tif,
saved as .npy), padded to 64 planes by mirroring its last 4, tiled TZ x TY x TX times (default
10 x 16 x 16: 4096 x 4096 x 640 u16, 21.5 GB), and its resolution levels the 2 x 2 x 2 means
down to 256 voxels across (each level the tiles of the means of the tile, which equals the
means of the tiled volume). Chunks of 16 x 256 x 256, shuffle and deflate (level 1) as Imaris
writes them; compressed by a thread per core and written with write_direct_chunk.

Usage: python3 make_ims.py NUCLEI.npy OUT.ims [TZ,TY,TX]
"""

import sys
import time
import zlib
from concurrent.futures import ThreadPoolExecutor

import h5py
import numpy as np

CHUNK = (16, 256, 256)


def text(node, name, value):
    node.attrs.create(name, np.frombuffer(str(value).encode(), dtype="S1"), dtype="S1")


def halve(v):
    z, y, x = v.shape
    return v.reshape(z // 2, 2, y // 2, 2, x // 2, 2).mean(axis=(1, 3, 5)).astype(np.uint16)


def compressed(block):
    shuffled = block.view(np.uint8).reshape(-1, 2).T.tobytes()
    return zlib.compress(shuffled, 1)


def main():
    nuclei = np.load(sys.argv[1])
    out = sys.argv[2]
    tiles = [int(t) for t in (sys.argv[3] if len(sys.argv) > 3 else "10,16,16").split(",")]
    tile = np.concatenate([nuclei, nuclei[-1:-5:-1]])  # 64 planes
    started = time.time()
    written = 0
    with h5py.File(out, "w") as f, ThreadPoolExecutor() as pool:
        for k, v in dict(DataSetDirectoryName="DataSet", DataSetInfoDirectoryName="DataSetInfo",
                         ImarisDataSet="ImarisDataSet", ImarisVersion="5.5.0",
                         ThumbnailDirectoryName="Thumbnail").items():
            text(f, k, v)
        base, level = tile, 0
        while True:
            dims = [n * t for n, t in zip(base.shape, tiles)]
            group = f.require_group(f"DataSet/ResolutionLevel {level}/TimePoint 0/Channel 0")
            chunk = tuple(min(c, d) for c, d in zip(CHUNK, dims))
            padded = [-(-d // c) * c for d, c in zip(dims, chunk)]
            data = group.create_dataset("Data", shape=padded, dtype=np.uint16, chunks=chunk,
                                        compression="gzip", compression_opts=1, shuffle=True)
            for axis, n in zip("ZYX", dims):
                text(group, f"ImageSize{axis}", n)
            for z0 in range(0, padded[0], chunk[0]):
                planes = [base[z % base.shape[0]] if z < dims[0] else np.zeros_like(base[0])
                          for z in range(z0, z0 + chunk[0])]
                slab = np.tile(np.stack(planes), (1, tiles[1], tiles[2]))
                boxes = [(y0, x0) for y0 in range(0, dims[1], chunk[1])
                         for x0 in range(0, dims[2], chunk[2])]
                parts = pool.map(lambda b: compressed(np.ascontiguousarray(
                    slab[:, b[0]:b[0] + chunk[1], b[1]:b[1] + chunk[2]])), boxes)
                for (y0, x0), part in zip(boxes, parts):
                    data.id.write_direct_chunk((z0, y0, x0), part, 0)
                    written += len(part)
            print(f"level {level}: {dims[2]}x{dims[1]}x{dims[0]} in {time.time() - started:.1f} s",
                  flush=True)
            if max(dims[1:]) <= 256 or min(base.shape) < 2:
                break
            base, level = halve(base), level + 1
        z, y, x = [n * t for n, t in zip(tile.shape, tiles)]
        image = f.require_group("DataSetInfo/Image")
        for k, v in [("X", x), ("Y", y), ("Z", z), ("Unit", "um"), ("ExtMin0", 0), ("ExtMin1", 0),
                     ("ExtMin2", 0), ("ExtMax0", f"{x * 0.26:.3f}"), ("ExtMax1", f"{y * 0.26:.3f}"),
                     ("ExtMax2", f"{z * 0.29:.3f}"), ("Name", "nuclei tiled")]:
            text(image, k, v)
        channel = f.require_group("DataSetInfo/Channel 0")
        text(channel, "Name", "nuclei")
        text(channel, "Color", "0.000 1.000 1.000")
        text(channel, "ColorRange", "2750 33811")
    print(f"wrote {out}: {written / 1e9:.2f} GB compressed in {time.time() - started:.1f} s")


if __name__ == "__main__":
    main()
