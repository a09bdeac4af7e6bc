#!/usr/bin/env bash
# Two parrt builds side by side on SPD scenes: the CPU seconds of a full render
# (one thread, 512×512, depth 5, as bench/peers.sh renders), the two builds interleaved run by
# run, and whether their images are the same bytes. Prints per scene the medians, the median of
# the per-run ratios new/old (runs paired back to back, so drifts of the machine's speed
# cancel) and the ratio of the fastest runs.
#
#   usage: bench/ab_render.sh OLD_BINARY NEW_BINARY [scene ...]   (names in data/spd)
#   env:   RUNS (default 5), PARRT_SPD_DIR (default: data/spd in the repository)
#
# For the least noise run it alone under `chrt -r 1` (root), e.g. copy the build before a
# change to target/parrt-before, rebuild, then
#   chrt -r 1 bench/ab_render.sh target/parrt-before target/release/parrt balls-4 tree-11
set -euo pipefail
[ $# -ge 2 ] || { sed -n '2,13p' "$0" >&2; exit 2; }
REPO=$(cd "$(dirname "$0")/.." && pwd)
SPD=$(cd "${PARRT_SPD_DIR:-$REPO/data/spd}" && pwd)
OLD=$1 NEW=$2
shift 2
[ $# -gt 0 ] || set -- mount-6 balls-4 gears-4 rings-7 teapot-6 teapot-12 tetra-6 tree-11 lattice-12 shells-5 jacks-4
RUNS=${RUNS:-5}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT

# CPU seconds (user + system) of one run (bench/cpu_seconds.py).
cpu() { python3 "$REPO/bench/cpu_seconds.py" "$@"; }
render() { cpu "$1" render "$SPD/$2.nff" --threads 1 --width 512 --height 512 --max-depth 5 -o "$3"; }

echo "| scene | old s (median) | new s (median) | new / old, paired median | fastest new / fastest old | image |"
echo "|---|---:|---:|---:|---:|---|"
for s in "$@"; do
    : > "$T/old"
    : > "$T/new"
    # The order alternates within pairs (old first, then new first): on this VM the run
    # that comes first in a pair reads up to 5 % faster, and alternating cancels that.
    for i in $(seq "$RUNS"); do
        if [ $((i % 2)) -eq 1 ]; then
            render "$OLD" "$s" "$T/old.png" >> "$T/old"
            render "$NEW" "$s" "$T/new.png" >> "$T/new"
        else
            render "$NEW" "$s" "$T/new.png" >> "$T/new"
            render "$OLD" "$s" "$T/old.png" >> "$T/old"
        fi
    done
    same=$(cmp -s "$T/old.png" "$T/new.png" && echo same || echo DIFFERENT)
    python3 - "$s" "$T/old" "$T/new" "$same" <<'PY'
import statistics as st, sys
name, old, new, same = sys.argv[1], *(list(map(float, open(f))) for f in sys.argv[2:4]), sys.argv[4]
pairs = [b / a for a, b in zip(old, new)]
print(f"| {name} | {st.median(old):.4f} ({min(old):.4f}–{max(old):.4f}) | "
      f"{st.median(new):.4f} ({min(new):.4f}–{max(new):.4f}) | {st.median(pairs):.3f} | "
      f"{min(new) / min(old):.3f} | {same} |")
PY
done
