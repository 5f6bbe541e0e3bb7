#!/usr/bin/python3
"""Every path a README, comment or script of the tree names exists: a file that moves without its
mentions fails here. A mention is a path under one of the top-level folders (api/, core/, render/,
server/, tests/, docker/, deploy/) or ../shared/, as written (from the root, or relative to the
file that names it); one without an extension names a folder, or the files of that stem
(`server/io/pmtiles` for pmtiles.h and pmtiles.cpp); a pattern (`{id}`, `*`, `<x>`) is skipped.
Paths under ../shared/ are checked where ../shared is present.

  doc_paths_test.py ROOT       checks the tree
  doc_paths_test.py --self     shows the check a moved file and a live one: it must flag the first
"""
import os
import re
import subprocess
import sys
import tempfile

TOP = r"(?:api|core|render|server|tests|docker|deploy)"
MENTION = re.compile(r"(?<![\w./$@{=-])((?:\.\./)*(?:" + TOP + r"|\.\./shared)/[A-Za-z0-9_./{}*<>-]*"
                     r"[A-Za-z0-9_*}>])")
TEXT = (".md", ".h", ".cpp", ".py", ".sh", ".txt", ".glsl", ".comp", ".frag", ".vert", ".hlsl",
        ".yaml", ".yml", ".lua", ".conf", ".cmake", ".js", ".mjs", ".html", ".css", "Makefile",
        "Dockerfile", "Containerfile")


def exists(root, where, path):
    for base in (root, os.path.join(root, os.path.dirname(where))):
        p = os.path.normpath(os.path.join(base, path))
        if os.path.exists(p):
            return True
        folder, stem = os.path.split(p)
        if "." not in stem and os.path.isdir(folder) and any(
                f.startswith(stem + ".") for f in os.listdir(folder)):
            return True
    return False


def missing(root, files):
    shared = os.path.isdir(os.path.join(root, "..", "shared"))
    out = []
    for f in files:
        if not f.endswith(TEXT) or "node_modules" in f or f.endswith("-lock.json"):
            continue
        with open(os.path.join(root, f), encoding="utf-8", errors="replace") as fh:
            for n, line in enumerate(fh, 1):
                for m in MENTION.finditer(line):
                    path = m.group(1).rstrip(".")
                    if any(c in path for c in "{}*<>"):
                        continue
                    if path.startswith("../") and "shared/" in path and not shared:
                        continue
                    if not exists(root, f, path):
                        out.append(f"{f}:{n}: {path}")
    return out


def tracked(root):
    return subprocess.run(["git", "-C", root, "ls-files"], capture_output=True, text=True,
                          check=True).stdout.split()


def self_check():
    gone = "server/io/" + "gone.h"  # spelled apart, or this file would name it
    with tempfile.TemporaryDirectory() as root:
        os.makedirs(os.path.join(root, "server", "io"))
        open(os.path.join(root, "server", "io", "pmtiles.h"), "w").close()
        with open(os.path.join(root, "README.md"), "w") as f:
            f.write(f"See server/io/pmtiles.h, server/io/pmtiles and {gone} "
                    "(and tiles/{z}/{x}/{y}.png).\n")
        found = missing(root, ["README.md"])
        assert found == [f"README.md:1: {gone}"], found
    print("self-check: a moved file is flagged, live ones and patterns are not")


def main():
    if sys.argv[1:] == ["--self"]:
        return self_check()
    root = os.path.realpath(sys.argv[1])
    self_check()
    files = tracked(root)
    bad = missing(root, files)
    for b in bad:
        print("names a path that does not exist:", b)
    print(f"{len(files)} files read, {len(bad)} missing paths")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
