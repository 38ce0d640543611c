"""Writes the codec fixtures of crates/voxscope-volume/tests/codecs.rs with the reference
implementation.

Run from the repository root:

    python3 -m venv /tmp/zpy && /tmp/zpy/bin/pip install zarr numcodecs numpy
    /tmp/zpy/bin/python tests/data/codecs/make_fixtures.py

One tiny array (10 x 9 x 7 voxels, x y z, u16; chunks 6 x 5 x 4, so every array has partial
chunks at its edges) per compressor that real Zarr v2 and v3 stores use, all holding the same
voxels: `voxels.u16le` (z, y, x order, x fastest, little-endian). zarr-python writes the
chunks with numcodecs; expected.json records the versions, each array's codec as `voxscope info`
names it, and, for the one layout voxscope refuses, the words of its error.
"""

import json
import lzma
import shutil
import sys
from pathlib import Path

import numcodecs
import numpy as np
import zarr
import zarr.codecs
import zarr.codecs.numcodecs as v3_numcodecs

HERE = Path(__file__).resolve().parent
SHAPE = (7, 9, 10)  # z, y, x
CHUNKS = (4, 5, 6)


def voxels() -> np.ndarray:
    """Values over the whole u16 range, varied enough that no codec stores them trivially."""
    z, y, x = np.indices(SHAPE, dtype=np.int64)
    values = (x * 2749 + y * 977 + z * 4001 + (x * y * z) % 255) % 65536
    return values.astype("<u2")


def write_v2(name: str, compressor) -> None:
    path = HERE / name
    shutil.rmtree(path, ignore_errors=True)
    array = zarr.create_array(
        store=str(path),
        shape=SHAPE,
        chunks=CHUNKS,
        dtype="<u2",
        zarr_format=2,
        compressors=compressor,
        fill_value=0,
    )
    array[...] = voxels()


def write_v3(name: str, compressors) -> None:
    path = HERE / name
    shutil.rmtree(path, ignore_errors=True)
    array = zarr.create_array(
        store=str(path),
        shape=SHAPE,
        chunks=CHUNKS,
        dtype="uint16",
        zarr_format=3,
        compressors=compressors,
        fill_value=0,
    )
    array[...] = voxels()


def main() -> None:
    data = voxels()
    (HERE / "voxels.u16le").write_bytes(data.tobytes(order="C"))
    fixtures = {}

    def v2(name, compressor, codec, error=None):
        write_v2(name, compressor)
        fixtures[name] = {"zarr_format": 2, "codec": codec}
        if error:
            fixtures[name]["error"] = error

    def v3(name, compressors, codec):
        write_v3(name, compressors)
        fixtures[name] = {"zarr_format": 3, "codec": codec}

    Blosc = numcodecs.Blosc
    for cname in ["blosclz", "lz4", "lz4hc", "zlib", "zstd"]:
        v2(f"v2-blosc-{cname}.zarr", Blosc(cname=cname, clevel=5, shuffle=Blosc.SHUFFLE), f"blosc {cname}")
    v2("v2-blosc-zstd-bitshuffle.zarr", Blosc(cname="zstd", shuffle=Blosc.BITSHUFFLE), "blosc zstd")
    v2("v2-blosc-lz4-noshuffle.zarr", Blosc(cname="lz4", shuffle=Blosc.NOSHUFFLE), "blosc lz4")
    v2("v2-zstd.zarr", numcodecs.Zstd(level=3), "zstd")
    v2("v2-gzip.zarr", numcodecs.GZip(level=5), "gzip")
    v2("v2-zlib.zarr", numcodecs.Zlib(level=5), "zlib")
    v2("v2-bz2.zarr", numcodecs.BZ2(level=9), "bz2")
    v2("v2-lz4.zarr", numcodecs.LZ4(acceleration=1), "lz4")
    v2("v2-lzma.zarr", numcodecs.LZMA(), "lzma")
    v2("v2-lzma-alone.zarr", numcodecs.LZMA(format=lzma.FORMAT_ALONE), "lzma")
    v2(
        "v2-lzma-raw-lzma2.zarr",
        numcodecs.LZMA(format=lzma.FORMAT_RAW, filters=[{"id": lzma.FILTER_LZMA2, "preset": 1}]),
        "lzma",
    )
    v2(
        "v2-lzma-raw-delta.zarr",
        numcodecs.LZMA(
            format=lzma.FORMAT_RAW,
            filters=[{"id": lzma.FILTER_DELTA, "dist": 2}, {"id": lzma.FILTER_LZMA2, "preset": 1}],
        ),
        "lzma",
        error="lzma: a raw stream with filters other than one LZMA2 filter",
    )
    v2("v2-none.zarr", None, "none")

    v3("v3-blosc-lz4.zarr", zarr.codecs.BloscCodec(cname="lz4", clevel=5, shuffle="shuffle"), "blosc lz4")
    v3("v3-zstd.zarr", zarr.codecs.ZstdCodec(level=3), "zstd")
    v3("v3-gzip.zarr", zarr.codecs.GzipCodec(level=5), "gzip")
    v3("v3-zlib.zarr", v3_numcodecs.Zlib(level=5), "zlib")
    v3("v3-bz2.zarr", v3_numcodecs.BZ2(level=9), "bz2")
    v3("v3-lz4.zarr", v3_numcodecs.LZ4(acceleration=1), "lz4")
    v3("v3-lzma.zarr", v3_numcodecs.LZMA(), "lzma")
    # numcodecs' own settings under a v3 name (zstd without `checksum`, blosc's numeric
    # `shuffle`), as zarr-python 3 writes them for numcodecs codecs.
    v3("v3-numcodecs-zstd.zarr", v3_numcodecs.Zstd(level=3), "zstd")
    v3("v3-numcodecs-blosc.zarr", v3_numcodecs.Blosc(cname="zstd", clevel=5, shuffle=1), "blosc zstd")
    v3("v3-none.zarr", None, "none")

    # Each array reads back equal to the voxels through the reference implementation.
    for name, fixture in fixtures.items():
        assert np.array_equal(zarr.open_array(str(HERE / name), mode="r")[...], data), name

    versions = {
        "zarr": zarr.__version__,
        "numcodecs": numcodecs.__version__,
        "numpy": np.__version__,
        "python": sys.version.split()[0],
    }
    expected = {"versions": versions, "shape_zyx": list(SHAPE), "chunks_zyx": list(CHUNKS), "fixtures": fixtures}
    (HERE / "expected.json").write_text(json.dumps(expected, indent=1) + "\n")


if __name__ == "__main__":
    main()
