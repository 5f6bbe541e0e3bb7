#!/usr/bin/env bash
# Tile throughput of a running textond (wrk from Debian's packages), cold (every tile distinct:
# render + encode) and warm (cached): requests/s, p50/p99 latency, errors, cache hit ratio and
# CPU-ms per tile of the server process. Not a unit test: machines are shared and noisy.
#
#   tests/load/load_test.sh                    # starts its own server on a free port
#   URL=http://127.0.0.1:8080 tests/load/load_test.sh   # against a running one (same machine
#                                                         for the CPU column)
#   tests/load/load_test.sh --replicas       # two replicas sharing Redis behind nginx, with a
#                                             # soak (tests/load/replicas_test.sh)
# Environment: DURATION (20s), CONNECTIONS (64), THREADS (2), EXEMPLAR, BIN, ACCESS_LOG=1 (keep
# the per-request log line, to a file), SERVER_ARGS (more `serve` flags).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
[ "${1:-}" = --replicas ] && exec "$here/replicas_test.sh"
root=$(cd "$here/../.." && pwd)
DURATION=${DURATION:-20s}
CONNECTIONS=${CONNECTIONS:-64}
THREADS=${THREADS:-2}
BIN=${BIN:-$root/build/release/textond}
EXEMPLAR=${EXEMPLAR:-$root/../shared/data/exemplars/etr_sand01.png}
[ -f "$EXEMPLAR" ] || EXEMPLAR=$root/shared/data/exemplars/etr_sand01.png

command -v wrk >/dev/null || bash "$root/docker/install-deps.sh"
command -v wrk >/dev/null || { echo "load_test: wrk is not installed" >&2; exit 1; }

server_pid=""
cleanup() { [ -n "$server_pid" ] && kill "$server_pid" 2>/dev/null && wait "$server_pid" 2>/dev/null; true; }
trap cleanup EXIT
if [ -z "${URL:-}" ]; then
    data=$(mktemp -d)
    log=$(mktemp)
    access=(--no-access-log --log-level warn)
    [ "${ACCESS_LOG:-0}" = 1 ] && access=()
    # shellcheck disable=SC2086
    "$BIN" serve --port 0 --data "$data" "${access[@]}" ${SERVER_ARGS:-} >"$log" 2>&1 &
    server_pid=$!
    for _ in $(seq 100); do grep -q "listening on" "$log" && break; sleep 0.1; done
    URL=$(sed -n 's/.*listening on \(http:[^ ]*\)\/$/\1/p' "$log")
    [ -n "$URL" ] || { cat "$log"; exit 1; }
fi
pid=${server_pid:-$(pgrep -f "textond serve" | head -1 || true)}

id=$(curl -sf -X POST -H 'Content-Type: image/png' --data-binary @"$EXEMPLAR" "$URL/v1/textons" |
     sed -n 's/.*"id": "\([0-9a-f]\{64\}\)".*/\1/p')
[ -n "$id" ] || { echo "load_test: upload failed" >&2; exit 1; }

cpu_ticks() { [ -n "$pid" ] && awk '{print $14 + $15}' "/proc/$pid/stat" || echo 0; }
cache() { curl -sf "$URL/metrics" | awk -v r="$1" '$1 == "textond_tile_cache_requests_total{result=\""r"\"}" {print $2}'; }
hz=$(getconf CLK_TCK)

printf "%-5s %10s %9s %9s %7s %10s %11s\n" mode "tiles/s" "p50 ms" "p99 ms" errors "hit ratio" "CPU-ms/tile"
for mode in cold warm; do
    if [ "$mode" = warm ]; then  # fill the warm set first
        for k in $(seq 0 63); do curl -sf -o /dev/null "$URL/v1/textons/$id/tiles/0/$((k % 8))/$((k / 8)).png?seed=7"; done
    fi
    h0=$(cache hit); m0=$(cache miss); c0=$(cpu_ticks)
    out=$(TEXTON=$id MODE=$mode SEED=$([ $mode = warm ] && echo 7 || echo $RANDOM) \
          wrk -t "$THREADS" -c "$CONNECTIONS" -d "$DURATION" --latency -s "$here/tiles.lua" "$URL" | grep '^WRK')
    h1=$(cache hit); m1=$(cache miss); c1=$(cpu_ticks)
    read -r _ n rps p50 p99 sock_err status_err bytes <<<"$out"
    hits=$((${h1%.*} - ${h0%.*})); misses=$((${m1%.*} - ${m0%.*}))
    awk -v m="$mode" -v rps="$rps" -v p50="$p50" -v p99="$p99" -v e=$((sock_err + status_err)) \
        -v h=$hits -v mi=$misses -v c=$((c1 - c0)) -v hz="$hz" -v n="$n" 'BEGIN {
        printf "%-5s %10.0f %9.2f %9.2f %7d %10.3f %11.3f\n", m, rps, p50, p99, e,
               (h + mi) ? h / (h + mi) : 0, n ? c * 1000 / hz / n : 0 }'
done
