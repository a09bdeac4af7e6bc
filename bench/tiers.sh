#!/usr/bin/env bash
# Each instruction-set tier's speed on the SPD scenes of the peers table: CPU seconds
# of a full render (one thread, 512×512, depth 5, as bench/peers.sh renders) with `PARRT_ISA`
# set to each tier this CPU runs, tiers interleaved run by run; medians with the min–max spread,
# each tier's median over the scalar tier's (and avx512's over avx2's: the AVX-512 kernels against
# the AVX ones on one binary), and whether every tier wrote the same image bytes.
# Prints a Markdown table.
#
#   usage: bench/tiers.sh [PARRT_BINARY] [scene ...]   (names in data/spd)
#   env:   RUNS (default 3), TIERS (default "scalar sse2 avx2 avx512"), PARRT_SPD_DIR (default:
#          data/spd in the repository)
#
# For the least noise run it under `chrt -r 1` (root):
#   chrt -r 1 bench/tiers.sh "$CARGO_TARGET_DIR/release/parrt"
set -euo pipefail
REPO=$(cd "$(dirname "$0")/.." && pwd)
SPD=$(cd "${PARRT_SPD_DIR:-$REPO/data/spd}" && pwd)
PARRT=${1:-$REPO/target/release/parrt}
[ $# -gt 0 ] && shift
[ $# -gt 0 ] || set -- mount-6 balls-4 gears-4 rings-7 teapot-6 teapot-12 tetra-6 tree-11 lattice-12 shells-5 jacks-4
RUNS=${RUNS:-3}
TIERS=${TIERS:-scalar sse2 avx2 avx512}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT

cpu() { python3 "$REPO/bench/cpu_seconds.py" "$@"; }

head="| scene |"
rule="|---|"
for t in $TIERS; do head="$head $t s |"; rule="$rule---:|"; done
for t in $TIERS; do [ "$t" = scalar ] || { head="$head $t / scalar |"; rule="$rule---:|"; }; done
case " $TIERS " in *" avx2 "*) case " $TIERS " in *" avx512 "*) head="$head avx512 / avx2 |"; rule="$rule---:|" ;; esac ;; esac
echo "$head images |"
echo "$rule---|"
for s in "$@"; do
    for t in $TIERS; do : > "$T/$t"; done
    for _ in $(seq "$RUNS"); do
        for t in $TIERS; do
            cpu env PARRT_ISA="$t" "$PARRT" render "$SPD/$s.nff" --threads 1 --width 512 \
                --height 512 --max-depth 5 -o "$T/$t.png" >> "$T/$t"
        done
    done
    same=same
    for t in $TIERS; do cmp -s "$T/scalar.png" "$T/$t.png" || same=DIFFERENT; done
    python3 - "$s" "$same" "$T" $TIERS <<'PY'
import statistics as st, sys
scene, same, d, tiers = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
v = {t: [float(x) for x in open(f"{d}/{t}")] for t in tiers}
cells = ["%.3f (%.3f–%.3f)" % (st.median(v[t]), min(v[t]), max(v[t])) for t in tiers]
base = st.median(v["scalar"]) if "scalar" in v else None
ratios = ["%.3f" % (st.median(v[t]) / base) for t in tiers if t != "scalar" and base]
if "avx2" in v and "avx512" in v:
    ratios.append("%.3f" % (st.median(v["avx512"]) / st.median(v["avx2"])))
print("| %s | %s | %s | %s |" % (scene, " | ".join(cells), " | ".join(ratios), same))
PY
done
