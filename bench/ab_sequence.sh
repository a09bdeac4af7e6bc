#!/usr/bin/env bash
# Two parrt builds on the local sequence goal: a 24-frame orbit through two local workers of one
# thread against the same orbit on two SMP threads. Each round runs SMP (the new build), the old
# build's workers and the new build's workers back to back, in a random order, so drifts of the
# machine's speed cancel. Prints SMP's median trace time (`--stats-json` trace_s) and, for each
# build, the workers' median, SMP's median over it and the median of each round's SMP/workers
# ratio; then names any frame that is not the same bytes as SMP's. Numbers only: no assertion.
#
#   usage: bench/ab_sequence.sh OLD_BINARY NEW_BINARY [ROUNDS]
#          ROUNDS defaults to 21 (this machine's spread needs 15 or more)
#   env:   SCENE (default mount:6), SIZE (default 512), FRAMES (default 24); OLD_FLAGS and
#          NEW_FLAGS, more flags for each build's workers (e.g. the same binary twice with
#          OLD_FLAGS="--window 2" compares two settings)
set -euo pipefail
[ $# -ge 2 ] || { sed -n '2,13p' "$0" >&2; exit 2; }
OLD=$1 NEW=$2 ROUNDS=${3:-21}
SCENE=${SCENE:-mount:6} SIZE=${SIZE:-512} FRAMES=${FRAMES:-24}
read -r -a old_flags <<< "${OLD_FLAGS:-}"
read -r -a new_flags <<< "${NEW_FLAGS:-}"
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
args=(render --scene "$SCENE" --orbit 360 --frames "$FRAMES" --width "$SIZE" --height "$SIZE")

# One run of `bin` as `tag` with the given flags: appends its trace_s to $T/<tag>.txt.
run() {
    local bin=$1 tag=$2
    shift 2
    mkdir -p "$T/$tag"
    "$bin" "${args[@]}" -o "$T/$tag/f-%04d.png" --stats-json "$T/$tag.json" "$@" >/dev/null 2>&1
    python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['trace_s'])" "$T/$tag.json" \
        >> "$T/$tag.txt"
}

# Each round runs the three in a fresh random order: in a fixed order the run after SMP's
# read a point or two apart from the same build's run in another place, more than the
# change being measured.
for _ in $(seq "$ROUNDS"); do
    for which in $(printf '%s\n' smp old new | shuf); do
        case $which in
        smp) run "$NEW" smp --threads 2 ;;
        old) run "$OLD" old --workers 2 --threads 1 "${old_flags[@]}" ;;
        new) run "$NEW" new --workers 2 --threads 1 "${new_flags[@]}" ;;
        esac
    done
done

python3 - "$T" <<'EOF'
import statistics as st, sys
t = sys.argv[1]
read = lambda tag: [float(x) for x in open(f"{t}/{tag}.txt")]
smp = read("smp")
print(f"SMP, 2 threads: median {st.median(smp):.3f} s over {len(smp)} rounds")
for tag in ("old", "new"):
    w = read(tag)
    pairs = st.median(a / b for a, b in zip(smp, w))
    print(f"{tag} build, 2 workers × 1 thread: median {st.median(w):.3f} s, "
          f"SMP/workers {st.median(smp) / st.median(w):.3f} (per round {pairs:.3f})")
EOF
for f in "$T"/smp/f-*.png; do
    for tag in old new; do
        cmp -s "$f" "$T/$tag/$(basename "$f")" || echo "$tag: $(basename "$f") differs from SMP's"
    done
done
