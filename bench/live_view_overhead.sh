#!/usr/bin/env bash
# What watching costs the render (issue 19): the trace time of one render with no live view, with
# --http and no page open, and with --http and CLIENTS `curl -N` event streams connected the whole
# time (each receiving every tile), alternated REPS times; prints the medians and the fastest runs
# (the least disturbed by other work on the machine) and their ratios.
# Needs `cargo build --release` first, and curl.
#
# Usage: bench/live_view_overhead.sh [REPS] [CLIENTS] [-- RENDER ARGS...]
#   default render: --scene mount:6 --width 1024 --height 1024   PARRT_BIN: target/release/parrt
set -euo pipefail
reps=${1:-5}
clients=${2:-10}
shift 2 || true
[ "${1:-}" = "--" ] && shift
args=("$@")
[ ${#args[@]} -gt 0 ] || args=(--scene mount:6 --width 1024 --height 1024)
bin=${PARRT_BIN:-target/release/parrt}
T=$(mktemp -d)
trap 'jobs -p | xargs -r kill 2>/dev/null; rm -rf "$T"' EXIT

trace() { jq -r .trace_s "$T/s.json"; }
run_plain() { "$bin" render "${args[@]}" -o "$T/o.png" --stats-json "$T/s.json" 2>/dev/null; trace; }
run_http() { # run_http CLIENTS
    "$bin" render "${args[@]}" -o "$T/o.png" --stats-json "$T/s.json" \
        --http 127.0.0.1:0 --http-linger 1 2>"$T/err" &
    local pid=$! url=
    if [ "$1" -gt 0 ]; then
        # The clients connect while the scene is built; the trace has not begun.
        for _ in $(seq 1 100); do
            url=$(sed -n 's/^parrt: live view at //p' "$T/err"); [ -n "$url" ] && break; sleep 0.02
        done
        for i in $(seq 1 "$1"); do curl -sN "${url}events" > "$T/c$i" 2>/dev/null & done
    fi
    # While it lingers: CPU ticks of the server's thread and of the whole process (threads that
    # ended included).
    for _ in $(seq 1 500); do grep -q "stays up" "$T/err" 2>/dev/null && break; sleep 0.02; done
    local http=0 all=0 f
    read -r all < <(awk '{print $14 + $15}' /proc/"$pid"/stat 2>/dev/null) || all=0
    for f in /proc/"$pid"/task/*; do
        [ "$(cat "$f/comm" 2>/dev/null)" = parrt-http ] || continue
        read -r u < <(awk '{print $14 + $15}' "$f/stat" 2>/dev/null) || continue
        http=$((http + u))
    done
    echo "$http $all" >> "$T/cpu$1"
    wait "$pid"
    trace
    [ "$1" -gt 0 ] && { for i in $(seq 1 "$1"); do [ -s "$T/c$i" ] || echo "client $i got nothing" >&2; done; }
    return 0
}
median() { sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
: > "$T/none"; : > "$T/idle"; : > "$T/watched"
for r in $(seq 1 "$reps"); do
    run_plain >> "$T/none"
    run_http 0 >> "$T/idle"
    run_http "$clients" >> "$T/watched"
    echo "round $r: none $(tail -1 "$T/none") s, --http $(tail -1 "$T/idle") s, $clients clients $(tail -1 "$T/watched") s" >&2
done
mn() { sort -g | head -1; }
sum() { awk '{h += $1; a += $2} END {printf "%d of %d CPU ticks (%.2f%%)", h, a, a ? 100 * h / a : 0}' "$1"; }
echo "Live view thread, summed over the runs: no page $(sum "$T/cpu0"); $clients clients $(sum "$T/cpu$clients") of the process's CPU."
echo
n=$(median < "$T/none"); i=$(median < "$T/idle"); w=$(median < "$T/watched")
n1=$(mn < "$T/none"); i1=$(mn < "$T/idle"); w1=$(mn < "$T/watched")
r() { echo "$1 / $2" | bc -l | awk '{printf "%.3f", $1}'; }
echo "| render | trace s, median of $reps | ratio | fastest | ratio |"
echo "|---|---:|---:|---:|---:|"
echo "| no --http | $n | 1.000 | $n1 | 1.000 |"
echo "| --http, no page | $i | $(r "$i" "$n") | $i1 | $(r "$i1" "$n1") |"
echo "| --http, $clients SSE clients | $w | $(r "$w" "$n") | $w1 | $(r "$w1" "$n1") |"
