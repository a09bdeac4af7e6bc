#!/usr/bin/env bash
# Casting throughput of each instruction-set tier on the SPD scenes of the peers table:
# `parrt bench cast` (eye rays through pixel centres + one shadow ray per light per hit, one
# thread, 512², as bench/peers.sh casts against Embree) with `PARRT_ISA` set to each tier, tiers
# interleaved run by run; Mrays per CPU second, medians with the min–max spread, and each tier's
# median over the first tier's. Prints a Markdown table.
#
#   usage: bench/tiers_cast.sh [PARRT_BINARY] [scene ...]   (names in data/spd)
#   env:   RUNS (default 3), TIERS (default "avx2 avx512"), MINTIME (default 1),
#          PARRT_SPD_DIR (default: data/spd in the repository)
#
# For the least noise run it under `chrt -r 1` (root):
#   chrt -r 1 bench/tiers_cast.sh "$CARGO_TARGET_DIR/release/parrt"
set -euo pipefail
REPO=$(cd "$(dirname "$0")/.." && pwd)
SPD=$(cd "${PARRT_SPD_DIR:-$REPO/data/spd}" && pwd)
PARRT=${1:-$REPO/target/release/parrt}
[ $# -gt 0 ] && shift
[ $# -gt 0 ] || set -- mount-6 balls-4 gears-4 rings-7 teapot-6 teapot-12 tetra-6 tree-11 lattice-12 shells-5 jacks-4
RUNS=${RUNS:-3}
TIERS=${TIERS:-avx2 avx512}
MINTIME=${MINTIME:-1}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT

first=${TIERS%% *}
head="| scene |"
rule="|---|"
for t in $TIERS; do head="$head $t Mrays/s |"; rule="$rule---:|"; done
for t in $TIERS; do [ "$t" = "$first" ] || { head="$head $t / $first |"; rule="$rule---:|"; }; done
echo "$head"
echo "$rule"
for s in "$@"; do
    for t in $TIERS; do : > "$T/$t"; done
    for _ in $(seq "$RUNS"); do
        for t in $TIERS; do
            PARRT_ISA="$t" "$PARRT" bench cast "$SPD/$s.nff" --size 512 --mintime "$MINTIME" \
                | tail -1 | awk -F'|' '{gsub(/ /,"",$10); print $10}' >> "$T/$t"
        done
    done
    python3 - "$s" "$T" $TIERS <<'PY'
import statistics as st, sys
scene, d, tiers = sys.argv[1], sys.argv[2], sys.argv[3:]
v = {t: [float(x) for x in open(f"{d}/{t}")] for t in tiers}
cells = ["%.2f (%.2f–%.2f)" % (st.median(v[t]), min(v[t]), max(v[t])) for t in tiers]
base = st.median(v[tiers[0]])
ratios = ["%.3f" % (st.median(v[t]) / base) for t in tiers[1:]]
print("| %s | %s |" % (scene, " | ".join(cells + ratios)))
PY
done
