#!/usr/bin/env bash
# Python's frame beside the command line's, on one machine and one volume, the same frames
# (docs/benchmarks.md "Python"): the 256³ T1 MRI as u8, 1024×768, 100 frames of a turn at 3
# radii, opacity gray over the window 0:255, unshaded, the bricks renderer.
#   Python: the peers' harness with only voxscope in it (docs/bench/peer_bench.py,
#     `Renderer(renderer="bricks")`, `ms_batch`: 100 `draw()` calls, azimuth 150° turning
#     3.6° a frame, then `finish()`).
#   Command line: `bench --renderer bricks` on the same voxels read raw, `--window 0:255
#     --frames 100 --azimuth 150`: its bricks `medium` rows (3 radii; `dvr-gray`: opacity gray
#     unshaded; `mip`), `wall_ms_per_frame`: the turn's 100 frames (azimuth 150° turning 3.6°
#     a frame the other way: the same 100 cameras) submitted back to back, then the device's
#     completion.
# The harness's azimuth a is voxscope's 180 − a (peer_bench.py): its AZ0 = 30 is 150 here.
# Expects what peers-python.sh expects (.whl with the voxscope wheel, .gl, .bench with
# mri-head-256.nii.gz) and the release binary as .bench/voxscope(.gz).
# The harness's one batch follows a short warm-up and can catch the GPU's clocks still ramping
# up; docs/bench/python_steady.py draws the same frames again, the median of 5 batches a mode.
# Usage: bash docs/bench/python-cli.sh RUN_NAME   (RUN_NAME-python-cli.tar.gz to $OUT); its last
# lines: `python-cli DVR python P ms cli C ms ratio R; MIP …` and the same of the steady
# batches (docs/bench/python_cli_summary.py).
set -uo pipefail
RUN=${1:?usage: python-cli.sh RUN_NAME}
FRAMES=100 SIZE=1024x768 AZIMUTH=150
DIR=/tmp/$RUN-python-cli
mkdir -p "$DIR"
[ -e .bench/voxscope ] || { gunzip -kf .bench/voxscope.gz && chmod +x .bench/voxscope; }
OUT_SAVED=${OUT:-}
# The Python side, as peers-python.sh runs it (100 frames at 1024×768).
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
np.savez(sys.argv[1] + "/head.npz", v=u8)
z, y, x = u8.shape
sz, sy, sx = vol.spacing
open(sys.argv[1] + "/layout", "w").write(f"{x}x{y}x{z}:u8 {sx},{sy},{sz}")
PY
read -r layout spacing <"$DIR/layout"
# The same frames once the GPU's clocks are up: 5 batches a mode, DVR, MIP, MIP, DVR.
python3 docs/bench/python_steady.py "$DIR/head.npz" "$FRAMES" "${SIZE%x*}" "${SIZE#*x}" "$AZIMUTH" \
    >>"$DIR/python.jsonl" 2>>"$DIR/python.log"
echo "python steady rc=$?"
# The gray DVR, binary DVR, MIP and shaded DVR cases at 1.5, 3 and 6 radii; the rows compared
# are the `medium` ones.
.bench/voxscope bench "$DIR/head.raw" --raw "$layout" --spacing "$spacing" --window 0:255 \
    --renderer bricks --frames "$FRAMES" --size "$SIZE" --azimuth "$AZIMUTH" --json \
    >"$DIR/cli.json" 2>"$DIR/cli.err"
echo "cli bench rc=$?"
rm -f "$DIR/head.raw" "$DIR/head.npz"
python3 docs/bench/python_cli_summary.py "$DIR/python.jsonl" "$DIR/cli.json" | tee "$DIR/summary.txt"
if [ -n "$OUT_SAVED" ]; then
    tar -czf "$OUT_SAVED/$RUN-python-cli.tar.gz" -C /tmp "$(basename "$DIR")"
fi
