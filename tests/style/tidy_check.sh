#!/usr/bin/env bash
# clang-tidy with the repository's .clang-tidy over every source file of core/, render/, server/
# and api/ that the build compiles. Findings are errors (WarningsAsErrors: '*').
# A file that passed is not checked again until its translation unit (the file, any header it
# includes, its flags), a .clang-tidy or clang-tidy itself changes: BUILD_DIR/tidy-cache keeps
# the keys (tests/style/tidy_changed.py). After an edit, the files it reaches plus half a minute
# to preprocess the tree.
# clang-tidy 22 (Debian 12's security archive): unlike 14 it does not run the AST checks over
# system headers, which were most of 14's time (performance-unnecessary-value-param alone spent
# 12 s a file in OpenImageIO's headers). Its static analyzer runs in shallow mode (fewer nodes and
# less inlining a function), as 22's deep mode took 58 s on api/requests.cpp against 14's 4 s.
# GCC's own include directory comes last, for omp.h (clang 22 ships none without libomp-22-dev).
#   tests/style/tidy_check.sh BUILD_DIR [FILE...]   # FILEs: only those (relative to the root)
#   TIDY_FULL=1 tests/style/tidy_check.sh BUILD_DIR # every file, cache or not
set -uo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:?usage: tidy_check.sh BUILD_DIR [FILE...]}
shift
cd "$root" || exit 1
tidy=$(command -v clang-tidy-22 || true)
[ -n "$tidy" ] || { echo "tidy_check: clang-tidy-22 is not installed (docker/install-deps.sh)" >&2; exit 1; }
# GCC's vectorisation hints (#pragma GCC ivdep) are unknown to clang: not a finding.
# std::stable_sort in GCC 12's libstdc++ calls get_temporary_buffer, which clang 22 finds
# deprecated (C++17) inside that system header: not ours to change.
tidy_args="--extra-arg=-Wno-unknown-pragmas --extra-arg=-Wno-deprecated-declarations \
--extra-arg=-Xclang --extra-arg=-analyzer-config --extra-arg=-Xclang --extra-arg=mode=shallow \
--extra-arg=-idirafter$(gcc -print-file-name=include)"
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
total=${#files[@]}
cache="$build/tidy-cache"
mkdir -p "$cache"
[ "${TIDY_FULL:-0}" = 1 ] && rm -f "$cache"/*
todo=$(TIDY_ARGS=$tidy_args /usr/bin/python3 "$root/tests/style/tidy_changed.py" \
       "$build/compile_commands.json" "$root" "$cache" "$tidy" "${files[@]}") || { echo "tidy_check: cannot key the files" >&2; exit 1; }
if [ -z "$todo" ]; then
    echo "tidy_check: $total files clean (all unchanged since their last clean pass)"
    exit 0
fi
log=$(mktemp)
trap 'rm -f "$log"' EXIT
# One file a run, so that each clean one leaves its key.
export tidy build cache tidy_args
printf '%s\n' "$todo" |
    xargs -P "$(nproc)" -L 1 bash -c '
        "$tidy" -p "$build" --quiet $tidy_args "$0" || exit 1
        printf "%s\n" "$1" > "$cache/$(printf "%s" "$0" | sha256sum | cut -c1-32)"' \
        >"$log" 2>&1
rc=$?
files=()
mapfile -t files < <(printf '%s\n' "$todo" | cut -d' ' -f1)
if [ "$rc" -ne 0 ]; then
    # 123: some run exited non-zero (findings); 124/125: clang-tidy crashed or was killed.
    grep -E "(warning|error):" "$log" | sort -u || tail -50 "$log"
    [ "$rc" -ge 124 ] && echo "tidy_check: clang-tidy crashed (xargs status $rc)" >&2
    echo "tidy_check: clang-tidy failed on ${#files[@]} files (xargs status $rc)" >&2
    exit 1
fi
echo "tidy_check: $total files clean (${#files[@]} checked, the rest unchanged)"
