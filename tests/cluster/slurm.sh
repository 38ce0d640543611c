#!/usr/bin/env bash
# docs/cluster/convert-slurm.sh on a real single-node Slurm (Debian's slurm-wlm and munge),
# started here on this machine and stopped after: the parts run as a job array of at most 2 at
# once, finalize after them (afterok), and the image equals the one-process `convert`'s file
# for file. Then a part that fails (its input gone) keeps finalize from running.
# Usage: bash tests/cluster/slurm.sh [VOXSCOPE]   (default target/debug/voxscope)
set -euo pipefail
cd "$(dirname "$0")/../.."
VOXSCOPE=$(realpath "${1:-target/debug/voxscope}")
NUCLEI=$(realpath ../shared/data/nuclei-60x256x256.tif)
for tool in munged slurmctld slurmd sbatch squeue; do
    command -v $tool >/dev/null || { echo "slurm.sh: $tool is missing (apt-get install slurm-wlm munge)" >&2; exit 1; }
done
WORK=$(mktemp -d /tmp/voxscope-slurm.XXXXXX)
port() { python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
NODE=$(hostname -s)
export SLURM_CONF=$WORK/slurm.conf
mkdir -p "$WORK"/{state,spool,log}
cat >"$SLURM_CONF" <<CONF
ClusterName=voxscope-test
SlurmctldHost=$NODE(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
SlurmctldPort=$(port)
SlurmdPort=$(port)
StateSaveLocation=$WORK/state
SlurmdSpoolDir=$WORK/spool
SlurmctldPidFile=$WORK/slurmctld.pid
SlurmdPidFile=$WORK/slurmd.pid
SlurmctldLogFile=$WORK/log/slurmctld.log
SlurmdLogFile=$WORK/log/slurmd.log
NodeName=$NODE NodeAddr=127.0.0.1 CPUs=$(nproc) RealMemory=2000 State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
MUNGE_STARTED=""
stop() {
    for pid in "$WORK/slurmd.pid" "$WORK/slurmctld.pid"; do
        [ -f "$pid" ] && kill "$(cat "$pid")" 2>/dev/null || true
    done
    [ -n "$MUNGE_STARTED" ] && pkill -x munged 2>/dev/null || true
    sleep 1
    rm -rf "$WORK"
}
trap stop EXIT
if ! munge -n >/dev/null 2>&1; then
    mkdir -p /run/munge && chown munge:munge /run/munge /var/log/munge 2>/dev/null || true
    munged --force
    MUNGE_STARTED=yes
fi
slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"
for _ in $(seq 100); do
    sinfo -h -N -o %T 2>/dev/null | grep -q idle && break
    sleep 0.2
done
sinfo -N -o "%N %c %m %T"

# Waits until none of the jobs named is in the queue.
wait_jobs() {
    for _ in $(seq 600); do
        [ -z "$(squeue -h -j "$1" 2>/dev/null)" ] && return 0
        sleep 0.5
    done
    echo "slurm.sh: jobs $1 still queued after 300 s" >&2
    squeue
    return 1
}

OPTIONS=(--format 0.5 --chunk 32 --shard 2 --tile 3,3,2)
"$VOXSCOPE" convert "$NUCLEI" "$WORK/whole.ome.zarr" "${OPTIONS[@]}" >/dev/null 2>&1
jobs=$(CPUS=1 MEM=500M VOXSCOPE="$VOXSCOPE" bash docs/cluster/convert-slurm.sh \
    "$NUCLEI" "$WORK/slurm.ome.zarr" 3 2 -- "${OPTIONS[@]}")
echo "submitted: parts and finalize $jobs"
read -r parts final <<<"$jobs"
wait_jobs "$parts,$final"
cat "$WORK/slurm.ome.zarr/.voxscope/logs/finalize.log"
grep -q "^finalized" "$WORK/slurm.ome.zarr/.voxscope/logs/finalize.log"
diff -r -x .voxscope "$WORK/whole.ome.zarr" "$WORK/slurm.ome.zarr"
echo "the Slurm array's image equals the one-process convert's"

# A part that fails: finalize does not run (afterok), and no image is published.
cp "$NUCLEI" "$WORK/gone.tif"
jobs=$(CPUS=1 MEM=500M VOXSCOPE="$VOXSCOPE" bash docs/cluster/convert-slurm.sh \
    "$WORK/gone.tif" "$WORK/failed.ome.zarr" 2 -- "${OPTIONS[@]}")
rm "$WORK/gone.tif"
read -r parts final <<<"$jobs"
wait_jobs "$parts,$final"
grep -h "error:" "$WORK"/failed.ome.zarr/.voxscope/logs/part-*.log
if [ -e "$WORK/failed.ome.zarr/zarr.json" ] || [ -e "$WORK/failed.ome.zarr/.voxscope/logs/finalize.log" ]; then
    echo "slurm.sh: finalize ran after a failed part" >&2
    exit 1
fi
echo "a failed part kept finalize from running"
