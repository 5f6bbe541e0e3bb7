#!/usr/bin/env bash
# Cold 256x256 PNG tiles at 256 connections (wrk, every request a distinct tile) against one
# server per backend, the CPU and llvmpipe (OSMesa) here, the GL path's code on any machine. A low
# bar, no speed: every connection opens, no request errs or times out, tiles come back, and the
# server still answers /healthz at once afterwards. Prints one line a backend.
#   tests/load/throughput_smoke.sh [BACKENDS]     (default "cpu osmesa"; CTest throughput_smoke)
# Environment: BIN, EXEMPLAR, CONNECTIONS (256), DURATION (5s).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=tests/load/server_url.sh
. "$here/server_url.sh"
root=$(cd "$here/../.." && pwd)
BACKENDS=${1:-cpu osmesa}
BIN=${BIN:-$root/build/release/textond}
EXEMPLAR=${EXEMPLAR:-$root/../shared/data/exemplars/etr_sand01.png}
[ -f "$EXEMPLAR" ] || EXEMPLAR=$root/shared/data/exemplars/etr_sand01.png
CONNECTIONS=${CONNECTIONS:-256}
DURATION=${DURATION:-5s}
command -v wrk >/dev/null || bash "$root/docker/install-deps.sh"
tmp=$(mktemp -d)
pid=""
cleanup() {
    [ -n "$pid" ] && kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null
    rm -rf "$tmp"
}
trap cleanup EXIT
fail() { echo "throughput_smoke: FAIL: $*" >&2; exit 1; }
for backend in $BACKENDS; do
    # llvmpipe renders a tile in a tenth of a second on 2 cores: requests wait in the render
    # queue for the whole run rather than being shed (429 is no error, but would hide a stall).
    "$BIN" serve --port 0 --data "$tmp/data-$backend" --backend "$backend" --no-access-log \
        --log-level warn --queue-timeout-ms 60000 >"$tmp/log-$backend" 2>&1 &
    pid=$!
    url=$(server_url "$tmp/log-$backend" 300) ||
        fail "$backend: the server did not start: $(cat "$tmp/log-$backend")"
    id=$(curl -sf -X POST -H 'Content-Type: image/png' --data-binary "@$EXEMPLAR" \
        "$url/v1/textons?size=32" | python3 -c 'import json,sys; print(json.load(sys.stdin)["id"])')
    line=$(TEXTON=$id MODE=cold SEED=$RANDOM wrk -t 2 -c "$CONNECTIONS" -d "$DURATION" \
        --timeout 60s -s "$here/tiles.lua" "$url" | grep '^WRK') ||
        fail "$backend: wrk printed no summary"
    # WRK requests rate p50 p99 socket_errors status_errors bytes
    read -r _ n rate p50 p99 socket_errors status_errors _ <<<"$line"
    start=$(date +%s%N)
    curl -sf -o /dev/null --max-time 5 "$url/healthz" || fail "$backend: /healthz after the run"
    health_ms=$((($(date +%s%N) - start) / 1000000))
    echo "$backend: $n tiles at $CONNECTIONS connections in $DURATION ($rate/s, p50 $p50 ms," \
        "p99 $p99 ms), $socket_errors socket errors, $status_errors non-2xx; /healthz after:" \
        "$health_ms ms"
    [ "$n" -gt 0 ] || fail "$backend: no tile came back"
    [ "$socket_errors" = 0 ] || fail "$backend: $socket_errors connect/read/write/timeout errors"
    [ "$status_errors" = 0 ] || fail "$backend: $status_errors answers that were not 2xx"
    kill "$pid"
    wait "$pid" 2>/dev/null || true
    pid=""
done
echo "throughput_smoke: passed"
