#!/usr/bin/env bash
# Start-up of parrt on the SPD scenes of the peers table: wall seconds from the
# fork of `parrt render` to the end of a 1×1 render (one pixel: process start, NFF read and
# parse, scene and BVH build, one eye ray and its shadow rays, a 1-pixel PPM), which is process
# start to first ray plus a few microseconds; the parse and build seconds the renderer itself
# measured (`--stats-json`); and `parrt --version` as the floor of starting the executable at all.
# Scenes interleaved run by run; medians with the min–max spread. Prints a Markdown table.
#
#   usage: bench/startup.sh [PARRT_BINARY] [scene ...]   (names in data/spd)
#   env:   RUNS (default 7), PARRT_SPD_DIR (default: data/spd in the repository)
#
# For the least noise run it under `chrt -r 1` (root):
#   chrt -r 1 bench/startup.sh "$CARGO_TARGET_DIR/release/parrt"
set -euo pipefail
REPO=$(cd "$(dirname "$0")/.." && pwd)
SPD=$(cd "${PARRT_SPD_DIR:-$REPO/data/spd}" && pwd)
PARRT=${1:-$REPO/target/release/parrt}
[ $# -gt 0 ] && shift
[ $# -gt 0 ] || set -- mount-6 balls-4 gears-4 rings-7 teapot-6 teapot-12 tetra-6 tree-11 lattice-12 shells-5 jacks-4
RUNS=${RUNS:-7}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT

python3 - "$PARRT" "$SPD" "$T" "$RUNS" "$@" <<'PY'
import json, os, statistics as st, subprocess, sys, time
parrt, spd, tmp, runs, scenes = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5:]

def wall(cmd):
    t = time.perf_counter()
    r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    dt = time.perf_counter() - t
    if r.returncode != 0:
        sys.exit("failed: " + " ".join(cmd))
    return dt

floor, w, parse, build = [], {s: [] for s in scenes}, {s: [] for s in scenes}, {s: [] for s in scenes}
js = os.path.join(tmp, "stats.json")
for _ in range(runs):
    floor.append(wall([parrt, "--version"]))
    for s in scenes:
        w[s].append(wall([parrt, "render", os.path.join(spd, s + ".nff"), "--threads", "1",
                          "--width", "1", "--height", "1", "--max-depth", "5",
                          "-o", os.path.join(tmp, "x.ppm"), "--stats-json", js]))
        j = json.load(open(js))
        parse[s].append(j["parse_s"])
        build[s].append(j["build_s"])

ms = lambda v: "%.1f" % (1e3 * st.median(v))
spread = lambda v: "%.1f–%.1f" % (1e3 * min(v), 1e3 * max(v))
print("| scene | start to first ray, ms (median) | spread | parse ms | build ms | rest ms |")
print("|---|---:|---:|---:|---:|---:|")
for s in scenes:
    rest = st.median(w[s]) - st.median(parse[s]) - st.median(build[s])
    print("| %s | %s | %s | %s | %s | %.1f |" % (s, ms(w[s]), spread(w[s]), ms(parse[s]), ms(build[s]), 1e3 * rest))
print("| `parrt --version` | %s | %s | | | |" % (ms(floor), spread(floor)))
PY
