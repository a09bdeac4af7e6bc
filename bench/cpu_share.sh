#!/usr/bin/env bash
# Where the CPU goes while a sequence renders, by role: a measure of the local sequence goal
# that this machine's drifting speed does not move. The throughput ratio of two local workers
# to SMP wanders ±5 points from one series of runs to the next (a virtual machine's cores
# speed up and slow down for everyone at once); the share of all CPU samples that each kind of
# thread takes while the render runs barely does. Samples every CPU at 2 kHz (`perf record -a`)
# through one run each of SMP and of the workers per round, keeps the samples between the render
# threads' first and last (less 10 ms at each end) and prints, per run, the percentage of them
# taken by:
#   render   threads that trace tiles (SMP's pool, the workers' `parrt-render-*`)
#   master   the master's other threads (its event loop: results, scheduling, the frames' PNGs)
#   links    the workers' other threads (their event loops: sealing and sending results)
#   idle     no thread (the kernel's idle task)
#   other    anything else on the machine
# and the render threads' share of parrt's own samples (render, master and links), which
# another program's bursts on the machine do not move.
# SMP's render threads also encode the frames' PNGs, which through workers the master does:
# about 1.5 points of the orbit's samples. Numbers only: no assertion.
#
#   usage: bench/cpu_share.sh BINARY [ROUNDS]     (ROUNDS defaults to 3)
#   env:   SCENE (default mount:6), SIZE (default 512), FRAMES (default 24)
#   needs: perf (Debian's linux-perf), and permission to sample every CPU
#          (kernel.perf_event_paranoid ≤ 0, or root)
set -euo pipefail
[ $# -ge 1 ] || { sed -n '2,23p' "$0" >&2; exit 2; }
BIN=$1 ROUNDS=${2:-3}
SCENE=${SCENE:-mount:6} SIZE=${SIZE:-512} FRAMES=${FRAMES:-24}
command -v perf >/dev/null || { echo "cpu_share: perf is not installed" >&2; exit 1; }
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
args=(render --scene "$SCENE" --orbit 360 --frames "$FRAMES" --width "$SIZE" --height "$SIZE"
      -o "$T/f-%04d.png")

# Samples one run of `BIN render … "$@"` and prints its shares by role.
shares() {
    perf record -q -F 2000 -a -o "$T/perf.data" -- "$BIN" "${args[@]}" "$@" >/dev/null 2>&1
    perf script -i "$T/perf.data" -F comm,pid,tid,time 2>/dev/null | python3 -c '
import collections, sys
samples = []
for line in sys.stdin:
    f = line.split()
    pid, tid = (int(x) for x in f[-2].split("/"))
    samples.append((" ".join(f[:-2]), pid, tid, float(f[-1].rstrip(":"))))
ours = sys.argv[1][:15]
master = min(p for c, p, t, _ in samples if c == ours and p == t)
def role(comm, pid, tid):
    if comm.startswith("parrt-render") or (pid == master and tid != pid and comm == ours):
        return "render"
    if pid == master:
        return "master"
    if comm == ours or comm.startswith("tokio-"):
        return "links"
    return "idle" if pid == 0 else "other"
roles = [(role(c, p, t), at) for c, p, t, at in samples]
traced = [at for r, at in roles if r == "render"]
lo, hi = min(traced) + 0.01, max(traced) - 0.01
n = collections.Counter(r for r, at in roles if lo <= at <= hi)
total = sum(n.values())
own = 100 * n["render"] / (n["render"] + n["master"] + n["links"])
print("  ".join(f"{r} {100 * n[r] / total:5.1f} %" for r in
                ("render", "master", "links", "idle", "other")),
      f"| render of parrt’s own {own:5.1f} % ({total} samples)")
' "$(basename "$BIN")"
}

for _ in $(seq "$ROUNDS"); do
    echo "SMP, 2 threads:              $(shares --threads 2)"
    echo "2 workers × 1 thread:        $(shares --workers 2 --threads 1)"
done
