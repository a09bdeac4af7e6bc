#!/bin/sh
# Run the Embree anchor over NFF scenes and print markdown tables.
#   usage: ./run_spd.sh [scene.nff ...]
#   default scenes: the SPD set at default sizes found in $SPD (default data/spd in the repository):
#     mount-6 balls-4 gears-4 tetra-6 teapot-6 rings-7 shells-5 lattice-12 jacks-1 tree-11 sombrero-1
#     plus teapot-12 (the "standard" ~10k-primitive teapot; the compiled default is 6)
#     (NAME-SIZE.nff, or NAME-default.nff, or NAME.nff)
#   env: NFFCAST (binary, default ${HOME}/.cache/embreework/nffcast), RUNDIR (logs + images, default
#        ${HOME}/.cache/embreework/runs), MINTIME (timed seconds per figure, default 1.0), THREADS (default 2),
#        IDLE_PCT / MAXWAIT: before each run wait (at most MAXWAIT s, default 900) until the rest of
#        the machine uses under IDLE_PCT % of all CPUs (default 5), since timings on a shared
#        2-core box are meaningless while something else runs.
#        NFFCAST_ARGS: extra options for the timed runs (e.g. "-noshadow" for primary rays only);
#        NOCONES=1 skips the extra "-cones user" runs.
set -eu
HERE=$(cd "$(dirname "$0")" && pwd)
NFFCAST=${NFFCAST:-${HOME}/.cache/embreework/nffcast}
RUNDIR=${RUNDIR:-${HOME}/.cache/embreework/runs}
SPD=${SPD:-$(cd "$(dirname "$0")/../../data/spd" && pwd)}
MINTIME=${MINTIME:-1.0}
THREADS=${THREADS:-2}
NFFCAST_ARGS=${NFFCAST_ARGS:-}
NOCONES=${NOCONES:-0}
IDLE_PCT=${IDLE_PCT:-5}
MAXWAIT=${MAXWAIT:-900}
[ -x "$NFFCAST" ] || "$HERE/build.sh" "$(dirname "$NFFCAST")"
mkdir -p "$RUNDIR"

busy_pct() { # % of all CPUs busy over 2 s
    set -- $(head -n 1 /proc/stat); t1=$(( $2+$3+$4+$5+$6+$7+$8+$9 )); i1=$(( $5+$6 ))
    sleep 2
    set -- $(head -n 1 /proc/stat); t2=$(( $2+$3+$4+$5+$6+$7+$8+$9 )); i2=$(( $5+$6 ))
    echo $(( 100 * ((t2-t1) - (i2-i1)) / (t2-t1 > 0 ? t2-t1 : 1) ))
}
wait_idle() {
    w=0
    while b=$(busy_pct); [ "$b" -gt "$IDLE_PCT" ] && [ "$w" -lt "$MAXWAIT" ]; do w=$((w + 2)); done
    echo "# idle-wait ${w}s, other load ${b}% of all CPUs, loadavg $(cut -d' ' -f1-3 /proc/loadavg)"
}

if [ $# -eq 0 ]; then
    for p in mount:6 balls:4 gears:4 tetra:6 teapot:6 rings:7 shells:5 lattice:12 jacks:1 tree:11 sombrero:1 teapot:12; do
        s=${p%%:*}; z=${p##*:}
        for f in "$SPD/$s-$z.nff" "$SPD/$s-default.nff" "$SPD/$s.nff"; do
            if [ -f "$f" ]; then set -- "$@" "$f"; break; fi
        done
    done
fi
: > "$RUNDIR/results.txt"
for f in "$@"; do
    n=$(basename "$f" .nff)
    echo "== $n" >&2
    { wait_idle; "$NFFCAST" -threads "$THREADS" -mintime "$MINTIME" $NFFCAST_ARGS -o "$RUNDIR/$n" -name "$n" "$f"; } > "$RUNDIR/$n.log"
    cat "$RUNDIR/$n.log" >&2
    grep '^RESULT' "$RUNDIR/$n.log" >> "$RUNDIR/results.txt"
    # BVH build with a single Embree (TBB) thread, no tracing figures
    "$NFFCAST" -bthreads 1 -threads 1 -packets none -noshadow -mintime 0 -minreps 1 -name "$n" "$f" > "$RUNDIR/$n.b1.log"
    grep '^RESULT' "$RUNDIR/$n.b1.log" | sed 's/^RESULT /RESULT1 /' >> "$RUNDIR/results.txt"
    if [ "$NOCONES" = 0 ] && grep -q ' cones=[1-9]' "$RUNDIR/$n.log"; then
        { wait_idle; "$NFFCAST" -threads "$THREADS" -mintime "$MINTIME" $NFFCAST_ARGS -cones user -o "$RUNDIR/$n.cones" -name "$n" "$f"; } > "$RUNDIR/$n.cones.log"
        cat "$RUNDIR/$n.cones.log" >&2
        grep '^RESULT' "$RUNDIR/$n.cones.log" | sed 's/^RESULT /RESULTC /' >> "$RUNDIR/results.txt"
    fi
done
python3 "$HERE/table.py" "$RUNDIR/results.txt"
