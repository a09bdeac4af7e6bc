#!/usr/bin/env bash
# Two parrt builds side by side on SPD scenes, casting: `parrt bench cast` (eye rays
# through pixel centres + one shadow ray per light per hit, one thread, 512², as bench/peers.sh
# casts against Embree), the two builds interleaved run by run. Prints per scene the medians of
# Mrays per CPU second with the min–max spread, the median of the per-run ratios new/old (runs
# paired back to back) and whether the two builds counted the same rays and hits.
#
#   usage: bench/ab_cast.sh OLD_BINARY NEW_BINARY [scene ...]   (names in data/spd)
#   env:   RUNS (default 3), MINTIME (default 1), PARRT_SPD_DIR (default: data/spd in the repository)
#
# For the least noise run it alone under `chrt -r 1` (root):
#   chrt -r 1 bench/ab_cast.sh ../parrt-before/target/release/parrt target/release/parrt gears-4
set -euo pipefail
[ $# -ge 2 ] || { sed -n '2,12p' "$0" >&2; exit 2; }
REPO=$(cd "$(dirname "$0")/.." && pwd)
SPD=$(cd "${PARRT_SPD_DIR:-$REPO/data/spd}" && pwd)
OLD=$1 NEW=$2
shift 2
[ $# -gt 0 ] || set -- mount-6 balls-4 gears-4 rings-7 teapot-6 teapot-12 tetra-6 tree-11 lattice-12 shells-5 jacks-4
RUNS=${RUNS:-3}
MINTIME=${MINTIME:-1}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT

# The last table row of `parrt bench cast`: Mrays per CPU second last; rays per frame, eye hits
# and shadow rays before, compared between the builds.
cast() { "$1" bench cast "$SPD/$2.nff" --size 512 --mintime "$MINTIME" | tail -1; }

echo "| scene | old Mrays/CPU-s | new Mrays/CPU-s | new / old, paired median | rays and hits |"
echo "|---|---:|---:|---:|---|"
for s in "$@"; do
    : > "$T/old"
    : > "$T/new"
    # The order alternates within pairs (old first, then new first): on this VM the run
    # that comes first in a pair reads up to 5 % faster, and alternating cancels that.
    for i in $(seq "$RUNS"); do
        if [ $((i % 2)) -eq 1 ]; then
            cast "$OLD" "$s" >> "$T/old"
            cast "$NEW" "$s" >> "$T/new"
        else
            cast "$NEW" "$s" >> "$T/new"
            cast "$OLD" "$s" >> "$T/old"
        fi
    done
    python3 - "$s" "$T/old" "$T/new" <<'PY'
import statistics as st, sys
name, old, new = sys.argv[1], *([l.split("|") for l in open(f)] for f in sys.argv[2:4])
rate = lambda rows: [float(r[9]) for r in rows]
counts = lambda rows: {tuple(c.strip() for c in r[4:7]) for r in rows}
a, b = rate(old), rate(new)
same = "same" if counts(old) == counts(new) and len(counts(old)) == 1 else "DIFFERENT"
pairs = [y / x for x, y in zip(a, b)]
print(f"| {name} | {st.median(a):.2f} ({min(a):.2f}–{max(a):.2f}) | "
      f"{st.median(b):.2f} ({min(b):.2f}–{max(b):.2f}) | {st.median(pairs):.3f} | {same} |")
PY
done
