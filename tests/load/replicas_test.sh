#!/usr/bin/env bash
# Two textond replicas sharing one Redis (--store), behind a local nginx running the edge config
# of deploy/base/nginx/edge.conf (consistent hashing on the texton id), all on this machine:
# tiles/s, p50/p99, errors and the share of tiles each replica served, for
#   direct   cold tiles straight at replica A (the baseline of this run)
#   cold     every tile distinct, through nginx, its cache bypassed
#   warm     a set of 64 tiles, through nginx, its cache bypassed (the replicas' caches)
#   edge     the same set, served by nginx's cache
# then a soak (every tile distinct, so the image caches churn at their budget) with each
# replica's resident memory before and after; it fails when memory grows by more than the cache
# budget, or when any request failed.
#
#   tests/load/load_test.sh --replicas      (or this script)
# Environment: DURATION (20s), SOAK (60s), CONNECTIONS (64), THREADS (2), TEXTONS (8 ids from
# one exemplar with different analysis seeds), CACHE_MB (64, each replica), EXEMPLAR, BIN.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=tests/load/server_url.sh
. "$here/server_url.sh"
root=$(cd "$here/../.." && pwd)
DURATION=${DURATION:-20s}
SOAK=${SOAK:-60s}
CONNECTIONS=${CONNECTIONS:-64}
THREADS=${THREADS:-2}
TEXTONS=${TEXTONS:-8}
CACHE_MB=${CACHE_MB:-64}
BIN=${BIN:-$root/build/release/textond}
EXEMPLAR=${EXEMPLAR:-$root/../shared/data/exemplars/etr_sand01.png}
[ -f "$EXEMPLAR" ] || EXEMPLAR=$root/shared/data/exemplars/etr_sand01.png

for tool in wrk redis-server /usr/sbin/nginx curl; do
    command -v "$tool" >/dev/null || bash "$root/docker/install-deps.sh"
done

tmp=$(mktemp -d)
pids=()
cleanup() {
    [ -f "$tmp/nginx.pid" ] && /usr/sbin/nginx -p "$tmp" -c "$tmp/nginx.conf" -s quit 2>/dev/null
    for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
    wait 2>/dev/null || true
    rm -rf "$tmp"
}
trap cleanup EXIT
free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }

redis_port=$(free_port)
mkdir -p "$tmp/redis"
redis-server --port "$redis_port" --bind 127.0.0.1 --dir "$tmp/redis" --save "" \
    --appendonly yes >"$tmp/redis.log" &
pids+=($!)
for _ in $(seq 100); do redis-cli -p "$redis_port" ping 2>/dev/null | grep -q PONG && break; sleep 0.05; done

urls=()
replica_pids=()
for r in a b; do
    "$BIN" serve --port 0 --data "$tmp/data-$r" --store "redis://127.0.0.1:$redis_port" \
        --cache-mb "$CACHE_MB" --no-access-log --log-level warn >"$tmp/$r.log" 2>&1 &
    pids+=($!)
    replica_pids+=($!)
    url=$(server_url "$tmp/$r.log") || { cat "$tmp/$r.log"; exit 1; }
    urls+=("$url")
done

# The edge config as deployed, with local paths, port and replicas; its cache is used only when
# a request says X-Edge-Cache: on.
nginx_port=$(free_port)
mkdir -p "$tmp/logs"
LOAD_TEST=1 WORKER_PROCESSES=1 ERROR_LOG=$tmp/logs/error.log "$root/deploy/local/edge-files.sh" "$tmp" \
    "127.0.0.1:$nginx_port" "${urls[@]#http://}"
echo 'map $http_x_edge_cache $textond_no_edge_cache { default 1; "on" 0; }' >"$tmp/settings.conf"
/usr/sbin/nginx -p "$tmp" -c "$tmp/nginx.conf"
edge=http://127.0.0.1:$nginx_port

rss_mib() { awk '/VmRSS/ {printf "%.1f", $2 / 1024}' "/proc/$1/status"; }
ids=()
for s in $(seq "$TEXTONS"); do
    id=$(curl -sf -X POST -H 'Content-Type: image/png' --data-binary @"$EXEMPLAR" \
        "$edge/v1/textons?size=32&seed=$s" | sed -n 's/.*"id": "\([0-9a-f]\{64\}\)".*/\1/p')
    [ -n "$id" ] || { echo "replicas_test: upload $s failed" >&2; exit 1; }
    ids+=("$id")
done
id_list=$(IFS=,; echo "${ids[*]}")
# A splat and a mix through the edge, read 20 times from both replicas, deleted everywhere.
python3 "$here/../deploy/shared_objects_check.py" "$edge" "${urls[@]}" \
    --exemplars "$(dirname "$EXEMPLAR")" || exit 1
start=("$(rss_mib "${replica_pids[0]}")" "$(rss_mib "${replica_pids[1]}")")

tiles_of() { curl -sf "$1/metrics" | awk '/^textond_tile_cache_requests_total/ {n += $2} END {print n + 0}'; }
cache_mib() { curl -sf "$1/metrics" | awk '$1 == "textond_image_cache_bytes" {printf "%.1f", $2 / 1048576}'; }

echo "2 replicas (--cache-mb $CACHE_MB), $TEXTONS textons, nginx edge (hash \$texton_id consistent); wrk -t$THREADS -c$CONNECTIONS -d$DURATION"
printf "%-7s %10s %9s %9s %7s %9s %9s\n" phase "tiles/s" "p50 ms" "p99 ms" errors "A share" "B share"
total_errors=0
run() { # phase target mode duration header
    local a0 b0 a1 b1 out
    a0=$(tiles_of "${urls[0]}"); b0=$(tiles_of "${urls[1]}")
    out=$(TEXTON=$id_list MODE=$3 SEED=$5 HEADER=$6 \
        wrk -t "$THREADS" -c "$CONNECTIONS" -d "$4" --latency -s "$here/tiles.lua" "$2" | grep '^WRK')
    a1=$(tiles_of "${urls[0]}"); b1=$(tiles_of "${urls[1]}")
    read -r _ n rps p50 p99 sock_err status_err bytes <<<"$out"
    total_errors=$((total_errors + sock_err + status_err))
    [ "$1" = "-" ] && return 0
    awk -v p="$1" -v rps="$rps" -v p50="$p50" -v p99="$p99" -v e=$((sock_err + status_err)) \
        -v a=$((a1 - a0)) -v b=$((b1 - b0)) 'BEGIN {
        printf "%-7s %10.0f %9.2f %9.2f %7d %9.3f %9.3f\n", p, rps, p50, p99, e,
               (a + b) ? a / (a + b) : 0, (a + b) ? b / (a + b) : 0 }'
}
run direct "${urls[0]}" cold "$DURATION" "$RANDOM" ""
run cold "$edge" cold "$DURATION" "$RANDOM" ""
run - "$edge" warm 3s 7 ""                      # fill the warm set
run warm "$edge" warm "$DURATION" 7 ""
run - "$edge" warm 3s 7 "X-Edge-Cache: on"      # fill nginx's cache
run edge "$edge" warm "$DURATION" 7 "X-Edge-Cache: on"

before=("$(rss_mib "${replica_pids[0]}")" "$(rss_mib "${replica_pids[1]}")")
run soak "$edge" cold "$SOAK" "$RANDOM" ""
after=("$(rss_mib "${replica_pids[0]}")" "$(rss_mib "${replica_pids[1]}")")

printf "\nresident memory, MiB (start: after the uploads; soak growth: after - before)\n"
printf "%-8s %8s %12s %11s %12s %13s\n" replica start "before soak" "after soak" "soak growth" "cache/budget"
fail=0
for i in 0 1; do
    name=$([ $i = 0 ] && echo A || echo B)
    growth=$(awk -v a="${after[$i]}" -v b="${before[$i]}" 'BEGIN {printf "%.1f", a - b}')
    printf "%-8s %8s %12s %11s %12s %13s\n" "$name" "${start[$i]}" "${before[$i]}" "${after[$i]}" "$growth" \
        "$(cache_mib "${urls[$i]}")/$CACHE_MB"
    awk -v g="$growth" -v c="$CACHE_MB" 'BEGIN {exit !(g > c)}' && fail=1
done
echo "errors: $total_errors"
[ "$total_errors" -eq 0 ] || fail=1
[ $fail -eq 0 ] || { echo "replicas_test: FAILED (errors, or memory grew beyond the cache budget)" >&2; exit 1; }
