#!/usr/bin/env bash
# The README walk-through: runs the shell examples of README.md, docs/*.md and BENCHMARKS.md as
# a newcomer would on a fresh clone — in order, in one shell, from the repository's root — and
# fails when one of them fails. The commands are read from the Markdown itself, never from a
# copy, so an example that rots fails CI.
#
#   usage: .ci/readme_walk.sh [FILE.md ...]
#          (default: README.md, then docs/*.md but those below, then BENCHMARKS.md)
#
# What counts as an example:
# - every fenced block opened with ```sh; other blocks (```rust, bare ```) are prose;
# - in a block whose lines start with `$ ` (a transcript), only those lines and their `\`
#   continuations are commands; the other lines are the output the doc shows;
# - a command whose comment says `# exit N` must exit N (the docs show refusals too);
# - a block right after `<!-- walk: skip: REASON -->` is not run: it needs what one machine in
#   CI has not (other hosts, ssh, a cluster launcher, root), or takes more than a minute
#   (BENCHMARKS.md's full studies); the reason is printed.
# Jobs a block starts with `&` are waited for at the block's end. WALK_DRY=1 lists the commands
# without running them.
#
# Every example writes under out/ (ignored by git), so that it can be run twice and leaves
# nothing else in the checkout: a file the walk leaves anywhere else that git would see is a
# failure, named. At the end the walk removes what it made (out/ too, if it made it; the quick
# start's parrt.png if it made it) unless WALK_KEEP=1.
set -uo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD

# Commands not run, with the reason (matched at the start of the command).
SKIP_PREFIXES=("cargo test --workspace")
SKIP_REASONS=("CI's test step has just run it")
# docs/*.md not walked, with the reason.
SKIP_DOCS=("docs/simulation.md")
SKIP_DOCS_REASONS=("its lines are synopses with placeholders (FILE, [--first S]) for minutes to \
hours of simulation (explore 10 000 seeds, scale in virtual time) after a release build of the \
simulator; CI runs \`sim explore --seeds 2000\` instead")

if [ $# -gt 0 ]; then
    FILES=("$@")
else
    FILES=(README.md)
    for f in docs/*.md; do
        skip=""
        for i in "${!SKIP_DOCS[@]}"; do
            [ "$f" = "${SKIP_DOCS[$i]}" ] && skip="${SKIP_DOCS_REASONS[$i]}"
        done
        if [ -n "$skip" ]; then
            echo "walk: $f: not walked: $skip"
        else
            FILES+=("$f")
        fi
    done
    FILES+=(BENCHMARKS.md)
fi

# Files present before the walk, so only what it made is removed.
before=$(mktemp)
script=$(mktemp)
{ git ls-files --others --exclude-standard; [ -e bench-out ] && echo bench-out/; } \
    | sort >"$before"

# Emits the walk as a bash script: walk_run FILE LINE WANT <<heredoc(command) per command,
# walk_skip for skipped blocks, walk_block_end after each block.
extract() {
    awk -v file="$1" '
    function flush_cmd() {
        if (cmd != "") {
            n++
            printf "walk_run %s %d %d <<'\''WALK_CMD_%d'\''\n%s\nWALK_CMD_%d\n", file, cmd_line, want(cmd), n, cmd, n
        }
        cmd = ""
    }
    function want(c,   m) {
        if (match(c, /# exit [0-9]+/)) return substr(c, RSTART + 7, RLENGTH - 7) + 0
        return 0
    }
    function run_block(   i, l, is_tx, cont) {
        is_tx = 0
        for (i = 1; i <= nb; i++) if (block[i] ~ /^[ \t]*\$ /) is_tx = 1
        cmd = ""; cont = 0
        for (i = 1; i <= nb; i++) {
            l = block[i]
            if (is_tx) {
                if (cont) { cmd = cmd "\n" l }
                else if (l ~ /^[ \t]*\$ /) { flush_cmd(); sub(/^[ \t]*\$ /, "", l); cmd = l; cmd_line = bl + i }
                else { flush_cmd(); continue }
            } else {
                if (cont) { cmd = cmd "\n" l }
                else { flush_cmd(); if (l ~ /^[ \t]*(#|$)/) continue; sub(/^[ \t]+/, "", l); cmd = l; cmd_line = bl + i }
            }
            cont = (l ~ /\\$/)
        }
        flush_cmd()
        printf "walk_block_end %s %d\n", file, bl
    }
    /^[ \t]*<!-- walk: skip: .*-->/ { reason = $0; sub(/^[ \t]*<!-- walk: skip: /, "", reason); sub(/ *-->.*/, "", reason); pending = 1; next }
    !inb && /^[ \t]*```/ {
        lang = $0; sub(/^[ \t]*```/, "", lang)
        inb = 1; nb = 0; bl = NR; is_sh = (lang == "sh")
        skip = pending; pending = 0; why = reason
        next
    }
    inb && /^[ \t]*```[ \t]*$/ {
        inb = 0
        if (is_sh && skip) { gsub(/'\''/, "", why); printf "walk_skip %s %d '\''%s'\''\n", file, bl, why }
        else if (is_sh) run_block()
        next
    }
    inb { block[++nb] = $0; next }
    /[^ \t]/ { pending = 0 }
    ' "$1"
}

for f in "${FILES[@]}"; do
    [ -f "$f" ] || { echo "walk: no file $f" >&2; exit 2; }
    extract "$f"
done >"$script"

ran=0
skipped=0
walk_run() {
    local file=$1 line=$2 want=$3 cmd rc
    cmd=$(cat)
    for i in "${!SKIP_PREFIXES[@]}"; do
        if [[ "$cmd" == "${SKIP_PREFIXES[$i]}"* ]]; then
            echo "walk: $file:$line: skipped \`$cmd\`: ${SKIP_REASONS[$i]}"
            skipped=$((skipped + 1))
            return 0
        fi
    done
    echo "walk: $file:$line: \$ $cmd"
    if [ "${WALK_DRY:-0}" = 1 ]; then
        ran=$((ran + 1))
        return 0
    fi
    eval "$cmd"
    rc=$?
    ran=$((ran + 1))
    if [ "$rc" != "$want" ]; then
        echo "walk: $file:$line: FAILED: exit $rc, the doc expects $want" >&2
        exit 1
    fi
}
walk_skip() {
    echo "walk: $1:$2: block skipped: $3"
    skipped=$((skipped + 1))
}
walk_block_end() {
    wait
}
walk_cleanup() {
    local status=$? pids strays
    pids=$(jobs -p)
    [ -n "$pids" ] && kill $pids 2>/dev/null
    cd "$ROOT" || return
    # What the walk made outside out/ that git would see: an example that writes there breaks
    # the rule that examples can be run twice and leave the checkout as it was.
    strays=$({ git ls-files --others --exclude-standard; [ -e bench-out ] && echo bench-out/; } \
        | sort | comm -13 "$before" -)
    if [ -n "$strays" ]; then
        echo "walk: FAILED: examples left files outside out/ (write them under out/):" >&2
        echo "$strays" | sed 's/^/walk:   /' >&2
        [ "$status" = 0 ] && status=1
    fi
    if [ "${WALK_KEEP:-0}" != 1 ]; then
        [ -n "$strays" ] && echo "$strays" | while read -r made; do rm -rf -- "$made"; done
        # parrt.png (the quick start's output) and out/ are ignored; remove them only if the
        # walk made them.
        [ -n "${made_parrt_png:-}" ] && rm -f parrt.png
        [ -n "${made_out:-}" ] && rm -rf out
    fi
    rm -f "$before" "$script"
    exit "$status"
}
[ -e parrt.png ] || made_parrt_png=1
[ -e out ] || made_out=1
trap walk_cleanup EXIT

start=$SECONDS
# shellcheck disable=SC1090
. "$script"
cd "$ROOT" || exit 1
echo "walk: ${#FILES[@]} files, $ran commands run as written, $skipped skipped (reasons above), \
0 failed, in $((SECONDS - start)) s"
