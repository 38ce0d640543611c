#!/usr/bin/env bash
# Budget-limited near views, two binaries on one machine (docs/benchmarks.md "Streaming"): the PD
# MRI series (../shared/data/brain-pd-dicom, carried as out/zarr-bench/brain-pd-dicom) tiled
# 16x16x52 by `voxscope convert` into a 4096x4096x1040 OME-Zarr (64³ chunks, zstd) on the
# machine's disk, as budget.sh makes it (or another store, below); then, for .bench/voxscope-base and .bench/voxscope (.gz),
# cold near renders (distance 0.6, 1024x768, the page cache dropped before each) under each GPU
# budget in BUDGETS (default "128MiB 512MiB") and mode in MODES (default "mip dvr"), --ram-cache
# 2GiB, --max-wait 30. Each render's status line says its finest and coarsest level, bricks read
# and frames; the PNGs show whether the view has a seam.
# Usage: bash docs/bench/budget-levels.sh RUN_NAME   (RUN_NAME-budget-levels.tar.gz to $OUT)
set -uo pipefail
RUN=${1:?usage: budget-levels.sh RUN_NAME}
D=.bench
# shellcheck source=docs/bench/device-setup.sh
source docs/bench/device-setup.sh
for bin in voxscope voxscope-base; do gunzip -kf "$D/$bin.gz" && chmod +x "$D/$bin"; done
OUTDIR=/tmp/$RUN-budget-levels
mkdir -p "$OUTDIR"
# STORE_NAME, INPUT and CONVERT_ARGS choose another store, e.g. the issue's 4096x4096x1064 CT:
# STORE_NAME=ct4096x1064 INPUT=synthetic:ct:512x512x133 CONVERT_ARGS="--tile 8,8,8".
STORE=$PWD/out/${STORE_NAME:-pd4096x1040}.ome.zarr
if [ ! -e "$STORE/.zattrs" ]; then
    t0=$SECONDS
    # shellcheck disable=SC2086 # CONVERT_ARGS are words
    timeout 300 $D/voxscope convert "${INPUT:-out/zarr-bench/brain-pd-dicom}" "$STORE" \
        ${CONVERT_ARGS:---tile 16,16,52 --spacing 1,1,1} --chunk 64 --compression zstd \
        2>"$OUTDIR/convert.err"
    echo "convert exit $? after $((SECONDS - t0)) s"
fi
[ -e "$STORE/.zattrs" ] || { echo "no store"; exit 1; }
for bin in voxscope-base voxscope; do
    for mode in ${MODES:-mip dvr}; do
        # The driver's pipeline cache: one small render per binary and mode first, untimed.
        timeout 60 $D/$bin render "$STORE" --renderer stream --mode "$mode" --size 64x48 \
            --max-wait 10 -o "$OUTDIR/warm.png" >/dev/null 2>&1
        for budget in ${BUDGETS:-128MiB 512MiB}; do
            sync; echo 3 >/proc/sys/vm/drop_caches 2>/dev/null || echo "page cache NOT dropped"
            name=$bin-$mode-$budget
            t0=$(date +%s.%N)
            timeout 60 $D/$bin render "$STORE" --renderer stream --mode "$mode" --distance 0.6 \
                --gpu-memory "$budget" --ram-cache 2GiB --max-wait 30 -o "$OUTDIR/$name.png" \
                >"$OUTDIR/$name.txt" 2>&1
            code=$?
            wall=$(python3 -c "import time; print(round(time.time() - $t0, 2))")
            echo "$name: exit $code, $wall s wall; $(tail -1 "$OUTDIR/$name.txt")"
        done
    done
done
rm -f "$OUTDIR/warm.png"
[ -n "${OUT:-}" ] && tar -czf "$OUT/$RUN-budget-levels.tar.gz" -C /tmp "$(basename "$OUTDIR")"
