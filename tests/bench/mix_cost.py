#!/usr/bin/env python3
"""The CPU of a texture mix against admission's model (server/app/work_cost.cpp, mix_work_s):
a x levels x channel-pixels of the common grid (the two exemplars' smaller width and height,
the more channels) x (iterations + c). The shared photos are paired by a rule fixed before any
measurement: sorted by name, photos 2k and 2k + 1 form pair k; even pairs fit c (each level's
fixed work in iterations, from the ratio of its CPU at 20 and at 100 iterations) and then a (the
mean of CPU / units), odd pairs report measured / model. One thread, levels 4 and 8, iterations
20 and 100, texton size 32; analysis time only (`textond mix`'s analysis_ms). Prints a table.

  tests/bench/mix_cost.py [BINARY] [EXEMPLARS]
"""
import json
import os
import subprocess
import sys
import tempfile

BINARY = sys.argv[1] if len(sys.argv) > 1 else "build/release/textond"
EXEMPLARS = sys.argv[2] if len(sys.argv) > 2 else "../shared/data/exemplars"
OUT = os.path.join(tempfile.mkdtemp(), "mix.png")


def run(u, v, levels, iterations):
    out = subprocess.run([BINARY, "mix", u, v, "--threads", "1", "--levels", str(levels),
                          "--iterations", str(iterations), "--size", "32", "--w", "16", "--h",
                          "16", "-o", OUT], capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"mix_cost: {u} {v}: {out.stderr.strip()}")
    j = json.loads(out.stdout)
    w, h = j["grid"]
    channels = max(channels_of(u), channels_of(v))
    return f"{w}x{h}x{channels}", j["analysis_ms"] / 1000, levels * w * h * channels


def channels_of(path):
    out = subprocess.run(["oiiotool", "--info", "-v", path], capture_output=True, text=True,
                         check=True).stdout
    return 1 if " 1 channel" in out else 3


def main():
    names = sorted(n for n in os.listdir(EXEMPLARS) if n.endswith(".png"))
    rows = []
    for k in range(len(names) // 2):
        u, v = (os.path.join(EXEMPLARS, n) for n in names[2 * k:2 * k + 2])
        for levels, iterations in ((4, 20), (8, 20), (4, 100), (8, 100)):
            grid, s, units = run(u, v, levels, iterations)
            rows.append((f"{names[2 * k]} + {names[2 * k + 1]}", "fit" if k % 2 == 0 else "report",
                         grid, levels, iterations, s, units))
    fit = [r for r in rows if r[1] == "fit"]
    cpu = {(r[0], r[3], r[4]): r[5] for r in fit}
    ratios = [cpu[(p, lv, 20)] / cpu[(p, lv, 100)] for p, _, _, lv, it, _, _ in fit if it == 20]
    c = sum((20 - 100 * q) / (q - 1) for q in ratios) / len(ratios)
    rows = [(*r[:6], r[6] * (r[4] + c)) for r in rows]
    a = sum(s / u for _, part, _, _, _, s, u in rows if part == "fit") / len(fit)
    print("| pair | part | grid | levels | iterations | CPU (s) | model (s) | measured / model |")
    print("|---|---|---|---|---|---|---|---|")
    for pair, part, grid, levels, it, s, u in rows:
        print(f"| {pair} | {part} | {grid} | {levels} | {it} | {s:.3f} | {a * u:.3f} | "
              f"{s / (a * u):.2f} |")
    report = [s / (a * u) for _, part, _, _, _, s, u in rows if part == "report"]
    print(f"\nfitted on {len(fit)} runs: c = {c:.1f} iterations, a = {a * 1e9:.2f} ns a grid "
          f"channel-pixel, level and iteration; held out ({len(report)} runs): measured / model "
          f"{min(report):.2f}-{max(report):.2f}")


if __name__ == "__main__":
    main()
