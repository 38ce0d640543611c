#!/usr/bin/env bash
# The streaming renderer's benchmark (issue 18, docs/benchmarks.md "Streaming") on the lent GPU
# machine, from the repository root there. It builds nothing: it expects, carried in
# out/stream-bench (git-ignored), voxscope.gz (and voxscope-a.gz, a variant to compare),
# shader_stats.gz (the example), stream.wgsl (ray_common.wgsl + stream.wgsl, composed; and
# stream-a.wgsl), and the Vulkan loader's .deb files in out/stream-bench/gl or .gl.
# Usage: [JOBS="noise ct noise-a noise8 stats image"] [LIMIT=seconds] bash stream.sh RUN_NAME
# (copied to out/stream-bench/run.sh). Files RUN_NAME-… go to $OUT.
set -uo pipefail
D=out/stream-bench
RUN=${1:-run46}
for deb in $D/gl/*.deb .gl/*.deb; do [ -e "$deb" ] && dpkg -x "$deb" /; done
ldconfig
export WGPU_BACKEND=vulkan
if [ ! -e /usr/share/vulkan/icd.d/nvidia_icd.json ]; then
    export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
for packed in $D/*.gz; do gunzip -kf "$packed" && chmod +x "${packed%.gz}"; done
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm --format=csv
nproc; free -g | head -2
OUTDIR=${OUT:-/tmp/out}; mkdir -p "$OUTDIR"
bench() { # NAME BINARY ARGS…
    local name=$1 binary=$2; shift 2
    echo "== $name: $binary $*"
    local started=$SECONDS
    timeout "${LIMIT:-200}" $binary bench "$@" --stream --json --gpu-memory 2GiB --ram-cache 8GiB \
        >"$OUTDIR/$RUN-$name.json" 2>"$OUTDIR/$RUN-$name.err"
    echo "   exit $? after $((SECONDS - started)) s"; tail -3 "$OUTDIR/$RUN-$name.err"
}
for job in ${JOBS:-noise ct stats image}; do
    case $job in
        noise) bench stream-noise16384 $D/voxscope synthetic:noise:16384 ;;
        noise-a) bench stream-noise16384-a $D/voxscope-a synthetic:noise:16384 ;;
        noise8) bench stream-noise16384-upload8 $D/voxscope synthetic:noise:16384 --upload-budget 8MiB ;;
        ct) bench stream-ct1024 $D/voxscope synthetic:ct:1024 ;;
        stats)
            { $D/shader_stats $D/stream.wgsl:main $D/stream.wgsl:main:SHADING=1 $D/stream.wgsl:main:CLIP=1 \
                  $D/stream-a.wgsl:main;
              $D/shader_stats; } >"$OUTDIR/$RUN-shader-stats.txt" 2>&1
            grep -E "^[^ ]|Register Count|Binary Size" "$OUTDIR/$RUN-shader-stats.txt" | head -40 ;;
        image)
            timeout 60 $D/voxscope render synthetic:noise:16384 --renderer stream --gpu-memory 2GiB \
                --ram-cache 8GiB -o "$OUTDIR/$RUN-noise16384.png" --max-wait 10 2>&1 | tail -2 ;;
    esac
done
python3 - "$OUTDIR" "$RUN" <<'PY'
import json, pathlib, sys
out, run = pathlib.Path(sys.argv[1]), sys.argv[2]
for path in sorted(out.glob(f"{run}-stream-*.json")):
    try:
        r = json.loads(path.read_text())
    except Exception as e:
        print(path.name, "unreadable", e); continue
    s = r["stopped_view"]
    print(path.name, r["adapter"], r["driver"], "first image", round(r["first_image_s"], 3), "pipeline", round(r["pipeline_build_s"], 3))
    print("  stopped:", s["complete"], round(s["seconds_after_first_image"], 3), "s after first;", s["bricks_read"], "read", s["view_bricks"], "view bricks, read/floor", round(s["read_over_floor"], 2))
    for o in r["orbits"]:
        print("  orbit", o["camera"], "gpu", {k: round(v, 3) for k, v in o["gpu_ms"].items()}, "wall", {k: round(v, 2) for k, v in o["wall_ms"].items()}, "over16", o["frames_over_16ms_wall"], "update", {k: round(v, 2) for k, v in o["update_ms"].items()})
    for row in r["resident"]["rows"]:
        print("  resident", row["mode"], row["camera"], row["complete"], round(row["stream_gpu_ms"], 4), round(row["bricks_gpu_ms"], 4), round(row["stream_over_bricks"], 2), "wall", round(row["stream_wall_ms_per_frame"], 3), round(row["bricks_wall_ms_per_frame"], 3))
PY
