#!/usr/bin/env bash
# The remote request path measured on one machine (docs/performance-log.md "Remote stores"): a
# 512x512x384 CT phantom converted to OME-Zarr twice (0.4, 64³ chunks, a file per chunk; 0.5,
# 32³ inner chunks in shards of 4³ chunks), each served on 127.0.0.1 by slow_http.py at 50 ms a
# request and one 100 MB/s link, and drawn from its URL by `render --renderer stream` at
# --lod-scale 0 (every visible brick at full detail: a few hundred requests). Prints the
# render's line (its time, first image, requests, bytes, most in flight), the server's counts
# (requests, bytes, most in flight, active seconds, waves of round trips) and the link's floor:
# max(bytes ÷ 100 MB/s, requests ÷ in-flight limit × 50 ms). Then each store drawn from its
# folder, the same view: what the CPU and the renderer take without a network (where
# ImageMagick's `compare` is installed, with the PSNR of the URL's image against it).
#
# Usage: bash docs/bench/remote-local.sh [VOXSCOPE] [SIZE]  (default target/debug/voxscope,
# 256x192; stores go to out/remote-bench)
set -uo pipefail
BIN=${1:-target/debug/voxscope}
SIZE=${2:-256x192}
LIMIT=${MAX_REQUESTS:-32}
D=out/remote-bench
mkdir -p $D
[ -e $D/ct512.ome.zarr/.zattrs ] || $BIN convert synthetic:ct:512x512x384 $D/ct512.ome.zarr \
    --chunk 64 --compression zstd 2>/dev/null
[ -e $D/ct512s.ome.zarr/zarr.json ] || $BIN convert synthetic:ct:512x512x384 $D/ct512s.ome.zarr \
    --format 0.5 --chunk 32 --shard 4 --compression zstd 2>/dev/null
PORT=${PORT:-8231}
for store in ct512.ome.zarr ct512s.ome.zarr; do
    python3 docs/bench/slow_http.py $D $PORT 0.05 100e6 2>$D/server.err &
    server=$!
    sleep 1
    $BIN render "http://127.0.0.1:$PORT/$store" -o $D/${store%.ome.zarr}-url.png --renderer stream \
        --size $SIZE --lod-scale 0 --max-requests $LIMIT 2>$D/render.err
    kill $server; wait $server 2>/dev/null
    echo "== $store"
    tail -1 $D/render.err
    python3 - "$D/server.err" "$LIMIT" <<'PY'
import ast, sys
line = open(sys.argv[1]).read().strip().splitlines()[-1]
counts = ast.literal_eval(line.split("served ", 1)[1])
limit = int(sys.argv[2])
floor = max(counts["bytes"] / 100e6, counts["requests"] / limit * 0.05)
print("server", counts, f"floor {floor:.2f} s (bytes {counts['bytes'] / 100e6:.2f} s,",
      f"requests {counts['requests'] / limit * 0.05:.2f} s); active / floor",
      round(counts.get("active_s", 0) / floor, 2) if floor else None)
PY
done
for store in ct512.ome.zarr ct512s.ome.zarr; do
    $BIN render $D/$store -o $D/${store%.ome.zarr}-folder.png --renderer stream --size $SIZE \
        --lod-scale 0 2>$D/render.err
    echo "== $store from its folder"
    tail -1 $D/render.err
    if command -v compare >/dev/null; then
        echo "URL against folder: $(compare -metric PSNR $D/${store%.ome.zarr}-url.png \
            $D/${store%.ome.zarr}-folder.png /dev/null 2>&1) dB"
    fi
done
