#!/usr/bin/env bash
# Copies the libraries a binary loads into DEST at the same paths, for an image that holds only
# those: its ldd closure, and what it opens at run time with its own closure: OSMesa (llvmpipe), glvnd's EGL
# and Mesa's EGL vendor with the software DRI driver, and glvnd's vendor file (under the NVIDIA
# container runtime the driver's vendor library and file are mounted in beside them). Run where
# the runtime packages are installed (docker/Dockerfile's build stage).
#   docker/runtime_closure.sh BINARY DEST
set -euo pipefail
bin=$1
dest=$2
arch=$(gcc -print-multiarch)
lib=/usr/lib/$arch
opened=("$lib/libOSMesa.so.8" "$lib/libEGL.so.1" "$lib/libEGL_mesa.so.0" "$lib/dri/swrast_dri.so"
    "$lib/dri/kms_swrast_dri.so")
declare -A seen=()
copy() { # the file and, for a symbolic link, what it names, at the same paths
    local f=$1
    while :; do
        # Through its directory's real path: /lib is a link to /usr/lib, which a copy must not
        # replace with a directory in the image.
        f=$(cd "$(dirname "$f")" && pwd -P)/$(basename "$f")
        [ -n "${seen[$f]:-}" ] && return 0
        seen[$f]=1
        mkdir -p "$dest$(dirname "$f")"
        cp -P "$f" "$dest$f"
        [ -L "$f" ] || return 0
        local to
        to=$(readlink "$f")
        [[ $to = /* ]] || to=$(dirname "$f")/$to
        f=$to
    done
}
# The binary's libraries (not the binary: the Dockerfile places it), then the opened ones.
for f in "$bin" "${opened[@]}"; do
    [ "$f" = "$bin" ] || copy "$f"
    if ldd "$f" | grep -q "not found"; then
        echo "runtime_closure: $f needs what is not installed:" >&2
        ldd "$f" | grep "not found" >&2
        exit 1
    fi
    while read -r dep; do copy "$dep"; done < <(ldd "$f" | awk '$2 == "=>" && $3 ~ /^\// {print $3}
        $1 ~ /^\/.*ld-linux/ {print $1}')
done
for f in /usr/share/glvnd/egl_vendor.d/50_mesa.json; do copy "$f"; done
echo "runtime_closure: ${#seen[@]} files, $(du -sh "$dest" | cut -f1)" >&2
