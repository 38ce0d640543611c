#!/usr/bin/env bash
# Streaming an OME-Zarr store from local disk (issue 18, docs/benchmarks.md "Streaming"): a
# real volume, the 256x256x20 proton-density MRI DICOM series (i16, ../shared/data), tiled
# 16x16x205 by `voxscope convert` into a 4096x4096x4100 OME-Zarr (64³ chunks, blosc zstd, spacing
# set to 1 so that the volume is a cube: the series has 5 mm slices) on
# the lent machine's disk; then `bench --stream` on the store and one streamed render to look
# at. It builds nothing: it expects, carried in out/zarr-bench (git-ignored), voxscope.gz and
# brain-pd-dicom/, and the Vulkan loader's .deb files in .gl.
# Usage: bash docs/bench/zarr-stream.sh RUN_NAME   (files RUN_NAME-… go to $OUT)
set -uo pipefail
D=out/zarr-bench
RUN=${1:-run51}
for deb in .gl/*.deb; do dpkg -x "$deb" /; done
ldconfig
export WGPU_BACKEND=vulkan
if [ ! -e /usr/share/vulkan/icd.d/nvidia_icd.json ]; then
    export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
gunzip -kf $D/voxscope.gz && chmod +x $D/voxscope
OUTDIR=${OUT:-/tmp/out}; mkdir -p "$OUTDIR"
STORE=${STORE:-$PWD/out/pd4096.ome.zarr}
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader; nproc; free -g | head -2
df -h "$PWD" | tail -1
started=$SECONDS
if [ ! -e "$STORE/.zattrs" ]; then
    timeout "${CONVERT_LIMIT:-360}" $D/voxscope convert $D/brain-pd-dicom "$STORE" --tile 16,16,205 --spacing 1,1,1 \
        --chunk 64 --compression blosc-zstd 2>"$OUTDIR/$RUN-convert.err"
    echo "convert exit $? after $((SECONDS - started)) s"
    tr '\r' '\n' <"$OUTDIR/$RUN-convert.err" | grep -v '%$' | tail -3
fi
du -sh "$STORE"
$D/voxscope info "$STORE" >"$OUTDIR/$RUN-info.txt" 2>&1
# "From local disk": the page cache still holds what convert wrote; drop it where allowed.
sync
if echo 3 >/proc/sys/vm/drop_caches 2>/dev/null; then echo "page cache dropped"; else echo "page cache NOT dropped"; fi
started=$SECONDS
timeout "${LIMIT:-150}" $D/voxscope bench "$STORE" --stream --json --gpu-memory 2GiB --ram-cache 8GiB \
    >"$OUTDIR/$RUN-stream-pd4096.json" 2>"$OUTDIR/$RUN-stream-pd4096.err"
echo "bench exit $? after $((SECONDS - started)) s"; tail -3 "$OUTDIR/$RUN-stream-pd4096.err"
timeout 45 $D/voxscope render "$STORE" --renderer stream --gpu-memory 2GiB --ram-cache 8GiB \
    --max-wait 20 -o "$OUTDIR/$RUN-pd4096.png" 2>&1 | tail -2
python3 - "$OUTDIR/$RUN-stream-pd4096.json" <<'PY'
import json, sys
try:
    r = json.load(open(sys.argv[1]))
except Exception as e:
    print("no JSON:", e); sys.exit()
s = r["stopped_view"]
print(r["adapter"], r["driver"], "first image", round(r["first_image_s"], 3), "pipeline", round(r["pipeline_build_s"], 3))
print("stopped:", s["complete"], round(s["seconds_after_first_image"], 3), "s after first;", s["bricks_read"], "read", s["view_bricks"], "view bricks, read/floor", round(s["read_over_floor"], 2))
for o in r["orbits"]:
    print("orbit", o["camera"], "gpu", {k: round(v, 3) for k, v in o["gpu_ms"].items()}, "wall", {k: round(v, 2) for k, v in o["wall_ms"].items()}, "over16", o["frames_over_16ms_wall"])
for row in r["resident"]["rows"]:
    print("resident", row["mode"], row["camera"], row["complete"], round(row["stream_gpu_ms"], 4), round(row["bricks_gpu_ms"], 4), round(row["stream_over_bricks"], 2))
PY
