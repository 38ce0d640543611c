#!/usr/bin/env bash
# The Imaris benchmark (issue 55: an .ims of ≥ 20 GB streams from disk, first image ≤ 0.3 s;
# docs/benchmarks.md "Imaris") on the lent GPU machine, from the repository root there. It
# builds nothing: it expects, carried in .bench (git-ignored), voxscope.gz (a stripped release
# binary), nuclei.npy (../shared/data/nuclei-60x256x256.tif as numpy saved it) and whl/ with
# h5py's Python 3.12 wheel; the Vulkan loader's .deb files in .gl.
# Usage: [JOBS="make bench zarr"] bash docs/bench/imaris.sh RUN_NAME   (files RUN_NAME-… to $OUT)
#   make   docs/bench/make_ims.py writes /tmp/nuclei-tiled.ims (4096×4096×640 u16, 21.5 GB raw)
#   bench  `bench --stream` of it, 512 MiB GPU / 2 GiB RAM, page cache dropped first
#   zarr   `convert` of it to OME-Zarr (64³ zstd, read by region), then the same bench of that
set -uo pipefail
RUN=${1:?usage: imaris.sh RUN_NAME}
D=.bench
OUTDIR=${OUT:-/tmp/out}; mkdir -p "$OUTDIR"
for deb in .gl/*.deb; do dpkg -x "$deb" /; done
ldconfig
export WGPU_BACKEND=vulkan
if [ ! -e /usr/share/vulkan/icd.d/nvidia_icd.json ]; then
    export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
gunzip -kf $D/voxscope.gz && chmod +x $D/voxscope
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
echo "$(nproc) cores; $(df -h /tmp | tail -1)"
IMS=/tmp/nuclei-tiled.ims
ZARR=/tmp/nuclei-tiled.ome.zarr
drop() {
    sync
    echo 3 >/proc/sys/vm/drop_caches 2>/dev/null || echo "page cache NOT dropped"
}
bench() { # NAME INPUT
    drop
    echo "== bench $1"
    local started=$SECONDS
    timeout "${LIMIT:-150}" $D/voxscope bench "$2" --stream --json --gpu-memory 512MiB \
        --ram-cache 2GiB --frames 40 --orbit-fps 60 >"$OUTDIR/$RUN-$1.json" 2>"$OUTDIR/$RUN-$1.err"
    echo "   exit $? after $((SECONDS - started)) s"; tail -2 "$OUTDIR/$RUN-$1.err"
    python3 - "$OUTDIR/$RUN-$1.json" <<'PY'
import json, sys
try:
    r = json.load(open(sys.argv[1]))
except Exception as e:
    print("   no JSON:", e); sys.exit()
s = r["stopped_view"]
print("  ", r["adapter"], "open", round(r.get("open_s", 0), 3), "first image", round(r["first_image_s"], 3),
      "stopped medium", s["complete"], round(s["seconds_after_first_image"], 3), "s after;",
      s["bricks_read"], "read for", s["view_bricks"])
for n in r["near_stopped_views"]:
    print("   near", n["mode"], n["distance"], n["complete"], round(n["seconds"], 2), "s")
for o in r["orbits"]:
    print("   orbit", o["camera"], "wall", {k: round(v, 2) for k, v in o["wall_ms"].items()},
          "over16", o["frames_over_16ms_wall"])
PY
}
for job in ${JOBS:-make bench zarr}; do
    case $job in
        make)
            python3 -m pip install -q --no-index --no-deps --target /tmp/site $D/whl/*.whl || exit 1
            started=$SECONDS
            PYTHONPATH=/tmp/site python3 docs/bench/make_ims.py $D/nuclei.npy $IMS \
                >"$OUTDIR/$RUN-make.txt" 2>&1
            echo "make exit $? after $((SECONDS - started)) s"; tail -3 "$OUTDIR/$RUN-make.txt"
            ls -l $IMS
            t0=$(date +%s.%N); drop
            $D/voxscope info $IMS >"$OUTDIR/$RUN-info.txt" 2>&1 </dev/null
            echo "info exit $? in $(python3 -c "import time; print(round(time.time() - $t0, 2))") s"
            head -14 "$OUTDIR/$RUN-info.txt"
            # The driver's pipeline cache, so that the benches time the data, not the compiler.
            timeout 60 $D/voxscope render $IMS --renderer stream --size 64x48 --max-wait 10 \
                -o "$OUTDIR/$RUN-warm.png" >/dev/null 2>&1 ;;
        bench) bench ims $IMS ;;
        zarr)
            drop; started=$SECONDS
            timeout "${CONVERT_LIMIT:-240}" $D/voxscope convert $IMS $ZARR --chunk 64 \
                --compression zstd 2>"$OUTDIR/$RUN-convert.err"
            echo "convert exit $? after $((SECONDS - started)) s"
            tr '\r' '\n' <"$OUTDIR/$RUN-convert.err" | grep -v '%$' | tail -2
            bench zarr $ZARR ;;
    esac
done
