#!/usr/bin/env bash
# Every C++ file of the tree formatted by the repository's .clang-format (CI checks
# style). Lists the tracked files in a git checkout, else every .cpp/.h outside build/.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
cd "$root"
command -v clang-format >/dev/null || { echo "format_check: clang-format is not installed" >&2; exit 1; }
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
    mapfile -t files < <(git ls-files '*.cpp' '*.h')
else
    mapfile -t files < <(find core render server api tests -name '*.cpp' -o -name '*.h' | grep -v node_modules)
fi
if ! clang-format --dry-run -Werror "${files[@]}"; then
    echo "format_check: run clang-format -i on the files above" >&2
    exit 1
fi
echo "format_check: ${#files[@]} files formatted"
