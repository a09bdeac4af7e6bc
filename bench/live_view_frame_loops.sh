#!/usr/bin/env bash
# Whether the render waits for `GET /frame` (it must not): the trace time of one
# 1-thread render with --http and no client, and with LOOPS `curl` loops fetching /frame as fast
# as they can, for each build given, alternating builds and kinds round by round.
#
# Usage: bench/live_view_frame_loops.sh REPS BIN [BIN...] [-- RENDER ARGS...]
#   default render: --scene balls:3 --width 2048 --height 2048 --threads 1
#   LOOPS: curl loops (default 2). CURL_SCHED=idle runs them under SCHED_IDLE (`chrt -i 0`), so
#   that they take only CPU the render leaves, as clients on another machine would.
# Prints one line per render (bin, kind, trace seconds) and then the medians, fastest and
# slowest per bin and kind. Run it under `chrt -r 1` on a quiet machine, as docs/live-view.md
# did.
set -euo pipefail
reps=${1:?REPS}
shift
bins=()
while [ $# -gt 0 ] && [ "$1" != -- ]; do bins+=("$1"); shift; done
[ "${1:-}" = -- ] && shift
render=("$@")
[ ${#render[@]} -eq 0 ] && render=(--scene balls:3 --width 2048 --height 2048 --threads 1)
loops=${LOOPS:-2}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT

one() { # one BIN KIND -> prints trace seconds
    local bin=$1 kind=$2 url="" pids=() pid
    "$bin" render "${render[@]}" --http 127.0.0.1:0 -o "$T/out.png" \
        --stats-json "$T/stats.json" 2>"$T/err" &
    pid=$!
    for _ in $(seq 1 2000); do
        url=$(sed -n 's/^parrt: live view at \(http[^ ]*\).*/\1/p' "$T/err")
        [ -n "$url" ] && break
        sleep 0.005
    done
    if [ "$kind" = loops ]; then
        for _ in $(seq 1 "$loops"); do
            if [ "${CURL_SCHED:-same}" = idle ]; then
                chrt -i 0 bash -c 'while kill -0 "$1" 2>/dev/null; do
                    curl -s -o /dev/null "$2" || true; done' _ "$pid" "${url}frame" &
            else
                (while kill -0 "$pid" 2>/dev/null; do
                    curl -s -o /dev/null "${url}frame" || true
                done) &
            fi
            pids+=($!)
        done
    fi
    wait "$pid"
    [ ${#pids[@]} -gt 0 ] && wait "${pids[@]}" 2>/dev/null || true
    python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["trace_s"])' "$T/stats.json"
}

for r in $(seq 1 "$reps"); do
    order=("${bins[@]}")
    [ $((r % 2)) -eq 0 ] && order=($(printf '%s\n' "${bins[@]}" | tac))
    for bin in "${order[@]}"; do
        for kind in none loops; do
            t=$(one "$bin" "$kind")
            echo "$bin $kind $t" | tee -a "$T/all"
        done
    done
done
python3 - "$T/all" <<'EOF'
import statistics, sys
rows = {}
for line in open(sys.argv[1]):
    b, k, t = line.split()
    rows.setdefault((b, k), []).append(float(t))
print("| build | clients | median s | fastest | slowest | n |")
print("|---|---|---:|---:|---:|---:|")
for (b, k), ts in rows.items():
    print(f"| {b} | {k} | {statistics.median(ts):.2f} | {min(ts):.2f} | {max(ts):.2f} | {len(ts)} |")
EOF
