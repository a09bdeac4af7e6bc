#!/usr/bin/env bash
# Two parrt builds side by side on casting (issue 33): `parrt bench cast` (eye rays through pixel
# centres + one shadow ray per light per hit, one thread, 512², as bench/peers.sh casts against
# Embree), the two builds interleaved run by run, Mrays per CPU second, medians with the min–max
# spread, and the median of the per-run ratios new/old (runs paired back to back). Also checks
# that both builds count the same rays, eye hits and shadow rays. Prints a Markdown table.
#
#   usage: bench/ab_cast.sh OLD_BINARY NEW_BINARY [scene ...]   (names in ../shared/spd)
#   env:   RUNS (default 3), MINTIME (default 1), PARRT_ISA (passed on),
#          SHARED (default: ../shared beside the repository)
#
# For the least noise run it under `chrt -r 1` (root).
set -euo pipefail
[ $# -ge 2 ] || { sed -n '2,11p' "$0" >&2; exit 2; }
REPO=$(cd "$(dirname "$0")/.." && pwd)
SHARED=${SHARED:-$(cd "$REPO/../shared" && pwd)}
OLD=$1 NEW=$2
shift 2
[ $# -gt 0 ] || set -- mount-6 balls-4 gears-4 rings-7 teapot-6 teapot-12 tetra-6 tree-11 lattice-12 shells-5 jacks-4
RUNS=${RUNS:-3}
MINTIME=${MINTIME:-1}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT

echo "| scene | old Mrays/s | new Mrays/s | new / old, paired median | counts |"
echo "|---|---:|---:|---:|---|"
for s in "$@"; do
    : > "$T/old"
    : > "$T/new"
    for _ in $(seq "$RUNS"); do
        for b in old new; do
            bin=$OLD
            [ "$b" = new ] && bin=$NEW
            "$bin" bench cast "$SHARED/spd/$s.nff" --size 512 --mintime "$MINTIME" | tail -1 \
                | awk -F'|' '{gsub(/ /,""); print $10, $5 "/" $6 "/" $7}' >> "$T/$b"
        done
    done
    python3 - "$s" "$T/old" "$T/new" <<'PY'
import statistics as st, sys
name = sys.argv[1]
rows = [[l.split() for l in open(f)] for f in sys.argv[2:4]]
old, new = ([float(r[0]) for r in rs] for rs in rows)
counts = {r[1] for rs in rows for r in rs}
same = "same" if len(counts) == 1 else "DIFFERENT " + " ".join(sorted(counts))
pairs = [b / a for a, b in zip(old, new)]
print(f"| {name} | {st.median(old):.2f} ({min(old):.2f}–{max(old):.2f}) | "
      f"{st.median(new):.2f} ({min(new):.2f}–{max(new):.2f}) | {st.median(pairs):.3f} | {same} |")
PY
done
