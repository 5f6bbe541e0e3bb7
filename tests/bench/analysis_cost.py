#!/usr/bin/env python3
"""The CPU of an analysis against admission's model (server/app/work_cost.cpp, analysis_work_s).
Two forms over the working window (core::window_size: W pixels, C channel-pixels), each plus 10 ns
a channel-pixel of the whole exemplar for its id:
  linear: a x C x (iterations + c)                      (the form before 2026-11-28)
  split:  a x C x iterations + b x C + g x W            (the projections, the per-channel steps,
                                                         the grey verdict and coherence)
  fixed:  split + d                                     (and a fixed cost an analysis)
  sides:  fixed, its window terms times (f(w) + f(h)) / 2, f(n) = 1 + e5 [5 | n] + e7 [7 | n]
          (FFTW's time a pixel for sides with a factor 5 or 7, which the FFT cut keeps)
The shared photos are split by a rule fixed before any measurement: sorted by name, even
positions fit, odd ones report measured / model; each photo at its own size and made 1024 x 1024
(oiiotool --resize: the largest window), 1000 x 1000 and 1008 x 1008, at 20 and 200 iterations, one thread, r 64, analysis
time only (`textond analyze`'s timings_ms.total). The form is chosen on the fit half (the worst
ratio, as a factor either way, nearer 1), fitted by least squares on measured / model - 1 (relative
error), and reported on the other half. Prints a table.

  tests/bench/analysis_cost.py [BINARY] [EXEMPLARS]
"""
import json
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from fft_sizes import fast_side  # noqa: E402

BINARY = sys.argv[1] if len(sys.argv) > 1 else "build/release/textond"
EXEMPLARS = sys.argv[2] if len(sys.argv) > 2 else "../shared/data/exemplars"
WHOLE_NS = 10e-9


def run(path, iterations, size=64):
    out = subprocess.run([BINARY, "analyze", path, "--threads", "1", "--iterations",
                          str(iterations), "--size", str(size), "-o", "/dev/null"],
                         capture_output=True, text=True, check=True).stdout
    j = json.loads(out)
    w, h, ch = j["exemplar"]["width"], j["exemplar"]["height"], j["channels"]
    ww, wh = fast_side(min(w, 1024), 2 * size), fast_side(min(h, 1024), 2 * size)
    return f"{w}x{h}x{ch}", j["timings_ms"]["total"] / 1000, ww * wh, ww * wh * ch, w * h * ch, \
        sides_with_factors(ww, wh)


def sides_with_factors(w, h):
    """How many of the two sides have a factor 5, and how many a factor 7."""
    return (sum(1 for n in (w, h) if n % 5 == 0), sum(1 for n in (w, h) if n % 7 == 0))


def solve(rows_x, rows_y):
    """Least squares (normal equations) for a small dense system."""
    n = len(rows_x[0])
    m = [[sum(x[i] * x[j] for x in rows_x) for j in range(n)] for i in range(n)]
    v = [sum(x[i] * y for x, y in zip(rows_x, rows_y)) for i in range(n)]
    for i in range(n):  # Gauss-Jordan
        p = max(range(i, n), key=lambda r: abs(m[r][i]))
        m[i], m[p], v[i], v[p] = m[p], m[i], v[p], v[i]
        for r in range(n):
            if r != i:
                f = m[r][i] / m[i][i]
                m[r] = [a - f * b for a, b in zip(m[r], m[i])]
                v[r] -= f * v[i]
    return [v[i] / m[i][i] for i in range(n)]


def features(form, r, e=(0.0, 0.0)):
    it, px, chpx, cls = r[2], r[4], r[5], r[8]
    if form == "linear":
        return [chpx * it, chpx]
    phi = 1 + (e[0] * cls[0] + e[1] * cls[1]) / 2 if form == "sides" else 1.0
    return [chpx * it * phi, chpx * phi, px * phi, 1.0] if form != "split" else \
        [chpx * it, chpx, px]


def fit_e(form, rows, e):
    # relative least squares: each row's features and target divided by its measured time
    xs = [[f / (r[3] - WHOLE_NS * r[6]) for f in features(form, r, e)] for r in rows]
    return solve(xs, [1.0] * len(rows))


def model(form, k, r):
    coefficients, e = k
    return sum(a * f for a, f in zip(coefficients, features(form, r, e))) + WHOLE_NS * r[6]


def fit(form, rows):
    grid = [(a / 20, b / 20) for a in range(61) for b in range(61)] if form == "sides" else \
        [(0.0, 0.0)]
    best = None
    for e in grid:
        k = (fit_e(form, rows, e), e)
        err = sum((r[3] / model(form, k, r) - 1) ** 2 for r in rows)
        if best is None or err < best[0]:
            best = (err, k)
    return best[1]


def main():
    names = sorted(n for n in os.listdir(EXEMPLARS) if n.endswith(".png"))
    tmp = tempfile.mkdtemp()
    rows = []
    for k, name in enumerate(names):
        path = os.path.join(EXEMPLARS, name)
        big = os.path.join(tmp, name)
        subprocess.run(["oiiotool", path, "--resize", "1024x1024", "-o", big], check=True,
                       capture_output=True)
        odd = []
        for side in (1000, 1008):
            odd.append(os.path.join(tmp, f"{side}_{name}"))
            subprocess.run(["oiiotool", path, "--resize", f"{side}x{side}", "-o", odd[-1]],
                           check=True, capture_output=True)
        for p in [path, big] + odd:
            for it in (20, 200):
                size, s, px, chpx, whole, cls = run(p, it)
                rows.append((name, "fit" if k % 2 == 0 else "report", it, s, px, chpx, whole,
                             size, cls))
    fit_rows = [r for r in rows if r[1] == "fit"]

    def worst(form):
        k = fit(form, fit_rows)
        return max(max(q, 1 / q) for q in (r[3] / model(form, k, r) for r in fit_rows)), k
    form = min(("linear", "split", "fixed", "sides"), key=lambda f: worst(f)[0])
    k = worst(form)[1]
    print("| exemplar | part | size | iterations | CPU (s) | model (s) | measured / model |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        m = model(form, k, r)
        print(f"| {r[0]} | {r[1]} | {r[7]} | {r[2]} | {r[3]:.3f} | {m:.3f} | {r[3] / m:.2f} |")
    report = [r[3] / model(form, k, r) for r in rows if r[1] == "report"]
    names_k = ["a (ns a window channel-pixel and iteration)", "b (ns a window channel-pixel)",
               "g (ns a window pixel)", "d (ms an analysis)"]
    scale = [1e9, 1e9, 1e9, 1e3]
    print(f"\nform {form} (worst fit-half ratio: " +
          ", ".join(f"{f} {worst(f)[0]:.2f}" for f in ("linear", "split", "fixed", "sides")) +
          f"); fitted on {len(fit_rows)} runs: " +
          ", ".join(f"{n} = {v * f:.2f}" for n, v, f in zip(names_k, k[0], scale)) +
          f", e5 = {k[1][0]:.2f}, e7 = {k[1][1]:.2f}" +
          f"; held out ({len(report)} runs): measured / model {min(report):.2f}-{max(report):.2f}")


if __name__ == "__main__":
    main()
