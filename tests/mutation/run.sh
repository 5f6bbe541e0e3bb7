#!/usr/bin/env bash
# make mutation: applies each one-line mutation of tests/mutation/mutations.py to the working tree
# in turn, rebuilds what it touches in the release build, runs the suites that should notice, and
# puts the file back. Prints a table and exits non-zero when a mutation survives. Not part of
# `make test` (about 4 minutes on 2 cores: each suite stops at its first failure); do not edit
# the tree while it runs.
#   tests/mutation/run.sh [NAME ...]    only these mutations
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${BUILD:-build/release}
if [ ! -f "$build/CMakeCache.txt" ]; then cmake --preset release >/dev/null; fi
exec python3 tests/mutation/mutations.py "$build" "$@"
