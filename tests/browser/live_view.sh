#!/usr/bin/env bash
# The live view in a real browser (issue 19): installs Debian's chromium when root, starts a
# distributed render with --http on loopback, and takes headless Chromium screenshots and DOM
# dumps of the page mid-render and after it. Checks: mid-render, part of the image is drawn and
# part is not, the progress reads 0 < done < total, and there is one row per worker; at the end
# the whole image is drawn, the state is done, every tile counted. /status is checked from Rust
# (tests/tests/live_view.rs).
#
#   usage: tests/browser/live_view.sh [PARRT_BINARY]     (default: target/debug/parrt)
#   LIVE_VIEW_SHOTS=DIR keeps the screenshots there (docs/live-view/ holds the committed ones).
# Needs root and apt (or chromium already installed); without them it prints why and exits 0.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
REPO=$(cd "$HERE/../.." && pwd)
BIN=${1:-$REPO/target/debug/parrt}
BIN=$(cd "$(dirname "$BIN")" && pwd)/$(basename "$BIN")
say() { echo "live-view: $*"; }
skip() { say "skipped: $*"; exit 0; }
fail() { say "FAILED: $*" >&2; exit 1; }
[ -x "$BIN" ] || fail "no parrt binary at $BIN"
command -v python3 >/dev/null || skip "no python3 to read the screenshots"

CHROME=$(command -v chromium || command -v chromium-browser || true)
if [ -z "$CHROME" ]; then
    [ "$(id -u)" = 0 ] || skip "chromium is not installed and installing it needs root"
    command -v apt-get >/dev/null || skip "no chromium and no apt-get on this machine"
    say "installing chromium"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >/dev/null 2>&1 || skip "apt-get update failed (no network or no mirror?)"
    apt-get install -y -qq --no-install-recommends chromium fonts-dejavu-core >/dev/null 2>&1 \
        || skip "apt-get install chromium failed"
    CHROME=$(command -v chromium || true)
    [ -n "$CHROME" ] || skip "chromium installed no chromium command"
fi

T=$(mktemp -d /tmp/parrt-live-view.XXXXXX)
PID=
cleanup() {
    [ -n "$PID" ] && kill "$PID" 2>/dev/null || true
    [ -n "$PID" ] && wait "$PID" 2>/dev/null || true
    rm -rf "$T"
}
trap cleanup EXIT

# Slow enough to be caught mid-render by a browser that needs seconds to start, whatever the
# build's speed: a calibration render at one thread sizes the image to about WORK seconds of
# one-thread work (about half that on two one-thread workers), 4 samples per pixel.
WORK=${LIVE_VIEW_WORK:-40}
"$BIN" render --scene mount:4 --width 96 --height 96 --spp 4 --threads 1 -o "$T/cal.png" \
    --stats-json "$T/cal.json" 2>/dev/null || fail "the calibration render failed"
SIZE=${LIVE_VIEW_SIZE:-$(python3 - "$T/cal.json" "$WORK" <<'PY'
import json, math, sys
t = max(json.load(open(sys.argv[1]))["trace_s"], 1e-4)
side = math.sqrt(float(sys.argv[2]) * 96 * 96 / t)
print(int(min(max(side, 128), 1536)) // 16 * 16)
PY
)}
say "image ${SIZE}x${SIZE} (calibration: $(python3 -c "import json;print(json.load(open('$T/cal.json'))['trace_s'])") s for 96x96)"
: > "$T/render.err"
"$BIN" render --scene mount:4 --width "$SIZE" --height "$SIZE" --spp 4 --tile 16 \
    --workers 2 --threads 1 --http 127.0.0.1:0 --http-linger 600 -o "$T/out.png" \
    2>"$T/render.err" &
PID=$!
URL=
for _ in $(seq 1 200); do
    URL=$(sed -n 's/^parrt: live view at //p' "$T/render.err" | head -1)
    [ -n "$URL" ] && break
    kill -0 "$PID" 2>/dev/null || { cat "$T/render.err" >&2; fail "parrt render ended early"; }
    sleep 0.1
done
[ -n "$URL" ] || fail "no live view address printed"
say "page at $URL"

status() { python3 - "$URL" <<'PY'
import json, sys, urllib.request
s = json.load(urllib.request.urlopen(sys.argv[1] + "status", timeout=5))
print(s["state"], s["tiles_done"], s["tiles_total"], len(s["workers"]))
PY
}

# Chromium, headless, on its own profile; the page gets TIMEOUT ms to load and draw.
shoot() { # shoot OUT.png|OUT.html TIMEOUT_MS
    local what=--screenshot="$1"
    case "$1" in *.html) what=--dump-dom ;; esac
    local out=$1
    timeout 60 "$CHROME" --headless --no-sandbox --disable-gpu --disable-dev-shm-usage \
        --no-first-run --hide-scrollbars --user-data-dir="$T/profile-$(basename "$1")" \
        --window-size=1100,760 --timeout="$2" "$what" "$URL" \
        > "$T/chrome.out" 2> "$T/chrome.err" || { cat "$T/chrome.err" >&2; fail "chromium failed"; }
    case "$out" in *.html) cp "$T/chrome.out" "$out" ;; esac
    [ -s "$out" ] || { cat "$T/chrome.err" >&2; fail "chromium wrote no $out"; }
}

# Mid-render: wait for the first tiles, then look.
for _ in $(seq 1 300); do
    read -r state done total workers < <(status)
    [ "$done" -gt 0 ] && break
    sleep 0.1
done
say "before the mid-render shots: $state $done/$total tiles, $workers workers"
[ "$state" = rendering ] || fail "the render was not caught mid-render ($state $done/$total); raise LIVE_VIEW_SIZE"
shoot "$T/mid.png" 3000
shoot "$T/mid.html" 3000
read -r state_after done_after total _ < <(status)
say "after them: $state_after $done_after/$total tiles"

# The end.
for _ in $(seq 1 3000); do
    read -r state done total workers < <(status)
    [ "$state" = done ] && break
    kill -0 "$PID" 2>/dev/null || fail "parrt render ended before its linger"
    sleep 0.1
done
[ "$state" = done ] || fail "the render did not finish"
shoot "$T/end.png" 4000
shoot "$T/end.html" 4000

rc=0
python3 - "$T" "$SIZE" <<'PY' || rc=$?
import re, struct, sys, zlib
d, size = sys.argv[1], int(sys.argv[2])

def png(path):
    """RGB(A) pixels of a non-interlaced 8-bit PNG (what Chromium writes)."""
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", path
    pos, idat, w = 8, b"", 0
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert depth == 8 and interlace == 0 and ctype in (2, 6), (depth, ctype)
            bpp = 3 if ctype == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw, rows, prev, i = zlib.decompress(idat), [], bytearray(w * bpp), 0
    for _ in range(h):
        f, line = raw[i], bytearray(raw[i + 1:i + 1 + w * bpp]); i += 1 + w * bpp
        for x in range(len(line)):
            a = line[x - bpp] if x >= bpp else 0
            b, c = prev[x], (prev[x - bpp] if x >= bpp else 0)
            if f == 1: line[x] = (line[x] + a) & 255
            elif f == 2: line[x] = (line[x] + b) & 255
            elif f == 3: line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c; pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append([tuple(line[k:k + 3]) for k in range(0, len(line), bpp)])
        prev = line
    return rows

def canvas_stats(rows):
    """Pixels inside the image box (its #333 frame, 4 px wide): those not drawn yet (black, as
    the frame holds them, or the page's #222 before any image) and all."""
    frame = (51, 51, 51)
    def run(cells):
        best, cur, start, at = (0, 0), 0, 0, 0
        for i, p in enumerate(cells):
            if p == frame:
                if cur == 0:
                    start = i
                cur += 1
                if cur > best[0]:
                    best = (cur, start)
            else:
                cur = 0
        return best
    for x0 in range(min(200, len(rows[0]))):
        length, y0 = run([r[x0] for r in rows])
        if length > 100:
            break
    else:
        raise AssertionError("no image frame on the page")
    y1 = y0 + length - 1
    width, _ = run(rows[y0][x0:])
    x1 = x0 + width - 1
    inner = [p for r in rows[y0 + 4:y1 - 3] for p in r[x0 + 4:x1 - 3]]
    unfilled = sum(1 for p in inner if p in ((0, 0, 0), (34, 34, 34)))
    return len(inner), unfilled, (x1 - x0 - 7, y1 - y0 - 7)

def dom(path):
    h = open(path, encoding="utf-8", errors="replace").read()
    num = lambda i: int(re.search(r'id="%s"[^>]*>(\d+)<' % i, h).group(1))
    state = re.search(r'id="state"[^>]*>([^<]*)<', h).group(1)
    return state, num("done"), num("total"), len(re.findall(r'<tr class="worker"', h))

ok = True
def check(cond, what):
    global ok
    print(("  ok   " if cond else "  FAIL ") + what)
    ok &= bool(cond)

n, unfilled, box = canvas_stats(png(d + "/mid.png"))
print(f"mid-render screenshot: image box {box[0]}x{box[1]}, {unfilled}/{n} pixels not drawn yet")
shown = min(size, 605)  # the page caps the image at 55% of the 1100-pixel window
check(abs(box[0] - shown) <= 0.03 * shown + 2 and n > 0.4 * shown * shown,
      "the image box is on the page at about its size")
check(0.02 * n < unfilled < 0.98 * n, "part of the image is drawn, part is not")
state, done, total, workers = dom(d + "/mid.html")
print(f"mid-render page: state {state!r}, {done}/{total} tiles, {workers} worker rows")
check(0 < done < total, "progress between none and all")
check(workers == 2, "one row per worker")
n, unfilled, box = canvas_stats(png(d + "/end.png"))
print(f"final screenshot: image box {box[0]}x{box[1]}, {unfilled}/{n} pixels not drawn")
check(unfilled < 0.002 * n, "the whole image is drawn")
state, done, total, workers = dom(d + "/end.html")
print(f"final page: state {state!r}, {done}/{total} tiles, {workers} worker rows")
check(state.startswith("done") and done == total > 0, "done, every tile")
check(workers == 2, "one row per worker")
sys.exit(0 if ok else 1)
PY
if [ -n "${LIVE_VIEW_SHOTS:-}" ]; then
    mkdir -p "$LIVE_VIEW_SHOTS"
    cp "$T/mid.png" "$LIVE_VIEW_SHOTS/mid-render.png"
    cp "$T/end.png" "$LIVE_VIEW_SHOTS/finished.png"
    say "screenshots kept in $LIVE_VIEW_SHOTS"
fi
[ $rc = 0 ] || fail "the page did not show what it should"
say "passed"
