#!/usr/bin/env bash
# clang-tidy with the repository's .clang-tidy over every source file of core/, render/, server/
# and api/ that the build compiles (issue 15: CI checks style). Findings are errors
# (WarningsAsErrors: '*'). About 5 minutes on 2 cores.
#   tests/style/tidy_check.sh BUILD_DIR [FILE...]   # FILEs: only those (relative to the root)
set -uo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:?usage: tidy_check.sh BUILD_DIR [FILE...]}
shift
cd "$root" || exit 1
tidy=$(command -v clang-tidy || command -v clang-tidy-14 || true)
[ -n "$tidy" ] || { echo "tidy_check: clang-tidy is not installed" >&2; exit 1; }
[ -f "$build/compile_commands.json" ] || { echo "tidy_check: no $build/compile_commands.json" >&2; exit 1; }
if [ $# -gt 0 ]; then
    files=("$@")
else
    list=$(/usr/bin/python3 - "$build/compile_commands.json" "$root" <<'PY'
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
) || { echo "tidy_check: cannot read $build/compile_commands.json" >&2; exit 1; }
    mapfile -t files <<<"$list"
fi
# Fewer than the tree holds means the list is wrong, not that the tree is clean.
[ "${#files[@]}" -gt 0 ] && [ -n "${files[0]}" ] || { echo "tidy_check: no files to check" >&2; exit 1; }
log=$(mktemp)
trap 'rm -f "$log"' EXIT
# GCC's vectorisation hints (#pragma GCC ivdep) are unknown to clang: not a finding.
printf '%s\n' "${files[@]}" |
    xargs -P "$(nproc)" -n 4 "$tidy" -p "$build" --quiet --extra-arg=-Wno-unknown-pragmas \
        >"$log" 2>&1
rc=$?
if [ "$rc" -ne 0 ]; then
    # 123: some run exited non-zero (findings); 124/125: clang-tidy crashed or was killed.
    grep -E "(warning|error):" "$log" | sort -u || tail -50 "$log"
    [ "$rc" -ge 124 ] && echo "tidy_check: clang-tidy crashed (xargs status $rc)" >&2
    echo "tidy_check: clang-tidy failed on ${#files[@]} files (xargs status $rc)" >&2
    exit 1
fi
echo "tidy_check: ${#files[@]} files clean"
