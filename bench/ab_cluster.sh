#!/usr/bin/env bash
# Two builds side by side on `parrt bench cluster`, run by run: for each run and each worker
# shape, OLD and NEW replay the same recording with the same flags (which goes first alternates
# run by run), and every row of their cluster.csv is kept with the build and run it came from.
# The summary gives, per shape and build, the median and range of efficiency, master CPU per
# tile and emulation CPU, and the paired NEW/OLD ratios (median, range).
#
#   RUNS=5 chrt -r 1 bench/ab_cluster.sh OLD_PARRT NEW_PARRT OUTDIR [SHAPE...] -- [bench cluster flags]
#
# SHAPE is WORKERSxTHREADS[@WORK_SECONDS] (default: 8x1@32 16x4@256); the flags after `--`
# (default: mount --size 1024 --tile 16) go to every run. The recording is made once, by NEW.
set -euo pipefail
old=${1:?old parrt}
new=${2:?new parrt}
out=${3:?output directory}
shift 3
shapes=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do
    shapes+=("$1")
    shift
done
[ $# -gt 0 ] && shift
flags=("$@")
[ ${#flags[@]} -eq 0 ] && flags=(mount --size 1024 --tile 16)
[ ${#shapes[@]} -eq 0 ] && shapes=(8x1@32 16x4@256)
runs=${RUNS:-5}
mkdir -p "$out"
rows="$out/rows.csv"
replay="$out/recording.replay"
echo "build,run,shape,$(head -1 <<'EOF'
workers,threads,tile,trace_s,efficiency,predicted,predicted_cluster,limit,binding,master_us_per_tile,emulation_cpu,machine_busy,bytes_received,identical,delivered_once,duplicates
EOF
)" >"$rows"

one() { # build-label binary run shape
    local label=$1 bin=$2 run=$3 shape=$4
    local wt=${shape%@*} work=${shape#*@}
    local w=${wt%x*} t=${wt#*x}
    local dir="$out/run-$run-$label-$wt"
    rm -rf "$dir"
    "$bin" bench cluster "${flags[@]}" --workers "$w" --threads "$t" --work-seconds "$work" \
        --replay "$replay" --out "$dir" >"$dir.out" 2>"$dir.err" || {
        echo "$label $shape run $run failed: see $dir.err" >&2
        return 1
    }
    tail -n +2 "$dir/cluster.csv" | sed "s/^/$label,$run,$wt,/" >>"$rows"
}

# The recording (one-thread renders of the scene), once.
if [ ! -f "$replay" ]; then
    "$new" bench cluster "${flags[@]}" --workers 1 --threads 1 --work-seconds 1 \
        --replay "$replay" --out "$out/record" >"$out/record.out" 2>"$out/record.err"
fi
for run in $(seq 1 "$runs"); do
    for shape in "${shapes[@]}"; do
        if [ $((run % 2)) -eq 1 ]; then
            one old "$old" "$run" "$shape"
            one new "$new" "$run" "$shape"
        else
            one new "$new" "$run" "$shape"
            one old "$old" "$run" "$shape"
        fi
    done
    echo "run $run of $runs done" >&2
done

python3 - "$rows" <<'EOF'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
shapes = sorted({r["shape"] for r in rows}, key=lambda s: [int(x) for x in s.split("x")])
def col(shape, build, key):
    return {r["run"]: float(r[key]) for r in rows if r["shape"] == shape and r["build"] == build}
def spread(v):
    return f"{statistics.median(v):.3f} ({min(v):.3f}–{max(v):.3f})"
print("| shape | build | runs | efficiency, median (range) | master µs/tile | emulation CPU | trace s |")
print("|---|---|---:|---|---|---|---|")
for s in shapes:
    for b in ("old", "new"):
        e = list(col(s, b, "efficiency").values())
        m = list(col(s, b, "master_us_per_tile").values())
        c = [100 * x for x in col(s, b, "emulation_cpu").values()]
        t = list(col(s, b, "trace_s").values())
        if not e:
            continue
        print(f"| {s} | {b} | {len(e)} | {spread(e)} | {statistics.median(m):.1f} ({min(m):.1f}–{max(m):.1f}) "
              f"| {statistics.median(c):.0f} % ({min(c):.0f}–{max(c):.0f}) | {spread(t)} |")
print()
print("| shape | efficiency new/old, paired median (range) | master µs/tile new − old, paired median (range) |")
print("|---|---|---|")
for s in shapes:
    eo, en = col(s, "old", "efficiency"), col(s, "new", "efficiency")
    mo, mn = col(s, "old", "master_us_per_tile"), col(s, "new", "master_us_per_tile")
    runs = sorted(set(eo) & set(en), key=int)
    if not runs:
        continue
    r = [en[k] / eo[k] for k in runs]
    d = [mn[k] - mo[k] for k in runs]
    print(f"| {s} | {statistics.median(r):.3f} ({min(r):.3f}–{max(r):.3f}) "
          f"| {statistics.median(d):+.1f} ({min(d):+.1f} … {max(d):+.1f}) |")
EOF
