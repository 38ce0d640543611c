#!/usr/bin/env bash
# The conversion benchmark (issue 56; docs/benchmarks.md "Convert") on the lent GPU machine's
# 16 cores, from the repository root there. It builds nothing: it expects, carried in .bench
# (git-ignored), voxscope.gz (a stripped release binary) and nuclei.npy
# (../shared/data/nuclei-60x256x256.tif as numpy saved it).
# Usage: bash docs/bench/convert-parts.sh RUN_NAME   (files RUN_NAME-… to $OUT)
#   1. /tmp/big.raw: the nuclei as i16 (halved: u16 above 32767 would wrap), tiled 16x16 in
#      x and y and repeated to DEPTH planes (default 532: 4096x4096x532, 17.9 GB; 1064 makes
#      the 35.7 GB of issue 56, but it and one output (blosc-lz4 barely compresses microscopy
#      noise) do not fit the machine's 64 GB disk together)
#   2. `convert` of it in one process to OME-Zarr 0.5 (64³ chunks in 128³ shards, blosc-lz4)
#   3. `convert plan --parts 4`, the 4 parts at once as 4 processes of 4 threads, `finalize`
#   The page cache is dropped before 2 and 3; the parts' objects are compared with the
#   one-process output's by their markers' CRC-32C (the one-process output is deleted first).
set -uo pipefail
RUN=${1:?usage: convert-parts.sh RUN_NAME}
D=.bench
OUTDIR=${OUT:-/tmp/out}; mkdir -p "$OUTDIR"
gunzip -kf $D/voxscope.gz && chmod +x $D/voxscope
echo "$(nproc) cores; $(free -g | awk '/Mem/ {print $2}') GB; $(df -h /tmp | tail -1)"
RAW=/tmp/big.raw
DEPTH=${DEPTH:-532}
LAYOUT=4096x4096x$DEPTH:i16
FORMAT="--format 0.5 --chunk 64 --shard 2"
drop() {
    sync
    echo 3 >/proc/sys/vm/drop_caches 2>/dev/null || echo "page cache NOT dropped"
}
now() { date +%s.%N; }
python3 - "$D/nuclei.npy" "$RAW" "$DEPTH" <<'PY'
import sys, time
import numpy as np
started = time.time()
nuclei = (np.load(sys.argv[1]) // 2).astype(np.int16)   # 60 x 256 x 256
plane_tiles = np.tile(nuclei, (1, 16, 16))               # 60 x 4096 x 4096
depth = int(sys.argv[3])
with open(sys.argv[2], "wb") as f:
    written = 0
    while written < depth:
        n = min(60, depth - written)
        plane_tiles[:n].tofile(f)
        written += n
print(f"raw written in {time.time() - started:.1f} s")
PY
ls -l $RAW
drop
t0=$(now)
$D/voxscope convert $RAW /tmp/whole.ome.zarr --raw $LAYOUT $FORMAT \
    >"$OUTDIR/$RUN-whole.txt" 2>"$OUTDIR/$RUN-whole.err"
echo "whole exit $? in $(python3 -c "print(round($(now) - $t0, 2))") s"; cat "$OUTDIR/$RUN-whole.txt"
cp /tmp/whole.ome.zarr/.voxscope/parts/0.json "$OUTDIR/$RUN-whole-marker.json"
du -sh /tmp/whole.ome.zarr
rm -rf /tmp/whole.ome.zarr
drop
t0=$(now)
$D/voxscope convert plan $RAW /tmp/parts.ome.zarr --raw $LAYOUT $FORMAT --parts 4 2>&1
t1=$(now)
for i in 0 1 2 3; do
    RAYON_NUM_THREADS=4 $D/voxscope convert run /tmp/parts.ome.zarr --part $i/4 \
        >"$OUTDIR/$RUN-part$i.txt" 2>/dev/null &
done
wait
t2=$(now)
$D/voxscope convert finalize /tmp/parts.ome.zarr 2>&1
t3=$(now)
cat "$OUTDIR"/$RUN-part?.txt
cp /tmp/parts.ome.zarr/.voxscope/plan.json "$OUTDIR/$RUN-plan.json"
for i in 0 1 2 3; do cp /tmp/parts.ome.zarr/.voxscope/parts/$i.json "$OUTDIR/$RUN-part$i.json"; done
python3 - "$OUTDIR" "$RUN" "$t0" "$t1" "$t2" "$t3" <<'PY'
import json, sys
out, run, t0, t1, t2, t3 = sys.argv[1], sys.argv[2], *map(float, sys.argv[3:])
whole = json.load(open(f"{out}/{run}-whole-marker.json"))
parts = [json.load(open(f"{out}/{run}-part{i}.json")) for i in range(4)]
same = all(whole["objects"].get(k) == v for p in parts for k, v in p["objects"].items())
total = t3 - t0
summary = {
    "whole_seconds": whole["seconds"],
    "whole_gb_per_s": whole["bytes_in"] / whole["seconds"] / 1e9,
    "whole_peak_memory_gb": (whole["peak_memory_bytes"] or 0) / 1e9,
    "plan_s": t1 - t0, "parts_s": t2 - t1, "finalize_s": t3 - t2, "total_s": total,
    "parts_over_whole": total / whole["seconds"],
    "finalize_share": (t3 - t2) / total,
    "part_seconds": [p["seconds"] for p in parts],
    "part_peak_memory_gb": [(p["peak_memory_bytes"] or 0) / 1e9 for p in parts],
    "parts_objects_equal_whole": same,
    "objects": sum(len(p["objects"]) for p in parts),
}
json.dump(summary, open(f"{out}/{run}-summary.json", "w"), indent=1)
print(json.dumps(summary, indent=1))
PY
