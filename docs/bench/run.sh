#!/usr/bin/env bash
# One benchmark run on the lent GPU machine (docs/benchmarks.md), from the repository root there.
# It builds nothing: it expects, carried beside the checkout (both ignored by git),
#   .gl/     the Vulkan loader's .deb files (device README), unpacked into / here;
#   $BENCH_DIR (default .bench/)  voxscope (a stripped release binary), optionally voxscope-base
#            (the binary to compare against), the volumes below, and optionally shader_stats
#            (the example, release) and composed WGSL variants NAME.wgsl for it. Any of these
#            may come gzipped (NAME.gz: three binaries fit the device tool's 64 MiB only so).
# Usage: bash docs/bench/run.sh RUN_NAME [JOB…]   (JSON files named RUN_NAME-… go to
# /tmp/voxscope-bench, and, where $OUT is set (the device tool brings back at most 8 files),
# packed in $OUT/RUN_NAME.tar.gz). JOBs, in the order given (default: all of them but stats):
#   ceilings  the GPU's own ceilings        head    the 256³ head, voxscope and voxscope-base
#   head64    the same at 64x48 pixels      bricks  the head's bricks at brick sizes 16 and 8
#   mni       the MNI152 template           grad    1024³ gradient, bricks and dense
#   noise     512³ noise, each renderer     ceilings-end  the ceilings again
#   levels    the head's bricks and dense at max levels 7, 6, 5 (pyramid levels 1–3)
#   channels  the head as a composite of 1, 2 and 4 channels (dense march)
#   stream-channels  the head streamed as 1, 2 and 4 channels together, resident (bench --stream)
#   stats     shader_stats: the driver's registers for voxscope's shaders and, for each
#             NAME.wgsl in $BENCH_DIR, its main and main_bricks
set -uo pipefail
run=${1:?usage: run.sh RUN_NAME [JOB…]}
shift
jobs=("$@")
[ ${#jobs[@]} -gt 0 ] || jobs=(ceilings head head64 bricks mni grad noise ceilings-end)
dir=${BENCH_DIR:-.bench}
out=/tmp/voxscope-bench
mkdir -p "$out"
for deb in .gl/*.deb; do dpkg -x "$deb" /; done
ldconfig
for packed in "$dir"/*.gz; do
    case $packed in
        *.nii.gz | "$dir/*.gz") ;;
        *) gunzip -kf "$packed" && chmod +x "${packed%.gz}" ;;
    esac
done
export WGPU_BACKEND=vulkan
if ! ldconfig -p | grep libvulkan >/dev/null; then echo "no Vulkan loader"; exit 1; fi
if [ ! -e /usr/share/vulkan/icd.d/nvidia_icd.json ]; then
    export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm,temperature.gpu --format=csv

head=$dir/mri-head-256.nii.gz
mni=$dir/mni152-t1-197x233x189.nii.gz
bench() { # NAME BINARY ARGS…
    local name=$1 binary=$2
    shift 2
    [ -x "$binary" ] || return 0
    echo "== $name: $binary $*"
    local started=$SECONDS
    if "$binary" bench "$@" --json >"$out/$run-$name.json" 2>"$out/$run-$name.err"; then
        echo "   $((SECONDS - started)) s"
    else
        echo "   FAILED: $(tail -3 "$out/$run-$name.err")"
    fi
    [ -s "$out/$run-$name.err" ] || rm -f "$out/$run-$name.err"
}

ceilings() { # NAME: the GPU's own ceilings (voxscope ceilings); a summary goes to the reply
    echo "== $1"
    "$dir/voxscope" ceilings --json >"$out/$run-$1.json" || return 0
    python3 - "$out/$run-$1.json" <<'EOF'
import json, sys
c = json.load(open(sys.argv[1]))
print(f"   {c['memory_bytes_per_s'] / 1e9:.0f} GB/s, {c['filtered_samples_per_s'] / 1e9:.0f} G samples/s, "
      f"latency {c['texture_latency_ns']:.0f} ns texture / {c['buffer_latency_ns']:.1f} ns buffer, "
      f"{c['fma_flops_per_s'] / 1e12:.1f} TFLOP/s, {c['store_only_invocations_per_s'] / 1e9:.0f} G store-only/s")
EOF
}

shader_stats() { # the driver's statistics of the ray casters, and of each NAME.wgsl variant
    [ -x "$dir/shader_stats" ] || { echo "no $dir/shader_stats"; return 0; }
    echo "== shader_stats"
    local variants=()
    for wgsl in "$dir"/*.wgsl; do
        [ -e "$wgsl" ] && variants+=("$wgsl:main" "$wgsl:main_bricks")
    done
    {
        "$dir/shader_stats"
        [ ${#variants[@]} -eq 0 ] || "$dir/shader_stats" "${variants[@]}"
    } 2>&1 | tee "$out/$run-shader-stats.txt" | grep -E "^device|^[^ ]|Register Count|Binary Size"
}

for job in "${jobs[@]}"; do
    case $job in
        ceilings | ceilings-end) ceilings "$job" ;;
        head)
            bench head256 "$dir/voxscope" "$head"
            bench head256-base "$dir/voxscope-base" "$head"
            ;;
        # Few rays, all in flight at once: the frame takes as long as the longest ray's chain.
        head64)
            bench head256-64x48 "$dir/voxscope" "$head" --size 64x48
            bench head256-64x48-base "$dir/voxscope-base" "$head" --size 64x48
            ;;
        # Brick size against the per-brick cost (runs 4-5 chose 32 when a brick cost a descent).
        bricks)
            bench head256-bricks-b16 "$dir/voxscope" "$head" --renderer bricks --brick-size 16
            bench head256-bricks-b8 "$dir/voxscope" "$head" --renderer bricks --brick-size 8
            ;;
        mni) bench mni152 "$dir/voxscope" "$mni" ;;
        grad)
            bench gradient1024-bricks "$dir/voxscope" synthetic:gradient:1024 --renderer bricks --frames 50
            bench gradient1024-dense "$dir/voxscope" synthetic:gradient:1024 --renderer dense --frames 50
            ;;
        # Nothing uniform, nothing transparent: rays end after a few samples. One process per
        # renderer: in one process the bricks renderer ran 2x slower after the octree's 1.8 GB
        # had come and gone (run 21; the head showed no such effect).
        noise)
            for renderer in octree dense bricks; do
                bench noise512-$renderer "$dir/voxscope" synthetic:noise:512 --renderer $renderer --frames 50
            done
            ;;
        # Each max level's own resolution: bricks between their brick level (3 for the head's
        # 32³ bricks) and full detail, dense below full detail, a pyramid level each.
        levels)
            for level in 7 6 5; do
                bench head256-bricks-l$level "$dir/voxscope" "$head" --renderer bricks --level $level
                bench head256-dense-l$level "$dir/voxscope" "$head" --renderer dense --level $level
            done
            ;;
        # The composite of 1, 2 and 4 channels (copies of the head, each its own table).
        channels)
            bench head256-composite "$dir/voxscope" "$head" --renderer dense --composite-channels 1,2,4
            ;;
        # The same streamed together once resident, against the one-channel streaming renderer.
        stream-channels)
            bench head256-stream-channels "$dir/voxscope" "$head" --stream --gpu-memory 2GiB \
                --composite-channels 1,2,4
            ;;
        stats) shader_stats ;;
        *) echo "unknown job $job" ;;
    esac
done

# A short table for the reply: renderer, mode, camera, median ms of each JSON.
python3 - "$out" "$run" <<'EOF'
import json, pathlib, sys
out, run = pathlib.Path(sys.argv[1]), sys.argv[2]
for path in sorted(out.glob(f"{run}-*.json")):
    report = json.loads(path.read_text())
    if "results" not in report:
        continue
    rows = {}
    for r in report["results"]:
        rows.setdefault((r["renderer"], r["mode"]), []).append(f'{r["median_ms"]:.3f}')
    print(path.name, report["adapter"], report.get("driver", ""))
    for (renderer, mode), times in rows.items():
        print(f"  {renderer:7} {mode:11} " + " / ".join(times))
EOF
[ -n "${OUT:-}" ] && tar czf "$OUT/$run.tar.gz" -C "$out" $(cd "$out" && ls | grep "^$run-")
