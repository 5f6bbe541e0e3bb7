# shellcheck shell=bash
# Sourced by the load scripts. server_url LOG [TRIES]: the URL a `textond serve --port 0` writes
# to LOG once it listens ("listening on http://HOST:PORT/"), waiting up to TRIES tenths of a
# second (default 100); nothing and status 1 if it never does.
server_url() {
    local log=$1 tries=${2:-100} url=""
    for _ in $(seq "$tries"); do
        url=$(sed -n 's/.*listening on \(http:[^ ]*\)\/$/\1/p' "$log" 2>/dev/null)
        if [ -n "$url" ]; then
            echo "$url"
            return 0
        fi
        sleep 0.1
    done
    return 1
}
