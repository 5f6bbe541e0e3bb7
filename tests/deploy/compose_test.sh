#!/usr/bin/env bash
# docker/compose.yaml for real, under podman-compose: Redis, two textond replicas and the nginx
# edge, with stand-ins for the official Redis and nginx images built from Debian's packages
# (tests/deploy/standins/, tests/deploy/compose.standins.yaml). Checks:
#   - an upload through the edge, then the same tile bytes from both replicas and the edge;
#   - kill -9 of a replica's process under wrk load through the edge: under 0.1% errors, every
#     upload answered 201 meanwhile is on both replicas afterwards, and the replica comes back
#     (restart: unless-stopped);
#   - Redis stopped: uploads 503, tiles of a texton the replicas hold still 200, /readyz 200
#     with "degraded": true; Redis started again: uploads 201 and /readyz not degraded.
# Set-up is tests/deploy/podman_setup.sh; the images are built by tests/deploy/build_images.sh.
#
#   tests/deploy/compose_test.sh HOST_TEXTOND EXEMPLAR_DIR
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
here=$root/tests/deploy
host_bin=$(realpath "$1")
exemplars=$(realpath "$2")
bash "$here/podman_setup.sh"
command -v wrk >/dev/null || bash "$root/docker/install-deps.sh"

project=textond-ct$$
tmp=$(mktemp -d)
compose() {
    podman-compose -p "$project" -f "$root/docker/compose.yaml" \
        -f "$here/compose.standins.yaml" "$@" >>"$tmp/compose.log" 2>&1
}
wrk_pid="" up_pid=""
cleanup() {
    for p in $wrk_pid $up_pid; do kill "$p" 2>/dev/null || true; done
    compose down -v -t 5 || true
    # podman-compose 1.0 removes the project's containers and volumes, not its network.
    podman network rm -f "${project}_default" >/dev/null 2>&1 || true
    rm -rf "$tmp"
}
trap cleanup EXIT
fail() {
    echo "FAIL: $*" >&2
    tail -20 "$tmp/compose.log" >&2 || true
    exit 1
}
ms() { date +%s%3N; }
free_port() {
    python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

t0=$(ms)
bash "$here/build_images.sh" "$host_bin"
t1=$(ms)
echo "images built in $(((t1 - t0) / 1000)) s"

export TEXTOND_EDGE_PORT=$(free_port) TEXTOND_REPLICA_1_PORT=$(free_port) \
    TEXTOND_REPLICA_2_PORT=$(free_port)
edge=http://127.0.0.1:$TEXTOND_EDGE_PORT
r1=http://127.0.0.1:$TEXTOND_REPLICA_1_PORT
r2=http://127.0.0.1:$TEXTOND_REPLICA_2_PORT
compose up -d --no-build || fail "podman-compose up"
wait_for() { # URL [tries of 0.1 s]
    for _ in $(seq "${2:-600}"); do curl -sf -o /dev/null "$1" && return 0; sleep 0.1; done
    return 1
}
for u in "$r1/readyz" "$r2/readyz" "$edge/nginx-healthz"; do
    wait_for "$u" || fail "$u does not answer"
done
# Ready includes degraded (a replica serves what it holds while Redis is down), and
# podman-compose 1.0 starts the replicas without waiting for Redis's health: wait until both
# are connected to it.
# Read whole, then searched (`curl | grep -q` under pipefail can fail on curl's write error).
connected() { grep -q '"degraded": *false' <<<"$(curl -sf "$1/readyz")"; }
for u in "$r1" "$r2"; do
    for _ in $(seq 300); do connected "$u" && break; sleep 0.1; done
    connected "$u" || fail "$u is not connected to Redis: $(curl -s "$u/readyz")"
done
t2=$(ms)
echo "stack up and ready in $(((t2 - t1) / 1000)) s"

# An upload through the edge; every replica serves its tiles with the same bytes.
upload() { # URL FILE [analysis seed] -> prints the HTTP status, writes the body to $tmp/up.json
    curl -s -o "$tmp/up.json" -w '%{http_code}' -X POST -H 'Content-Type: image/png' \
        --data-binary "@$2" "$1/v1/textons?size=16&iterations=5&seed=${3:-0}"
}
[ "$(upload "$edge" "$exemplars/etr_sand01.png")" = 201 ] || fail "upload through the edge: $(cat "$tmp/up.json")"
id=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["id"])' "$tmp/up.json")
tile="/v1/textons/$id/tiles/0/5/-3.png?seed=11"
for u in "$r1" "$r2" "$edge"; do
    curl -sf -o "$tmp/tile-${u##*:}.png" "$u$tile" || fail "$u$tile"
done
cmp -s "$tmp/tile-$TEXTOND_REPLICA_1_PORT.png" "$tmp/tile-$TEXTOND_REPLICA_2_PORT.png" ||
    fail "the two replicas' tiles differ"
cmp -s "$tmp/tile-$TEXTOND_REPLICA_1_PORT.png" "$tmp/tile-$TEXTOND_EDGE_PORT.png" ||
    fail "the edge's tile differs from the replicas'"
echo "upload through the edge; the same tile bytes from both replicas and the edge"
# A splat and a mix through the edge, read 20 times from both replicas, deleted everywhere.
python3 "$root/tests/deploy/shared_objects_check.py" "$edge" "$r1" "$r2" --exemplars "$exemplars" ||
    fail "splats and mixes through the edge"

# kill -9 of replica 1's process (a crash, not an engine stop) under load through the edge.
c1=${project}_textond-1_1
pid=$(podman inspect -f '{{.State.Pid}}' "$c1")
restarts() { podman inspect -f '{{.RestartCount}}' "$c1"; }
before=$(restarts)
TEXTON=$id MODE=cold wrk -t 2 -c 16 -d 20s -s "$root/tests/load/tiles.lua" "$edge" |
    grep '^WRK' >"$tmp/wrk.out" &
wrk_pid=$!
(   # uploads beside the tile load, each a new texton (its analysis seed)
    for s in $(seq 1 12); do
        code=$(curl -s -o "$tmp/up-$s.json" -w '%{http_code}' -X POST -H 'Content-Type: image/png' \
            --data-binary "@$exemplars/etr_sand01.png" "$edge/v1/textons?size=16&iterations=5&seed=$s")
        echo "$s $code" >>"$tmp/uploads"
        sleep 1
    done
) &
up_pid=$!
sleep 6
kill -9 "$pid"
t3=$(ms)
wait "$wrk_pid" "$up_pid"
read -r _ requests rate p50 p99 socket_errors status_errors _ <"$tmp/wrk.out"
errors=$((socket_errors + status_errors))
echo "kill -9 under load: $requests tiles at $rate/s, p50 $p50 ms, p99 $p99 ms, $errors errors"
python3 -c "import sys; sys.exit(0 if $errors * 1000 < $requests else 1)" ||
    fail "$errors errors in $requests requests (0.1% allowed)"
wait_for "$r1/readyz" 600 || fail "replica 1 did not come back after kill -9"
t4=$(ms)
[ "$(restarts)" -gt "$before" ] || fail "replica 1 answers but was not restarted"
echo "replica 1 back $(((t4 - t3) / 1000)) s after kill -9 (restart: unless-stopped)"
answered=0
ids=("$id")
while read -r s code; do
    [ "$code" = 201 ] || continue
    answered=$((answered + 1))
    up=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["id"])' "$tmp/up-$s.json")
    ids+=("$up")
    for u in "$r1" "$r2"; do
        curl -sf -o /dev/null "$u/v1/textons/$up" || fail "upload $s ($up) answered 201 but $u has lost it"
    done
done <"$tmp/uploads"
[ "$answered" -gt 0 ] || fail "no upload answered 201 during the kill"
echo "$answered of $(wc -l <"$tmp/uploads") uploads during the kill answered 201; all on both replicas"
# The restarted replica is back on the edge's ring (once fail_timeout has passed): the textons
# that hash to it reach it again.
tiles_of() { curl -sf "$1/metrics" | awk '/^textond_tile_cache_requests_total/ {n += $2} END {print n + 0}'; }
# Polled, a new tile each round, rather than a sleep sized to fail_timeout on this machine.
back=""
for round in $(seq 60); do
    n1=$(tiles_of "$r1")
    for t in "${ids[@]}"; do
        curl -sf -o /dev/null "$edge/v1/textons/$t/tiles/0/77/$round.png" || fail "edge tile of $t"
    done
    if [ "$(tiles_of "$r1")" -gt "$n1" ]; then back=$round; break; fi
    sleep 0.5
done
[ -n "$back" ] || fail "the edge sends nothing to replica 1 30 s after its restart"
echo "the edge routes to replica 1 again (round $back): $(($(tiles_of "$r1") - n1)) of ${#ids[@]} textons' tiles"

# Redis stopped: the replicas go on serving what they hold and refuse uploads.
podman stop -t 5 "${project}_redis_1" >/dev/null
code=$(upload "$edge" "$exemplars/etr_floor01.png" 99)
[ "$code" = 503 ] || fail "upload with Redis stopped answered $code: $(cat "$tmp/up.json")"
for u in "$r1" "$r2"; do
    curl -sf -o /dev/null "$u/v1/textons/$id/tiles/0/40/40.png?seed=3" ||
        fail "$u no longer serves the texton it holds with Redis stopped"
    grep -q '"degraded": *true' <<<"$(curl -sf "$u/readyz")" || fail "$u/readyz is not degraded: $(curl -s "$u/readyz")"
done
curl -sf -o /dev/null "$edge$tile" || fail "the edge no longer serves a cached tile with Redis stopped"
echo "Redis stopped: uploads 503, tiles 200, /readyz degraded"
podman start "${project}_redis_1" >/dev/null
ok=""
for _ in $(seq 300); do
    if connected "$r1" && connected "$r2"; then ok=1; break; fi
    sleep 0.1
done
[ -n "$ok" ] || fail "the replicas stay degraded after Redis came back"
code=$(upload "$edge" "$exemplars/etr_floor01.png" 99)
[ "$code" = 201 ] || fail "upload after Redis came back answered $code: $(cat "$tmp/up.json")"
echo "Redis back: /readyz recovered and uploads 201"
echo "compose_test: passed"
