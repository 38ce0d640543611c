#!/usr/bin/env bash
# voxscope's Python module beside vispy and pygfx in the peers' own harness
# (docs/bench/peer_bench.py; docs/benchmarks.md "Python") on the lent GPU
# machine. VTK stays out: its wheel (133 MB) does not fit a call's 64 MiB; its figures by the
# same method are in ../shared/docs/peers.md.
#
# It builds nothing: it expects in .whl (git-ignored) the voxscope wheel (`maturin build
# --release`) and the peers' Python 3.12 wheels (../shared/peers/README.md lists them), and the
# Vulkan loader's .deb files in .gl. The volume is the 256³ T1 MRI (.bench/mri-head-256.nii.gz),
# read by voxscope.open and mapped full range to u8, as the peers' runs had it.
# Usage: bash docs/bench/peers-python.sh RUN_NAME   (RUN_NAME.tar.gz to $OUT)
set -uo pipefail
RUN=${1:-run61}
for deb in .gl/*.deb; do dpkg -x "$deb" /; done
ldconfig
export WGPU_BACKEND=vulkan PYOPENGL_PLATFORM=egl PYTHONUNBUFFERED=1
export VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow
if [ ! -e /usr/share/vulkan/icd.d/nvidia_icd.json ]; then
    export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
    --target /tmp/site .whl/*.whl || exit 1
export PYTHONPATH=/tmp/site
DIR=/tmp/$RUN
mkdir -p "$DIR/shots"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
python3 - "$DIR/head256.npz" <<'PY'
import sys, numpy as np, voxscope
print("voxscope on", voxscope.device())
vol = voxscope.open(".bench/mri-head-256.nii.gz")
v = vol.read().astype(np.float64)
u8 = np.round((v - v.min()) / (v.max() - v.min()) * 255).astype(np.uint8)
np.savez(sys.argv[1], v=u8, spacing=np.array(vol.spacing))
print("head", u8.shape, vol.spacing)
PY
PEERS=${PEERS:-vispy,pygfx,voxscope} OUT="$DIR/shots" PEER_TIMEOUT=150 \
    python3 docs/bench/peer_bench.py "$DIR/head256.npz" 100 1024 768 | tee "$DIR/$RUN-peers.jsonl"
python3 docs/bench/peer_bench.py --sheet "$DIR/shots" | tail -4
rm -f "$DIR/head256.npz"
if [ -n "${OUT:-}" ]; then
    tar -czf "$OUT/$RUN.tar.gz" -C /tmp "$RUN"
fi
