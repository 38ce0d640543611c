#!/usr/bin/env python3
"""voxscope corpus sweep (issue 27, "Data as it is found").

Writes a corpus of small Zarr / OME-Zarr layouts that the specs and their producers allow
(zarr-python v2 and v3 options, ome-zarr-py, bioformats2raw-style containers, hand-written
OME-Zarr 0.1-0.5 metadata), plus a few illegal layouts that must be refused, then runs
voxscope on every member and prints a Markdown table (the body of docs/bench/corpus.md).

Run:
    python3 -m venv /tmp/corpus-venv
    /tmp/corpus-venv/bin/pip install zarr numcodecs ome-zarr numpy
    WGPU_BACKEND=vulkan XDG_RUNTIME_DIR=/tmp/xdg \
        /tmp/corpus-venv/bin/python docs/bench/corpus.py --voxscope PATH/TO/voxscope \
        --dir /tmp/corpus/members > corpus-table.md
    (--no-render skips the render step.)

Versions used for docs/bench/corpus.md: Python 3.11.7 venv with zarr 3.1.6, numcodecs 0.16.6,
ome-zarr 0.18.0 (ome-zarr-models 1.7), numpy 2.4.6, dask 2026.8.0; voxscope 0.1.0, a dev build
of main at 001ee70; lavapipe (Mesa's software Vulkan) for render.

Each member is a tiny image (level 0 is 13x17x20 zyx, or 17x20 yx, with t/c axes where the
layout has them) of seeded random values filling the dtype's range (floats: normal values).
For every member:
  1. `voxscope info --json MEMBER` (+ the member's options): opens or not; the one-line error.
  2. Bit-identical check: for every (channel, time) frame written, `voxscope convert
     --compression none --channel C --time T MEMBER OUT.ome.zarr`, then zarr-python reads
     OUT/0 and every voxel is compared with the array written (NaN equal to NaN). This
     proves voxscope read every voxel of the frame right (convert writes the values it read,
     uncompressed). uint64/int64 are read as float64 by design (docs/formats.md): those are
     compared after both sides are rounded to float64.
     `info`'s value_range is also compared with the frame's min/max (channel 0, time 0).
  3. `voxscope render MEMBER -o x.png --size 64x48` (lavapipe), exit status only.
  4. A member voxscope does not open is read with zarr-python (`zarr.open_array`), to show
     the layout is readable by its producer (a group says so).
`expect`: "open" (legal, should open), "refuse" (illegal, or a refusal docs/formats.md
documents: a one-line error is the right answer), "either" (defensible both ways).
"""
import argparse, json, os, shutil, subprocess, sys, traceback, warnings
warnings.simplefilter("ignore")  # numcodecs.zarr3 deprecation / v2 metadata notices
import numpy as np
import zarr
import numcodecs
from numcodecs import zarr3 as n3
from zarr.codecs import (BloscCodec, BytesCodec, GzipCodec, ZstdCodec, ShardingCodec,
                         TransposeCodec, Crc32cCodec)

ZYX = (13, 17, 20)
YX = (17, 20)
MEMBERS = []


def member(name, layout, expect="open", opts=(), conv_opts=None, conv_path=None, notes=""):
    def deco(fn):
        MEMBERS.append(dict(name=name, layout=layout, expect=expect, opts=list(opts),
                            conv_opts=conv_opts, conv_path=conv_path, fn=fn, notes=notes))
        return fn
    return deco


def data(shape, dtype, seed):
    rng = np.random.default_rng(seed)
    dt = np.dtype(dtype)
    if dt.kind == "f":
        return rng.normal(100, 30, shape).astype(dt)
    if dt.kind == "b":
        return rng.integers(0, 2, shape).astype(bool)
    if dt.kind == "c":
        return (rng.normal(size=shape) + 1j * rng.normal(size=shape)).astype(dt)
    info = np.iinfo(dt)
    return rng.integers(info.min, info.max, shape, dtype=dt.newbyteorder("="), endpoint=True).astype(dt)


def frames(a, axes):
    """{(c,t): 3D/2D frame} from an array with the named axes."""
    out = {}
    C = a.shape[axes.index("c")] if "c" in axes else 1
    T = a.shape[axes.index("t")] if "t" in axes else 1
    for c in range(C):
        for t in range(T):
            idx = []
            for ax, n in zip(axes, a.shape):
                idx.append(c if ax == "c" else t if ax == "t" else slice(None))
            out[(c, t)] = a[tuple(idx)]
    return out


def arr(path, a, zf, name=None, **kw):
    kw.setdefault("chunks", tuple(min(8, n) for n in a.shape))
    z = zarr.create_array(path, name=name, shape=a.shape, dtype=a.dtype, zarr_format=zf,
                          overwrite=True, **kw)
    z[...] = a
    return z


def plain(path, a, zf, axes="zyx", **kw):
    arr(path, a, zf, **kw)
    return frames(a, axes)

# ---------------------------------------------------------------- OME-Zarr by hand

def levels_of(a, axes, n=3, factors=None):
    """Coarser levels by striding the spatial axes (values unchecked)."""
    out = [a]
    for i in range(1, n):
        f = factors[i] if factors else 2 ** i
        idx = tuple(slice(None, None, f if ax in "zyx" else 1) for ax in axes)
        out.append(np.ascontiguousarray(a[idx]))
    return out


def axes_json(axes, version, units=True):
    if version in ("0.1", "0.2"):
        return None
    if version == "0.3":
        return list(axes)
    kinds = {"t": "time", "c": "channel", "z": "space", "y": "space", "x": "space"}
    res = []
    for ax in axes:
        d = {"name": ax, "type": kinds.get(ax, "space")}
        if units and kinds.get(ax) == "space":
            d["unit"] = "micrometer"
        res.append(d)
    return res


def ome(path, a, axes, version="0.4", nlev=3, factors=None, paths=None, scale0=None,
        translation=None, ms_transform=None, omero=None, chunks=None, extra_ms=None,
        zarr_format=None, consolidate=False, ms_extra_fields=None, dimension_names=False,
        **akw):
    zf = zarr_format or (3 if version == "0.5" else 2)
    g = zarr.open_group(path, mode="w", zarr_format=zf)
    levs = levels_of(a, axes, nlev, factors)
    paths = paths or [str(i) for i in range(nlev)]
    datasets = []
    for i, (p, lv) in enumerate(zip(paths, levs)):
        kw = dict(akw)
        if chunks:
            kw["chunks"] = chunks[i] if isinstance(chunks, list) else chunks
        if dimension_names:
            kw["dimension_names"] = list(axes)
        arr(os.path.join(path, p), lv, zf, **kw)
        ds = {"path": p}
        if version in ("0.4", "0.5"):
            sc = []
            for ax, n0, n in zip(axes, a.shape, lv.shape):
                base = (scale0 or {}).get(ax, 1.0)
                sc.append(base * (n0 / n) if ax in "zyx" else 1.0)
            ds["coordinateTransformations"] = [{"type": "scale", "scale": sc}]
            if translation:
                ds["coordinateTransformations"].append(
                    {"type": "translation", "translation": [translation.get(ax, 0.0) for ax in axes]})
        datasets.append(ds)
    ms = {"version": version, "datasets": datasets, "name": "img"}
    if version == "0.5":
        del ms["version"]
    ax = axes_json(axes, version)
    if ax is not None:
        ms["axes"] = ax
    if ms_transform:
        ms["coordinateTransformations"] = ms_transform
    if ms_extra_fields:
        ms.update(ms_extra_fields)
    mss = [ms] + (extra_ms or [])
    attrs = {"multiscales": mss}
    if omero:
        attrs["omero"] = omero
    if version == "0.5":
        g.attrs.update({"ome": dict(version="0.5", **attrs)})
    else:
        g.attrs.update(attrs)
    if consolidate:
        zarr.consolidate_metadata(path, zarr_format=zf)
    return frames(a, axes)


def omero_for(C, dtype):
    cols = ["00FF00", "FF00FF", "00FFFF", "FFFF00"]
    return {"channels": [{"label": f"ch{c}", "color": cols[c % 4], "active": True,
                          "window": {"start": 0, "end": 200, "min": 0, "max": 255}}
                         for c in range(C)], "rdefs": {"model": "color"}}

# ================================================================ members
# ---- plain Zarr v2 arrays: dtypes
for i, dt in enumerate(["u1", "i1", "<u2", "<i2", "<u4", "<i4", "<f4", "<f8", ">u2", ">i4", ">f4", ">f8", "<u8", "<i8"]):
    member(f"v2-dtype-{dt.replace('<','le').replace('>','be')}", f"v2 plain zyx, dtype '{dt}', zstd")(
        lambda p, dt=dt, i=i: plain(p, data(ZYX, dt, 100 + i), 2))
for i, dt in enumerate(["|b1", "<f2", "<c8"]):
    member(f"v2-dtype-{dt[1:]}", f"v2 plain zyx, dtype '{dt}' (documented as refused)", expect="refuse")(
        lambda p, dt=dt, i=i: plain(p, data(ZYX, dt, 120 + i), 2))

# ---- v2 compressors
V2C = {
    "none": None, "gzip": numcodecs.GZip(5), "zlib": numcodecs.Zlib(1), "bz2": numcodecs.BZ2(9),
    "lz4": numcodecs.LZ4(), "lz4-accel10": numcodecs.LZ4(acceleration=10),
    "lzma-xz": numcodecs.LZMA(), "lzma-alone": numcodecs.LZMA(format=2),
    "lzma-raw": numcodecs.LZMA(format=3, filters=[dict(id=0x21, preset=6)]),  # FORMAT_RAW, LZMA2
    "zstd": numcodecs.Zstd(3), "zstd-22-checksum": numcodecs.Zstd(level=22, checksum=True),
    "zstd-neg": numcodecs.Zstd(level=-5),
    "blosc-lz4-shuffle": numcodecs.Blosc("lz4", 5, numcodecs.Blosc.SHUFFLE),
    "blosc-lz4-bitshuffle": numcodecs.Blosc("lz4", 5, numcodecs.Blosc.BITSHUFFLE),
    "blosc-lz4-noshuffle": numcodecs.Blosc("lz4", 5, numcodecs.Blosc.NOSHUFFLE),
    "blosc-lz4hc": numcodecs.Blosc("lz4hc", 9, numcodecs.Blosc.SHUFFLE),
    "blosc-zstd-bitshuffle": numcodecs.Blosc("zstd", 5, numcodecs.Blosc.BITSHUFFLE),
    "blosc-zlib-shuffle": numcodecs.Blosc("zlib", 5, numcodecs.Blosc.SHUFFLE),
    "blosc-blosclz-noshuffle": numcodecs.Blosc("blosclz", 5, numcodecs.Blosc.NOSHUFFLE),
    "blosc-zstd-blocksize256": numcodecs.Blosc("zstd", 5, numcodecs.Blosc.SHUFFLE, blocksize=256),
    "blosc-clevel0": numcodecs.Blosc("lz4", 0, numcodecs.Blosc.SHUFFLE),
}
for i, (cn, c) in enumerate(V2C.items()):
    member(f"v2-comp-{cn}", f"v2 plain zyx u16, compressor {cn}")(
        lambda p, c=c, i=i: plain(p, data(ZYX, "<u2", 200 + i), 2, compressors=c))
member("v2-comp-blosc-f32-bitshuffle", "v2 plain zyx f32, blosc zstd bitshuffle")(
    lambda p: plain(p, data(ZYX, "<f4", 230), 2, compressors=numcodecs.Blosc("zstd", 5, 2)))

# ---- v2 filters (numcodecs `filters`)
V2F = {"delta": [numcodecs.Delta(dtype="<i2")],
       "shuffle": [numcodecs.Shuffle(elementsize=2)],
       "delta+shuffle": [numcodecs.Delta(dtype="<i2"), numcodecs.Shuffle(elementsize=2)],
       "fixedscaleoffset": [numcodecs.FixedScaleOffset(offset=0, scale=1, dtype="<i2", astype="<i2")]}
for i, (fn_, f) in enumerate(V2F.items()):
    member(f"v2-filter-{fn_}", f"v2 plain zyx i16, filters [{fn_}] + zstd")(
        lambda p, f=f, i=i: plain(p, data(ZYX, "<i2", 300 + i), 2, filters=f))

# ---- v2 order, separators, chunk shapes, fill values
member("v2-order-F-u16", "v2 plain zyx u16, order F")(lambda p: plain(p, data(ZYX, "<u2", 400), 2, order="F"))
member("v2-order-F-f64-gzip", "v2 plain zyx f64, order F, gzip")(
    lambda p: plain(p, data(ZYX, "<f8", 401), 2, order="F", compressors=numcodecs.GZip()))
member("v2-sep-slash", "v2 plain zyx u16, dimension_separator '/'")(
    lambda p: plain(p, data(ZYX, "<u2", 402), 2, chunk_key_encoding={"name": "v2", "separator": "/"}))
for i, ch in enumerate([(1, 17, 20), (13, 17, 1), (1, 1, 20), (5, 7, 3), (13, 17, 20), (32, 64, 64), (2, 3, 11)]):
    member(f"v2-chunks-{'x'.join(map(str, ch))}", f"v2 plain zyx u16, chunks {ch}")(
        lambda p, ch=ch, i=i: plain(p, data(ZYX, "<u2", 410 + i), 2, chunks=ch))


def sparse(dt, fill, seed):
    a = data(ZYX, dt, seed)
    a[:8, :8, :] = fill      # whole chunks of the fill value: not written
    a[8:, 8:16, 8:16] = fill
    return a


member("v2-missing-fill0", "v2 u16, chunks of the fill value 0 not written")(
    lambda p: plain(p, sparse("<u2", 0, 420), 2))
member("v2-missing-fill7", "v2 u16, fill_value 7, chunks of 7 not written")(
    lambda p: plain(p, sparse("<u2", 7, 421), 2, fill_value=7))
member("v2-missing-fillNaN-f32", "v2 f32, fill_value NaN, NaN chunks not written")(
    lambda p: plain(p, sparse("<f4", np.nan, 422), 2, fill_value=np.nan))
member("v2-missing-fill-neg-i16", "v2 i16, fill_value -1000, chunks of it not written")(
    lambda p: plain(p, sparse("<i2", -1000, 423), 2, fill_value=-1000))


def v2_fill_null(p):
    a = sparse("<u2", 0, 424)
    plain(p, a, 2)
    meta = json.load(open(os.path.join(p, ".zarray")))
    meta["fill_value"] = None
    json.dump(meta, open(os.path.join(p, ".zarray"), "w"))
    return frames(a, "zyx")


member("v2-fill-null-missing", "v2 u16, fill_value null (legal in v2), chunks missing",
       notes="spec: missing chunks of a null-fill array are undefined; zeros expected")(v2_fill_null)

# 2D / 4D / 5D plain v2
member("v2-plain-2d", "v2 plain yx u16 (2-D)")(lambda p: plain(p, data(YX, "<u2", 430), 2, axes="yx"))
member("v2-plain-4d-czyx", "v2 plain 4-D (c=2) u16, axes from the right: c z y x")(
    lambda p: plain(p, data((2,) + ZYX, "<u2", 431), 2, axes="czyx"))
member("v2-plain-5d-tczyx", "v2 plain 5-D (t=2,c=2) u8")(
    lambda p: plain(p, data((2, 2) + ZYX, "u1", 432), 2, axes="tczyx"))

# ---- plain Zarr v3 arrays
for i, dt in enumerate(["uint8", "int8", "uint16", "int16", "uint32", "int32", "float32", "float64", "uint64", "int64"]):
    member(f"v3-dtype-{dt}", f"v3 plain zyx {dt}, zstd (default)")(
        lambda p, dt=dt, i=i: plain(p, data(ZYX, dt, 500 + i), 3))
for i, dt in enumerate(["bool", "float16"]):
    member(f"v3-dtype-{dt}", f"v3 plain zyx {dt} (documented as refused)", expect="refuse")(
        lambda p, dt=dt, i=i: plain(p, data(ZYX, dt, 520 + i), 3))
member("v3-bytes-big-endian-u16", "v3 zyx u16, bytes codec endian big")(
    lambda p: plain(p, data(ZYX, "uint16", 530), 3, serializer=BytesCodec(endian="big")))
member("v3-bytes-big-endian-f64", "v3 zyx f64, bytes codec endian big, gzip")(
    lambda p: plain(p, data(ZYX, "float64", 531), 3, serializer=BytesCodec(endian="big"), compressors=GzipCodec()))

V3C = {
    "none": None, "gzip": GzipCodec(level=9), "zstd-checksum": ZstdCodec(level=3, checksum=True),
    "blosc-lz4-shuffle": BloscCodec(cname="lz4", shuffle="shuffle"),
    "blosc-zstd-bitshuffle": BloscCodec(cname="zstd", shuffle="bitshuffle"),
    "blosc-zlib-noshuffle": BloscCodec(cname="zlib", shuffle="noshuffle"),
    "blosc-blosclz-shuffle": BloscCodec(cname="blosclz", shuffle="shuffle"),
    "blosc-lz4hc-bitshuffle": BloscCodec(cname="lz4hc", shuffle="bitshuffle"),
    "numcodecs.zlib": n3.Zlib(level=1), "numcodecs.bz2": n3.BZ2(level=9),
    "numcodecs.lz4": n3.LZ4(), "numcodecs.lzma": n3.LZMA(),
    "crc32c": Crc32cCodec(), "zstd+crc32c": [ZstdCodec(level=3), Crc32cCodec()],
    "numcodecs.gzip": n3.GZip(level=5), "numcodecs.zstd": n3.Zstd(level=3),
}
for i, (cn, c) in enumerate(V3C.items()):
    member(f"v3-comp-{cn}", f"v3 plain zyx u16, bytes-to-bytes {cn}")(
        lambda p, c=c, i=i: plain(p, data(ZYX, "uint16", 600 + i), 3, compressors=c))
member("v3-comp-numcodecs.zstd-checksum", "v3 plain zyx u16, numcodecs.zstd with checksum true")(
    lambda p: plain(p, data(ZYX, "uint16", 620), 3, compressors=n3.Zstd(level=3, checksum=True)))
member("v3-comp-numcodecs.blosc", "v3 plain zyx u16, numcodecs.blosc (lz4, shuffle 1)")(
    lambda p: plain(p, data(ZYX, "uint16", 621), 3, compressors=n3.Blosc(cname="lz4", clevel=5, shuffle=1)))
member("v3-comp-numcodecs.blosc-zstd-bit", "v3 plain zyx f32, numcodecs.blosc (zstd, bitshuffle 2)")(
    lambda p: plain(p, data(ZYX, "float32", 622), 3, compressors=n3.Blosc(cname="zstd", clevel=5, shuffle=2)))
member("v3-filter-numcodecs.fixedscaleoffset", "v3 zyx i16, array-to-array numcodecs.fixedscaleoffset")(
    lambda p: plain(p, data(ZYX, "int16", 632), 3, filters=[n3.FixedScaleOffset(offset=0, scale=1, dtype="<i2")]))
member("v3-filter-numcodecs.delta", "v3 zyx i16, array-to-array numcodecs.delta")(
    lambda p: plain(p, data(ZYX, "int16", 630), 3, filters=[n3.Delta(dtype="<i2")]))
member("v3-filter-numcodecs.shuffle", "v3 zyx u16, bytes-to-bytes numcodecs.shuffle + zstd")(
    lambda p: plain(p, data(ZYX, "uint16", 631), 3, compressors=[n3.Shuffle(elementsize=2), ZstdCodec()]))
member("v3-transpose-210", "v3 zyx u16, transpose codec order [2,1,0]")(
    lambda p: plain(p, data(ZYX, "uint16", 640), 3, filters=[TransposeCodec(order=(2, 1, 0))]))
member("v3-transpose-120", "v3 zyx f32, transpose codec order [1,2,0]")(
    lambda p: plain(p, data(ZYX, "float32", 641), 3, filters=[TransposeCodec(order=(1, 2, 0))]))
member("v3-order-F", "v3 zyx u16 written with order='F' (array config only)")(
    lambda p: plain(p, data(ZYX, "uint16", 642), 3, order="F"))
member("v3-key-v2-dot", "v3 zyx u16, chunk_key_encoding v2 '.'")(
    lambda p: plain(p, data(ZYX, "uint16", 650), 3, chunk_key_encoding={"name": "v2", "separator": "."}))
member("v3-key-default-dot", "v3 zyx u16, chunk_key_encoding default '.'")(
    lambda p: plain(p, data(ZYX, "uint16", 651), 3, chunk_key_encoding={"name": "default", "separator": "."}))
member("v3-key-v2-slash", "v3 zyx u16, chunk_key_encoding v2 '/'")(
    lambda p: plain(p, data(ZYX, "uint16", 652), 3, chunk_key_encoding={"name": "v2", "separator": "/"}))
# sharding
member("v3-shard-end", "v3 zyx u16, shards 8x16x16 of 4³ chunks, index at end (crc32c)")(
    lambda p: plain(p, data(ZYX, "uint16", 660), 3, chunks=(4, 4, 4), shards=(8, 16, 16)))
member("v3-shard-single", "v3 zyx f32, one shard larger than the array")(
    lambda p: plain(p, data(ZYX, "float32", 661), 3, chunks=(4, 4, 4), shards=(16, 20, 20)))


def shard_custom(p, seed, index_location="end", index_codecs=None, inner=None, dt="uint16", a=None):
    a = data(ZYX, dt, seed) if a is None else a
    sc = ShardingCodec(chunk_shape=(4, 4, 4), codecs=inner or [BytesCodec(), ZstdCodec()],
                       index_codecs=index_codecs or [BytesCodec(), Crc32cCodec()],
                       index_location=index_location)
    z = zarr.create_array(p, shape=a.shape, dtype=a.dtype, chunks=(8, 8, 8), serializer=sc,
                          compressors=None, filters=None, overwrite=True)
    z[...] = a
    return frames(a, "zyx")


member("v3-shard-index-start", "v3 zyx u16, sharding index_location start")(lambda p: shard_custom(p, 662, "start"))
member("v3-shard-index-nocrc", "v3 zyx u16, sharding index without crc32c")(
    lambda p: shard_custom(p, 663, index_codecs=[BytesCodec()]))
member("v3-shard-inner-blosc-bigendian", "v3 zyx u16, shard inner bytes(big)+blosc")(
    lambda p: shard_custom(p, 664, inner=[BytesCodec(endian="big"), BloscCodec(cname="lz4", shuffle="bitshuffle")]))
member("v3-shard-inner-transpose", "v3 zyx u16, shard inner transpose+bytes+gzip")(
    lambda p: shard_custom(p, 665, inner=[TransposeCodec(order=(2, 1, 0)), BytesCodec(), GzipCodec()]))
member("v3-shard-missing-inner", "v3 zyx u16, shards with empty inner chunks, fill 0")(
    lambda p: shard_custom(p, 666, a=sparse("uint16", 0, 666)))
member("v3-shard-index-start-lz4", "v3 zyx i32, index start, inner numcodecs.lz4")(
    lambda p: shard_custom(p, 667, "start", inner=[BytesCodec(), n3.LZ4()], dt="int32"))
member("v3-shard-nested", "v3 zyx u16, sharding inside sharding")(
    lambda p: shard_custom(p, 668, inner=[ShardingCodec(chunk_shape=(2, 2, 2), codecs=[BytesCodec()])]))
for i, ch in enumerate([(1, 17, 20), (5, 7, 3), (32, 64, 64)]):
    member(f"v3-chunks-{'x'.join(map(str, ch))}", f"v3 plain zyx u16, chunks {ch}")(
        lambda p, ch=ch, i=i: plain(p, data(ZYX, "uint16", 670 + i), 3, chunks=ch))
member("v3-missing-fillNaN-f64", "v3 f64 fill NaN, NaN chunks not written")(
    lambda p: plain(p, sparse("float64", np.nan, 680), 3, fill_value=np.nan))
member("v3-missing-fill5-u8", "v3 u8 fill 5, chunks of 5 not written")(
    lambda p: plain(p, sparse("uint8", 5, 681), 3, fill_value=5))
member("v3-dimnames-zyx", "v3 zyx u16 dimension_names [z,y,x]")(
    lambda p: plain(p, data(ZYX, "uint16", 690), 3, dimension_names=["z", "y", "x"]))
member("v3-dimnames-czyx", "v3 c=3 zyx u16 dimension_names [c,z,y,x]")(
    lambda p: plain(p, data((3,) + ZYX, "uint16", 691), 3, axes="czyx", dimension_names=list("czyx")))
member("v3-dimnames-tzyx", "v3 t=2 zyx u8 dimension_names [t,z,y,x]")(
    lambda p: plain(p, data((2,) + ZYX, "uint8", 692), 3, axes="tzyx", dimension_names=list("tzyx")))
member("v3-dimnames-zcyx", "v3 z c y x (c=2 second) u16, dimension_names [z,c,y,x]")(
    lambda p: plain(p, data((13, 2, 17, 20), "uint16", 693), 3, axes="zcyx", dimension_names=list("zcyx")))
member("v3-dimnames-null-mixed", "v3 4-D, dimension_names [null,z,y,x] (c from the right)")(
    lambda p: plain(p, data((2,) + ZYX, "uint16", 694), 3, axes="czyx", dimension_names=[None, "z", "y", "x"]))
member("v3-plain-2d", "v3 plain yx f32 (2-D)")(lambda p: plain(p, data(YX, "float32", 695), 3, axes="yx"))

# ---- OME-Zarr written by hand: 0.1 - 0.5
member("ome0.1-tczyx-5d", "OME 0.1 (v2), 5-D 1x1xZYX, 3 levels, no axes")(
    lambda p: ome(p, data((1, 1) + ZYX, "<u2", 700), "tczyx", "0.1"))
member("ome0.2-tczyx-c2-omero", "OME 0.2 (v2), 5-D c=2, omero")(
    lambda p: ome(p, data((1, 2) + ZYX, "<u2", 701), "tczyx", "0.2", omero=omero_for(2, "u2")))
member("ome0.2-tczyx-t3", "OME 0.2 (v2), 5-D t=3 c=1 f32")(
    lambda p: ome(p, data((3, 1) + ZYX, "<f4", 702), "tczyx", "0.2"))
member("ome0.3-zyx", "OME 0.3 (v2), axes [z,y,x]")(lambda p: ome(p, data(ZYX, "<u2", 703), "zyx", "0.3"))
member("ome0.3-czyx", "OME 0.3 (v2), axes [c,z,y,x] c=2")(
    lambda p: ome(p, data((2,) + ZYX, "<u2", 704), "czyx", "0.3"))
member("ome0.3-yx-2d", "OME 0.3 (v2), axes [y,x] 2-D pyramid")(
    lambda p: ome(p, data(YX, "u1", 705), "yx", "0.3"))
member("ome0.3-tzyx", "OME 0.3 (v2), axes [t,z,y,x] t=2")(
    lambda p: ome(p, data((2,) + ZYX, "<i2", 706), "tzyx", "0.3"))
member("ome0.4-zyx", "OME 0.4 (v2) zyx u16, scale, units")(lambda p: ome(p, data(ZYX, "<u2", 710), "zyx"))
member("ome0.4-zyx-translation-aniso", "OME 0.4 zyx, anisotropic scale + translation")(
    lambda p: ome(p, data(ZYX, "<u2", 711), "zyx", scale0={"z": 2.5, "y": 0.3, "x": 0.3},
                  translation={"z": 10.0, "y": -4.0, "x": 7.5}))
member("ome0.4-tczyx-t2c3-omero", "OME 0.4 tczyx t=2 c=3, omero")(
    lambda p: ome(p, data((2, 3) + ZYX, "<u2", 712), "tczyx", omero=omero_for(3, "u2")))
member("ome0.4-czyx-i16", "OME 0.4 czyx c=2 i16")(lambda p: ome(p, data((2,) + ZYX, "<i2", 713), "czyx"))
member("ome0.4-tzyx-f32", "OME 0.4 tzyx t=2 f32")(lambda p: ome(p, data((2,) + ZYX, "<f4", 714), "tzyx"))
member("ome0.4-tcyx-2d", "OME 0.4 tcyx 2-D, t=2 c=2")(lambda p: ome(p, data((2, 2) + YX, "<u2", 715), "tcyx"))
member("ome0.4-yx-2d-pyramid", "OME 0.4 yx 2-D pyramid, 4 levels")(
    lambda p: ome(p, data(YX, "<u2", 716), "yx", nlev=4))
member("ome0.4-cyx-2d", "OME 0.4 cyx 2-D, c=3 u8")(lambda p: ome(p, data((3,) + YX, "u1", 717), "cyx"))
member("ome0.4-ms-transform", "OME 0.4 zyx, multiscale-level coordinateTransformations scale")(
    lambda p: ome(p, data(ZYX, "<u2", 718), "zyx",
                  ms_transform=[{"type": "scale", "scale": [0.5, 0.5, 0.5]}]))
member("ome0.4-nonpow2-levels", "OME 0.4 zyx, levels downsampled by 1, 3, 7 (non-power-of-two)")(
    lambda p: ome(p, data(ZYX, "<u2", 719), "zyx", factors=[1, 3, 7]))
member("ome0.4-per-level-chunks", "OME 0.4 zyx, different chunks per level")(
    lambda p: ome(p, data(ZYX, "<u2", 720), "zyx", chunks=[(5, 7, 9), (4, 4, 4), (13, 17, 20)]))
member("ome0.4-paths-nested", "OME 0.4 zyx, dataset paths 'scale/s0' … (nested)")(
    lambda p: ome(p, data(ZYX, "<u2", 721), "zyx", paths=["scale/s0", "scale/s1", "scale/s2"]))
member("ome0.4-consolidated", "OME 0.4 zyx, consolidated .zmetadata")(
    lambda p: ome(p, data(ZYX, "<u2", 722), "zyx", consolidate=True))
member("ome0.4-two-multiscales", "OME 0.4, two multiscales in the list (first is read)")(
    lambda p: ome(p, data(ZYX, "<u2", 723), "zyx",
                  extra_ms=[{"version": "0.4", "name": "other", "axes": axes_json("zyx", "0.4"),
                             "datasets": [{"path": "1", "coordinateTransformations": [
                                 {"type": "scale", "scale": [2.0, 2.0, 2.0]}]}]}]))
member("ome0.4-type-gaussian-metadata", "OME 0.4, multiscale type + metadata fields")(
    lambda p: ome(p, data(ZYX, "<u2", 724), "zyx",
                  ms_extra_fields={"type": "gaussian", "metadata": {"method": "skimage", "version": "0.19"}}))
member("ome0.4-order-F-blosc", "OME 0.4 zyx, arrays order F, blosc zstd bitshuffle")(
    lambda p: ome(p, data(ZYX, "<u2", 725), "zyx", order="F",
                  compressors=numcodecs.Blosc("zstd", 5, 2)))
member("ome0.4-sep-slash-lz4", "OME 0.4 zyx, '/' separator, numcodecs lz4")(
    lambda p: ome(p, data(ZYX, "<u2", 726), "zyx", chunk_key_encoding={"name": "v2", "separator": "/"},
                  compressors=numcodecs.LZ4()))
member("ome0.4-missing-nan", "OME 0.4 zyx f32, fill NaN, NaN chunks not written")(
    lambda p: ome(p, sparse("<f4", np.nan, 727), "zyx", fill_value=np.nan))
member("ome0.4-no-units", "OME 0.4 zyx without units")(
    lambda p: (lambda fr: (_strip_units(p), fr)[1])(ome(p, data(ZYX, "<u2", 728), "zyx")))


def _strip_units(p):
    a = json.load(open(os.path.join(p, ".zattrs")))
    for ax in a["multiscales"][0]["axes"]:
        ax.pop("unit", None)
    json.dump(a, open(os.path.join(p, ".zattrs"), "w"))


member("ome0.4-axis-custom-type", "OME 0.4, axes c is {type: 'channel'}, plus a custom-named time axis 'time'")(
    lambda p: _rename_axis(p, ome(p, data((2, 2) + ZYX, "<u2", 729), "tczyx"), 0, "time"))


def _rename_axis(p, fr, i, name):
    a = json.load(open(os.path.join(p, ".zattrs")))
    a["multiscales"][0]["axes"][i]["name"] = name
    json.dump(a, open(os.path.join(p, ".zattrs"), "w"))
    return fr


member("ome0.5-zyx", "OME 0.5 (v3) zyx u16, zstd")(lambda p: ome(p, data(ZYX, "uint16", 740), "zyx", "0.5"))
member("ome0.5-tczyx-omero", "OME 0.5 tczyx t=2 c=2, omero, dimension_names")(
    lambda p: ome(p, data((2, 2) + ZYX, "uint16", 741), "tczyx", "0.5", omero=omero_for(2, "u2"),
                  dimension_names=True))
member("ome0.5-sharded", "OME 0.5 zyx, sharded (4³ chunks in 8x16x16 shards)")(
    lambda p: ome(p, data(ZYX, "uint16", 742), "zyx", "0.5", chunks=(4, 4, 4), shards=(8, 16, 16)))
member("ome0.5-sharded-index-start-blosc", "OME 0.5 czyx c=2, shards index start, blosc")(
    lambda p: ome(p, data((2,) + ZYX, "uint16", 743), "czyx", "0.5", nlev=2,
                  serializer=ShardingCodec(chunk_shape=(1, 4, 4, 4), codecs=[BytesCodec(), BloscCodec()],
                                           index_location="start"), chunks=(1, 8, 16, 16),
                  compressors=None, filters=None))
member("ome0.5-yx-2d", "OME 0.5 yx 2-D f32")(lambda p: ome(p, data(YX, "float32", 744), "yx", "0.5"))
member("ome0.5-nonpow2", "OME 0.5 zyx, levels by 1, 3, 5")(
    lambda p: ome(p, data(ZYX, "int16", 745), "zyx", "0.5", factors=[1, 3, 5]))
member("ome0.5-consolidated", "OME 0.5 zyx, consolidated metadata in zarr.json")(
    lambda p: ome(p, data(ZYX, "uint16", 746), "zyx", "0.5", consolidate=True))
member("ome0.5-transpose-lzma", "OME 0.5 zyx, transpose codec + numcodecs.lzma")(
    lambda p: ome(p, data(ZYX, "uint16", 747), "zyx", "0.5", filters=[TransposeCodec(order=(2, 1, 0))],
                  compressors=n3.LZMA()))
member("ome0.5-translation-ms", "OME 0.5 tzyx, translation + multiscale scale")(
    lambda p: ome(p, data((2,) + ZYX, "float64", 748), "tzyx", "0.5", translation={"z": 1, "y": 2, "x": 3},
                  ms_transform=[{"type": "scale", "scale": [60.0, 1.0, 1.0, 1.0]}]))
member("ome0.4-on-v3", "OME 0.4 attributes on a Zarr v3 group (mixed; not a spec combination)",
       expect="either")(lambda p: ome(p, data(ZYX, "uint16", 749), "zyx", "0.4", zarr_format=3))

member("ome0.4-level-array-direct", "OME 0.4 zyx, its level array '0' opened as a plain array")(
    lambda p: ome(p, data(ZYX, "<u2", 750), "zyx"))
MEMBERS[-1]["open_sub"] = "0"
member("ome0.5-level-array-direct", "OME 0.5 zyx, its level array '1' opened as a plain array")(
    lambda p: {k: v[::2, ::2, ::2] for k, v in ome(p, data(ZYX, "uint16", 751), "zyx", "0.5").items()})
MEMBERS[-1]["open_sub"] = "1"


def plain_group(p, zf, seed):
    g = zarr.open_group(p, mode="w", zarr_format=zf)
    a = data(ZYX, "uint16", seed)
    arr(os.path.join(p, "raw"), a, zf)
    g.attrs.update({"description": "a plain Zarr group, no OME metadata"})
    return frames(a, "zyx")


member("v2-group-no-ome", "v2 plain group (no multiscales) holding one array 'raw'", expect="either")(
    lambda p: plain_group(p, 2, 752))
member("v3-group-no-ome", "v3 plain group (no multiscales) holding one array 'raw'", expect="either")(
    lambda p: plain_group(p, 3, 753))

# ---- illegal OME layouts: must be refused with one line
member("bad-4-space-axes", "OME 0.4 with 4 space axes (illegal)", expect="refuse")(
    lambda p: ome(p, data((2,) + ZYX, "<u2", 760), "wzyx"))
member("bad-dataset-dotdot", "OME 0.4 dataset path '../x' (illegal)", expect="refuse")(
    lambda p: _bad_path(p))


def _bad_path(p):
    fr = ome(p, data(ZYX, "<u2", 761), "zyx", nlev=1)
    a = json.load(open(os.path.join(p, ".zattrs")))
    a["multiscales"][0]["datasets"][0]["path"] = "../x"
    json.dump(a, open(os.path.join(p, ".zattrs"), "w"))
    return fr


member("bad-axes-ndim-mismatch", "OME 0.4 axes [c,z,y,x] over 3-D arrays (illegal)", expect="refuse")(
    lambda p: _rename(p, ome(p, data(ZYX, "<u2", 762), "zyx"),
                      lambda a: a["multiscales"][0].__setitem__("axes", axes_json("czyx", "0.4"))))


def _rename(p, fr, f):
    a = json.load(open(os.path.join(p, ".zattrs")))
    f(a)
    json.dump(a, open(os.path.join(p, ".zattrs"), "w"))
    return fr


def _missing_level(p):
    fr = ome(p, data(ZYX, "<u2", 763), "zyx")
    shutil.rmtree(os.path.join(p, "2"))
    return fr


member("bad-missing-level", "OME 0.4, dataset '2' listed but absent", expect="either",
       notes="level 0 is intact; refusing or opening level 0 are both defensible")(_missing_level)
member("bad-two-channel-axes", "OME 0.4 with two channel axes (illegal)", expect="refuse")(
    lambda p: _rename(p, ome(p, data((2, 2) + ZYX, "<u2", 764), "tczyx"),
                      lambda a: a["multiscales"][0]["axes"][0].__setitem__("type", "channel")))
member("bad-no-datasets", "OME 0.4 multiscales with empty datasets (illegal)", expect="refuse")(
    lambda p: _rename(p, ome(p, data(ZYX, "<u2", 765), "zyx"),
                      lambda a: a["multiscales"][0].__setitem__("datasets", [])))

# ---- ome-zarr-py 0.18 writers
from ome_zarr.format import FormatV04, FormatV05
from ome_zarr import writer as ow


def ozw(p, a, axes, fmt, **kw):
    zf = 3 if isinstance(fmt, FormatV05) else 2
    g = zarr.open_group(p, mode="w", zarr_format=zf)
    ow.write_image(a, g, axes=axes, fmt=fmt, **kw)
    return g


def ozw_member(a, axes, fmt, **kw):
    def fn(p):
        ozw(p, a, axes, fmt, **kw)
        return frames(a, axes)
    return fn


member("omezarrpy-v04-zyx", "ome-zarr-py write_image, fmt 0.4, zyx u16")(
    ozw_member(data(ZYX, "uint16", 800), "zyx", FormatV04()))
member("omezarrpy-v05-zyx", "ome-zarr-py write_image, fmt 0.5, zyx u16")(
    ozw_member(data(ZYX, "uint16", 801), "zyx", FormatV05()))
member("omezarrpy-v04-tczyx", "ome-zarr-py fmt 0.4 tczyx t=2 c=2 u8")(
    ozw_member(data((2, 2) + ZYX, "uint8", 802), "tczyx", FormatV04()))
member("omezarrpy-v05-czyx-scale", "ome-zarr-py fmt 0.5 czyx c=3 f32, scale + units")(
    ozw_member(data((3,) + ZYX, "float32", 803), "czyx", FormatV05(),
               scale={"z": 2.0, "y": 0.5, "x": 0.5}, axes_units={"z": "micrometer", "y": "micrometer", "x": "micrometer"}))
member("omezarrpy-v04-yx", "ome-zarr-py fmt 0.4 yx 2-D pyramid")(
    ozw_member(data(YX, "uint16", 804), "yx", FormatV04()))
member("omezarrpy-v05-tzyx-chunks", "ome-zarr-py fmt 0.5 tzyx t=2, storage_options chunks (1,5,5,5)")(
    ozw_member(data((2,) + ZYX, "int16", 805), "tzyx", FormatV05(), storage_options={"chunks": (1, 5, 5, 5)}))
member("omezarrpy-v04-scale-factors-3", "ome-zarr-py fmt 0.4 zyx, scale_factors (3, 6) (non-power-of-two)")(
    ozw_member(data(ZYX, "uint16", 806), "zyx", FormatV04(), scale_factors=(3, 6)))


def labels_member(fmt, seed):
    def fn(p):
        a = data(ZYX, "uint16", seed)
        g = ozw(p, a, "zyx", fmt)
        lab = (np.arange(np.prod(ZYX)).reshape(ZYX) // 500 % 7).astype("uint8")
        ow.write_labels(lab, g, name="cells", axes="zyx", fmt=fmt)
        return frames(a, "zyx")
    return fn


def labels_direct(fmt, seed):
    def fn(p):
        labels_member(fmt, seed)(p)
        lab = (np.arange(np.prod(ZYX)).reshape(ZYX) // 500 % 7).astype("uint8")
        return frames(lab, "zyx")
    return fn


# (ome-zarr-py 0.18 refuses to write 0.1-0.3: "Writing ome-zarr v0.3 is deprecated and has been
# removed in version 0.15.0"; those versions are written by hand above.)
member("omezarrpy-v04-labels", "ome-zarr-py fmt 0.4 image + labels/cells")(labels_member(FormatV04(), 810))
member("omezarrpy-v05-labels", "ome-zarr-py fmt 0.5 image + labels/cells")(labels_member(FormatV05(), 811))
member("omezarrpy-v04-labels-direct", "the label image labels/cells of a 0.4 image, opened itself",
       conv_path="labels/cells")(labels_direct(FormatV04(), 812))
MEMBERS[-1]["open_sub"] = "labels/cells"
member("omezarrpy-v05-labels-direct", "the label image labels/cells of a 0.5 image, opened itself")(
    labels_direct(FormatV05(), 813))
MEMBERS[-1]["open_sub"] = "labels/cells"


def plate(fmt, seed, field=None):
    def fn(p):
        zf = 3 if isinstance(fmt, FormatV05) else 2
        root = zarr.open_group(p, mode="w", zarr_format=zf)
        rows, cols = ["A", "B"], ["1", "2", "3"]
        wells = ["A/1", "A/3", "B/2"]
        ow.write_plate_metadata(root, rows, cols, wells, fmt=fmt, field_count=2, name="plate")
        out = {}
        for k, w in enumerate(wells):
            r, c = w.split("/")
            wg = root.require_group(r).require_group(c)
            ow.write_well_metadata(wg, ["0", "1"], fmt=fmt)
            for f in range(2):
                a = data((2,) + ZYX, "uint16", seed + 10 * k + f)
                ig = wg.require_group(str(f))
                ow.write_image(a, ig, axes="czyx", fmt=fmt, scale_factors=(2,))
                out[(w, f)] = a
        want = field or ("A/1", 0)
        return frames(out[want], "czyx")
    return fn


member("plate-v04", "HCS plate 0.4 (ome-zarr-py): 3 wells x 2 fields, czyx; first field")(plate(FormatV04(), 820))
member("plate-v05", "HCS plate 0.5 (ome-zarr-py): first field")(plate(FormatV05(), 830))
member("plate-v04-field-B2-1", "HCS plate 0.4, --field B/2/1", opts=["--field", "B/2/1"])(
    plate(FormatV04(), 840, ("B/2", 1)))
member("plate-v05-field-A3-1", "HCS plate 0.5, --field A/3/1", opts=["--field", "A/3/1"])(
    plate(FormatV05(), 850, ("A/3", 1)))
member("plate-v04-field-path", "HCS plate 0.4, the field's own path B/2/0")(plate(FormatV04(), 860, ("B/2", 0)))
MEMBERS[-1]["open_sub"] = "B/2/0"

# ---- bioformats2raw-style containers


def b2r(p, zf=2, series_attr=True, n=3, seed=900, which=0, omexml=True):
    version = "0.5" if zf == 3 else "0.4"
    g = zarr.open_group(p, mode="w", zarr_format=zf)
    if zf == 3:
        g.attrs.update({"ome": {"version": "0.5", "bioformats2raw.layout": 3}})
    else:
        g.attrs.update({"bioformats2raw.layout": 3})
    og = g.require_group("OME")
    if series_attr:
        if zf == 3:
            og.attrs.update({"ome": {"version": "0.5", "series": [str(i) for i in range(n)]}})
        else:
            og.attrs.update({"series": [str(i) for i in range(n)]})
    if omexml:
        with open(os.path.join(p, "OME", "METADATA.ome.xml"), "w") as f:
            f.write('<?xml version="1.0" encoding="UTF-8"?><OME xmlns="http://www.openmicroscopy.org/Schemas/OME/2016-06">'
                    + "".join(f'<Image ID="Image:{i}" Name="s{i}"><Pixels ID="Pixels:{i}" DimensionOrder="XYZCT" Type="uint16" SizeX="20" SizeY="17" SizeZ="13" SizeC="1" SizeT="1"/></Image>' for i in range(n))
                    + "</OME>")
    out = []
    for i in range(n):
        a = data((1, 1) + ZYX, "uint16", seed + i)
        ome(os.path.join(p, str(i)), a, "tczyx", version, nlev=2, chunks=(1, 1, 8, 8, 8))
        out.append(a)
    return frames(out[which], "tczyx")


member("b2r-v2-3series", "bioformats2raw layout 3, Zarr v2, 3 series, OME/METADATA.ome.xml, series attr")(
    lambda p: b2r(p))
member("b2r-v2-series1-path", "bioformats2raw v2 container, series '1' opened by its path")(
    lambda p: b2r(p, seed=910, which=1))
MEMBERS[-1]["open_sub"] = "1"
member("b2r-v2-no-series-attr", "bioformats2raw v2 container without OME 'series' attribute (older layout)")(
    lambda p: b2r(p, seed=920, series_attr=False))
member("b2r-v2-no-omexml", "bioformats2raw v2 container without METADATA.ome.xml")(
    lambda p: b2r(p, seed=930, omexml=False))
member("b2r-v3-0.5", "bioformats2raw layout in an OME-Zarr 0.5 (Zarr v3) container, 2 series")(
    lambda p: b2r(p, zf=3, n=2, seed=940))

# ================================================================ runner


def run(cmd, env=None, timeout=120):
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout)
        return r.returncode, r.stdout, r.stderr
    except subprocess.TimeoutExpired:
        return 124, "", "timed out"


def last_line(s):
    lines = [l for l in s.replace("\r", "\n").splitlines() if l.strip() and not l.startswith("converting")]
    return lines[-1].strip() if lines else ""


def compare(expected, got):
    exp = np.asarray(expected)
    if exp.ndim == 2:
        exp = exp[None]
    got = np.asarray(got)
    if got.shape != exp.shape:
        return False, f"shape {got.shape} != written {exp.shape}"
    if exp.dtype.kind in "iu" and exp.dtype.itemsize == 8:
        ok = np.array_equal(got.astype(np.float64), exp.astype(np.float64))
        return ok, "" if ok else "values differ"
    if exp.dtype.kind == "f":
        ok = np.array_equal(got.astype(exp.dtype.newbyteorder("=")), exp.astype(exp.dtype.newbyteorder("=")), equal_nan=True)
    else:
        ok = np.array_equal(got, exp)
    if not ok:
        diff = np.count_nonzero(~((got == exp) | (np.isnan(got.astype(float)) & np.isnan(exp.astype(float)))))
        return False, f"{diff} of {exp.size} voxels differ"
    if got.dtype.newbyteorder("=") != exp.dtype.newbyteorder("="):
        return True, f"read as {got.dtype}"
    return True, ""


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--voxscope", default="/tmp/corpus/voxscope")
    ap.add_argument("--dir", default="/tmp/corpus/members")
    ap.add_argument("--no-render", action="store_true")
    ap.add_argument("--only", default=None)
    ap.add_argument("--json", default=None, help="also write the results as JSON here")
    args = ap.parse_args()
    vx = args.voxscope
    os.makedirs(args.dir, exist_ok=True)
    env = dict(os.environ, WGPU_BACKEND=os.environ.get("WGPU_BACKEND", "vulkan"),
               XDG_RUNTIME_DIR=os.environ.get("XDG_RUNTIME_DIR", "/tmp/xdg"))
    os.makedirs(env["XDG_RUNTIME_DIR"], exist_ok=True)
    results = []
    for m in MEMBERS:
        if args.only and args.only not in m["name"]:
            continue
        path = os.path.join(args.dir, m["name"] + (".ome.zarr" if m["name"].startswith(("ome", "plate", "b2r", "bad")) else ".zarr"))
        shutil.rmtree(path, ignore_errors=True)
        res = dict(name=m["name"], layout=m["layout"], expect=m["expect"], notes=m["notes"])
        try:
            expected = m["fn"](path)
        except Exception as e:
            res.update(written=False, error="writer: " + last_line(traceback.format_exc()))
            results.append(res)
            print(f"{m['name']}: WRITE FAILED {res['error']}", file=sys.stderr)
            continue
        res["written"] = True
        target = os.path.join(path, m.get("open_sub", "")) if m.get("open_sub") else path
        rc, out, err = run([vx, "info", "--json", target] + m["opts"], env)
        res["opens"] = rc == 0
        if rc != 0:
            res["error"] = last_line(err) or last_line(out)
            try:
                za = zarr.open_array(target, mode="r")
                ok, _ = compare(expected[(0, 0)], za[...]) if za.ndim == np.asarray(expected[(0, 0)]).ndim else (None, "")
                res["zarr_python"] = "reads it back equal" if ok else f"reads it ({za.dtype}, {za.shape})"
            except Exception as e:
                res["zarr_python"] = "no array at the root (a group)" if ("no array found" in str(e).lower() or "got 'group'" in str(e).lower()) \
                    else "fails: " + str(e).splitlines()[0][:80]
        else:
            try:
                info = json.loads(out)
                vr = info["volume"]["value_range"]
                f0 = np.asarray(expected[(0, 0)], dtype=np.float64)
                want = [float(np.nanmin(f0)), float(np.nanmax(f0))]
                res["range_ok"] = np.allclose(vr, want, rtol=1e-6, atol=0)
                res["info"] = f"{info['volume']['dims']} {info['volume']['voxel_type']}, " \
                    f"c={len(info['volume']['channels'])} t={info['volume']['time_points']}"
            except Exception as e:
                res["range_ok"] = False
                res["info"] = f"info json: {e}"
            # bit-identical: convert every frame, read it back
            conv_src = target
            if m["opts"] and m["opts"][0] == "--field":
                conv_src = os.path.join(path, m["opts"][1].rsplit("/", 1)[0], m["opts"][1].rsplit("/", 1)[1])
                r_, c_, f_ = m["opts"][1].split("/")
                conv_src = os.path.join(path, r_, c_, f_)
            ok_all, notes = True, []
            for (c, t), fr in sorted(expected.items()):
                outp = os.path.join(args.dir, "_conv.ome.zarr")
                shutil.rmtree(outp, ignore_errors=True)
                rc2, o2, e2 = run([vx, "convert", "--compression", "none", "--channel", str(c), "--time", str(t),
                                   conv_src, outp], env)
                if rc2 != 0:
                    ok_all = False
                    notes.append(f"convert c{c} t{t}: {last_line(e2) or last_line(o2)}")
                    break
                got = zarr.open_array(os.path.join(outp, "0"), mode="r")[...]
                ok, why = compare(fr, got)
                if why:
                    notes.append(f"c{c} t{t}: {why}")
                if not ok:
                    ok_all = False
                    break
            res["identical"] = ok_all
            res["frames"] = len(expected)
            res["check_notes"] = "; ".join(sorted(set(n.split(": ", 1)[1] if n.startswith("c") and "read as" in n else n for n in notes)))
            if not args.no_render:
                rc3, o3, e3 = run([vx, "render", target, "-o", os.path.join(args.dir, "_r.png"), "--size", "64x48"]
                                  + m["opts"], env)
                res["renders"] = rc3 == 0
                if rc3 != 0:
                    res["render_error"] = last_line(e3)
        results.append(res)
        print(f"{m['name']}: opens={res.get('opens')} identical={res.get('identical')} "
              f"{res.get('error', '')} {res.get('check_notes', '')}", file=sys.stderr)
    if args.json:
        json.dump(results, open(args.json, "w"), indent=1)
    # table
    print("| # | member | layout | expected | opens | bit-identical (frames) | render | error / note |")
    print("|---|---|---|---|---|---|---|---|")
    for i, r in enumerate(results, 1):
        r["layout"] = r["layout"].replace("|", "\\|")
        if not r["written"]:
            print(f"| {i} | `{r['name']}` | {r['layout']} | {r['expect']} | (not written) | | | {r['error']} |")
            continue
        op = "yes" if r["opens"] else "no"
        ident = ("yes" if r["identical"] else "**no**") + f" ({r['frames']})" if r["opens"] else ""
        if r["opens"] and not r.get("range_ok", True):
            ident += ", info range differs"
        rend = ("yes" if r.get("renders") else "**no**") if r["opens"] and "renders" in r else ""
        note = r.get("error") or r.get("check_notes") or ""
        if r.get("zarr_python"):
            note += f" (zarr-python: {r['zarr_python']})"
        if r.get("render_error"):
            note += " render: " + r["render_error"]
        if r.get("notes"):
            note += (" — " if note else "") + r["notes"]
        note = note.replace("|", "\\|")
        print(f"| {i} | `{r['name']}` | {r['layout']} | {r['expect']} | {op} | {ident} | {rend} | {note} |")


if __name__ == "__main__":
    main()
