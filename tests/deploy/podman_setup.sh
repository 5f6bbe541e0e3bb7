#!/usr/bin/env bash
# Podman on a Debian 12 machine that reaches Debian's archive but no image registry, as root
# without CAP_SYS_RESOURCE (these CI machines). Idempotent; run by the container tests.
#   - packages: podman, runc (crun refuses the hybrid cgroup layout here), mmdebstrap,
#     podman-compose, CNI's dnsname plugin so that compose services find each other by name,
#     catatonit for the pods of `podman kube play`;
#   - /etc/containers/containers.conf.d/textond.conf: runc with cgroupfs, and rlimits root may set here (podman's
#     defaults ask for more and fail with "setrlimit RLIMIT_NOFILE: Operation not permitted");
#   - docker.io/library/debian:bookworm-slim, made from Debian's packages by mmdebstrap (about
#     30 s) when it is not in podman's store, so `FROM debian:bookworm-slim` builds with
#     --pull=never.
set -euo pipefail
need=()
for p in podman runc mmdebstrap podman-compose uidmap catatonit \
    golang-github-containernetworking-plugin-dnsname; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || need+=("$p")
done
if [ ${#need[@]} -ne 0 ]; then
    echo "podman_setup: installing ${need[*]}" >&2
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
fi
conf=/etc/containers/containers.conf.d/textond.conf
if [ ! -s "$conf" ]; then
    mkdir -p "$(dirname "$conf")"
    cat > "$conf" <<'CONF'
# textond: tests/deploy/podman_setup.sh
[containers]
default_ulimits = ["nofile=4096:4096", "nproc=4096:4096"]

[engine]
runtime = "runc"
cgroup_manager = "cgroupfs"
events_logger = "file"
CONF
fi
if ! podman image exists docker.io/library/debian:bookworm-slim; then
    tmp=$(mktemp -d)
    echo "podman_setup: making debian:bookworm-slim with mmdebstrap" >&2
    mmdebstrap --quiet --variant=minbase --format=tar bookworm "$tmp/base.tar"
    # Under the official image's name, so that docker/Dockerfile builds unchanged; on a machine
    # that can pull, the official image is used instead.
    podman import --quiet "$tmp/base.tar" docker.io/library/debian:bookworm-slim >/dev/null
    rm -rf "$tmp"
fi
