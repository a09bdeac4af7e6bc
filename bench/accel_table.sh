#!/usr/bin/env bash
# BVH against the uniform grid (at several densities) on the SPD default scenes: build and trace
# time at 512×512 on one thread, with primitive tests, box tests and grid cell steps per ray.
# Prints a Markdown table on stdout; timings are medians of REPS runs (benchmarks print numbers,
# they assert nothing: docs/design-measures.md, *Efficiency*). Needs `cargo build --release` first, and jq.
#
# Usage: bench/accel_table.sh [REPS] [DENSITIES...]
#   PARRT_SPD_DIR  where the .nff files are (default data/spd in the repository)
#   PARRT_BIN      the parrt binary (default target/release/parrt)
#   SLOW           a run whose trace takes longer (seconds) is not repeated (default 8)
set -euo pipefail

reps=${1:-3}
shift || true
densities=("$@")
[ ${#densities[@]} -gt 0 ] || densities=(1 3 8 27)
spd=${PARRT_SPD_DIR:-$(cd "$(dirname "$0")/../data/spd" && pwd)}
bin=${PARRT_BIN:-target/release/parrt}
slow=${SLOW:-8}
scenes=(mount-6 balls-4 gears-4 rings-7 teapot-12 tetra-6 tree-11 lattice-12 shells-5)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

median() { sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }

# run SCENE ACCEL DENSITY -> prints one table row
run() {
    local scene=$1 accel=$2 density=$3 i
    local n=$reps
    for ((i = 0; i < n; i++)); do
        "$bin" render "$spd/$scene.nff" --accel "$accel" --grid-density "$density" \
            --threads 1 --width 512 --height 512 --stats-json "$tmp/$i.json" \
            -o "$tmp/img.ppm" >/dev/null 2>&1
        # A run slower than SLOW seconds is not repeated (the table marks it with *).
        if [ "$i" -eq 0 ] && awk -v t="$(jq .trace_s "$tmp/0.json")" -v s="$slow" 'BEGIN {exit !(t > s)}'; then
            n=1
        fi
    done
    local build trace mark=""
    [ "$n" -eq "$reps" ] || mark="*"
    build=$(for ((i = 0; i < n; i++)); do jq .build_s "$tmp/$i.json"; done | median)
    trace=$(for ((i = 0; i < n; i++)); do jq .trace_s "$tmp/$i.json"; done | median)
    jq -r --arg acc "$accel" --arg den "$density" --arg build "$build" --arg trace "$trace" \
        --arg mark "$mark" '
        def r(x; n): (x * pow(10; n) | round) / pow(10; n);
        (.total_rays) as $n |
        [ (.scene | split("/") | last | rtrimstr(".nff")), (.primitives | tostring),
          (if $acc == "grid" then "grid \($den)" else $acc end),
          (if $acc == "grid" then "\(.accel.nodes) (\(r(100 - 100 * .accel.leaves / .accel.nodes; 0))% empty)"
           else "\(.accel.nodes) nodes" end),
          (r(.accel.references / .primitives; 2) | tostring),
          (r(($build | tonumber) * 1000; 1) | tostring),
          ((r($trace | tonumber; 3) | tostring) + $mark),
          (r($n / ($trace | tonumber) / 1e6; 2) | tostring),
          (r(.primitive_tests / $n; 1) | tostring),
          (r(.box_tests / $n; 1) | tostring),
          (r(.cell_steps / $n; 1) | tostring) ]
        | "| " + join(" | ") + " |"' "$tmp/0.json"
}

echo "| scene | prims | accel | cells / nodes | refs per prim | build ms | trace s | Mrays/s | prim tests/ray | box tests/ray | cell steps/ray |"
echo "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|"
for s in "${scenes[@]}"; do
    run "$s" bvh 1
    for d in "${densities[@]}"; do
        run "$s" grid "$d"
    done
done
