#!/usr/bin/env bash
# Peak resident memory of `parrt render` (SMP, to PNG) against image size: the maximum RSS
# `/usr/bin/time -v` reports, at each size, and the bytes a pixel beyond a 64×64 render of the
# same scene (what the scene, the accelerator and the process take on their own). Prints a
# Markdown table. Needs GNU time (Debian package `time`).
#
#   usage: bench/rss_per_pixel.sh [PARRT_BINARY] [SCENE] [EDGE ...]
#   e.g.   bench/rss_per_pixel.sh target/release/parrt tetra 4096 8192 16384
set -euo pipefail
REPO=$(cd "$(dirname "$0")/.." && pwd)
PARRT=${1:-$REPO/target/release/parrt}
SCENE=${2:-tetra}
[ $# -gt 2 ] && shift 2 || set -- 4096 8192 16384
[ -x /usr/bin/time ] || { echo "needs GNU time: apt-get install time" >&2; exit 1; }
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
maxrss() { # KiB
    /usr/bin/time -v "$PARRT" render --scene "$SCENE" --size "$1x$1" -o "$T/x.png" 2> "$T/t.txt" > /dev/null
    awk -F: '/Maximum resident/ {gsub(/ /, "", $2); print $2}' "$T/t.txt"
}
base=$(maxrss 64)
echo "Scene $SCENE; a 64×64 render peaks at $((base / 1024)) MiB."
echo
echo "| size | peak RSS, MiB | bytes a pixel beyond 64×64 |"
echo "|---|---:|---:|"
for e in "$@"; do
    k=$(maxrss "$e")
    awk -v e="$e" -v k="$k" -v b="$base" \
        'BEGIN { printf "| %d² | %.0f | %.2f |\n", e, k / 1024, (k - b) * 1024 / (e * e) }'
done
