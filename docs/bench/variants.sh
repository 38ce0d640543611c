#!/usr/bin/env bash
# Shader variants side by side on the lent GPU (docs/performance-log.md, attempt 17; runs 23-24).
# Each variant is a release binary built from one version of the shaders, stripped and gzipped
# into .bench/voxscope-NAME.gz (three or four fit the device tool's 64 MiB carry), beside
# .bench/mri-head-256.nii.gz and the Vulkan loader debs in .gl/ (see run.sh).
# Usage: VARIANTS="base b c8" bash docs/bench/variants.sh RUN_NAME head head64 grad noise
set -uo pipefail
run=$1; shift
out=/tmp/voxscope-bench; mkdir -p "$out"
for deb in .gl/*.deb; do dpkg -x "$deb" /; done; ldconfig
export WGPU_BACKEND=vulkan
[ -e /usr/share/vulkan/icd.d/nvidia_icd.json ] || export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
for f in .bench/*.gz; do [ "${f%.gz}" = .bench/mri-head-256.nii ] || gunzip -kf "$f"; done
chmod +x .bench/voxscope-*
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm,temperature.gpu --format=csv
head=.bench/mri-head-256.nii.gz
bench() { local name=$1 bin=$2; shift 2; local s=$SECONDS
  .bench/$bin bench "$@" --json >"$out/$run-$name.json" 2>"$out/$run-$name.err" || echo "FAILED $name: $(tail -2 $out/$run-$name.err)"
  echo "== $name $((SECONDS-s)) s"; }
vs=${VARIANTS:-base b}
for job in "$@"; do
  case $job in
    head) for v in $vs; do bench head256-$v voxscope-$v "$head"; done ;;
    head64) for v in $vs; do bench head256-64x48-$v voxscope-$v "$head" --size 64x48 --renderer bricks; bench head256-64x48-dense-$v voxscope-$v "$head" --size 64x48 --renderer dense; done ;;
    grad) for v in $vs; do for r in dense bricks; do bench gradient1024-$r-$v voxscope-$v synthetic:gradient:1024 --renderer $r --frames 50; done; done ;;
    noise) for v in $vs; do for r in dense bricks; do bench noise512-$r-$v voxscope-$v synthetic:noise:512 --renderer $r --frames 50; done; done ;;
  esac
done
python3 - "$out" "$run" <<'PY'
import json, pathlib, sys
out, run = pathlib.Path(sys.argv[1]), sys.argv[2]
for p in sorted(out.glob(f"{run}-*.json")):
    try: d = json.loads(p.read_text())
    except Exception as e: print(p.name, "bad", e); continue
    for r in d["results"]:
        print(f'{p.stem[len(run)+1:]:28} {r["renderer"]:7} {r["mode"]:11} {r["camera"]:7} {r["median_ms"]:.4f} {r["p95_ms"]:.4f}')
PY
[ -n "${OUT:-}" ] && tar czf "$OUT/$run.tar.gz" -C "$out" .
