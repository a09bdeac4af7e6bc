#!/usr/bin/env bash
# Real cluster launchers: installs Open MPI and Slurm from Debian's packages, starts a
# one-node Slurm cluster on this machine (munged, slurmctld, slurmd with a minimal slurm.conf in a
# temp dir, on their own socket and ports), and renders a small SPD scene with
#   mpirun --allow-run-as-root --oversubscribe -np 3 parrt cluster ...
#   srun -n 3 parrt cluster ...
#   sbatch scripts/slurm-parrt.sbatch
# Each image must equal the SMP render byte for byte. Every daemon started here is stopped (trap).
#
#   usage: tests/cluster/launchers.sh [PARRT_BINARY]     (default: target/debug/parrt)
# Needs root and apt; without them it prints why and exits 0 (skipped). A launcher whose daemons
# cannot start in this sandbox is skipped with the reason; a launcher that runs and renders a
# wrong image (or fails) fails the script.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
REPO=$(cd "$HERE/../.." && pwd)
BIN=${1:-$REPO/target/debug/parrt}
BIN=$(cd "$(dirname "$BIN")" && pwd)/$(basename "$BIN")
START=$(date +%s)
say() { echo "launchers: $*"; }
skip() { say "skipped: $*"; exit 0; }
[ "$(id -u)" = 0 ] || skip "needs root to install packages and start Slurm"
command -v apt-get >/dev/null || skip "no apt-get on this machine"
[ -x "$BIN" ] || { echo "launchers: no parrt binary at $BIN" >&2; exit 1; }

export DEBIAN_FRONTEND=noninteractive
need=()
command -v mpirun >/dev/null || need+=(openmpi-bin)
command -v slurmctld >/dev/null && command -v slurmd >/dev/null && command -v srun >/dev/null \
    || need+=(slurm-wlm)
command -v munged >/dev/null || need+=(munge)
if [ ${#need[@]} -gt 0 ]; then
    say "installing ${need[*]}"
    apt-get update -qq >/dev/null 2>&1 || skip "apt-get update failed (no network or no mirror?)"
    apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null 2>&1 \
        || skip "apt-get install ${need[*]} failed"
fi
say "packages ready after $(( $(date +%s) - START )) s"

T=$(mktemp -d /tmp/parrt-launchers.XXXXXX)
chmod 755 "$T"
PIDFILES=()
cleanup() {
    for f in "${PIDFILES[@]:-}"; do
        [ -n "$f" ] && [ -s "$f" ] && kill "$(cat "$f")" 2>/dev/null || true
    done
    sleep 0.5
    for f in "${PIDFILES[@]:-}"; do
        [ -n "$f" ] && [ -s "$f" ] && kill -9 "$(cat "$f")" 2>/dev/null || true
    done
    rm -rf "$T"
}
trap cleanup EXIT

# The scene: a small SPD file from the repository's test data, else generated.
SCENE=$REPO/data/spd/balls-3.nff
if [ ! -f "$SCENE" ]; then
    SCENE=$T/balls.nff
    "$BIN" scene balls:3 -o "$SCENE"
fi
FLAGS=(--width 160 --height 120 --tile 16)
"$BIN" render "$SCENE" "${FLAGS[@]}" -o "$T/smp.png" >/dev/null 2>&1
FAILED=0
RAN=()
SKIPPED=()
check() { # check NAME IMAGE LOG: the image, the rendezvous file gone, rank 0's line shown
    grep -h "is the master on" "$3" 2>/dev/null | sed 's/^/    /' || true
    if ls "$(dirname "$2")"/parrt-rendezvous-* >/dev/null 2>&1; then
        say "$1: FAILED: rendezvous file left behind"; FAILED=1
    elif [ -f "$2" ] && cmp -s "$2" "$T/smp.png"; then
        say "$1: image equals the SMP render byte for byte"
        RAN+=("$1")
    else
        say "$1: FAILED: image missing or different from the SMP render"
        FAILED=1
    fi
}

# --- Open MPI -------------------------------------------------------------------------------
mkdir -p "$T/mpi"
if (cd "$T/mpi" && timeout 120 mpirun --allow-run-as-root --oversubscribe -np 3 \
        "$BIN" cluster "$SCENE" "${FLAGS[@]}" -o "$T/mpi/out.png") >"$T/mpi.log" 2>&1; then
    check "mpirun -np 3" "$T/mpi/out.png" "$T/mpi.log"
else
    say "mpirun -np 3: FAILED; its log:"; tail -20 "$T/mpi.log"; FAILED=1
fi

# --- Slurm: munged, slurmctld, slurmd on this machine -----------------------------------------
slurm() {
    local host; host=$(hostname)
    mkdir -p "$T/munge" "$T/state" "$T/spool" "$T/job"
    chmod 700 "$T/munge"
    dd if=/dev/urandom of="$T/munge/munge.key" bs=1024 count=1 status=none
    chmod 400 "$T/munge/munge.key"
    PIDFILES+=("$T/munge/munged.pid")
    if ! munged --force --socket="$T/munge/munge.sock" --key-file="$T/munge/munge.key" \
            --pid-file="$T/munge/munged.pid" --log-file="$T/munge/munged.log" \
            --seed-file="$T/munge/munged.seed" >"$T/munged.out" 2>&1; then
        SKIPPED+=("srun, sbatch: munged cannot start here: $(tail -1 "$T/munged.out")")
        return 0
    fi
    local cpus; cpus=$(nproc)
    cat >"$T/slurm.conf" <<EOF
ClusterName=parrtci
SlurmctldHost=$host
AuthType=auth/munge
AuthInfo=socket=$T/munge/munge.sock
CredType=cred/munge
SlurmUser=root
SlurmdUser=root
SlurmctldPort=16817
SlurmdPort=16818
SlurmctldPidFile=$T/slurmctld.pid
SlurmdPidFile=$T/slurmd.pid
SlurmctldLogFile=$T/slurmctld.log
SlurmdLogFile=$T/slurmd.log
StateSaveLocation=$T/state
SlurmdSpoolDir=$T/spool
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
NodeName=$host CPUs=$cpus State=UNKNOWN
PartitionName=ci Nodes=$host Default=YES MaxTime=INFINITE State=UP OverSubscribe=YES
EOF
    export SLURM_CONF=$T/slurm.conf
    PIDFILES+=("$T/slurmctld.pid" "$T/slurmd.pid")
    if ! slurmctld -c >"$T/slurmctld.out" 2>&1; then
        SKIPPED+=("srun, sbatch: slurmctld cannot start here: $(tail -2 "$T/slurmctld.log" "$T/slurmctld.out" 2>/dev/null | tr '\n' ' ')")
        return 0
    fi
    if ! slurmd >"$T/slurmd.out" 2>&1; then
        SKIPPED+=("srun, sbatch: slurmd cannot start here: $(tail -2 "$T/slurmd.log" "$T/slurmd.out" 2>/dev/null | tr '\n' ' ')")
        return 0
    fi
    local i
    for i in $(seq 60); do
        if sinfo -h -o %t 2>/dev/null | grep -qE '^(idle|mix|alloc)'; then break; fi
        sleep 0.5
    done
    if ! sinfo -h -o %t 2>/dev/null | grep -qE '^(idle|mix|alloc)'; then
        SKIPPED+=("srun, sbatch: the node never became idle: $(sinfo -h -o '%t %E' 2>&1 | head -1); slurmd log: $(tail -2 "$T/slurmd.log" 2>/dev/null | tr '\n' ' ')")
        return 0
    fi
    say "one-node Slurm cluster up ($host, $cpus CPUs) after $(( $(date +%s) - START )) s"

    mkdir -p "$T/srun"
    if (cd "$T/srun" && timeout 120 srun -n 3 --overcommit "$BIN" cluster "$SCENE" \
            "${FLAGS[@]}" -o "$T/srun/out.png") >"$T/srun.log" 2>&1; then
        check "srun -n 3" "$T/srun/out.png" "$T/srun.log"
    else
        say "srun -n 3: FAILED; its log:"; tail -20 "$T/srun.log"; FAILED=1
    fi

    local id state
    if ! id=$(cd "$T/job" && SCENE=$SCENE OUT=$T/job/out.png PARRT=$BIN \
            PARRT_ARGS="${FLAGS[*]}" sbatch --parsable --nodes=1 --ntasks=3 \
            --cpus-per-task=1 --overcommit --time=5 \
            "$REPO/scripts/slurm-parrt.sbatch" 2>"$T/sbatch.err"); then
        say "sbatch: FAILED to submit: $(cat "$T/sbatch.err")"; FAILED=1; return 0
    fi
    for i in $(seq 240); do
        state=$(scontrol show job "$id" 2>/dev/null | grep -o 'JobState=[A-Z_]*' | cut -d= -f2)
        case "$state" in COMPLETED|FAILED|CANCELLED|TIMEOUT|NODE_FAIL|OUT_OF_MEMORY) break ;; esac
        sleep 0.5
    done
    if [ "$state" = COMPLETED ]; then
        check "sbatch scripts/slurm-parrt.sbatch" "$T/job/out.png" "$T/job/parrt-$id.log"
    else
        say "sbatch: FAILED (job $id: ${state:-unknown}); its log:"
        tail -20 "$T/job/parrt-$id.log" 2>/dev/null || true
        FAILED=1
    fi
}
slurm

for s in "${SKIPPED[@]:-}"; do [ -n "$s" ] && say "skipped $s"; done
say "ran: ${RAN[*]:-none}; took $(( $(date +%s) - START )) s"
exit $FAILED
