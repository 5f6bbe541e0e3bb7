#!/usr/bin/env bash
# Builds the fuzz preset (clang, libFuzzer, address + UB sanitizers), makes the seed corpus and
# runs decode_analyze_fuzzer for SECONDS (default 60, the CI smoke). Prints executions and
# coverage; a crash leaves its input in build/fuzz/crashes/ and fails the script. Make every
# crash a regression test in tests/fuzz/regressions/ (replayed by this script first).
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
set +e
"$fuzzer" build/fuzz/work -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=20 \
    -artifact_prefix=build/fuzz/crashes/ -print_final_stats=1 >build/fuzz/last-run.log 2>&1
status=$?
set -e
grep -E "^#[0-9]+ +DONE|stat::number_of_executed_units|stat::peak_rss_mb|cov:" build/fuzz/last-run.log | tail -n 4
if [ $status -ne 0 ]; then
    echo "fuzz: the fuzzer failed (status $status); inputs in build/fuzz/crashes/:" >&2
    ls build/fuzz/crashes >&2
    grep -m 20 -E "ERROR|SUMMARY|runtime error" build/fuzz/last-run.log >&2 || true
    exit 1
fi
echo "fuzz: ${seconds}s clean"
