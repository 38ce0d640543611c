#!/usr/bin/env bash
# The streamed composite on the lent GPU (docs/benchmarks.md "Streaming", issue 54): the CT
# phantom tiled 4x4x4 by `voxscope convert` into a 2048x2048x532 OME-Zarr (64³ chunks, zstd) on
# the machine's disk, copied to four stores (four channels of the same voxels, each read from
# its own files); then cold stopped views (1024x768, the page cache dropped before each,
# --gpu-memory 512MiB --ram-cache 2GiB, --max-wait 30) of one channel (the one-channel
# streaming renderer), of the same channel as a composite of one, and of the four channels
# streamed together (`--channels-from`), DVR, at the medium distance and near (0.6). Each
# render's status line says its first image, completion, bricks read and frames. Then the
# resident comparison of run.sh's stream-channels job (the head streamed as 1, 2 and 4
# channels once resident).
# Usage: bash docs/bench/stream-channels.sh RUN_NAME   (RUN_NAME-stream-channels.tar.gz to $OUT)
set -uo pipefail
RUN=${1:?usage: stream-channels.sh RUN_NAME}
D=.bench
# shellcheck source=docs/bench/device-setup.sh
source docs/bench/device-setup.sh
gunzip -kf "$D/voxscope.gz" && chmod +x "$D/voxscope"
OUTDIR=/tmp/$RUN-stream-channels
mkdir -p "$OUTDIR"
STORE=$PWD/out/ct2048x532.ome.zarr
if [ ! -e "$STORE/.zattrs" ]; then
    t0=$SECONDS
    timeout 300 $D/voxscope convert synthetic:ct:512x512x133 "$STORE" --tile 4,4,4 --chunk 64 \
        --compression zstd 2>"$OUTDIR/convert.err"
    echo "convert exit $? after $((SECONDS - t0)) s"
fi
[ -e "$STORE/.zattrs" ] || { echo "no store"; exit 1; }
for c in 1 2 3; do
    [ -e "out/ct-c$c.ome.zarr" ] || cp -r "$STORE" "out/ct-c$c.ome.zarr"
done
ONE=$STORE
FOUR=$STORE,$PWD/out/ct-c1.ome.zarr,$PWD/out/ct-c2.ome.zarr,$PWD/out/ct-c3.ome.zarr
# The driver's pipeline cache: one small render of each kind first, untimed.
timeout 60 $D/voxscope render "$ONE" --renderer stream --size 64x48 --max-wait 10 \
    -o "$OUTDIR/warm.png" >/dev/null 2>&1
timeout 60 $D/voxscope render --channels-from "$FOUR" --renderer stream --size 64x48 \
    --max-wait 10 -o "$OUTDIR/warm.png" >/dev/null 2>&1
view() { # NAME ARGS…
    local name=$1
    shift
    sync; echo 3 >/proc/sys/vm/drop_caches 2>/dev/null || echo "page cache NOT dropped"
    local t0
    t0=$(date +%s.%N)
    timeout 60 $D/voxscope render "$@" --renderer stream --gpu-memory 512MiB --ram-cache 2GiB \
        --max-wait 30 -o "$OUTDIR/$name.png" >"$OUTDIR/$name.txt" 2>&1
    local code=$?
    local wall
    wall=$(python3 -c "import time; print(round(time.time() - $t0, 2))")
    echo "$name: exit $code, $wall s wall; $(tail -1 "$OUTDIR/$name.txt")"
}
for distance in medium 0.6; do
    where=()
    [ "$distance" = medium ] || where=(--distance "$distance")
    view "one-$distance" "$ONE" "${where[@]}"
    view "composite1-$distance" --channels-from "$ONE" "${where[@]}"
    view "composite4-$distance" --channels-from "$FOUR" "${where[@]}" \
        --channel-colors green,magenta,cyan,yellow
done
rm -f "$OUTDIR/warm.png"
bash docs/bench/run.sh "$RUN" stream-channels
cp /tmp/voxscope-bench/"$RUN"-head256-stream-channels.* "$OUTDIR/" 2>/dev/null
[ -n "${OUT:-}" ] && tar -czf "$OUT/$RUN-stream-channels.tar.gz" -C /tmp "$(basename "$OUTDIR")"
