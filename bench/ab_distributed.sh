#!/usr/bin/env bash
# Two parrt builds side by side on the two-worker comparison (a change to the master must keep
# its speed): `parrt render --workers 2 --threads 1` and `parrt render --threads 2`, tile 32,
# each build run back to back with the other, run by run, so drifts of the machine's speed cancel.
# Prints per case the medians of the trace phase (`--stats-json` trace_s), of the whole process
# (start to exit) and of the master's CPU per tile, old and new, the median of the paired ratios
# new/old, and whether the four images are the same bytes. Numbers only: no assertion.
#
#   usage: bench/ab_distributed.sh OLD_BINARY NEW_BINARY [SCENE:SIZE@PIXELS ...]
#          default cases: mount:6@512 mount:6@2048 gears:4@512 gears:4@2048
#   env:   RUNS (default 5), TILE (default 32)
#
# For the least noise run it under `chrt -r 1` (root).
set -euo pipefail
[ $# -ge 2 ] || { sed -n '2,13p' "$0" >&2; exit 2; }
OLD=$1 NEW=$2
shift 2
[ $# -gt 0 ] || set -- mount:6@512 mount:6@2048 gears:4@512 gears:4@2048
RUNS=${RUNS:-5}
TILE=${TILE:-32}
command -v jq >/dev/null || { echo "needs jq (apt-get install jq)" >&2; exit 2; }
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT

# One render: appends "trace_s whole_s master_cpu_us" to $T/<tag>.
run() {
    local bin=$1 tag=$2 scene=$3 px=$4
    shift 4
    local t0 t1
    t0=$(date +%s.%N)
    "$bin" render --scene "$scene" --width "$px" --height "$px" --tile "$TILE" "$@" \
        -o "$T/$tag.png" --stats-json "$T/$tag.json" 2>/dev/null
    t1=$(date +%s.%N)
    echo "$(jq .trace_s "$T/$tag.json") $(echo "$t1 - $t0" | bc -l) $(jq '.master_cpu_per_tile_us // 0' "$T/$tag.json")" >> "$T/$tag"
}

echo "| case | mode | trace old s | trace new s | trace new/old (paired) | whole old s | whole new s | whole new/old (paired) | master µs/tile old | new | images |"
echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|"
for c in "$@"; do
    scene=${c%@*}
    px=${c#*@}
    for mode in smp2 dist2; do : > "$T/old-$mode"; : > "$T/new-$mode"; done
    for _ in $(seq "$RUNS"); do
        for mode in smp2 dist2; do
            case $mode in
                smp2) flags=(--threads 2) ;;
                dist2) flags=(--workers 2 --threads 1) ;;
            esac
            run "$OLD" "old-$mode" "$scene" "$px" "${flags[@]}"
            run "$NEW" "new-$mode" "$scene" "$px" "${flags[@]}"
        done
    done
    same=same
    for f in old-dist2 new-smp2 new-dist2; do
        cmp -s "$T/old-smp2.png" "$T/$f.png" || same=DIFFERENT
    done
    for mode in smp2 dist2; do
        python3 - "$c" "$mode" "$T/old-$mode" "$T/new-$mode" "$same" <<'PY'
import statistics as st, sys
case, mode, old_f, new_f, same = sys.argv[1:]
old = [list(map(float, l.split())) for l in open(old_f)]
new = [list(map(float, l.split())) for l in open(new_f)]
med = lambda rows, i: st.median(r[i] for r in rows)
paired = lambda i: st.median(n[i] / o[i] for o, n in zip(old, new))
cpu_o, cpu_n = med(old, 2), med(new, 2)
cpu = f"{cpu_o:.1f} | {cpu_n:.1f}" if mode == "dist2" else "— | —"
print(f"| {case} | {mode} | {med(old,0):.3f} | {med(new,0):.3f} | {paired(0):.3f} | "
      f"{med(old,1):.3f} | {med(new,1):.3f} | {paired(1):.3f} | {cpu} | {same} |")
PY
    done
done
