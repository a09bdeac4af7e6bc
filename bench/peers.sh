#!/usr/bin/env bash
# parrt beside its peers on the SPD scenes: POV-Ray 3.7 and Tachyon 0.99 (full
# render, CPU time, each one's start-up on an empty scene subtracted; Tachyon reads the NFF file
# itself), Embree 3 through the shared nffcast harness (ray casting: eye rays through pixel
# centres + one shadow ray per light per hit, one thread), and the 2-thread efficiency of parrt
# and Tachyon (wall time, t1 / (2 t2)). Installs POV-Ray, Tachyon and libembree-dev with apt-get
# when missing. Prints Markdown tables.
#
#   usage: bench/peers.sh [scene ...]        scenes as names in data/spd (e.g. mount-6)
#   env:   RUNS (default 3: medians), MINTIME (casting seconds per figure, default 1),
#          PARRT_SPD_DIR (the NFF files; default data/spd in the repository),
#          OUT (default bench-out/peers),
#          TABLES (default "render cast efficiency": which tables to print),
#          NFFCAST (the Embree harness; built from bench/embree into OUT/embree when
#          missing), PARRT (a parrt binary to measure instead of building one; the build honours
#          CARGO_TARGET_DIR)
set -euo pipefail
REPO=$(cd "$(dirname "$0")/.." && pwd)
SPD=$(cd "${PARRT_SPD_DIR:-$REPO/data/spd}" && pwd)
RUNS=${RUNS:-3}
MINTIME=${MINTIME:-1}
OUT=${OUT:-$REPO/bench-out/peers}
TABLES=${TABLES:-render cast efficiency}
want() { case " $TABLES " in *" $1 "*) return 0 ;; *) return 1 ;; esac; }
mkdir -p "$OUT"

need_apt=""
command -v povray >/dev/null || need_apt="$need_apt povray"
command -v tachyon >/dev/null || need_apt="$need_apt tachyon"
[ -f /usr/include/embree3/rtcore.h ] || need_apt="$need_apt libembree-dev"
if [ -n "$need_apt" ]; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $need_apt >/dev/null
fi
NFFCAST=${NFFCAST:-$OUT/embree/nffcast}
[ -x "$NFFCAST" ] || sh "$REPO/bench/embree/build.sh" "$(dirname "$NFFCAST")" >/dev/null
if [ -z "${PARRT:-}" ]; then
    (cd "$REPO" && cargo build --release -q -p parrt-master)
    PARRT=${CARGO_TARGET_DIR:-$REPO/target}/release/parrt
fi

if [ $# -eq 0 ]; then
    set -- mount-6 balls-4 gears-4 rings-7 teapot-6 teapot-12 tetra-6 tree-11 lattice-12 shells-5 jacks-4
fi

# CPU seconds (user + system) of one run of a command (bench/cpu_seconds.py).
cpu() { python3 "$REPO/bench/cpu_seconds.py" "$@" || { echo "failed: $*" >&2; return 1; }; }
# Wall seconds of one run of a command (for the 2-thread efficiency, where CPU time says nothing).
wall() {
    python3 - "$@" <<'PY' || { echo "failed: $*" >&2; return 1; }
import os, subprocess, sys, time
t = time.monotonic()
r = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
if r.returncode != 0:
    sys.exit(1)
print("%.4f" % (time.monotonic() - t))
PY
}
# Why Tachyon's image of an NFF file is not comparable with parrt's, or nothing: a blank image
# (every pixel alike); a scene with refracting surfaces ("f" with transmittance > 0), which
# Tachyon draws see-through without bending the rays; or a framing that differs (Tachyon keeps
# its own field of view, not the file's "angle": it covers under half the pixels parrt covers,
# so it traces far fewer rays into the scene). Arguments: Tachyon's PPM, the NFF, parrt's PPM/PAM.
tachyon_note() {
    python3 - "$1" "$2" "$3" <<'PY'
import sys
from collections import Counter

def pixels(path):
    d = open(path, "rb").read()
    if d.startswith(b"P7"):  # PAM: header lines up to ENDHDR
        end = d.index(b"ENDHDR\n") + 7
        head = dict(l.split(b" ", 1) for l in d[3:end - 7].split(b"\n") if b" " in l)
        depth = int(head[b"DEPTH"])
        p = d[end:]
    else:
        fields, i = [], 0
        while len(fields) < 4:
            while d[i:i + 1].isspace():
                i += 1
            j = i
            while not d[j:j + 1].isspace():
                j += 1
            fields.append(d[i:j])
            i = j
        depth, p = 3, d[i + 1:]
    return [p[k:k + 3] for k in range(0, len(p), depth)]

def coverage(px):
    return 1 - Counter(px).most_common(1)[0][1] / len(px)

t = pixels(sys.argv[1])
notes = []
if len(set(t)) <= 1:
    notes.append("blank image")
for line in open(sys.argv[2]):
    f = line.split()
    if len(f) >= 9 and f[0] == "f" and float(f[7]) > 0:
        notes.append("no refraction")
        break
ct, cp = coverage(t), coverage(pixels(sys.argv[3]))
if t and len(set(t)) > 1 and ct < 0.5 * cp:
    notes.append("framed smaller (covers %.0f%% of the image, parrt %.0f%%)" % (100 * ct, 100 * cp))
print(", ".join(notes))
PY
}
median() { sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
# The min–max spread of a file of figures, each less an offset (default 0), for the tables.
spread() { sort -g "$1" | awk -v o="${2:-0}" '{a[NR]=$1 - o} END {printf "%.3f–%.3f", a[1], a[NR]}'; }
runs() { for _ in $(seq "$RUNS"); do cpu "$@"; done | median; }

cd "$OUT"
printf 'camera{location <0,0,-1> look_at 0} light_source{<0,0,-5> color rgb 1}\n' > empty.pov
printf 'v\nfrom 0 0 -1\nat 0 0 0\nup 0 1 0\nangle 45\nhither 0.01\nresolution 512 512\nl 0 0 -5\n' > empty.nff
POVARGS="+W512 +H512 -A -D +WT1 -GA"
TACHARGS="-res 512 512 -raydepth 5 -aasamples 0 -format PPM"
pov_empty=$(runs povray +Iempty.pov +Oempty.png $POVARGS)
tach_empty=$(runs tachyon empty.nff $TACHARGS -numthreads 1 -o empty.ppm)

echo "Machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores; $(date -u +%Y-%m-%d)."
echo "Start-up on an empty scene, subtracted: POV-Ray ${pov_empty}s, Tachyon ${tach_empty}s CPU."
echo "Medians of $RUNS runs, the three renderers interleaved."
echo
if want render; then
echo "## Full render, one thread, 512×512, one eye ray per pixel centre, depth 5 (CPU seconds)"
echo
echo "Medians, with the min–max spread of the $RUNS runs in parentheses."
echo
echo "| scene | POV-Ray 3.7 | Tachyon 0.99 | parrt | parrt / POV-Ray | goal ≤ 0.25 | parrt / Tachyon | goal ≤ 0.5 | Tachyon's image |"
echo "|---|---:|---:|---:|---:|---|---:|---|---|"
sub() { awk -v a="$1" -v b="$2" 'BEGIN {printf "%.4f", a - b}'; }
ratio() { awk -v a="$1" -v b="$2" 'BEGIN {printf "%.3f", a / b}'; }
for s in "$@"; do
    pov=$OUT/pov/$s.pov; nff=$SPD/$s.nff
    [ -f "$nff" ] || { echo "| $s | missing | | | | | | | |"; continue; }
    # POV-Ray reads the same scene, written from the NFF file by parrt itself.
    mkdir -p "$OUT/pov" && "$PARRT" scene "$nff" -o "$pov"
    : > p.txt; : > t.txt; : > q.txt
    for _ in $(seq "$RUNS"); do
        cpu povray +I"$pov" +O"$OUT/$s.pov.png" $POVARGS >> p.txt
        cpu tachyon "$nff" $TACHARGS -numthreads 1 -o "$OUT/$s.tachyon.ppm" >> t.txt
        cpu "$PARRT" render "$nff" --threads 1 --width 512 --height 512 --max-depth 5 -o "$OUT/$s.parrt.png" >> q.txt
    done
    p=$(sub "$(median < p.txt)" "$pov_empty")
    t=$(sub "$(median < t.txt)" "$tach_empty")
    q=$(median < q.txt)
    r=$(ratio "$q" "$p"); rt=$(ratio "$q" "$t")
    ok=$(awk -v r="$r" 'BEGIN {print (r <= 0.25) ? "met" : "not met"}')
    "$PARRT" render "$nff" --threads 1 --width 512 --height 512 --max-depth 5 -o "$OUT/$s.parrt.ppm" >/dev/null 2>&1
    note=$(tachyon_note "$OUT/$s.tachyon.ppm" "$nff" "$OUT/$s.parrt.ppm")
    okt=$(awk -v r="$rt" -v n="$note" 'BEGIN {print (n != "") ? "—" : (r <= 0.5) ? "met" : "not met"}')
    echo "| $s | $p ($(spread p.txt "$pov_empty")) | $t ($(spread t.txt "$tach_empty")) | $q ($(spread q.txt)) | $r | $ok | $rt | $okt | ${note:-comparable} |"
done
fi
if want cast; then
echo
echo "## Ray casting, one thread: eye + shadow rays per CPU second (Mrays/s)"
echo
echo "Medians of $RUNS interleaved runs (Embree, then parrt), min–max spread in parentheses."
echo
echo "| scene | Embree 3 (single rays) | Embree 16-wide packets | parrt | parrt / Embree single | goal ≥ 1.0 | parrt / Embree packets | goal ≥ 0.75 |"
echo "|---|---:|---:|---:|---:|---|---:|---|"
for s in "$@"; do
    nff=$SPD/$s.nff
    [ -f "$nff" ] || continue
    cones=""
    grep -q '^c ' "$nff" && cones="-cones user"
    : > es.txt; : > ep.txt; : > qc.txt
    for _ in $(seq "$RUNS"); do
        e=$("$NFFCAST" -threads 1 -mintime "$MINTIME" $cones "$nff" | grep '^RESULT')
        echo "$e" | tr ' ' '\n' | awk -F= '$1=="st_cpu_mrays" {print $2}' >> es.txt
        echo "$e" | tr ' ' '\n' | awk -F= '$1=="pk16_st_cpu_mrays" {print $2}' >> ep.txt
        "$PARRT" bench cast "$nff" --size 512 --mintime "$MINTIME" | tail -1 | awk -F'|' '{gsub(/ /,"",$10); print $10}' >> qc.txt
    done
    est=$(median < es.txt); epk=$(median < ep.txt); q=$(median < qc.txt)
    r=$(awk -v a="$q" -v b="$est" 'BEGIN {printf "%.3f", a / b}')
    ok=$(awk -v r="$r" 'BEGIN {print (r >= 1.0) ? "met" : "not met"}')
    rp=$(awk -v a="$q" -v b="$epk" 'BEGIN {printf "%.3f", a / b}')
    okp=$(awk -v r="$rp" 'BEGIN {print (r >= 0.75) ? "met" : "not met"}')
    est="$est ($(spread es.txt))"; epk="$epk ($(spread ep.txt))"; q="$q ($(spread qc.txt))"
    echo "| $s | $est | $epk | $q | $r | $ok | $rp | $okp |"
done
fi
if want efficiency; then
echo
echo "## Two threads against one: efficiency t1 / (2 t2) of wall time, full render 512×512"
echo
echo "| scene | Tachyon t1 s | Tachyon t2 s | Tachyon efficiency | parrt t1 s | parrt t2 s | parrt efficiency |"
echo "|---|---:|---:|---:|---:|---:|---:|"
for s in "$@"; do
    nff=$SPD/$s.nff
    [ -f "$nff" ] || continue
    for n in 1 2; do : > "t$n.txt"; : > "q$n.txt"; done
    for _ in $(seq "$RUNS"); do
        for n in 1 2; do
            wall tachyon "$nff" $TACHARGS -numthreads $n -o "$OUT/$s.tachyon.ppm" >> "t$n.txt"
            wall "$PARRT" render "$nff" --threads $n --width 512 --height 512 --max-depth 5 -o "$OUT/$s.parrt.png" >> "q$n.txt"
        done
    done
    t1=$(median < t1.txt); t2=$(median < t2.txt); q1=$(median < q1.txt); q2=$(median < q2.txt)
    et=$(awk -v a="$t1" -v b="$t2" 'BEGIN {printf "%.3f", a / (2 * b)}')
    eq=$(awk -v a="$q1" -v b="$q2" 'BEGIN {printf "%.3f", a / (2 * b)}')
    echo "| $s | $t1 | $t2 | $et | $q1 | $q2 | $eq |"
done
fi
