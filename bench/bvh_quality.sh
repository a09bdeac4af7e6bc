#!/usr/bin/env bash
# BVH quality: the binned-SAH build (`--accel bvh`) against a Goldsmith–Salmon hierarchy
# (`--accel bvh-gs`) on the SPD default scenes, one thread, 512×512 (the issue "Performance":
# box tests per ray well below Goldsmith–Salmon's, SAH cost reported per scene). Prints a
# Markdown table on stdout; the ratios are G–S over SAH, of box tests and of all tests (box +
# primitive) per ray. SAH costs and tests per ray are exact and repeatable; trace seconds
# are medians of REPS runs. A G–S row marked † had parts rebuilt to fit the traversal stack
# (the build warns). Needs `cargo build --release -p parrt-master` first, and jq.
#
# Usage: bench/bvh_quality.sh [REPS]
#   PARRT_SPD_DIR  where the .nff files are (default data/spd in the repository)
#   PARRT_BIN      the parrt binary (default target/release/parrt)
set -euo pipefail

reps=${1:-3}
spd=${PARRT_SPD_DIR:-$(cd "$(dirname "$0")/../data/spd" && pwd)}
bin=${PARRT_BIN:-target/release/parrt}
scenes=(mount-6 balls-4 gears-4 rings-7 teapot-6 teapot-12 tetra-6 tree-11 lattice-12 shells-5
    jacks-4)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

median() { sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }

# run SCENE ACCEL: renders REPS times; leaves $tmp/ACCEL.json (first run), $tmp/ACCEL.trace
# (median trace seconds) and $tmp/ACCEL.err (stderr of the first run).
run() {
    local scene=$1 accel=$2 i
    for ((i = 0; i < reps; i++)); do
        # One ray at a time, so box tests per ray mean what they say (packets test a box once for
        # up to 16 rays).
        "$bin" render "$spd/$scene.nff" --accel "$accel" --threads 1 --width 512 --height 512 --no-packets \
            --stats-json "$tmp/$accel.$i.json" -o "$tmp/img.ppm" >/dev/null 2>"$tmp/$accel.$i.err"
    done
    cp "$tmp/$accel.0.json" "$tmp/$accel.json"
    cp "$tmp/$accel.0.err" "$tmp/$accel.err"
    for ((i = 0; i < reps; i++)); do jq .trace_s "$tmp/$accel.$i.json"; done | median >"$tmp/$accel.trace"
}

echo "| scene | prims | SAH cost (SAH) | SAH cost (G–S) | box tests/ray (SAH) | box tests/ray (G–S) | G–S / SAH box tests | prim tests/ray (SAH) | prim tests/ray (G–S) | G–S / SAH box + prim tests | trace s (SAH) | trace s (G–S) | depth (SAH / G–S) |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
for s in "${scenes[@]}"; do
    run "$s" bvh
    run "$s" bvh-gs
    mark=""
    grep -q "too deep" "$tmp/bvh-gs.err" && mark="†"
    jq -r -n --slurpfile a "$tmp/bvh.json" --slurpfile g "$tmp/bvh-gs.json" \
        --arg scene "$s" --arg mark "$mark" \
        --arg ta "$(cat "$tmp/bvh.trace")" --arg tg "$(cat "$tmp/bvh-gs.trace")" '
        def r(x; n): (x * pow(10; n) | round) / pow(10; n);
        def per(j; k): j[k] / j.total_rays;
        def all(j): per(j; "box_tests") + per(j; "primitive_tests");
        ($a[0]) as $a | ($g[0]) as $g |
        [ $scene, ($a.primitives | tostring),
          (r($a.accel.sah_cost; 1) | tostring), (r($g.accel.sah_cost; 1) | tostring),
          (r(per($a; "box_tests"); 1) | tostring), (r(per($g; "box_tests"); 1) | tostring),
          (r(per($g; "box_tests") / per($a; "box_tests"); 2) | tostring),
          (r(per($a; "primitive_tests"); 2) | tostring), (r(per($g; "primitive_tests"); 2) | tostring),
          (r(all($g) / all($a); 2) | tostring),
          (r($ta | tonumber; 3) | tostring), (r($tg | tonumber; 3) | tostring),
          "\($a.accel.max_depth) / \($g.accel.max_depth)\($mark)" ]
        | "| " + join(" | ") + " |"'
done
