#!/usr/bin/env bash
# The image for real: docker/Dockerfile built by podman and run as an operator would run it, with a
# read-only root filesystem and the data volume, against the host build in one run:
#   - /healthz, then an upload and a tile through the container: the same texton id, the same
#     tile bytes and the same ETag as the host build's server;
#   - the image's HEALTHCHECK (kept by --format docker) passes;
#   - SIGTERM (podman stop) lets an upload in flight finish with its 201;
#   - `textond --help` runs inside, and OSMesa renders there (--backend osmesa);
#   - the image's size and its layers, printed.
# Set-up (packages, podman's configuration, the base image) is tests/deploy/podman_setup.sh.
# The image is built by tests/deploy/build_images.sh (a proxy's CA: BUILD_CA=/path/to/ca.pem, else
# NODE_EXTRA_CA_CERTS, passed as the build secret `build_ca` of docker/Dockerfile).
#
#   tests/deploy/container_test.sh HOST_TEXTOND EXEMPLAR_DIR
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
host_bin=$(realpath "$1")
exemplars=$(realpath "$2")
bash "$root/tests/deploy/podman_setup.sh"

tag=localhost/textond:local # tests/deploy/build_images.sh
name=textond-container-test-$$
volume=textond-container-test-$$
tmp=$(mktemp -d)
host_pid=""
cleanup() {
    podman rm -f -t 0 "$name" >/dev/null 2>&1 || true
    podman volume rm -f "$volume" >/dev/null 2>&1 || true
    if [ -n "$host_pid" ]; then
        kill "$host_pid" 2>/dev/null || true
        wait "$host_pid" 2>/dev/null || true
    fi
    rm -rf "$tmp"
}
trap cleanup EXIT
fail() {
    echo "FAIL: $*" >&2
    exit 1
}
ms() { date +%s%3N; }

# The host build's server first: its build id names the commit the image must be built at for
# ETags to match (the id names the commit and OpenImageIO's version).
free_port() {
    python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}
host_port=$(free_port)
"$host_bin" serve --port "$host_port" --data "$tmp/host" --backend cpu --log-level warn >/dev/null &
host_pid=$!
host="http://127.0.0.1:$host_port"
for _ in $(seq 300); do curl -sf "$host/healthz" >/dev/null && break; sleep 0.1; done
curl -sf "$host/healthz" >/dev/null || fail "the host build's server does not answer"
build=$(curl -sf "$host/healthz" | python3 -c 'import json,sys; print(json.load(sys.stdin)["build"])')
t0=$(ms)
bash "$root/tests/deploy/build_images.sh" "$host_bin" # the commit from the host build's id
t1=$(ms)
echo "image built in $(((t1 - t0) / 1000)) s"

port=$(free_port)
podman volume create "$volume" >/dev/null
podman run -d --name "$name" --network host --read-only --tmpfs /tmp \
    -v "$volume:/var/lib/textond" -e TEXTOND_PORT=$port -e TEXTOND_BACKEND=cpu \
    -e TEXTOND_SLOW_POINT=analysis=3 "$tag" >/dev/null
box="http://127.0.0.1:$port"
for _ in $(seq 300); do curl -sf "$box/healthz" >/dev/null && break; sleep 0.1; done
t2=$(ms)
curl -sf "$box/healthz" >/dev/null || fail "the container does not answer /healthz"
echo "container healthy $((t2 - t1)) ms after the build"
[ "$(curl -sf "$box/healthz" | python3 -c 'import json,sys; print(json.load(sys.stdin)["build"])')" = "$build" ] ||
    fail "the image's build id differs from the host build's: $build"

# An upload and a tile, through both.
upload() { curl -sf -X POST --data-binary "@$exemplars/etr_sand01.png" -H 'Content-Type: image/png' \
    "$1/v1/textons?size=16&iterations=5" | python3 -c 'import json,sys; print(json.load(sys.stdin)["id"])'; }
id_box=$(upload "$box")
id_host=$(upload "$host")
[ "$id_box" = "$id_host" ] || fail "texton ids differ: container $id_box, host $id_host"
tile="/v1/textons/$id_box/tiles/0/3/-2.png?seed=7"
curl -sf -D "$tmp/box.h" -o "$tmp/box.png" "$box$tile"
curl -sf -D "$tmp/host.h" -o "$tmp/host.png" "$host$tile"
cmp -s "$tmp/box.png" "$tmp/host.png" || fail "the container's tile bytes differ from the host's"
etag() { grep -i '^etag:' "$1" | tr -d '\r' | cut -d' ' -f2; }
[ "$(etag "$tmp/box.h")" = "$(etag "$tmp/host.h")" ] ||
    fail "ETags differ: $(etag "$tmp/box.h") against $(etag "$tmp/host.h")"
echo "upload and tile: the host build's id, bytes and ETag"

# The image's own health check, as the engine runs it.
podman healthcheck run "$name" || fail "the image's HEALTHCHECK fails"
echo "HEALTHCHECK passes"

# OSMesa inside the image: a tile rendered by llvmpipe (a second container on the same volume).
podman run --rm --network host --read-only --tmpfs /tmp -v "$volume:/var/lib/textond" "$tag" \
    render "/var/lib/textond/textons/$id_box.exr" --backend osmesa --w 64 --h 64 \
    -o /tmp/osmesa.png >/dev/null 2>"$tmp/osmesa.err" ||
    fail "render --backend osmesa inside the image: $(tail -3 "$tmp/osmesa.err")"
echo "OSMesa renders inside the image"
podman run --rm "$tag" --help >"$tmp/help" || fail "textond --help does not run in the image"
grep -q "serve" "$tmp/help" || fail "textond --help prints no commands"

# SIGTERM with an upload in flight: it finishes (201) before the container exits.
slow_upload() {
    curl -s -o "$tmp/slow.json" -w '%{http_code}' -X POST -H 'Content-Type: image/png' \
        --data-binary "@$exemplars/mypaint_HR_Cork.png" "$box/v1/textons?size=64&iterations=150" \
        >"$tmp/slow.status"
}
# Read whole, then searched: `curl | grep -q` under pipefail fails when grep has its line and exits
# before curl has written the rest (curl's write error, status 23).
running() { grep -q '^textond_analysis_running 1' <<<"$(curl -sf "$box/metrics")"; }
# Analyses are held at 3x their estimate (TEXTOND_SLOW_POINT above), so the upload is still running
# when it is seen, on a machine of any speed; the poll's limit only ends a broken run. An upload
# answered before it was seen running is said (status and body); one refused as busy (503 with
# Retry-After) is sent again, as a client would.
seen=0
for attempt in 1 2 3; do
    slow_upload &
    slow=$!
    for _ in $(seq 1200); do # until the analysis runs, or the upload has its answer
        running && { seen=1; break; }
        kill -0 "$slow" 2>/dev/null || break
        sleep 0.05
    done
    [ "$seen" = 1 ] && break
    wait "$slow" || true
    echo "upload $attempt answered $(cat "$tmp/slow.status") before it was seen running: $(head -c 300 "$tmp/slow.json")"
    [ "$(cat "$tmp/slow.status")" = 503 ] || break
    sleep 1
done
[ "$seen" = 1 ] || fail "the upload to stop the container under was not seen running"
podman stop -t 60 "$name" >/dev/null
wait "$slow" || true
[ "$(cat "$tmp/slow.status")" = 201 ] ||
    fail "the upload in flight at SIGTERM answered $(cat "$tmp/slow.status"), not 201"
echo "SIGTERM finished the upload in flight"

size=$(podman image inspect "$tag" --format '{{.Size}}')
echo "image size: $((size / 1000000)) MB"
podman history --format '{{.Size}}\t{{.CreatedBy}}' "$tag" | cut -c1-150
echo "container_test: passed"
