#!/usr/bin/env bash
# Converts a volume to a multiscale OME-Zarr image on a Slurm cluster: the plan here, the parts
# as a job array (at most CAP running at once), and `finalize` as a job that starts only when
# every part has succeeded (afterok). OUT must be on a file system every node shares.
#
#   convert-slurm.sh IN OUT.ome.zarr PARTS [CAP] [-- convert's options]
#
# VOXSCOPE names the binary (default: voxscope on PATH); SBATCH_ARGS are added to both
# submissions (--partition, --time, --account, …). Each part asks for CPUS CPUs (default 4,
# its threads) and MEM of memory (default 3G: a part's columns hold under 2 GB); prints the
# two jobs' ids.
set -euo pipefail
IN=${1:?usage: convert-slurm.sh IN OUT PARTS [CAP] [-- options]}
OUT=${2:?usage: convert-slurm.sh IN OUT PARTS [CAP] [-- options]}
PARTS=${3:?usage: convert-slurm.sh IN OUT PARTS [CAP] [-- options]}
CAP=8
shift 3
if [ $# -gt 0 ] && [ "$1" != "--" ]; then CAP=$1; shift; fi
[ "${1:-}" = "--" ] && shift
VOXSCOPE=${VOXSCOPE:-voxscope}
OUT=$(realpath -m "$OUT")

n=$("$VOXSCOPE" convert plan "$IN" "$OUT" --parts "$PARTS" "$@")
mkdir -p "$OUT/.voxscope/logs"
# The part's number is the array task's id (SLURM_ARRAY_TASK_ID), which `convert run` reads.
parts=$(sbatch --parsable ${SBATCH_ARGS:-} --job-name=voxscope-parts \
    --array="0-$((n - 1))%$CAP" --cpus-per-task="${CPUS:-4}" --mem="${MEM:-3G}" \
    --output="$OUT/.voxscope/logs/part-%a.log" \
    --wrap="RAYON_NUM_THREADS=\${SLURM_CPUS_PER_TASK:-4} exec '$VOXSCOPE' convert run '$OUT'")
final=$(sbatch --parsable ${SBATCH_ARGS:-} --job-name=voxscope-finalize \
    --dependency="afterok:$parts" --kill-on-invalid-dep=yes \
    --output="$OUT/.voxscope/logs/finalize.log" \
    --wrap="exec '$VOXSCOPE' convert finalize '$OUT'")
echo "$parts $final"
