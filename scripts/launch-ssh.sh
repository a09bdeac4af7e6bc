#!/usr/bin/env bash
# launch-ssh.sh — start parrt workers on other hosts over ssh, each dialling a running master.
#
#   PARRT_TOKEN=... scripts/launch-ssh.sh MASTER_HOST:PORT HOST[:THREADS] [HOST[:THREADS] ...]
#
# Start the master first (on a host the workers can reach), e.g.
#   parrt master scene.nff --listen 0.0.0.0:7878 --token-file ~/.parrt-token --min-workers 3 -o out.png
# then this script with the same token (PARRT_TOKEN, or TOKEN_FILE=path).
#
# The token travels on ssh's stdin and reaches the worker through its environment: it never
# appears on a command line (ps) on either side. The script waits for every worker; workers exit
# by themselves when the master finishes. Ctrl-C stops them all.
#
# Environment:
#   PARRT_TOKEN / TOKEN_FILE  the shared secret (one of the two is required)
#   PARRT_WORKER              the worker command on the remote hosts (default: "parrt worker")
#   SSH                       the ssh command (default: "ssh -o BatchMode=yes"); SSH=none runs
#                             each "host"'s worker on this machine with sh -c (for a local test)
set -euo pipefail

if [ $# -lt 2 ]; then
    sed -n '2,20p' "$0" >&2
    exit 2
fi
master=$1
shift

if [ -n "${TOKEN_FILE:-}" ]; then
    token=$(cat "$TOKEN_FILE")
elif [ -n "${PARRT_TOKEN:-}" ]; then
    token=$PARRT_TOKEN
else
    echo "launch-ssh.sh: set PARRT_TOKEN or TOKEN_FILE" >&2
    exit 2
fi
worker_cmd=${PARRT_WORKER:-parrt worker}
ssh_cmd=${SSH:-ssh -o BatchMode=yes}

pids=()
cleanup() {
    for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
}
trap cleanup INT TERM

for spec in "$@"; do
    host=${spec%%:*}
    threads=""
    if [ "$host" != "$spec" ]; then threads="--threads ${spec#*:}"; fi
    # Read the token from stdin, export it, exec the worker: nothing secret in argv.
    remote="IFS= read -r PARRT_TOKEN && export PARRT_TOKEN && exec $worker_cmd --connect $master $threads"
    if [ "$ssh_cmd" = none ]; then
        sh -c "$remote" <<<"$token" &
    else
        # shellcheck disable=SC2086
        $ssh_cmd "$host" "$remote" <<<"$token" &
    fi
    pids+=($!)
    echo "launch-ssh.sh: started worker on $host (pid $!)" >&2
done

status=0
for p in "${pids[@]}"; do
    wait "$p" || status=$?
done
exit $status
