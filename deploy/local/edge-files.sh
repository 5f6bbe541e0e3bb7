#!/usr/bin/env bash
# The edge of deploy/base/nginx made local, for run-edge.sh and the load tests: writes into DIR
# edge.conf (local paths, LISTEN as its address), settings.conf, upstream-servers.conf (one
# server a HOST:PORT) and an nginx.conf that includes them. Environment: ERROR_LOG (DIR/error.log),
# WORKER_PROCESSES (auto), WORKER_CONNECTIONS (4096), LOAD_TEST=1: the per-address limits raised
# (limit_conn to WORKER_CONNECTIONS, limit_req out of reach), as every client of a load test is
# 127.0.0.1; they are a policy against one hostile address, not the capacity measured.
#   deploy/local/edge-files.sh DIR LISTEN HOST:PORT...
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
dir=$1 listen=$2
shift 2
mkdir -p "$dir/cache"
# nginx workers drop root; they write the tile cache and buffered bodies there.
chmod 0755 "$dir"
chmod 0777 "$dir/cache"
sed -e "s|/etc/nginx/textond/|$dir/|; s|/var/cache/nginx/|$dir/cache/|; s|listen 8080 |listen $listen |" \
    "$root/deploy/base/nginx/edge.conf" >"$dir/edge.conf"
if [ "${LOAD_TEST:-0}" = 1 ]; then
    sed -i -e "s|limit_conn textond_conn 256;|limit_conn textond_conn ${WORKER_CONNECTIONS:-4096};|" \
        -e "s|rate=500r/s;|rate=1000000r/s;|" "$dir/edge.conf"
fi
cp "$root/deploy/base/nginx/settings.conf" "$dir/settings.conf"
# max_fails=0, as deploy/base/nginx/upstream-servers.conf says why.
for upstream in "$@"; do echo "server $upstream max_fails=0;"; done >"$dir/upstream-servers.conf"
cat >"$dir/nginx.conf" <<CONF
pid $dir/nginx.pid;
error_log ${ERROR_LOG:-$dir/error.log} warn;
worker_processes ${WORKER_PROCESSES:-auto};
worker_rlimit_nofile 65536;
events { worker_connections ${WORKER_CONNECTIONS:-4096}; }
http {
    access_log off;
    client_body_temp_path $dir/body;
    proxy_temp_path $dir/proxy;
    include $dir/settings.conf;
    include $dir/edge.conf;
}
CONF
