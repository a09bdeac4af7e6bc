#!/usr/bin/env bash
# The live view in a real browser: installs Debian's chromium when root, then
# tests/browser/live_view.py starts a distributed render with --http on loopback and keeps ONE
# headless Chromium page open on it, driven over the DevTools protocol (python3's standard
# library), capturing it twice mid-render and once at the end. It checks that tiles reach the
# open page by its event stream (more drawn at the second capture, with no reload between) and
# are drawn where they belong (every drawn tile equals the PNG parrt wrote), part drawn and part
# not mid-render, the whole image at the end, one row per worker. /status is checked from Rust
# (tests/tests/watching/live_view.rs).
#
#   usage: tests/browser/live_view.sh [PARRT_BINARY]     (default: target/debug/parrt)
# It runs twice: with the default --http-full-rate (every tile drawn at full resolution) and
# with --http-full-rate LIVE_VIEW_PREVIEW_RATE (default 0.005 megapixels a second, far under the
# render's pace: mid-render tiles come as block means, which must equal the PNG's).
#   LIVE_VIEW_SHOTS=DIR keeps the screenshots there, the preview pass's in DIR/preview
#   (docs/live-view/ holds the committed ones).
#   LIVE_VIEW_BREAK=tiles|offset breaks the page's drawing of tiles: the test must then fail.
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
command -v python3 >/dev/null || skip "no python3 to drive the browser"

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

# Two passes: tiles at full resolution (the default rate: this render lands far under it), then
# with --http-full-rate low enough that mid-render tiles come as block means (the preview).
T=$(mktemp -d /tmp/parrt-live-view.XXXXXX)
trap 'rm -rf "$T"' EXIT
for pass in full preview; do
    mkdir -p "$T/$pass"
    rate=
    [ $pass = preview ] && rate=${LIVE_VIEW_PREVIEW_RATE:-0.005}
    shots=${LIVE_VIEW_SHOTS:+$LIVE_VIEW_SHOTS${rate:+/preview}}
    say "pass: $pass"
    # The driver ends Chromium and parrt itself on every path; `timeout` is the last resort.
    rc=0
    PYTHONDONTWRITEBYTECODE=1 LIVE_VIEW_FULL_RATE=$rate LIVE_VIEW_SHOTS=$shots \
        timeout -k 10 300 python3 "$HERE/live_view.py" "$CHROME" "$BIN" "$T/$pass" || rc=$?
    if [ $rc != 0 ]; then
        for f in render.err chrome.log; do
            [ -s "$T/$pass/$f" ] && { echo "--- $f (last lines)" >&2; grep -v dbus "$T/$pass/$f" | tail -n 20 >&2; }
        done
        fail "the page did not show what it should in the $pass pass (exit $rc)"
    fi
done
