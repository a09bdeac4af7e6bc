#!/usr/bin/env bash
# Two workers against two threads, what distributing costs on one machine: `parrt render
# --workers 2 --threads 1` against `parrt render --threads 2` (and `--threads 1` for t₁), as a
# user runs them, with a PNG output (EXT: another format). Runs alternate (smp1, smp2, dist2, smp1, ...) so the three see the same machine; the
# table gives medians of REPS runs of the trace phase and of the whole process (wall clock,
# start to exit: parse, worker start-up, build, trace, PNG), the efficiency e = t₁/(2·t₂) of
# each, their ratio, and the master's CPU per tile. Numbers only: no assertion.
#
# Usage: bench/smp_vs_distributed.sh [REPS] [SCENE:SIZE@PIXELS ...]
#   default: 5 runs of mount:6 and gears:4 at 512 and 2048 pixels, tile 32
#   PARRT_BIN  the parrt binary (default target/release/parrt); TILE (default 32); EXT the
#   output's format, png (default), exr (f32 pixels through the workers) or ppm
set -euo pipefail
reps=${1:-5}
shift || true
cases=("$@")
[ ${#cases[@]} -gt 0 ] || cases=(mount:6@512 mount:6@2048 gears:4@512 gears:4@2048)
bin=${PARRT_BIN:-target/release/parrt}
tile=${TILE:-32}
ext=${EXT:-png}
case $ext in png|exr|ppm) ;; *) echo "EXT must be png, exr or ppm, not $ext" >&2; exit 2 ;; esac
command -v jq >/dev/null || { echo "needs jq (apt-get install jq)" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
median() { sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }

echo "| scene | size | t₁ s | t₂ SMP s | t₂ 2 workers s | e SMP | e dist | e dist / e SMP | whole SMP s | whole dist s | dist / SMP | master CPU µs/tile |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
for c in "${cases[@]}"; do
    scene=${c%@*}
    px=${c#*@}
    : > "$tmp/s1"; : > "$tmp/s2"; : > "$tmp/d2"; : > "$tmp/ws2"; : > "$tmp/wd2"; : > "$tmp/cpu"
    for ((i = 0; i < reps; i++)); do
        for mode in s1 s2 d2; do
            case $mode in
                s1) flags=(--threads 1) ;;
                s2) flags=(--threads 2) ;;
                d2) flags=(--workers 2 --threads 1) ;;
            esac
            t0=$(date +%s.%N)
            "$bin" render --scene "$scene" --width "$px" --height "$px" --tile "$tile" \
                "${flags[@]}" -o "$tmp/$mode.$ext" --stats-json "$tmp/$mode.json" 2>/dev/null
            t1=$(date +%s.%N)
            jq .trace_s "$tmp/$mode.json" >> "$tmp/$mode"
            case $mode in
                s2) echo "$t1 - $t0" | bc -l >> "$tmp/ws2" ;;
                d2) echo "$t1 - $t0" | bc -l >> "$tmp/wd2"
                    jq .master_cpu_per_tile_us "$tmp/$mode.json" >> "$tmp/cpu" ;;
            esac
        done
        cmp -s "$tmp/s2.$ext" "$tmp/d2.$ext" || { echo "images differ for $c" >&2; exit 1; }
    done
    t1=$(median < "$tmp/s1"); s2=$(median < "$tmp/s2"); d2=$(median < "$tmp/d2")
    ws=$(median < "$tmp/ws2"); wd=$(median < "$tmp/wd2"); cpu=$(median < "$tmp/cpu")
    awk -v sc="$scene" -v px="$px" -v t1="$t1" -v s2="$s2" -v d2="$d2" -v ws="$ws" -v wd="$wd" -v cpu="$cpu" 'BEGIN {
        es = t1 / (2 * s2); ed = t1 / (2 * d2)
        printf "| %s | %d² | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f | %.1f |\n",
            sc, px, t1, s2, d2, es, ed, ed / es, ws, wd, wd / ws, cpu }'
done
