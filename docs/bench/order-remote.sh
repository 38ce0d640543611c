#!/usr/bin/env bash
# Two binaries side by side on the lent GPU machine, in one call (docs/benchmarks.md, "Remote stores"):
# .bench/voxscope-base.gz and .bench/voxscope.gz on the 4096x4096x1040 store of budget.sh
# (the PD series tiled 16x16x52, OME-Zarr 0.4, 64³ chunks, zstd): near MIP stopped views from
# disk (page cache dropped before each cold process, TAKES times each), then `bench --stream`
# of the same store over docs/bench/slow_http.py at 50 ms a request and one 100 MB/s link, with
# the link's floor for what crossed it: max(bytes / 100 MB/s, requests / 32 × 50 ms).
# Expects out/zarr-bench/brain-pd-dicom/, .bench/ and the Vulkan loader's .deb files in .gl.
# Usage: bash docs/bench/order-remote.sh RUN_NAME   (files RUN_NAME-… go to $OUT; BINS=voxscope
# measures the one binary, without voxscope-base.gz)
set -uo pipefail
started=$SECONDS
RUN=${1:-run66}
D=.bench
# shellcheck source=docs/bench/device-setup.sh
source docs/bench/device-setup.sh
BINS=${BINS:-voxscope-base voxscope}
for bin in $BINS; do gunzip -kf $D/$bin.gz && chmod +x $D/$bin; done
OUTDIR=${OUT:-/tmp/out}; mkdir -p "$OUTDIR"
# STORE_NAME: another store already on the machine (budget.sh makes the upsampled one).
NAME=${STORE_NAME:-pd4096x1040}.ome.zarr
STORE=$PWD/out/$NAME
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
if [ ! -e "$STORE/.zattrs" ] && [ -z "${STORE_NAME:-}" ]; then
    timeout 240 $D/voxscope convert out/zarr-bench/brain-pd-dicom "$STORE" --tile 16,16,52 \
        --spacing 1,1,1 --chunk 64 --compression zstd 2>/dev/null
    echo "convert exit $? after $((SECONDS - started)) s"
fi
drop() { sync; echo 3 >/proc/sys/vm/drop_caches 2>/dev/null || echo "page cache NOT dropped"; }
for take in $(seq 1 "${TAKES:-2}"); do
    for bin in $BINS; do
        for distance in 0.6 1.0; do
            drop
            name=$RUN-$bin-mip-$distance-$take
            timeout 45 $D/$bin render "$STORE" --renderer stream --mode mip --distance $distance \
                --gpu-memory 512MiB --ram-cache 2GiB --max-wait 30 -o "$OUTDIR/$name.png" \
                >"$OUTDIR/$name.txt" 2>&1
            echo "$bin mip $distance: $(tail -1 "$OUTDIR/$name.txt" | sed 's/.*(Vulkan) //')"
        done
    done
done
# SERVERS: the slow servers to measure over, each a script as slow_http.py (its file name
# tags the results: run 81 compared the server before its TCP_NODELAY with the one now).
for server in ${SERVERS:-docs/bench/slow_http.py}; do
tag=$(basename "$server" .py)
python3 "$server" out 8123 0.05 100e6 2>"$OUTDIR/$RUN-$tag-server.err" &
SERVER=$!
sleep 1
for bin in $BINS; do
    drop
    timeout 150 $D/$bin bench "http://127.0.0.1:8123/$NAME" --stream --json --gpu-memory 512MiB \
        --ram-cache 2GiB >"$OUTDIR/$RUN-$tag-$bin-http.json" 2>"$OUTDIR/$RUN-$tag-$bin-http.err"
    echo "$bin bench (HTTP, $tag) exit $? after $((SECONDS - started)) s"
done
kill $SERVER; wait $SERVER 2>/dev/null; tail -5 "$OUTDIR/$RUN-$tag-server.err"
python3 - "$OUTDIR" "$RUN-$tag" $BINS <<'PY'
import json, sys, pathlib
out, run = pathlib.Path(sys.argv[1]), sys.argv[2]
for bin in sys.argv[3:]:
    try:
        r = json.loads((out / f"{run}-{bin}-http.json").read_text())
    except Exception as e:
        print(bin, "no JSON", e); continue
    s = r["stopped_view"]
    f = s.get("fetched") or {}
    floor = max(f.get("bytes", 0) / 100e6, f.get("requests", 0) / 32 * 0.05)
    print(bin, "open", round(r["volume"]["open_seconds"], 3), "first image", round(r["first_image_s"], 3),
          "complete", s["complete"], "after first", round(s["seconds_after_first_image"], 3),
          "from open", round(s["seconds_from_open"], 3), "fetched", f,
          "floor", round(floor, 3), "x floor", round(s["seconds_from_open"] / floor, 2) if floor else None)
    for n in r["near_stopped_views"]:
        print("  near", n["mode"], n["complete"], round(n["seconds"], 2), "s,", n["bricks_read"], "read")
PY
done
echo "done after $((SECONDS - started)) s"
