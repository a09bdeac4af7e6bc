#!/usr/bin/env bash
# parrt beside its peers on the SPD scenes (issue 9): POV-Ray 3.7 (full render, CPU time, its
# start-up on an empty scene subtracted) and Embree 3 through the shared nffcast harness (ray
# casting: eye rays through pixel centres + one shadow ray per light per hit, one thread).
# Installs POV-Ray and libembree-dev with apt-get when missing. Prints Markdown tables.
#
#   usage: bench/peers.sh [scene ...]        scenes as names in ../shared/spd/pov (e.g. mount-6)
#   env:   RUNS (default 3: medians), MINTIME (casting seconds per figure, default 1),
#          SHARED (default: ../shared beside the repository), OUT (default bench-out/peers)
set -euo pipefail
REPO=$(cd "$(dirname "$0")/.." && pwd)
SHARED=${SHARED:-$(cd "$REPO/../shared" && pwd)}
SPD=$SHARED/spd
RUNS=${RUNS:-3}
MINTIME=${MINTIME:-1}
OUT=${OUT:-$REPO/bench-out/peers}
mkdir -p "$OUT"

need_apt=""
command -v povray >/dev/null || need_apt="$need_apt povray"
[ -f /usr/include/embree3/rtcore.h ] || need_apt="$need_apt libembree-dev"
if [ -n "$need_apt" ]; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $need_apt >/dev/null
fi
NFFCAST=${NFFCAST:-/tmp/embreework/nffcast}
[ -x "$NFFCAST" ] || sh "$SHARED/anchors/embree/build.sh" "$(dirname "$NFFCAST")" >/dev/null
(cd "$REPO" && cargo build --release -q -p parrt-master)
PARRT=$REPO/target/release/parrt

if [ $# -eq 0 ]; then
    set -- mount-6 balls-4 gears-4 rings-7 teapot-6 teapot-12 tetra-6 tree-11 lattice-12 shells-5 jacks-4
fi

# CPU seconds (user + system) of one run of a command, from wait4's rusage (microseconds; GNU
# time's %U/%S round to 10 ms, which is a third of the smallest scene's render).
cpu() {
    python3 - "$@" <<'PY' || { echo "failed: $*" >&2; return 1; }
import os, sys
pid = os.fork()
if pid == 0:
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    os.dup2(null, 2)
    os.execvp(sys.argv[1], sys.argv[1:])
_, status, usage = os.wait4(pid, 0)
if os.waitstatus_to_exitcode(status) != 0:
    sys.exit(1)
print("%.4f" % (usage.ru_utime + usage.ru_stime))
PY
}
median() { sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
runs() { for _ in $(seq "$RUNS"); do cpu "$@"; done | median; }

cd "$OUT"
printf 'camera{location <0,0,-1> look_at 0} light_source{<0,0,-5> color rgb 1}\n' > empty.pov
POVARGS="+W512 +H512 -A -D +WT1 -GA"
pov_empty=$(runs povray +Iempty.pov +Oempty.png $POVARGS)

echo "Machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores; $(date -u +%Y-%m-%d)."
echo "POV-Ray start-up (empty scene): ${pov_empty}s CPU. Medians of $RUNS runs."
echo
echo "## Full render, one thread, 512×512, one eye ray per pixel centre, depth 5 (CPU seconds)"
echo
echo "| scene | POV-Ray 3.7 | parrt | parrt / POV-Ray | goal ≤ 0.25 |"
echo "|---|---:|---:|---:|---|"
for s in "$@"; do
    pov=$SPD/pov/$s.pov; nff=$SPD/$s.nff
    [ -f "$pov" ] && [ -f "$nff" ] || { echo "| $s | missing | | | |"; continue; }
    # sombrero's POV file reads its height field beside it.
    p=$(cd "$SPD/pov" && runs povray +I"$pov" +O"$OUT/$s.pov.png" $POVARGS)
    p=$(awk -v a="$p" -v b="$pov_empty" 'BEGIN {printf "%.4f", a - b}')
    q=$(runs "$PARRT" render "$nff" --threads 1 --width 512 --height 512 --max-depth 5 -o "$OUT/$s.parrt.png")
    r=$(awk -v a="$q" -v b="$p" 'BEGIN {printf "%.3f", a / b}')
    ok=$(awk -v r="$r" 'BEGIN {print (r <= 0.25) ? "met" : "not met"}')
    echo "| $s | $p | $q | $r | $ok |"
done
echo
echo "## Ray casting, one thread: eye + shadow rays per CPU second (Mrays/s)"
echo
echo "| scene | Embree 3 (single rays) | parrt | parrt / Embree | goal ≥ 0.5 | Embree 16-wide packets |"
echo "|---|---:|---:|---:|---|---:|"
for s in "$@"; do
    nff=$SPD/$s.nff
    [ -f "$nff" ] || continue
    cones=""
    grep -q '^c ' "$nff" && cones="-cones user"
    e=$("$NFFCAST" -threads 1 -mintime "$MINTIME" $cones "$nff" | grep '^RESULT')
    est=$(echo "$e" | tr ' ' '\n' | awk -F= '$1=="st_cpu_mrays" {print $2}')
    epk=$(echo "$e" | tr ' ' '\n' | awk -F= '$1=="pk16_st_cpu_mrays" {print $2}')
    q=$("$PARRT" bench cast "$nff" --size 512 --mintime "$MINTIME" | tail -1 | awk -F'|' '{gsub(/ /,"",$10); print $10}')
    r=$(awk -v a="$q" -v b="$est" 'BEGIN {printf "%.3f", a / b}')
    ok=$(awk -v r="$r" 'BEGIN {print (r >= 0.5) ? "met" : "not met"}')
    echo "| $s | $est | $q | $r | $ok | $epk |"
done
