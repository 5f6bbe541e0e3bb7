#!/usr/bin/env bash
# Builds the fuzz preset (clang, libFuzzer, address + UB sanitizers), makes the seed corpus and
# runs three targets at once, each for SECONDS of CPU (default 60, the CI smoke):
# decode_analyze_fuzzer, request_fuzzer (api/ parsers, mix fields, surface parameters, and the
# framing property of the connection loop) and render_fuzzer (what the parsers accept, rendered:
# a tiny mix, surface points, a mesh preview). Prints executions and coverage; a crash leaves its
# input in build/fuzz/crashes/ and fails the script. Make every crash a regression test in
# tests/fuzz/regressions/ (replayed by this script first).
#
#   tests/fuzz/run_fuzz.sh [SECONDS]
set -euo pipefail
seconds=${1:-60}
root=$(cd "$(dirname "$0")/../.." && pwd)
cd "$root"
need=(clang libclang-rt-14-dev libomp-14-dev openimageio-tools python3)
missing=()
for p in "${need[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -ne 0 ]; then
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
exemplars=$root/../shared/data/exemplars
[ -d "$exemplars" ] || exemplars=$root/shared/data/exemplars

cmake --preset fuzz >/dev/null
cmake --build build/fuzz -j "$(nproc)" >/dev/null
fuzzer=build/fuzz/decode_analyze_fuzzer
corpus=build/fuzz/corpus
[ -d "$corpus" ] && [ -n "$(ls -A "$corpus")" ] || /usr/bin/python3 tests/fuzz/make_corpus.py "$exemplars" "$corpus"
mkdir -p build/fuzz/crashes build/fuzz/work

# Every past crash first: each must now run clean.
if compgen -G "tests/fuzz/regressions/*" >/dev/null; then
    "$fuzzer" tests/fuzz/regressions/* 2>&1 | tail -n 2
fi
# The corpus is copied so the run's new inputs do not grow the seed directory.
cp -n "$corpus"/* build/fuzz/work/ 2>/dev/null || true
# The request parsers: seeds are a few real paths and queries (selector byte first).
rcorpus=build/fuzz/request-work
mkdir -p "$rcorpus"
printf '\0000/3/-7/png|seed=42&mni=30' >"$rcorpus/tile"
printf '\003|u=%064d&v=%064d&dx=1e308&dy=1e308&levels=2' 0 0 >"$rcorpus/mix"
printf '\0022/exr|x=-500&y=200&w=1920&h=1080&z=1' >"$rcorpus/region"
printf '\004mesh|width=512&height=512&eye=0,0,3&target=0,0,0&fov=35' >"$rcorpus/mesh"
printf '\005|size=64&order=3&iterations=50&periodic=true' >"$rcorpus/analysis"
# Framing streams (selector 6): the fuzzer grows them from a few bytes of choices.
printf '\006\003\001\004\002\000\001\007\001\003\005\002\001' >"$rcorpus/framing"
printf '\006\007\000\001\005\001\003\002\004\001\006\000\002\001\001\004' >"$rcorpus/framing2"
# Parsed values into small renders: seeds in tests/fuzz/seeds/render (selector byte first).
wcorpus=build/fuzz/render-work
mkdir -p "$wcorpus"
cp -n tests/fuzz/seeds/render/* "$wcorpus"/

# The three targets run at once, each single-threaded. Each is given the CPU time it would have
# had alone for SECONDS (SECONDS x targets / cores of wall time when the targets outnumber the
# cores): the same executions and coverage per CPU second, in less wall time.
cores=$(nproc) # before OMP_NUM_THREADS below, which nproc would report instead
# One thread each (the analysis's OpenMP FFTs included): three targets already share the cores.
export OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE
targets=(decode_analyze_fuzzer:build/fuzz/work request_fuzzer:"$rcorpus" render_fuzzer:"$wcorpus")
wall=$seconds
[ "$cores" -lt ${#targets[@]} ] && wall=$(((seconds * ${#targets[@]} + cores - 1) / cores))
pids=()
trap 'kill "${pids[@]}" 2>/dev/null || true' EXIT # none left running if the script stops early
for t in "${targets[@]}"; do
    name=${t%%:*}
    "build/fuzz/$name" "${t#*:}" -max_total_time="$wall" -rss_limit_mb=2048 -timeout=20 \
        -artifact_prefix=build/fuzz/crashes/ -print_final_stats=1 \
        >"build/fuzz/last-${name%_fuzzer}-run.log" 2>&1 &
    pids+=($!)
done
failed=0
for i in "${!targets[@]}"; do
    name=${targets[$i]%%:*}
    log=build/fuzz/last-${name%_fuzzer}-run.log
    set +e
    wait "${pids[$i]}"
    status=$?
    set -e
    echo "$name ($wall s of wall time):"
    grep -E "stat::number_of_executed_units|stat::peak_rss_mb|cov:" "$log" | tail -n 3 || true
    if [ $status -ne 0 ]; then
        echo "fuzz: $name failed (status $status); inputs in build/fuzz/crashes/:" >&2
        ls build/fuzz/crashes >&2
        grep -m 20 -E "ERROR|SUMMARY|runtime error|deadly" "$log" >&2 || true
        failed=1
    fi
done
[ "$failed" = 0 ] || exit 1
echo "fuzz: ${seconds}s clean"
