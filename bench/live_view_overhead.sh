#!/usr/bin/env bash
# What watching costs the render: the trace time of one render with no live view, with
# --http and no page open, and with --http and CLIENTS `curl -N` event streams connected before the
# trace begins (each receiving every tile), alternated REPS times; prints the medians and the
# fastest runs (the least disturbed by other work on the machine), their ratios, and CPU time that
# load moves little: the server's thread, the whole render process, and the clients, per render.
# Needs `cargo build --release` first, curl and jq.
#
# The clients are started before the render, each blocked opening its config file (a FIFO) so that
# their process start-up (exec, loading the TLS libraries) is over before the render begins; the
# URL is written to them as soon as the render prints it, while the scene is parsed and built
# (~0.1 s for mount:8), so they are connected before the trace begins. Each client's first
# `status` event says whether it was: `starting` (connected before the trace) or not; the script
# counts the late ones. (With mount:6 the build takes ~3 ms and clients connect mid-trace.)
#
# KIND says what the clients do: `read` (default) reads every event as it comes; `slow` reads
# at SLOW_RATE (curl --limit-rate, default 100k: a slow link, the page falls behind and is
# told to reload); `stuck` sends its request and never reads (python3: the render starts once
# every one has said on a FIFO that its interpreter is up, then each waits for the URL).
#
# CLIENT_SCHED=idle starts the clients under SCHED_IDLE (`chrt -i 0`): they run only on a core
# the render leaves idle, as a browser on another machine takes nothing from the render's
# cores, so what is left is what the server itself costs the render (and a page that cannot
# keep up, which is what a slow or stuck browser is).
#
# The three renders of a round run back to back, in an order that turns from round to round,
# so each round also gives paired ratios (its render with clients over its render without, and
# so on), which drifts in the machine's speed over the run do not move: the script prints their
# median with a 95 % bootstrap interval.
#
# Usage: bench/live_view_overhead.sh [REPS] [CLIENTS] [-- RENDER ARGS...]
#   default render: --scene mount:8 --width 1024 --height 1024 --threads 2
#   PARRT_BIN: target/release/parrt; KIND: read, slow or stuck; SLOW_RATE: 100k;
#   CLIENT_SCHED: same (default) or idle; HTTP_ARGS: more flags for the --http renders, e.g.
#   "--http-full-rate 0.5"
set -euo pipefail
reps=${1:-5}
clients=${2:-10}
shift 2 || true
[ "${1:-}" = "--" ] && shift
args=("$@")
[ ${#args[@]} -gt 0 ] || args=(--scene mount:8 --width 1024 --height 1024 --threads 2)
bin=${PARRT_BIN:-target/release/parrt}
read -r -a http_args <<< "${HTTP_ARGS:-}"
kind=${KIND:-read}
case $kind in read | slow | stuck) ;; *) echo "KIND must be read, slow or stuck" >&2; exit 2 ;; esac
case ${CLIENT_SCHED:-same} in
    same) sched=() ;;
    idle) sched=(chrt -i 0) ;;
    *) echo "CLIENT_SCHED must be same or idle" >&2; exit 2 ;;
esac
# The stuck client: the URL from its FIFO, then the request, then nothing read until killed.
stuck='import socket, sys, time, urllib.parse
socket.getaddrinfo("127.0.0.1", 80)  # the resolver loaded now, not during the render
with open(sys.argv[2], "w") as ready:
    ready.write("up\n")
u = urllib.parse.urlsplit(open(sys.argv[1]).read().strip())
s = socket.socket()
s.connect((u.hostname, u.port))
s.sendall(f"GET {u.path} HTTP/1.1\r\nHost: {u.netloc}\r\n\r\n".encode())
time.sleep(3600)'
T=$(mktemp -d)
trap 'jobs -p | xargs -r kill 2>/dev/null; rm -rf "$T"' EXIT

trace() { jq -r .trace_s "$T/s.json"; }
# Adds the nanoseconds on a CPU of the threads or processes /proc/ID... to the variable named
# first (their schedstat; 0 once gone). Bash builtins only: nothing is started while the render
# runs, so the script itself takes no CPU from it.
add_ns() {
    local -n sum=$1; local f a
    shift
    for f in "$@"; do a=0; { read -r a _ < "$f/schedstat"; } 2>/dev/null || a=0; sum=$((sum + a)); done
}
run_plain() { "$bin" render "${args[@]}" -o "$T/o.png" --stats-json "$T/s.json" 2>/dev/null; trace; }
run_http() { # run_http CLIENTS
    local n=$1 i cpids=()
    rm -f "$T/ready"; mkfifo "$T/ready"; exec 4<>"$T/ready"
    for i in $(seq 1 "$n"); do
        rm -f "$T/k$i" "$T/c$i"
        mkfifo "$T/k$i"
        if [ "$kind" = stuck ]; then
            "${sched[@]}" python3 -c "$stuck" "$T/k$i" "$T/ready" > "$T/c$i" 2>/dev/null &
        else
            "${sched[@]}" curl -sN -K "$T/k$i" > "$T/c$i" 2>/dev/null &
        fi
        cpids+=($!)
    done
    if [ "$kind" = stuck ]; then for ((i = 1; i <= n; i++)); do read -r -u 4 _; done; fi
    exec 4<&-
    rm -f "$T/errpipe"; mkfifo "$T/errpipe"
    "$bin" render "${args[@]}" -o "$T/o.png" --stats-json "$T/s.json" \
        --http 127.0.0.1:0 --http-linger 1 "${http_args[@]}" 2>"$T/errpipe" &
    local pid=$! url= c0=0 line
    # The address as soon as it is printed (blocking reads of a FIFO, no polling).
    exec 3<"$T/errpipe"
    while IFS= read -r -u 3 line; do
        case $line in "parrt: live view at "*) url=${line#parrt: live view at }; break ;; esac
    done
    add_ns c0 "${cpids[@]/#//proc/}"
    for ((i = 1; i <= n; i++)); do
        case $kind in
            stuck) echo "${url}events" > "$T/k$i" ;;
            slow) printf 'url = "%s"\nlimit-rate = "%s"\n' "${url}events" "${SLOW_RATE:-100k}" > "$T/k$i" ;;
            read) echo "url = \"${url}events\"" > "$T/k$i" ;;
        esac
    done
    # Then nothing until it lingers (the trace is over).
    while IFS= read -r -u 3 line; do case $line in *"stays up"*) break ;; esac; done
    cat <&3 > /dev/null &
    exec 3<&-
    # CPU of the server's thread, of the whole process (threads that ended included; clock
    # ticks) and of the clients since they were given the URL.
    local http=0 all=0 c1=0 f
    read -r all < <(awk '{print $14 + $15}' /proc/"$pid"/stat 2>/dev/null) || all=0
    for f in /proc/"$pid"/task/*; do
        [ "$(cat "$f/comm" 2>/dev/null)" = parrt-http ] && add_ns http "$f"
    done
    add_ns c1 "${cpids[@]/#//proc/}"
    echo "$http $((all * 1000000000 / $(getconf CLK_TCK))) $((c1 - c0))" >> "$T/cpu$n"
    wait "$pid"
    trace
    # Slow and stuck clients would take long to read what the sockets hold, or never.
    [ "$kind" = read ] || kill "${cpids[@]}" 2>/dev/null || true
    if [ "$kind" = stuck ]; then
        wait "${cpids[@]}" 2>/dev/null || true
        return 0
    fi
    local late=0
    for i in $(seq 1 "$n"); do
        [ -s "$T/c$i" ] || { echo "client $i got nothing" >&2; continue; }
        stat -c %s "$T/c$i" >> "$T/bytes"
        awk '/^event: (status|done)/ {getline; print; exit}' "$T/c$i" \
            | grep -q '"state":"starting"' || late=$((late + 1))
    done
    [ "$late" = 0 ] || echo "$late of $n clients connected after the trace began" >&2
    wait "${cpids[@]}" 2>/dev/null || true
    return 0
}
median() { sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
: > "$T/none"; : > "$T/idle"; : > "$T/watched"; : > "$T/cpu0"; : > "$T/cpu$clients"; : > "$T/bytes"
for r in $(seq 1 "$reps"); do
    # Each round starts with a different one of the three, so none of them always follows the
    # same other (a render's speed can depend on what ran just before it).
    for k in 0 1 2; do
        case $(((r + k) % 3)) in
            0) run_plain >> "$T/none" ;;
            1) run_http 0 >> "$T/idle" ;;
            2) run_http "$clients" >> "$T/watched" ;;
        esac
    done
    echo "round $r: none $(tail -1 "$T/none") s, --http $(tail -1 "$T/idle") s, $clients clients $(tail -1 "$T/watched") s" >&2
done
mn() { sort -g | head -1; }
cpu() { awk '{h += $1; a += $2; c += $3} END {printf "server thread %.1f ms, process %.0f ms, clients %.1f ms", h / NR / 1e6, a / NR / 1e6, c / NR / 1e6}' "$1"; }
echo "CPU per render, mean of $reps: no page: $(cpu "$T/cpu0"); $clients clients: $(cpu "$T/cpu$clients")"
echo "Each client received $(awk '{b += $1} END {printf "%.2f", NR ? b / NR / 1e6 : 0}' "$T/bytes") MB per render."
echo
n=$(median < "$T/none"); i=$(median < "$T/idle"); w=$(median < "$T/watched")
n1=$(mn < "$T/none"); i1=$(mn < "$T/idle"); w1=$(mn < "$T/watched")
r() { echo "$1 / $2" | bc -l | awk '{printf "%.3f", $1}'; }
echo "| render | trace s, median of $reps | ratio | fastest | ratio |"
echo "|---|---:|---:|---:|---:|"
echo "| no --http | $n | 1.000 | $n1 | 1.000 |"
echo "| --http, no page | $i | $(r "$i" "$n") | $i1 | $(r "$i1" "$n1") |"
echo "| --http, $clients SSE clients ($kind, ${CLIENT_SCHED:-same}) | $w | $(r "$w" "$n") | $w1 | $(r "$w1" "$n1") |"
echo "| $clients clients ($kind, ${CLIENT_SCHED:-same}) against --http with no page | | $(r "$w" "$i") | | $(r "$w1" "$i1") |"
echo
echo "Paired by round (each round's renders back to back): median ratio [95 % bootstrap interval of the median] over $reps rounds"
python3 - "$T/none" "$T/idle" "$T/watched" "$clients clients ($kind, ${CLIENT_SCHED:-same})" <<'PY'
import random, statistics, sys
none, idle, watched = ([float(x) for x in open(f)] for f in sys.argv[1:4])
def show(label, a, b):
    r = [y / x for x, y in zip(a, b)]
    rng = random.Random(1)
    meds = sorted(statistics.median(rng.choices(r, k=len(r))) for _ in range(2000))
    print(f"| {label} | {statistics.median(r):.3f} [{meds[49]:.3f}, {meds[1949]:.3f}] |")
print("| ratio | paired median [95 % interval] |")
print("|---|---:|")
show("--http, no page / no --http", none, idle)
show(f"{sys.argv[4]} / no --http", none, watched)
show(f"{sys.argv[4]} / --http, no page", idle, watched)
PY
