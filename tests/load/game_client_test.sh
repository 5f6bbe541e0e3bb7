#!/usr/bin/env bash
# The game-client workload (tests/load/game_client.py) against one server, then through the
# nginx edge of deploy/base/nginx/edge.conf in front of it (its tile cache on), one texton:
# frame-set latency p50/p99, tiles/s, 304s from ETag revalidation, retries after Retry-After.
# It fails when a tile fails after its retries, or when no revalidation answered 304.
#   tests/load/game_client_test.sh [FRAMES]    (make load-game; CTest game_client_smoke: 30)
# Environment: BIN, EXEMPLAR, RING (2), CONNECTIONS (8), REVALIDATE_FRAMES (20).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=tests/load/server_url.sh
. "$here/server_url.sh"
root=$(cd "$here/../.." && pwd)
FRAMES=${1:-120}
BIN=${BIN:-$root/build/release/textond}
EXEMPLAR=${EXEMPLAR:-$root/../shared/data/exemplars/etr_sand01.png}
[ -f "$EXEMPLAR" ] || EXEMPLAR=$root/shared/data/exemplars/etr_sand01.png
command -v /usr/sbin/nginx >/dev/null || bash "$root/docker/install-deps.sh"
tmp=$(mktemp -d)
chmod 0755 "$tmp" # nginx workers (not root) reach the edge directory inside
pid=""
cleanup() {
    [ -f "$tmp/edge/nginx.pid" ] && /usr/sbin/nginx -p "$tmp/edge" -c "$tmp/edge/nginx.conf" -s quit 2>/dev/null
    [ -n "$pid" ] && kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null
    rm -rf "$tmp"
}
trap cleanup EXIT
"$BIN" serve --port 0 --data "$tmp/data" --backend cpu --no-access-log --log-level warn >"$tmp/log" 2>&1 &
pid=$!
server=$(server_url "$tmp/log") || { cat "$tmp/log"; exit 1; }
edge_port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
LOAD_TEST=1 "$root/deploy/local/edge-files.sh" "$tmp/edge" "127.0.0.1:$edge_port" "${server#http://}"
/usr/sbin/nginx -p "$tmp/edge" -c "$tmp/edge/nginx.conf"
id=$(curl -sf -X POST -H 'Content-Type: image/png' --data-binary "@$EXEMPLAR" \
    "$server/v1/textons?size=32" | python3 -c 'import json,sys; print(json.load(sys.stdin)["id"])')
run() {
    /usr/bin/python3 "$here/game_client.py" "$1" "$id" --frames "$FRAMES" --ring "${RING:-2}" \
        --connections "${CONNECTIONS:-8}" --revalidate-frames "${REVALIDATE_FRAMES:-20}" --seed "$2" --json
}
echo "| target | frames | frame-set p50 ms | p99 ms | tiles/s | 304s | LRU hits | retries | errors |"
echo "|---|---|---|---|---|---|---|---|---|"
status=0
for target in server edge; do
    url=$server
    [ "$target" = edge ] && url=http://127.0.0.1:$edge_port
    # The same flight over the same ground, through each: a seed of its own, so the edge's cache
    # starts cold as the server's does.
    seed=1
    [ "$target" = edge ] && seed=2
    out=$(run "$url" "$seed") || status=1
    python3 - "$target" "$out" <<'PY'
import json, sys
r = json.loads(sys.argv[2])
print(f"| {sys.argv[1]} | {r['frames']} | {r['frame_p50_ms']} | {r['frame_p99_ms']} | {r['tiles_per_s']} "
      f"| {r['revalidated_304']} | {r['lru_hits']} | {r['retries']} | {r['errors']} |")
if r["revalidated_304"] == 0:
    sys.exit("FAIL: no revalidation answered 304")
PY
done
[ "$status" = 0 ] || { echo "FAIL: tiles failed after their retries" >&2; exit 1; }
echo "game_client_test: passed"
