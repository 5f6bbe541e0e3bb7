#!/usr/bin/env bash
# 2,000 concurrent keep-alive clients, through the deployment the README documents:
# textond behind the nginx edge of deploy/base/nginx (deploy/local/run-edge.sh's layout). wrk
# holds CONNECTIONS connections for DURATION on the tiles of one texton (MODE=warm: the 64 tiles
# a map view keeps asking for; MODE=cold: every request a new tile); the script reports wrk's
# errors (connect, read, write, timeout, non-2xx), the edge's and textond's memory before and
# during the run, and nginx's memory per connection. With DIRECT=1 the same wrk goes to textond
# alone, to show why the edge is in front. Not part of `make test` (a minute or more; wrk and the
# server share the machine's cores).
#
#   tests/load/connections_test.sh               # 2000 connections, 60 s, through the edge
#   CONNECTIONS=500 DURATION=20s DIRECT=1 tests/load/connections_test.sh
#
# The edge's per-address limits (limit_conn 256, limit_req 500 r/s) are raised for the run: every
# client here has one address, 127.0.0.1; they are a policy against one hostile address, not the
# capacity tested.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
CONNECTIONS=${CONNECTIONS:-2000}
DURATION=${DURATION:-60s}
THREADS=${THREADS:-2}
MODE=${MODE:-warm}
BIN=${BIN:-$root/build/release/textond}
EXEMPLAR=${EXEMPLAR:-$root/../shared/data/exemplars/etr_sand01.png}
command -v wrk >/dev/null && [ -x /usr/sbin/nginx ] || bash "$root/docker/install-deps.sh"
[ -x "$BIN" ] || { echo "connections_test: build first (make build)" >&2; exit 1; }
ulimit -n 65536 2>/dev/null || ulimit -n "$(ulimit -Hn)"
[ "$(ulimit -n)" -ge $((CONNECTIONS * 2 + 64)) ] ||
    { echo "connections_test: ulimit -n $(ulimit -n) is below 2 x $CONNECTIONS" >&2; exit 1; }

tmp=$(mktemp -d)
server_pid=""
cleanup() {
    [ -f "$tmp/nginx.pid" ] && /usr/sbin/nginx -p "$tmp" -c "$tmp/nginx.conf" -s quit 2>/dev/null
    [ -n "$server_pid" ] && kill "$server_pid" 2>/dev/null && wait "$server_pid" 2>/dev/null
    rm -rf "$tmp"
    true
}
trap cleanup EXIT INT TERM
free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
app_port=$(free_port)
edge_port=$(free_port)

"$BIN" serve --host 127.0.0.1 --port "$app_port" --data "$tmp/data" --no-access-log \
    --log-level warn >"$tmp/textond.log" 2>&1 &
server_pid=$!
LOAD_TEST=1 WORKER_CONNECTIONS=$((CONNECTIONS * 2 + 1024)) "$root/deploy/local/edge-files.sh" "$tmp" \
    "$edge_port" "127.0.0.1:$app_port"
/usr/sbin/nginx -p "$tmp" -c "$tmp/nginx.conf"
edge=http://127.0.0.1:$edge_port
for _ in $(seq 100); do curl -sf "http://127.0.0.1:$app_port/healthz" >/dev/null && break; sleep 0.1; done

id=$(curl -sf -X POST -H 'Content-Type: image/png' --data-binary @"$EXEMPLAR" "$edge/v1/textons" |
     sed -n 's/.*"id": "\([0-9a-f]\{64\}\)".*/\1/p')
[ -n "$id" ] || { echo "connections_test: upload failed" >&2; exit 1; }
for k in $(seq 0 63); do
    curl -sf -o /dev/null "$edge/v1/textons/$id/tiles/0/$((k % 8))/$((k / 8)).png?seed=7"
done

rss_kb() { # total resident kB of the processes whose ids are given
    local total=0 p
    for p in "$@"; do total=$((total + $(awk '/^VmRSS/ {print $2}' "/proc/$p/status" 2>/dev/null || echo 0))); done
    echo "$total"
}
nginx_pids() { pgrep -f "nginx: (master|worker) process.*$tmp" || pgrep -P "$(cat "$tmp/nginx.pid")" ; }

run() { # target label -> one table row
    local target=$1 label=$2 out before_n before_t during_n during_t
    before_n=$(rss_kb $(cat "$tmp/nginx.pid") $(pgrep -P "$(cat "$tmp/nginx.pid")"))
    before_t=$(rss_kb "$server_pid")
    TEXTON=$id MODE=$MODE SEED=7 wrk -t "$THREADS" -c "$CONNECTIONS" -d "$DURATION" --timeout 10s \
        -s "$here/tiles.lua" "$target" >"$tmp/wrk.out" 2>&1 &
    local wrk_pid=$!
    # Halfway through, every connection is open: the memory they hold.
    local secs=${DURATION%s}
    sleep $((secs / 2))
    during_n=$(rss_kb $(cat "$tmp/nginx.pid") $(pgrep -P "$(cat "$tmp/nginx.pid")"))
    during_t=$(rss_kb "$server_pid")
    local open
    open=$(ss -Htn state established "( sport = :$edge_port or sport = :$app_port )" | wc -l)
    wait "$wrk_pid" || true
    local rps errors non2xx
    rps=$(awk '/^Requests\/sec/ {print $2}' "$tmp/wrk.out")
    errors=$(awk '/Socket errors/ {gsub(",", ""); print $4 + $6 + $8 + $10}' "$tmp/wrk.out")
    non2xx=$(awk '/Non-2xx/ {print $5}' "$tmp/wrk.out")
    printf '| %s | %s | %s | %s | %s | %s | %s -> %s | %s -> %s | %s |\n' "$label" "$CONNECTIONS" \
        "$DURATION" "$open" "$rps" "$((${errors:-0} + ${non2xx:-0}))" "$((before_n / 1024))" \
        "$((during_n / 1024))" "$((before_t / 1024))" "$((during_t / 1024))" \
        "$(awk -v a="$before_n" -v b="$during_n" -v t0="$before_t" -v t1="$during_t" -v c="$CONNECTIONS" \
            'BEGIN {printf "%.1f, %.1f", (b - a) / c, (t1 - t0) / c}')"
    grep -E "Socket errors|Non-2xx" "$tmp/wrk.out" | sed 's/^/    /' >&2 || true
}

echo "textond $(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo '?'), $(nproc) cores, MODE=$MODE"
echo "| path | connections | duration | established (sampled) | requests/s | errors | nginx MiB | textond MiB | kB/connection (nginx, textond) |"
echo "|---|---|---|---|---|---|---|---|---|"
run "$edge" "through the nginx edge"
if [ "${DIRECT:-0}" = 1 ]; then
    run "http://127.0.0.1:$app_port" "textond alone"
fi
