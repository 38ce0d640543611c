#!/usr/bin/env bash
# Python's frame beside the command line's, on one machine and one volume (docs/benchmarks.md
# "Python"): the 256³ T1 MRI as u8, 1024×768, 100 frames. Python: the peers' harness with only
# voxscope in it (docs/bench/peer_bench.py, `Renderer(renderer="bricks")`, `ms_batch`). The
# command line: `bench --stream` on the same voxels read raw, its `resident` rows'
# `bricks_wall_ms_per_frame` (a frame of a batch of 100, then the device's completion), the
# figure the peers' table quotes.
# Expects what peers-python.sh expects (.whl with the voxscope wheel, .gl, .bench with
# mri-head-256.nii.gz) and the release binary as .bench/voxscope(.gz).
# Usage: bash docs/bench/python-cli.sh RUN_NAME   (RUN_NAME-python-cli.tar.gz to $OUT)
set -uo pipefail
RUN=${1:?usage: python-cli.sh RUN_NAME}
DIR=/tmp/$RUN-python-cli
mkdir -p "$DIR"
[ -e .bench/voxscope ] || { gunzip -kf .bench/voxscope.gz && chmod +x .bench/voxscope; }
OUT_SAVED=${OUT:-}
# The Python side, as peers-python.sh runs it.
PEERS=voxscope OUT= bash docs/bench/peers-python.sh "$RUN" >"$DIR/python.log" 2>&1
cp /tmp/$RUN/$RUN-peers.jsonl "$DIR/python.jsonl" 2>/dev/null
tail -5 "$DIR/python.log"
export WGPU_BACKEND=vulkan PYTHONPATH=/tmp/site
if [ ! -e /usr/share/vulkan/icd.d/nvidia_icd.json ]; then
    export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
python3 - "$DIR" <<'PY'
import sys, numpy as np, voxscope
vol = voxscope.open(".bench/mri-head-256.nii.gz")
v = vol.read().astype(np.float64)
u8 = np.round((v - v.min()) / (v.max() - v.min()) * 255).astype(np.uint8)
u8.tofile(sys.argv[1] + "/head.raw")
z, y, x = u8.shape
sz, sy, sx = vol.spacing
open(sys.argv[1] + "/layout", "w").write(f"{x}x{y}x{z}:u8 {sx},{sy},{sz}")
PY
read -r layout spacing <"$DIR/layout"
# Every mode and camera; the `resident` rows hold the batch's wall time per frame.
.bench/voxscope bench "$DIR/head.raw" --raw "$layout" --spacing "$spacing" --window 0:255 \
    --stream --json >"$DIR/cli-stream.json" 2>"$DIR/cli-stream.err"
echo "cli bench --stream rc=$?"
rm -f "$DIR/head.raw"
if [ -n "$OUT_SAVED" ]; then
    tar -czf "$OUT_SAVED/$RUN-python-cli.tar.gz" -C /tmp "$(basename "$DIR")"
fi
