#!/usr/bin/env bash
# Thin-chunked stores (issue 54, docs/benchmarks.md "Streaming"): the same voxels three times,
# written by zarr-python/ome-zarr-py: 64³ chunks (OME-Zarr 0.4), one-plane 1×1024×1024 chunks
# (0.4, unsharded) and one-plane inner chunks of 64×1024×1024 shards (0.5). The voxels: the
# 256³ head (../shared/data) upsampled 4×4×1 with noise by `voxscope convert` onto 1024×1024×256,
# as u16 (value × 16 plus 4 bits of seeded noise); levels by 2× mean down to 64×64×16, every
# level chunked as level 0 is (a one-plane chunk is one plane of the level). Then the stopped
# medium view of each, `render --renderer stream` until complete, from the folder (page cache as
# it is: warm after the first) and over slow_http.py (50 ms a request, 100 MB/s) on 127.0.0.1.
# Prints per store and path: wall seconds, the render's line (bricks, chunks decoded, requests,
# bytes), the server's counts.
#
# Usage: bash docs/bench/thin-chunks.sh [VOXSCOPE] [SIZE] [LOD_SCALE]   (default
# target/release/voxscope, 256x192, 0.25: at 256x192 the levels a 1024x768 view reads at
# --lod-scale 1, a sixteenth of its rays). Needs a Python with zarr, ome-zarr and numpy
# (PYTHON, default /tmp/thinvenv/bin/python); the stores go to $DIR (default /tmp/thin). GPU and
# RAM set --gpu-memory (512MiB) and --ram-cache (2GiB); the level-0 view of the figures:
# GPU=1GiB RAM=1GiB bash docs/bench/thin-chunks.sh target/release/voxscope 64x48 0.03125.
set -uo pipefail
BIN=${1:-target/release/voxscope}
SIZE=${2:-256x192}
LOD=${3:-0.25}
PY=${PYTHON:-/tmp/thinvenv/bin/python}
DIR=${DIR:-/tmp/thin}
PORT=${PORT:-8232}
VIEW="--renderer stream --size $SIZE --lod-scale $LOD --gpu-memory ${GPU:-512MiB} --ram-cache ${RAM:-2GiB} --max-wait 300"
mkdir -p "$DIR"
[ -e "$DIR/src.ome.zarr/.zattrs" ] || $BIN convert ../shared/data/mri-head-256.nii.gz \
    "$DIR/src.ome.zarr" --upsample 4,4,1 --noise 2 --chunk 64 --compression none 2>/dev/null
[ -e "$DIR/thin-sharded.ome.zarr/zarr.json" ] || "$PY" - "$DIR" <<'PY'
import sys, numpy as np, numcodecs, zarr, zarr.codecs
from ome_zarr.format import FormatV04, FormatV05
from ome_zarr.writer import write_multiscale
d = sys.argv[1]
src = zarr.open_group(f"{d}/src.ome.zarr", mode="r")
level0 = src[src.attrs["multiscales"][0]["datasets"][0]["path"]][...]
noise = np.random.default_rng(54).integers(0, 16, size=level0.shape, dtype=np.uint16)
levels = [level0.astype(np.uint16) * 16 + noise]
del noise
while max(levels[-1].shape) > 64:
    v = levels[-1].astype(np.uint32)
    z, y, x = v.shape
    s = v.reshape(z // 2, 2, y // 2, 2, x // 2, 2).sum(axis=(1, 3, 5))
    levels.append(((s + 4) // 8).astype(np.uint16))
axes = [{"name": n, "type": "space", "unit": "millimeter"} for n in "zyx"]
def transforms(spacing):
    return [[{"type": "scale", "scale": [s * 2**l for s in spacing]},
             {"type": "translation", "translation": [s * (2**l - 1) / 2 for s in spacing]}]
            for l in range(len(levels))]
lz4 = numcodecs.Blosc(cname="lz4", clevel=5, shuffle=numcodecs.Blosc.SHUFFLE)
v3lz4 = [zarr.codecs.BloscCodec(cname="lz4", clevel=5, shuffle="shuffle")]
stores = {
    "cubic64": (2, FormatV04(), [{"chunks": (64, 64, 64), "compressor": lz4}] * len(levels)),
    "thin": (2, FormatV04(), [{"chunks": (1,) + l.shape[1:], "compressor": lz4} for l in levels]),
    "thin-sharded": (3, FormatV05(), [{"chunks": (1,) + l.shape[1:], "shards": (min(64, l.shape[0]),) + l.shape[1:],
                                       "compressor": v3lz4} for l in levels]),
}
for name, (version, fmt, storage) in stores.items():
    group = zarr.open_group(f"{d}/{name}.ome.zarr", mode="w", zarr_format=version)
    write_multiscale(levels, group, fmt=fmt, axes=axes, coordinate_transformations=transforms((1.0, 0.25, 0.25)),
                     storage_options=storage, name="head")
    print("wrote", name, file=sys.stderr)
PY
du -sh "$DIR"/cubic64.ome.zarr "$DIR"/thin.ome.zarr "$DIR"/thin-sharded.ome.zarr
timed() {
    local t0
    t0=$(date +%s.%N)
    # shellcheck disable=SC2086 # VIEW is words
    $BIN render "$@" $VIEW 2>"$DIR/render.err"
    echo "exit $?, $(python3 -c "import time; print(round(time.time() - $t0, 2))") s wall"
    tail -1 "$DIR/render.err"
}
for store in cubic64 thin thin-sharded; do
    echo "== $store from its folder"
    timed "$DIR/$store.ome.zarr" -o "$DIR/$store-folder.png"
done
for store in cubic64 thin thin-sharded; do
    echo "== $store over the link"
    python3 docs/bench/slow_http.py "$DIR" $PORT 0.05 100e6 2>"$DIR/server.err" &
    server=$!
    sleep 1
    timed "http://127.0.0.1:$PORT/$store.ome.zarr" -o "$DIR/$store-url.png"
    kill $server
    wait $server 2>/dev/null
    grep '^served' "$DIR/server.err"
done
