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
# shellcheck source=tests/load/server_url.sh
. "$here/server_url.sh"
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
    URL=$(server_url "$log") || { cat "$log"; exit 1; }
fi
pid=${server_pid:-$(pgrep -o -f "textond serve" || true)} # the oldest: not its stderr reader

id=$(curl -sf -X POST -H 'Content-Type: image/png' --data-binary @"$EXEMPLAR" "$URL/v1/textons" |
     sed -n 's/.*"id": "\([0-9a-f]\{64\}\)".*/\1/p')
[ -n "$id" ] || { echo "load_test: upload failed" >&2; exit 1; }

cpu_ticks() { [ -n "$pid" ] && awk '{print $14 + $15}' "/proc/$pid/stat" || echo 0; }
cache() { curl -sf "$URL/metrics" | awk -v r="$1" '$1 == "textond_tile_cache_requests_total{result=\""r"\"}" {print $2}'; }
hz=$(getconf CLK_TCK)

# Waits until the server has used no CPU for 0.5 s (at most 30 s): requests of the cold phase
# that were queued when wrk stopped must not be measured as part of the warm one.
wait_idle() {
    [ -n "$pid" ] || { sleep 2; return; }
    local last now
    last=$(cpu_ticks)
    for _ in $(seq 60); do
        sleep 0.5
        now=$(cpu_ticks)
        [ "$now" = "$last" ] && return
        last=$now
    done
}

printf "%-5s %10s %9s %9s %7s %10s %11s\n" mode "tiles/s" "p50 ms" "p99 ms" errors "hit ratio" "CPU-ms/tile"
for mode in cold warm; do
    if [ "$mode" = warm ]; then  # fill the warm set first
        wait_idle
        for k in $(seq 0 63); do curl -sf -o /dev/null "$URL/v1/textons/$id/tiles/0/$((k % 8))/$((k / 8)).png?seed=7"; done
        wait_idle
    fi
    h0=$(cache hit); m0=$(cache miss); c0=$(cpu_ticks)
    out=$(TEXTON=$id MODE=$mode SEED=$([ $mode = warm ] && echo 7 || echo $RANDOM) \
          wrk -t "$THREADS" -c "$CONNECTIONS" -d "$DURATION" --latency -s "$here/tiles.lua" "$URL" | grep '^WRK')
    h1=$(cache hit); m1=$(cache miss); c1=$(cpu_ticks)
    read -r _ n rps p50 p99 sock_err status_err bytes <<<"$out"
    hits=$((${h1%.*} - ${h0%.*})); misses=$((${m1%.*} - ${m0%.*}))
    line=$(awk -v m="$mode" -v rps="$rps" -v p50="$p50" -v p99="$p99" -v e=$((sock_err + status_err)) \
        -v h=$hits -v mi=$misses -v c=$((c1 - c0)) -v hz="$hz" -v n="$n" 'BEGIN {
        printf "%-5s %10.0f %9.2f %9.2f %7d %10.3f %11.3f\n", m, rps, p50, p99, e,
               (h + mi) ? h / (h + mi) : 0, n ? c * 1000 / hz / n : 0 }')
    echo "$line"
    [ "$mode" = cold ] && cold_cpu=${line##* }
done

# The server's CPU per cold tile against what the tile itself costs on one thread (render +
# encode, `textond bench tile` on the same exemplar, in this run): the server's overhead.
if [ -n "${server_pid:-}" ] || [ "${BENCH:-0}" = 1 ]; then
    base=$("$BIN" bench tile --exemplar "$EXEMPLAR" --count 100 2>/dev/null |
           awk -F'|' '/render \+ encode/ {gsub(/ /, "", $3); print $3}')
    [ -n "$base" ] && awk -v s="$cold_cpu" -v b="$base" 'BEGIN {
        printf "cold: server %.3f CPU-ms/tile, one-thread render + encode %.3f ms: %.2fx\n", s, b, s / b }'
fi

# The warm path against nginx serving the same 64 tiles from disk, at the same paths, through the
# same wrk script, threads, connections and duration: both sides pay the same client cost (the Lua
# request() builds each URL, and wrk shares this machine's cores with the server), so the ratio
# is what the cached path costs over a static file server.
if command -v nginx >/dev/null || [ -x /usr/sbin/nginx ]; then
    ngx=$(command -v nginx || echo /usr/sbin/nginx)
    static=$(mktemp -d)
    for k in $(seq 0 63); do
        f="v1/textons/$id/tiles/0/$((k % 8))/$((k / 8)).png"
        mkdir -p "$static/$(dirname "$f")"
        curl -sf -o "$static/$f" "$URL/$f?seed=7"
    done
    nport=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
    cat >"$static/nginx.conf" <<NGINX
worker_processes auto;
pid $static/nginx.pid;
error_log $static/error.log;
events { worker_connections 1024; }
http {
    access_log off;
    client_body_temp_path $static; proxy_temp_path $static; fastcgi_temp_path $static;
    uwsgi_temp_path $static; scgi_temp_path $static;
    server { listen 127.0.0.1:$nport; root $static; location / { } }
}
NGINX
    if "$ngx" -c "$static/nginx.conf" -p "$static" 2>/dev/null; then
        sleep 0.3
        read -r _ _ nrps _ _ _ nerr _ <<<"$(TEXTON=$id MODE=warm SEED=7 wrk -t "$THREADS" \
            -c "$CONNECTIONS" -d "$DURATION" -s "$here/tiles.lua" "http://127.0.0.1:$nport" | grep '^WRK')"
        [ "${nerr:-0}" = 0 ] || echo "nginx answered $nerr requests with an error status"
        kill "$(cat "$static/nginx.pid")" 2>/dev/null || true
        awk -v w="$rps" -v n="$nrps" 'BEGIN {
            printf "nginx static, same bytes: %.0f/s; warm tiles / nginx = %.2fx\n", n, n ? w / n : 0 }'
    else
        echo "nginx could not start; no static comparison"
    fi
    rm -rf "$static"
fi
