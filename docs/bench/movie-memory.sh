#!/usr/bin/env bash
# Movies and memory on the lent GPU machine, in one call (docs/benchmarks.md, "Movies" and
# "Memory"): `voxscope movie` turntables at 1920x1080 of the 256³ head (in memory) and of a
# 4096x4096x1040 OME-Zarr streamed under a 512 MiB GPU budget (the PD series tiled as
# budget.sh tiles it), frames per second written by stage; then the peak memory of
# `bench --stream` of synthetic:noise:1024 under 64 MiB budgets and of the store under 64 MiB
# and 1 GiB RAM budgets, and of near `render`s of the store.
#
# It builds nothing: it expects out/zarr-bench/brain-pd-dicom/, .bench/ with voxscope.gz and
# mri-head-256.nii.gz, and the Vulkan loader's .deb files in .gl.
# Usage: bash docs/bench/movie-memory.sh RUN_NAME [JOB…]   (JOBs: movies memory; default both;
# RUN_NAME.tar.gz of every small file goes to $OUT, a summary to stdout)
set -uo pipefail
started=$SECONDS
D=.bench
RUN=${1:-run64}
shift
jobs=("$@")
[ ${#jobs[@]} -gt 0 ] || jobs=(movies memory)
for deb in .gl/*.deb; do dpkg -x "$deb" /; done
ldconfig
export WGPU_BACKEND=vulkan
if [ ! -e /usr/share/vulkan/icd.d/nvidia_icd.json ]; then
    export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
gunzip -kf $D/voxscope.gz && chmod +x $D/voxscope
OUTDIR=/tmp/$RUN
mkdir -p "$OUTDIR"
STORE=$PWD/out/pd4096x1040.ome.zarr
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
echo "$(nproc) cores"
if [ ! -e "$STORE/.zattrs" ]; then
    rm -rf "$STORE"
    timeout 240 $D/voxscope convert out/zarr-bench/brain-pd-dicom "$STORE" --tile 16,16,52 \
        --spacing 1,1,1 --chunk 64 --compression zstd 2>"$OUTDIR/$RUN-convert.err"
    echo "convert exit $? after $((SECONDS - started)) s"
fi
if [ ! -e "$STORE/.zattrs" ]; then echo "no store: stopping"; exit 1; fi
drop() {
    sync
    echo 3 >/proc/sys/vm/drop_caches 2>/dev/null || echo "page cache NOT dropped"
}
movie() { # NAME ARGS…: one movie, its summary line kept
    local name=$1
    shift
    rm -rf "/tmp/frames-$name"
    timeout 240 $D/voxscope movie "$@" >"$OUTDIR/$RUN-$name.txt" 2>&1
    echo "movie $name: exit $?"
    tr '\r' '\n' <"$OUTDIR/$RUN-$name.txt" | grep -v '^ *$' | grep -v 'frame [0-9]* of' | tail -2
}
for job in "${jobs[@]}"; do
    case $job in
    movies)
        movie head-png $D/mri-head-256.nii.gz --turntable --frames 360 --size 1920x1080 \
            -o /tmp/frames-head-png
        cp /tmp/frames-head-png/frame_00000.png "$OUTDIR/$RUN-head-frame0.png" 2>/dev/null
        cp /tmp/frames-head-png/frame_00090.png "$OUTDIR/$RUN-head-frame90.png" 2>/dev/null
        movie head-gif $D/mri-head-256.nii.gz --turntable --frames 360 --size 1920x1080 \
            -o /tmp/frames-head.gif
        ls -la /tmp/frames-head.gif 2>/dev/null
        drop
        movie store-png "$STORE" --renderer stream --gpu-memory 512MiB --turntable --frames 72 \
            --size 1920x1080 --max-wait 20 -o /tmp/frames-store-png
        cp /tmp/frames-store-png/frame_00000.png "$OUTDIR/$RUN-store-frame0.png" 2>/dev/null
        cp /tmp/frames-store-png/frame_00036.png "$OUTDIR/$RUN-store-frame36.png" 2>/dev/null
        ;;
    memory)
        for spec in "noise1024 synthetic:noise:1024 64MiB 64MiB" "store-ram64MiB $STORE 512MiB 64MiB" \
            "store-ram1GiB $STORE 512MiB 1GiB"; do
            set -- $spec
            drop
            timeout 200 $D/voxscope bench --stream "$2" --gpu-memory "$3" --ram-cache "$4" --frames 100 \
                --json >"$OUTDIR/$RUN-bench-$1.json" 2>"$OUTDIR/$RUN-bench-$1.err"
            echo "bench $1: exit $?"
            python3 - "$OUTDIR/$RUN-bench-$1.json" <<'PY'
import json, sys
try:
    m = json.load(open(sys.argv[1]))["memory"]
except Exception as e:
    print("  no memory figures:", e); sys.exit()
M = 1 << 20
print("  baseline %.0f MiB, streaming peak %.0f MiB" % (m["baseline_bytes"] / M, m["streaming_peak_bytes"] / M))
for p in m["phases"]:
    print("  %-24s peak %6.0f end %6.0f ram %s store %s" % (p["phase"], p["peak_bytes"] / M, p["end_bytes"] / M,
          p["ram_cache_bytes"] and round(p["ram_cache_bytes"] / M, 1), p["store_cache_bytes"] and round(p["store_cache_bytes"] / M, 1)))
PY
        done
        for ram in 64MiB 1GiB; do
            for mode in dvr mip; do
                drop
                timeout 45 $D/voxscope render "$STORE" --renderer stream --mode $mode --distance 0.6 \
                    --gpu-memory 512MiB --ram-cache $ram --max-wait 30 -o "$OUTDIR/$RUN-near-$mode-$ram.png" \
                    >"$OUTDIR/$RUN-near-$mode-$ram.txt" 2>&1
                echo "render $mode $ram: exit $?; $(tail -1 "$OUTDIR/$RUN-near-$mode-$ram.txt" | sed 's/.*atlas slots used//')"
            done
        done
        ;;
    esac
done
echo "total $((SECONDS - started)) s"
if [ -n "${OUT:-}" ]; then
    tar -czf "$OUT/$RUN.tar.gz" -C /tmp "$RUN"
fi
