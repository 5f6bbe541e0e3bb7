#!/usr/bin/env python3
"""Which of FILES clang-tidy must check again: those whose translation unit changed since their
last clean pass. A file's key is the hash of clang-tidy's version and arguments (TIDY_ARGS), every
.clang-tidy of the tree,
its compile command and its preprocessed text with comments and macro definitions (so an edited
header re-checks every file that includes it, a removed NOLINT or a new macro re-checks, and a
changed flag re-checks what it compiles). Clean passes leave the key in
CACHE_DIR; `tidy_check.sh` writes it.

    tidy_changed.py COMPILE_COMMANDS ROOT CACHE_DIR TIDY FILE...   # prints "FILE KEY" to check
"""
import concurrent.futures
import hashlib
import json
import os
import shlex
import subprocess
import sys


def preprocess(entry):
    args = shlex.split(entry["command"])
    out, skip = [], False
    for a in args:
        if skip:
            skip = False
            continue
        if a == "-o":
            skip = True
            continue
        if a == "-c":
            continue
        out.append(a)
    r = subprocess.run(out + ["-E", "-P", "-C", "-dD"], cwd=entry["directory"], capture_output=True)
    # A file that does not preprocess has no stable key: check it every time.
    return r.stdout if r.returncode == 0 else os.urandom(16)


def main():
    commands, root, cache, tidy = sys.argv[1:5]
    files = sys.argv[5:]
    root = os.path.realpath(root)
    by_file = {}
    for e in json.load(open(commands, encoding="utf-8")):
        f = os.path.realpath(os.path.join(e["directory"], e["file"]))
        by_file[os.path.relpath(f, root)] = e
    common = hashlib.sha256()
    common.update(subprocess.run([tidy, "--version"], capture_output=True).stdout)
    common.update(os.environ.get("TIDY_ARGS", "").encode())
    for d, _, names in sorted(os.walk(root)):
        if "node_modules" in d or os.path.relpath(d, root).split(os.sep)[0] in ("build", ".git"):
            continue
        if ".clang-tidy" in names:
            with open(os.path.join(d, ".clang-tidy"), "rb") as f:
                common.update(d.encode() + f.read())

    def key(rel):
        h = common.copy()
        e = by_file.get(rel)
        if e is None:
            return rel, os.urandom(16).hex()
        h.update(e["command"].encode())
        h.update(preprocess(e))
        return rel, h.hexdigest()

    with concurrent.futures.ThreadPoolExecutor(os.cpu_count() or 2) as pool:
        for rel, k in pool.map(key, files):
            stamp = os.path.join(cache, hashlib.sha256(rel.encode()).hexdigest()[:32])
            try:
                with open(stamp, encoding="utf-8") as f:
                    if f.read().strip() == k:
                        continue
            except OSError:
                pass
            print(rel, k)


if __name__ == "__main__":
    main()
