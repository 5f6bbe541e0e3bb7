#!/usr/bin/env bash
# clang-tidy with the repository's .clang-tidy over every source file of core/, render/, server/
# and api/ that the build compiles (issue 15: CI checks style). Findings are errors
# (WarningsAsErrors: '*'). About 5 minutes on 2 cores.
#   tests/style/tidy_check.sh BUILD_DIR [FILE...]   # FILEs: only those (relative to the root)
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:?usage: tidy_check.sh BUILD_DIR [FILE...]}
shift
cd "$root"
tidy=$(command -v clang-tidy || command -v clang-tidy-14 || true)
[ -n "$tidy" ] || { echo "tidy_check: clang-tidy is not installed" >&2; exit 1; }
[ -f "$build/compile_commands.json" ] || { echo "tidy_check: no $build/compile_commands.json" >&2; exit 1; }
if [ $# -gt 0 ]; then
    files=("$@")
else
    mapfile -t files < <(python3 - "$build/compile_commands.json" "$root" <<'PY'
import json, os, sys
root = os.path.realpath(sys.argv[2])
seen = set()
for e in json.load(open(sys.argv[1])):
    f = os.path.realpath(os.path.join(e["directory"], e["file"]))
    rel = os.path.relpath(f, root)
    if rel.split(os.sep)[0] in ("core", "render", "server", "api") and "node_modules" not in rel:
        seen.add(rel)
print("\n".join(sorted(seen)))
PY
)
fi
log=$(mktemp)
trap 'rm -f "$log"' EXIT
# GCC's vectorisation hints (#pragma GCC ivdep) are unknown to clang: not a finding.
if ! printf '%s\n' "${files[@]}" |
    xargs -P "$(nproc)" -n 4 "$tidy" -p "$build" --quiet --extra-arg=-Wno-unknown-pragmas \
        >"$log" 2>&1; then
    grep -E "(warning|error):" "$log" | sort -u
    echo "tidy_check: clang-tidy found the above in ${#files[@]} files" >&2
    exit 1
fi
echo "tidy_check: ${#files[@]} files clean"
