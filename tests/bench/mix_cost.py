#!/usr/bin/env python3
"""The CPU of a texture mix against admission's model (server/app/work_cost.cpp, mix_work_s):
a x levels x channel-pixels P of the common grid (core::mix_grid: the two exemplars' smaller
width and height, at most 1024, at fast FFT sizes; the more channels) x (iterations + c), times
log2(P) / 16 in the "n log n" form (an FFT's cost a pixel grows with log2 of its size; 16 at a
256 x 256 grid). The shared photos are paired by a rule fixed before any measurement: sorted by
name, photos 2k and 2k + 1 form pair k, each pair at its own size and both made 1024 x 1024
(oiiotool --resize: the largest grid a mix has); even pairs fit c (each level's fixed work in
iterations, from the ratio of its CPU at 20 and at 100 iterations), choose the form (the one
whose worst fit-half ratio is nearer 1) and fit a (the mean of CPU / units), odd pairs report
measured / model. One thread, levels 4 and 8 (4 at 1024), iterations 20 and 100, texton size 32;
analysis time only (`textond mix`'s analysis_ms). Prints a table. The shared photos' sides are
powers of two; work_cost.cpp multiplies the model by fft_sides_factor for grids with a side
divisible by 5 or 7 (taken from analysis_cost.py's fit, not refitted here).

  tests/bench/mix_cost.py [BINARY] [EXEMPLARS]
"""
import json
import math
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


def resized(path, side, tmp):
    out = os.path.join(tmp, f"{side}_" + os.path.basename(path))
    subprocess.run(["oiiotool", path, "--resize", f"{side}x{side}", "-o", out], check=True,
                   capture_output=True)
    return out


def main():
    names = sorted(n for n in os.listdir(EXEMPLARS) if n.endswith(".png"))
    tmp = tempfile.mkdtemp()
    rows = []
    for k in range(len(names) // 2):
        u, v = (os.path.join(EXEMPLARS, n) for n in names[2 * k:2 * k + 2])
        pair = f"{names[2 * k]} + {names[2 * k + 1]}"
        for scale, uu, vv, runs in (
                ("own size", u, v, ((4, 20), (8, 20), (4, 100), (8, 100))),
                ("1024", resized(u, 1024, tmp), resized(v, 1024, tmp), ((4, 20), (4, 100)))):
            for levels, iterations in runs:
                grid, s, units = run(uu, vv, levels, iterations)
                rows.append((f"{pair}, {scale}", "fit" if k % 2 == 0 else "report", grid, levels,
                             iterations, s, units))
    fit = [r for r in rows if r[1] == "fit"]
    cpu = {(r[0], r[3], r[4]): r[5] for r in fit}
    ratios = [cpu[(p, lv, 20)] / cpu[(p, lv, 100)] for p, _, _, lv, it, _, _ in fit if it == 20]
    c = sum((20 - 100 * q) / (q - 1) for q in ratios) / len(ratios)

    def units_of(r, form):
        per_level = r[6] * (r[4] + c)
        return per_level * math.log2(r[6] / r[3] / channels(r[2])) / 16 if form else per_level

    def worst(form):  # on the fit half: the ratio farthest from 1 (as a factor)
        a = sum(r[5] / units_of(r, form) for r in fit) / len(fit)
        return max(max(q, 1 / q) for q in (r[5] / (a * units_of(r, form)) for r in fit)), a
    form = min((False, True), key=lambda f: worst(f)[0])
    a = worst(form)[1]
    print("| pair | part | grid | levels | iterations | CPU (s) | model (s) | measured / model |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        m = a * units_of(r, form)
        print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]} | {r[5]:.3f} | {m:.3f} | "
              f"{r[5] / m:.2f} |")
    report = [r[5] / (a * units_of(r, form)) for r in rows if r[1] == "report"]
    print(f"\nform {'n log n' if form else 'linear'} (worst fit-half ratio {worst(True)[0]:.2f} "
          f"n log n, {worst(False)[0]:.2f} linear); fitted on {len(fit)} runs: c = {c:.1f} "
          f"iterations, a = {a * 1e9:.2f} ns a grid channel-pixel, level and iteration; held out "
          f"({len(report)} runs): measured / model {min(report):.2f}-{max(report):.2f}")


def channels(grid):
    return int(grid.split("x")[2])


if __name__ == "__main__":
    main()
