#!/usr/bin/env bash
# The live view in a real browser (issue 19): installs Debian's chromium when root, then
# tests/browser/live_view.py starts a distributed render with --http on loopback and keeps ONE
# headless Chromium page open on it, driven over the DevTools protocol (python3's standard
# library), capturing it twice mid-render and once at the end. It checks that tiles reach the
# open page by its event stream (more drawn at the second capture, with no reload between) and
# are drawn where they belong (every drawn tile equals the PNG parrt wrote), part drawn and part
# not mid-render, the whole image at the end, one row per worker. /status is checked from Rust
# (tests/tests/live_view.rs).
#
#   usage: tests/browser/live_view.sh [PARRT_BINARY]     (default: target/debug/parrt)
#   LIVE_VIEW_SHOTS=DIR keeps the screenshots there (docs/live-view/ holds the committed ones).
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

T=$(mktemp -d /tmp/parrt-live-view.XXXXXX)
trap 'rm -rf "$T"' EXIT
# The driver ends Chromium and parrt itself on every path; `timeout` is the last resort.
rc=0
PYTHONDONTWRITEBYTECODE=1 timeout -k 10 300 python3 "$HERE/live_view.py" "$CHROME" "$BIN" "$T" || rc=$?
if [ $rc != 0 ]; then
    for f in render.err chrome.log; do
        [ -s "$T/$f" ] && { echo "--- $f (last lines)" >&2; grep -v dbus "$T/$f" | tail -n 20 >&2; }
    done
    fail "the page did not show what it should (exit $rc)"
fi
