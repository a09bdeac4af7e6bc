#!/usr/bin/env bash
# Real network faults for distributed rendering: the master and two workers run in
# separate network namespaces joined by veth pairs; each worker's link gets 100-200 ms of latency
# and a few % of loss (tc netem when the kernel has it, else a user-space relay, impair.py); one
# worker's link is cut mid-job and brought back. The job must complete with an image identical to
# the SMP render, and the master's log must say what happened.
#
#   usage: tests/netns/fault.sh [PARRT_BINARY]     (default: target/debug/parrt)
# Needs root and `ip netns`; without them it prints why and exits 0 (skipped). Traffic stays
# inside namespaces this script creates (10.213.x.0/30 links that exist only there).
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
REPO=$(cd "$HERE/../.." && pwd)
BIN=${1:-$REPO/target/debug/parrt}
BIN=$(cd "$(dirname "$BIN")" && pwd)/$(basename "$BIN")
skip() { echo "netns fault test: skipped: $*"; exit 0; }
[ "$(id -u)" = 0 ] || skip "needs root to create network namespaces"
command -v ip >/dev/null || skip "iproute2 (ip) is not installed"
command -v python3 >/dev/null || skip "python3 is not installed"
[ -x "$BIN" ] || { echo "netns fault test: no parrt binary at $BIN" >&2; exit 1; }

M=parrt-ft-m; W1=parrt-ft-w1; W2=parrt-ft-w2
T=$(mktemp -d)
PIDS=()
cleanup() {
    for p in "${PIDS[@]:-}"; do [ -n "$p" ] && kill "$p" 2>/dev/null || true; done
    for n in $M $W1 $W2; do ip netns del "$n" 2>/dev/null || true; done
    rm -rf "$T"
}
trap cleanup EXIT
for n in $M $W1 $W2; do ip netns del "$n" 2>/dev/null || true; done
ip netns add $M 2>/dev/null || skip "cannot create network namespaces here"
ip netns add $W1; ip netns add $W2
for n in $M $W1 $W2; do ip -n $n link set lo up; done
link() { # link N WORKER_NS
    ip link add ftm$1 type veth peer name ftw$1
    ip link set ftm$1 netns $M; ip link set ftw$1 netns $2
    ip -n $M addr add 10.213.$1.1/30 dev ftm$1; ip -n $2 addr add 10.213.$1.2/30 dev ftw$1
    ip -n $M link set ftm$1 up; ip -n $2 link set ftw$1 up
}
link 1 $W1; link 2 $W2

# Impairment: netem on both ends of each link if the kernel has it, else the relay.
if ip netns exec $W1 tc qdisc add dev ftw1 root netem delay 150ms 50ms loss 3% 2>/dev/null; then
    ip netns exec $M tc qdisc add dev ftm1 root netem delay 150ms 50ms loss 3%
    ip netns exec $W2 tc qdisc add dev ftw2 root netem delay 150ms 50ms loss 3%
    ip netns exec $M tc qdisc add dev ftm2 root netem delay 150ms 50ms loss 3%
    IMPAIR="tc netem: 100-200 ms, 3% loss each way"
    A1=10.213.1.1:7878; A2=10.213.2.1:7878
else
    ip netns exec $W1 python3 "$HERE/impair.py" 127.0.0.1:7900 10.213.1.1:7878 0.03 120 & PIDS+=($!)
    ip netns exec $W2 python3 "$HERE/impair.py" 127.0.0.1:7900 10.213.2.1:7878 0.03 120 & PIDS+=($!)
    IMPAIR="user-space relay (no sch_netem in this kernel): 100-200 ms per chunk, 3% held back 300 ms"
    A1=127.0.0.1:7900; A2=127.0.0.1:7900
    sleep 0.5
fi
echo "netns fault test: $IMPAIR"

SCENE=(--scene mount:4 --width 96 --height 96 --max-depth 5)
echo "fault-test-token-$$" > "$T/token"
"$BIN" render "${SCENE[@]}" --threads 1 -o "$T/smp.exr" 2>/dev/null

PARRT_LOG=info ip netns exec $M "$BIN" master "${SCENE[@]}" --tile 16 --listen 0.0.0.0:7878 \
    --token-file "$T/token" --min-workers 2 --wait-workers 30 --tile-deadline 4 \
    --heartbeat-timeout 3 -o "$T/dist.exr" --report-json "$T/report.json" 2> "$T/master.log" &
MASTER=$!; PIDS+=($MASTER)
sleep 0.5
for w in 1 2; do
    ns=$W1; addr=$A1; [ $w = 2 ] && { ns=$W2; addr=$A2; }
    PARRT_WORKER_TILE_DELAY_MS=60 ip netns exec $ns "$BIN" worker --connect $addr --threads 1 \
        --name w$w --token-file "$T/token" --dial-timeout 20 2> "$T/worker$w.log" &
    PIDS+=($!)
done
# Cut worker 1's link once the job is under way, and bring it back.
for _ in $(seq 100); do grep -q "starting" "$T/master.log" 2>/dev/null && break; sleep 0.1; done
sleep 1.5
ip -n $W1 link set ftw1 down
echo "netns fault test: cut worker 1's link"
sleep 6
ip -n $W1 link set ftw1 up
echo "netns fault test: restored worker 1's link"

status=0
wait $MASTER || status=$?
if [ $status != 0 ]; then
    echo "netns fault test: FAILED: master exited $status" >&2; cat "$T/master.log" >&2; exit 1
fi
if ! cmp -s "$T/smp.exr" "$T/dist.exr"; then
    echo "netns fault test: FAILED: the distributed image differs from the SMP one" >&2; exit 1
fi
python3 - "$T/report.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
workers = ", ".join(f"{w['name']}: {w['tiles']} tiles" + (f" (left: {w['left']})" if w.get("left") else "")
                    for w in r.get("workers", []))
print(f"netns fault test: report: {r['tiles']} tiles; requeued {r['requeued']}, duplicates ignored "
      f"{r['duplicate_results']}, backups {r['backups']}, dropped {r['dropped']}; {workers}")
if sum(w["tiles"] for w in r["workers"]) != r["tiles"]:
    sys.exit("netns fault test: FAILED: the workers' first results do not add up to the tiles")
if not r["requeued"] and not r["backups"]:
    sys.exit("netns fault test: FAILED: the cut produced no requeue or backup: was the fault injected?")
PY
echo "netns fault test: the master's log lines about the fault (warnings and the INFO lines of workers lost, tiles requeued):"
grep -E "WARN|fault|dropping|left|requeue" "$T/master.log" | sed 's/^/  /' | head -12
echo "netns fault test: passed: identical image, nothing lost or doubled"
