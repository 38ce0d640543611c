#!/usr/bin/env bash
# Streaming an OME-Zarr store over a slow HTTP link on the lent GPU machine (issue 19,
# docs/benchmarks.md "Remote stores"): the 256x256x20 PD MRI series tiled 8x8x103 by
# `voxscope convert` (2048x2048x2060, OME-Zarr 0.4, 64³ chunks, blosc zstd, a file per chunk),
# served on 127.0.0.1 by slow_http.py with 50 ms a request and one 100 MB/s link; `bench
# --stream` from the URL and from the folder. Expects, in out/zarr-bench, voxscope.gz and
# brain-pd-dicom/; the Vulkan loader's .deb files in .gl.
# Usage: bash docs/bench/remote-stream.sh RUN_NAME   (files RUN_NAME-… go to $OUT)
set -uo pipefail
D=out/zarr-bench
RUN=${1:-run52}
for deb in .gl/*.deb; do dpkg -x "$deb" /; done
ldconfig
export WGPU_BACKEND=vulkan
if [ ! -e /usr/share/vulkan/icd.d/nvidia_icd.json ]; then
    export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
gunzip -kf $D/voxscope.gz && chmod +x $D/voxscope
OUTDIR=${OUT:-/tmp/out}; mkdir -p "$OUTDIR"
STORE=$PWD/out/pd2048.ome.zarr
started=$SECONDS
[ -e "$STORE/.zattrs" ] || $D/voxscope convert $D/brain-pd-dicom "$STORE" --tile 8,8,103 --spacing 1,1,1 \
    --chunk 64 --compression blosc-zstd 2>"$OUTDIR/$RUN-convert.err"
echo "convert after $((SECONDS - started)) s"; du -sh "$STORE"
python3 docs/bench/slow_http.py out 8123 0.05 100e6 2>"$OUTDIR/$RUN-server.err" &
SERVER=$!
sleep 1
sync; echo 3 >/proc/sys/vm/drop_caches 2>/dev/null && echo "page cache dropped"
timeout "${LIMIT:-150}" $D/voxscope bench http://127.0.0.1:8123/pd2048.ome.zarr --stream --json \
    --gpu-memory 2GiB --ram-cache 8GiB >"$OUTDIR/$RUN-stream-pd2048-http.json" 2>"$OUTDIR/$RUN-http.err"
echo "bench (HTTP) exit $?"; tail -2 "$OUTDIR/$RUN-http.err"
kill $SERVER; wait $SERVER 2>/dev/null; cat "$OUTDIR/$RUN-server.err"
sync; echo 3 >/proc/sys/vm/drop_caches 2>/dev/null
timeout 60 $D/voxscope bench "$STORE" --stream --json --gpu-memory 2GiB --ram-cache 8GiB \
    >"$OUTDIR/$RUN-stream-pd2048-folder.json" 2>"$OUTDIR/$RUN-folder.err"
echo "bench (folder) exit $?"
python3 - "$OUTDIR" "$RUN" <<'PY'
import json, sys, pathlib
out, run = pathlib.Path(sys.argv[1]), sys.argv[2]
for name in ("http", "folder"):
    try:
        r = json.loads((out / f"{run}-stream-pd2048-{name}.json").read_text())
    except Exception as e:
        print(name, "no JSON", e); continue
    s = r["stopped_view"]
    print(name, "open", round(r["volume"]["open_seconds"], 3), "first image", round(r["first_image_s"], 3),
          "complete after first", round(s["seconds_after_first_image"], 3), "read", s["bricks_read"],
          "view", s["view_bricks"], "floor MB", round(s["floor_bytes"] / 1e6, 2), "fetched", s.get("fetched"))
    for o in r["orbits"]:
        print("  orbit", o["camera"], "gpu", {k: round(v, 3) for k, v in o["gpu_ms"].items()},
              "wall", {k: round(v, 2) for k, v in o["wall_ms"].items()}, "over16", o["frames_over_16ms_wall"],
              "update", {k: round(v, 2) for k, v in o["update_ms"].items()})
PY
