#!/usr/bin/env bash
# The GPU's targets in one call on a GPU host: the GPU tests, `bench render` for cpu and the GL
# backend (and the GL backend with the host-listed point kernel, for the kernel's share), then
# cold 256x256 PNG tiles by level over HTTP for cpu, the GL backend and auto (wrk, every request a
# distinct tile, CPU-ms a tile from the server's /proc/PID/stat), and the GL backend at level 0
# by --gpu-lanes. Prints one table: each target, what was measured and whether it holds. Within
# 6 minutes on the device machine.
#
# On the device machine (after ../shared/tools/device-bundle.sh with EXTRA_BINS="wrk"):
#   source .device/env.sh && tests/gpu/device_check.sh build/release
# Here, a dry run of the script itself on llvmpipe (its figures mean nothing):
#   GPU=osmesa LEVELS="0 2" DURATION=2s MAX_SIDE=256 tests/gpu/device_check.sh build/release
# Environment: GPU (egl), LEVELS (-2 0 2 4 8 16 24), DURATION (4s a row), CONNECTIONS (256),
# THREADS (8), MAX_SIDE (3840), LANES (1 2 4 6: --gpu-lanes at level 0; empty: none), OUT (a
# folder for the raw outputs; a temporary one by default).
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
build=${1:-build/release}
bin=$build/textond
GPU=${GPU:-egl}
LEVELS=${LEVELS:-"-2 0 2 4 8 16 24"}
DURATION=${DURATION:-4s}
CONNECTIONS=${CONNECTIONS:-256}
THREADS=${THREADS:-8}
MAX_SIDE=${MAX_SIDE:-3840}
LANES=${LANES-"1 2 4 6"}
OUT=${OUT:-$(mktemp -d)}
mkdir -p "$OUT"
exemplars=$root/../shared/data/exemplars
[ -d "$exemplars" ] || exemplars=$root/shared/data/exemplars
[ -x "$bin" ] || { echo "device_check: no $bin" >&2; exit 2; }
command -v wrk >/dev/null || { echo "device_check: wrk missing (EXTRA_BINS=wrk in the bundle)" >&2; exit 2; }
start=$(date +%s)

echo "== GPU tests"
"$build/tests/render_test" --gtest_filter='EglBackend.*:BackendFactory.*' >"$OUT/gpu_tests.txt" 2>&1
echo "gpu_tests_rc $?" >"$OUT/results.txt"
grep -E '^\[  (PASSED|FAILED|SKIPPED) ' "$OUT/gpu_tests.txt" | head -20

echo "== bench render (cpu, $GPU; then $GPU with the host-listed kernel)"
"$bin" bench render --exemplars "$exemplars" --backends "cpu,$GPU" --repeat 5 \
    --max-side "$MAX_SIDE" >"$OUT/bench.txt" 2>&1
"$bin" bench render --exemplars "$exemplars" --backends "$GPU" --gl-points listed --repeat 3 \
    --max-side "$MAX_SIDE" >"$OUT/bench_listed.txt" 2>&1
grep -E '^(cpu|egl|osmesa):' "$OUT/bench.txt" "$OUT/bench_listed.txt"

echo "== cold tiles by level (wrk -t $THREADS -c $CONNECTIONS -d $DURATION)"
hz=$(getconf CLK_TCK)
# tiles LABEL LEVELS SERVE_ARGS...: one server, a wrk run a level, a line each in results.txt.
tiles() {
    local label=$1 levels=$2 data pid url picked id level line c0 c1 cpu_ms
    shift 2
    data=$(mktemp -d)
    "$bin" serve --port 0 --data "$data" "$@" --no-access-log --log-level warn \
        >"$OUT/serve-$label.log" 2>&1 &
    pid=$!
    url=""
    for _ in $(seq 600); do
        url=$(sed -n 's/.*listening on \(http:[^ ]*\)\/$/\1/p' "$OUT/serve-$label.log")
        [ -n "$url" ] && break
        sleep 0.1
    done
    if [ -z "$url" ]; then
        echo "device_check: textond $* did not start" >&2
        kill "$pid" 2>/dev/null
        return
    fi
    picked=$(curl -sf "$url/metrics" |
        grep -E '^textond_(backend_info|backend_calibration_ms|gpu_lanes)' | tr '\n' ' ')
    echo "$label: $picked"
    id=$(curl -sf -X POST -H 'Content-Type: image/png' --data-binary @"$exemplars/etr_sand01.png" \
        "$url/v1/textons" | sed -n 's/.*"id": "\([0-9a-f]\{64\}\)".*/\1/p')
    for level in $levels; do
        c0=$(awk '{print $14 + $15}' "/proc/$pid/stat")
        line=$(TEXTON=$id MODE=cold LEVEL=$level SEED=$RANDOM wrk -t "$THREADS" -c "$CONNECTIONS" \
            -d "$DURATION" --timeout 10s -s "$root/tests/load/tiles.lua" "$url" | grep '^WRK')
        c1=$(awk '{print $14 + $15}' "/proc/$pid/stat")
        # WRK requests rate p50 p99 socket_errors status_errors bytes
        read -r _ n rate p50 p99 se st _ <<<"$line"
        cpu_ms=$(awk -v c=$((c1 - c0)) -v hz="$hz" -v n="${n:-0}" \
            'BEGIN {printf "%.2f", (n > 0 ? c * 1000 / hz / n : 0)}')
        echo "tiles $label $level ${rate:-0} ${p99:-0} $((${se:-0} + ${st:-0})) $cpu_ms" |
            tee -a "$OUT/results.txt"
    done
    kill "$pid" 2>/dev/null
    wait "$pid" 2>/dev/null
    rm -rf "$data"
}
for backend in cpu "$GPU" auto; do
    tiles "$backend" "$LEVELS" --backend "$backend"
done
# The lanes' fence wait: polled and asleep (the default, above) against the driver's own wait,
# which spins on NVIDIA (render/gl/fence_wait.h): the CPU-ms a tile of the two.
TEXTOND_GL_WAIT=driver tiles "$GPU-driver-wait" 0 --backend "$GPU"
# The lane count is chosen on these level-0 runs; the rows above (the default) report it.
for lanes in $LANES; do
    tiles "$GPU-lanes$lanes" 0 --backend "$GPU" --gpu-lanes "$lanes"
done

echo "== targets ($(($(date +%s) - start)) s)"
python3 "$here/device_targets.py" "$GPU" "$OUT"
