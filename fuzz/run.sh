#!/usr/bin/env bash
# Runs parrt's fuzz targets with libFuzzer (by hand; not part of CI).
#   usage: fuzz/run.sh [TARGET] [SECONDS]     TARGET: parse_nff | decode_frames (default: both)
# Uses `cargo fuzz` when it is installed; otherwise builds the target with the nightly toolchain
# and the same sanitizer-coverage flags cargo-fuzz passes (rustup toolchain install nightly).
# The corpora in fuzz/corpus/ are small committed seeds; runs add to them (commit only what stays small).
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
SECONDS_EACH=${2:-120}
TARGETS=${1:-"parse_nff decode_frames"}
SPD=${PARRT_SPD_DIR:-$HERE/../data/spd}
for t in $TARGETS; do
    corpus=$HERE/corpus/$t
    mkdir -p "$corpus"
    if [ "$t" = parse_nff ] && [ -z "$(ls -A "$corpus")" ] && [ -d "$SPD" ]; then
        for f in balls-3 gears-1 mount-4 rings-2 teapot-2 tetra-4 tree-6 jacks-1; do
            [ -f "$SPD/$f.nff" ] && cp "$SPD/$f.nff" "$corpus/"
        done
    fi
    if cargo fuzz --help >/dev/null 2>&1; then
        (cd "$HERE" && cargo +nightly fuzz run "$t" "$corpus" -- -max_total_time="$SECONDS_EACH")
    else
        RUSTFLAGS="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing -Zsanitizer=address" \
            cargo +nightly build --release --manifest-path "$HERE/Cargo.toml" --bin "$t" \
            --target x86_64-unknown-linux-gnu --target-dir "$HERE/target"
        "$HERE/target/x86_64-unknown-linux-gnu/release/$t" "$corpus" \
            -max_total_time="$SECONDS_EACH" -max_len=65536 -rss_limit_mb=2048 -print_final_stats=1
    fi
done
