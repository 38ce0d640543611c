#!/usr/bin/env bash
# The streaming atlas's upload paths side by side on the lent GPU machine, in one call
# (docs/performance-log.md, "Uploads into the atlas"): `bench --stream --uploads P` of
# one binary (.bench/voxscope.gz) for each path P of PATHS (default "scatter copies"), TAKES
# times (default 2) in turn, on the 4096x4096x1040 store of budget.sh (the PD series tiled
# 16x16x52, OME-Zarr 0.4, 64³ chunks, zstd; converted here when the machine lacks it), page
# cache dropped before each, under --gpu-memory 512MiB --ram-cache 2GiB.
# Expects out/zarr-bench/brain-pd-dicom/, .bench/ and the Vulkan loader's .deb files in .gl.
# Usage: bash docs/bench/upload-paths.sh RUN_NAME   (RUN_NAME.tar.gz of the JSON to $OUT; a
# summary line per run and orbit to stdout; ARGS are added to each bench's options, e.g.
# ARGS="--upload-budget 16MiB")
set -uo pipefail
started=$SECONDS
D=.bench
RUN=${1:-run88}
# shellcheck source=docs/bench/device-setup.sh
source docs/bench/device-setup.sh
gunzip -kf $D/voxscope.gz && chmod +x $D/voxscope
OUTDIR=/tmp/$RUN
mkdir -p "$OUTDIR"
STORE=$PWD/out/pd4096x1040.ome.zarr
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
if [ ! -e "$STORE/.zattrs" ]; then
    rm -rf "$STORE"
    timeout "${CONVERT_LIMIT:-240}" $D/voxscope convert out/zarr-bench/brain-pd-dicom "$STORE" \
        --tile 16,16,52 --spacing 1,1,1 --chunk 64 --compression zstd 2>/dev/null
    echo "convert exit $? after $((SECONDS - started)) s"
fi
if [ ! -e "$STORE/.zattrs" ]; then echo "no store: stopping"; exit 1; fi
drop() {
    sync
    echo 3 >/proc/sys/vm/drop_caches 2>/dev/null || echo "page cache NOT dropped"
}
for take in $(seq 1 "${TAKES:-2}"); do
    for path in ${PATHS:-scatter copies}; do
        name=$RUN-$path-$take
        drop
        t0=$SECONDS
        timeout "${LIMIT:-150}" $D/voxscope bench "$STORE" --stream --json --gpu-memory 512MiB \
            --ram-cache 2GiB --uploads "$path" ${ARGS:-} >"$OUTDIR/$name.json" 2>"$OUTDIR/$name.err"
        echo "$name: exit $? after $((SECONDS - t0)) s"
        python3 - "$OUTDIR/$name.json" <<'PY'
import json, sys
try:
    r = json.load(open(sys.argv[1]))
except Exception as e:
    print("  no JSON:", e); sys.exit()
s = r["stopped_view"]
line = ["  first", round(r["first_image_s"], 3), "medium", round(s["seconds_after_first_image"], 3),
        "staging on GPU", dict(r["gpu_bytes"]).get("upload_staging")]
for n in r["near_stopped_views"]:
    p = n["pipeline"]
    line += [n["mode"], n["distance"], n["complete"], round(n["seconds"], 2), "s up",
             round((p["upload_bytes_per_s"] or 0) / 1e9, 2), "copy", round((p["copy_bytes_per_s"] or 0) / 1e9, 2)]
print(*line)
for o in r["orbits"]:
    c = o["counters"]; p = c["upload_parts"]
    print("  orbit", o["camera"], "wall med/p99/max", round(o["wall_ms"]["median"], 2), round(o["wall_ms"]["p99"], 2),
          round(o["wall_ms"]["max"], 2), "over16", o["frames_over_16ms_wall"],
          "wait med/p99", round(o.get("wait_ms", {}).get("median", -1), 2), round(o.get("wait_ms", {}).get("p99", -1), 2),
          "missing", o["missing_bricks"]["median"], "MB", round(o["uploaded_bytes"] / 1e6),
          "up GB/s", round(c["bytes_uploaded"] / max(c["upload_seconds"], 1e-9) / 1e9, 2),
          "GPU copy GB/s", round(p["copy_timed_bytes"] / max(p["copy_gpu_seconds"], 1e-9) / 1e9, 2),
          "allowance MB", round(c["upload_allowance"] / 1e6, 1),
          "ring/queue bricks", p["ring_bricks"], p["queue_bricks"], "dispatches", p.get("scatter_dispatches"))
for row in r["resident"]["rows"]:
    print("  resident", row["mode"], row["camera"], round(row["stream_over_bricks"], 2))
PY
    done
done
if [ -n "${OUT:-}" ]; then
    tar -czf "$OUT/$RUN.tar.gz" -C /tmp "$RUN"
fi
echo "done after $((SECONDS - started)) s"
