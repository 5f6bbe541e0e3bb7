#!/usr/bin/env bash
# One machine, as it should face a network: textond on 127.0.0.1:8081 behind nginx on :8080
# with the edge config of deploy/base/nginx/edge.conf (slow clients, header and body limits,
# per-address connection and request limits, the tile cache). `make run-edge`; Ctrl-C stops both.
#   deploy/local/run-edge.sh [PUBLIC_PORT] [-- textond serve options]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
port=${1:-8080}
[ "${2:-}" = "--" ] && shift 2 || shift $(($# > 0 ? 1 : 0))
bin=$root/build/release/textond
[ -x "$bin" ] || { echo "build first: make build" >&2; exit 1; }
[ -x /usr/sbin/nginx ] || { echo "nginx is missing: apt-get install nginx-light" >&2; exit 1; }
tmp=$(mktemp -d)
cleanup() {
    [ -f "$tmp/nginx.pid" ] && /usr/sbin/nginx -p "$tmp" -c "$tmp/nginx.conf" -s quit 2>/dev/null
    [ -n "${pid:-}" ] && kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null
    rm -rf "$tmp"
}
trap cleanup EXIT INT TERM
ERROR_LOG=stderr "$root/deploy/local/edge-files.sh" "$tmp" "$port" 127.0.0.1:8081
"$bin" serve --host 127.0.0.1 --port 8081 --public-url "http://127.0.0.1:$port" "$@" &
pid=$!
/usr/sbin/nginx -p "$tmp" -c "$tmp/nginx.conf"
echo "edge listening on http://127.0.0.1:$port/ (textond on 127.0.0.1:8081)"
wait "$pid"
