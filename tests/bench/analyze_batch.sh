#!/usr/bin/env bash
# `textond analyze` over many files in one process against its own analysis time, and against one
# process a file, in one run (the target: wall time a file at most 1.3x the analyses'
# own `timings_ms.total`). Files: the shared photos, then corpus crops to reach COUNT.
#
#   tests/bench/analyze_batch.sh [COUNT]      # default 24 files; BIN, JOBS (1) from the environment
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
BIN=${BIN:-$root/build/release/textond}
count=${1:-24}
jobs=${JOBS:-1}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
{ ls "$root"/../shared/data/exemplars/*.png; ls "$root"/tests/verdict/corpus/*.jpg; } |
    head -n "$count" > "$tmp/list"
n=$(wc -l < "$tmp/list")
ms() { date +%s%3N; }

t0=$(ms)
"$BIN" analyze --from-list "$tmp/list" --jobs "$jobs" -o "$tmp/batch/" > "$tmp/batch.jsonl" || true
t1=$(ms)
while read -r f; do "$BIN" analyze "$f" -o "$tmp/one.exr" > "$tmp/one.json" 2>/dev/null || true; done < "$tmp/list"
t2=$(ms)

/usr/bin/python3 - "$tmp/batch.jsonl" "$n" "$((t1 - t0))" "$((t2 - t1))" "$jobs" <<'PY'
import json, sys
lines = [json.loads(l) for l in open(sys.argv[1])]
n, batch_ms, single_ms, jobs = int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
ok = [l for l in lines if "error" not in l]
total = sum(l["timings_ms"]["total"] for l in ok)
print(f"{n} files ({len(ok)} analysed, {n - len(ok)} failed), --jobs {jobs}")
print("| run | wall ms | ms a file | / the analyses' own total |")
print("|---|---|---|---|")
print(f"| one process (`--from-list`) | {batch_ms} | {batch_ms / n:.0f} | {batch_ms / total:.2f}x |")
print(f"| a process a file | {single_ms} | {single_ms / n:.0f} | {single_ms / total:.2f}x |")
print(f"| the analyses' own `timings_ms.total`, summed | {total:.0f} | {total / n:.0f} | 1.00x |")
PY
