#!/usr/bin/env python3
"""Every shell block the READMEs mark runnable (an HTML comment `<!-- runnable -->` on the line
before its ```sh fence), run as a reader would paste it: from a copy of the repository root whose
`build/` and `../shared` are the real ones, against a real `textond serve` standing in for the
`make run` of the text (its port replaces 8080). `curl` fails on an HTTP error (-f), and a block
fails on any failing command (bash -euo pipefail).

    doc_test.py ROOT BUILD_DIR TEXTOND
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

DOCS = ["README.md", "api/README.md", "core/README.md", "render/README.md", "deploy/README.md",
        "tests/README.md"]
MARK = "<!-- runnable -->"
PREAMBLE = "set -euo pipefail\ncurl() { command curl -f \"$@\"; }\n"


def runnable_blocks(root):
    blocks = []
    for doc in DOCS:
        lines = open(os.path.join(root, doc), encoding="utf-8").read().split("\n")
        for i, line in enumerate(lines):
            if line.strip() != MARK:
                continue
            if i + 1 >= len(lines) or not lines[i + 1].strip().startswith("```sh"):
                blocks.append((doc, i + 1, None))  # a mark on anything else is an error
                continue
            end = next(k for k in range(i + 2, len(lines)) if lines[k].strip() == "```")
            blocks.append((doc, i + 2, "\n".join(lines[i + 2:end]) + "\n"))
    return blocks


def main():
    root, build, binary = (os.path.realpath(a) for a in sys.argv[1:4])
    blocks = runnable_blocks(root)
    failed = 0
    # The tour, the API tour and the commands at least: a doc without marks tests nothing.
    if len(blocks) < 3:
        print(f"FAIL: {len(blocks)} runnable blocks found, expected at least 3")
        return 1
    tmp = tempfile.mkdtemp(prefix="textond-docs-")
    work = os.path.join(tmp, "repo")
    os.makedirs(work)
    os.symlink(os.path.realpath(os.path.join(root, "..", "shared")), os.path.join(tmp, "shared"))
    os.makedirs(os.path.join(work, "build"))
    # The blocks name build/release/textond: the build under test stands there, whatever preset.
    for name in {"release", os.path.basename(build)}:
        os.symlink(build, os.path.join(work, "build", name))
    data = os.path.join(tmp, "data")
    server = subprocess.Popen([binary, "serve", "--port", "0", "--data", data, "--backend", "cpu",
                               "--log-level", "warn", "--no-access-log"],
                              stdout=subprocess.PIPE, text=True)
    try:
        line = server.stdout.readline()
        m = re.search(r":(\d+)/?\s*$", line)
        if not m:
            print(f"FAIL: the server did not start: {line!r}")
            return 1
        port = m.group(1)
        for doc, line_no, text in blocks:
            where = f"{doc}:{line_no}"
            if text is None:
                print(f"FAIL {where}: '{MARK}' is not followed by a ```sh block")
                failed += 1
                continue
            if re.search(r"&&|\|\|", text):  # set -e ignores the left side of either
                print(f"FAIL {where}: && or || in a runnable block hides a failing command")
                failed += 1
                continue
            script = PREAMBLE + text.replace("127.0.0.1:8080", "127.0.0.1:" + port)
            r = subprocess.run(["bash", "-c", script], cwd=work, capture_output=True, text=True,
                               timeout=600)
            if r.returncode != 0:
                failed += 1
                print(f"FAIL {where}: exit {r.returncode}\n{r.stderr[-2000:]}")
            else:
                print(f"ok   {where} ({text.count(chr(10))} lines)")
    finally:
        server.terminate()
        server.wait(timeout=30)
        shutil.rmtree(tmp, ignore_errors=True)
    if server.returncode not in (0, -15):
        print(f"FAIL: the server exited {server.returncode}")
        failed += 1
    print(f"{len(blocks) - failed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
