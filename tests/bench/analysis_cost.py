#!/usr/bin/env python3
"""The CPU of an analysis against admission's model (server/app/work_cost.cpp, analysis_work_s):
a x channel-pixels of the working window (core::window_size) x (iterations + 8). The shared photos are split by a
rule fixed before any measurement: sorted by name, even positions fit a (the mean of CPU / units
over their runs), odd ones report measured / model. One thread, iterations 20 and 50, analysis
time only (`textond analyze`'s timings_ms.total). Prints a table.

  tests/bench/analysis_cost.py [BINARY] [EXEMPLARS]
"""
import json
import os
import subprocess
import sys

BINARY = sys.argv[1] if len(sys.argv) > 1 else "build/release/textond"
EXEMPLARS = sys.argv[2] if len(sys.argv) > 2 else "../shared/data/exemplars"


def fast_side(n, least):
    """core::fast_side: the largest m <= n of the form 2^a 3^b 5^c 7^d, unless under least."""
    for m in range(n, 1, -1):
        k = m
        for prime in (2, 3, 5, 7):
            while k % prime == 0:
                k //= prime
        if k == 1:
            return m if m >= least else n
    return n


def run(path, iterations, size=64):
    out = subprocess.run([BINARY, "analyze", path, "--threads", "1", "--iterations",
                          str(iterations), "-o", "/dev/null"], capture_output=True, text=True,
                         check=True).stdout
    j = json.loads(out)
    w, h = j["exemplar"]["width"], j["exemplar"]["height"]
    window = (fast_side(min(w, 1024), 2 * size) * fast_side(min(h, 1024), 2 * size) *
              j["channels"])
    return w, h, j["channels"], j["timings_ms"]["total"] / 1000, window * (iterations + 8)


def main():
    names = sorted(n for n in os.listdir(EXEMPLARS) if n.endswith(".png"))
    rows = []
    for k, name in enumerate(names):
        for it in (20, 50):
            w, h, ch, s, units = run(os.path.join(EXEMPLARS, name), it)
            rows.append((name, "fit" if k % 2 == 0 else "report", f"{w}x{h}x{ch}", it, s, units))
    fit = [s / u for _, part, _, _, s, u in rows if part == "fit"]
    a = sum(fit) / len(fit)
    print("| exemplar | part | size | iterations | CPU (s) | model (s) | measured / model |")
    print("|---|---|---|---|---|---|---|")
    for name, part, size, it, s, u in rows:
        print(f"| {name} | {part} | {size} | {it} | {s:.3f} | {a * u:.3f} | {s / (a * u):.2f} |")
    report = [s / (a * u) for _, part, _, _, s, u in rows if part == "report"]
    print(f"\nfitted on {len(fit)} runs: a = {a * 1e9:.1f} ns a window channel-pixel and "
          f"iteration; held out ({len(report)} runs): measured / model "
          f"{min(report):.2f}-{max(report):.2f}")


if __name__ == "__main__":
    main()
