#!/usr/bin/env python3
"""Chooses the micro/macro verdict (core/shape_verdict.h) and the RME threshold of the page's
wording on the fit halves, and reports them on the held-out halves. Reads verdict_features' table.

  build/release/tests/verdict_features tests/verdict tests/verdict/shapes tests/verdict/third \
      tests/verdict/fourth > features.tsv
  tests/verdict/fit_verdict.py features.tsv              # the choice, on the fit set
  tests/verdict/fit_verdict.py features.tsv --held-out   # and the held-out halves' tables

The fit set: the whole first corpus (tests/verdict: its held-out half has been seen) and the fit
half of the shapes corpus (tests/verdict/shapes); borderline textures are not scored. Held out,
each scored once after the choice: the shapes corpus's other half; then the third corpus
(tests/verdict/third), drawn after that score; then the fourth (tests/verdict/fourth), drawn
after the third's held-out half was scored, and scored once the refit study below, on the first
three corpora, had kept the verdict unchanged.

  build/release/tests/verdict_candidates CORPUS... > candidates.tsv
  mkdir -p SHARED/corpus && (printf 'name\tlabel\thalf\n'; for f in ../shared/data/exemplars/*.png
    do n=$(basename "$f" .png); ln -sf "$(realpath "$f")" SHARED/corpus/"$n".jpg
    case $n in skimage_brick|etr_pave02) k=macro;; *) k=micro;; esac
    printf '%s\t%s\tshared\n' "$n" "$k"; done) > SHARED/corpus.tsv
  build/release/tests/verdict_candidates SHARED > shared.tsv   # the nine shared photos
  tests/verdict/fit_verdict.py - --candidates candidates.tsv shared.tsv

The refit study (core/README.md "Micro or macro"): forward selection over verdict_candidates'
30 statistics on every texture of the corpora given (a statistic joins while it adds at least
0.005 of cross-validated balanced accuracy), then each refit, with a band keeping 90% or 92% of
each class (band_of), compared with the unchanged verdict on those textures and on the nine
shared photos (a target: they keep their kinds). Run on the first three corpora before the
fourth was scored, on all four after, and on all six once the sixth was scored. SHARED is a
directory holding corpus.tsv (name, label, half) and corpus/NAME.jpg, a link to each photo (the
decoder reads a PNG by its content), as the commands above make it; the kinds are
../shared/data/exemplars/README.md's.

The second scale's offset (core/README.md "Two scales"; scales_study below; needs SHARED
above, and about 7 GB of packages in build/verdict/):

  for c in tests/verdict tests/verdict/shapes tests/verdict/third tests/verdict/fourth \
      tests/verdict/fifth tests/verdict/sixth; do tests/verdict/make_corpus.py native --corpus $c
  done
  N=build/verdict/native
  build/release/tests/verdict_scales $N/verdict $N/shapes $N/third $N/fourth $N/fifth $N/sixth \
      SHARED > scales.tsv
  tests/verdict/fit_verdict.py --scales scales.tsv

1. Candidate sets of statistics (each one's excess over its ADSN null), nested in the order the
   statistics separate the fit set alone; each scored by balanced accuracy under 5-fold
   cross-validation on the fit set (three shuffles), a logistic regression with balanced classes
   on standardised statistics (L2 penalty 0.01, 6000 gradient steps of 0.5); then the chosen
   set's penalty by the same cross-validation over 1, 0.1 and 0.01. The best set, or a smaller one within 0.005 of
   it, is refitted on the whole fit set; its weights in raw units go to kShapeWeights.
2. The borderline band +-b on the score: the widest b (0.25 steps) that keeps at least 90% of the
   fit set's micro and 90% of its macro textures right (the held-out target). A band that also
   called no fit macro texture micro would be 2.0 wide and leave 77% of each right.
3. The RME threshold: the 95th percentile of the RME of the fit set's micro textures. The RME
   does not separate micro from macro (best fit balanced accuracy about 0.6); what it says is
   how far the texton is from its own model, and above nearly every micro texture's the page
   no longer says the noise keeps the exemplar's look.
"""
import csv
import math
import os
import random
import re
import sys

STATS = ("tensor", "tv", "lines", "specks")
HEADER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "core",
                      "shape_verdict.h")


def shipped():
    """kShapeWeights (bias, then STATS's weights) and kShapeBand as core/shape_verdict.h has them."""
    text = open(HEADER).read()
    weights = re.search(r"kShapeWeights\{([^}]*)\}", text).group(1)
    band = re.search(r"kShapeBand = ([0-9.]+);", text).group(1)
    return [float(v) for v in weights.split(",")], float(band)


def load(path):
    with open(path) as f:
        rows = list(csv.DictReader(f, delimiter="\t"))
    for r in rows:
        r["shapes"] = r["corpus"].rstrip("/").endswith("shapes")
        r["first"] = r["corpus"].rstrip("/").endswith("verdict")
        r["x"] = [float(r[s]) - float(r[s + "_null"]) for s in STATS]
        r["y"] = 1.0 if r["label"] == "macro" else 0.0
    return rows


def standardise(xs):
    n = len(xs)
    mu = [sum(x[i] for x in xs) / n for i in range(len(xs[0]))]
    sd = [math.sqrt(sum((x[i] - mu[i]) ** 2 for x in xs) / n) or 1.0 for i in range(len(mu))]
    return mu, sd


def solve(a, b):
    """x with a x = b (Gaussian elimination, partial pivoting; a is small and positive definite)."""
    n = len(b)
    m = [row[:] + [v] for row, v in zip(a, b)]
    for c in range(n):
        p = max(range(c, n), key=lambda r: abs(m[r][c]))
        m[c], m[p] = m[p], m[c]
        for r in range(c + 1, n):
            f = m[r][c] / m[c][c]
            for k in range(c, n + 1):
                m[r][k] -= f * m[c][k]
    x = [0.0] * n
    for c in range(n - 1, -1, -1):
        x[c] = (m[c][n] - sum(m[c][k] * x[k] for k in range(c + 1, n))) / m[c][c]
    return x


def logistic(xs, ys, lam=0.01, steps=30):
    """Balanced-class logistic regression on standardised inputs, L2 penalty lam on the weights
    (not the bias), by Newton's method: the minimiser of sum c_i loss_i + lam |w|^2 / 2."""
    mu, sd = standardise(xs)
    zs = [[1.0] + [(x[i] - mu[i]) / sd[i] for i in range(len(mu))] for x in xs]
    pos = sum(ys) / len(ys)
    wt = [0.5 / pos if y else 0.5 / (1 - pos) for y in ys]
    d = len(mu) + 1
    beta = [0.0] * d
    for _ in range(steps):
        grad = [0.0] * d
        hess = [[0.0] * d for _ in range(d)]
        for z, y, c in zip(zs, ys, wt):
            t = sum(bi * zi for bi, zi in zip(beta, z))
            p = 1.0 / (1.0 + math.exp(-max(-50.0, min(50.0, t))))
            g, h = (p - y) * c, max(p * (1 - p), 1e-12) * c
            for i in range(d):
                grad[i] += g * z[i]
                hi = h * z[i]
                for k in range(i + 1):
                    hess[i][k] += hi * z[k]
        for i in range(d):
            for k in range(i):
                hess[k][i] = hess[i][k]
        for i in range(1, d):
            grad[i] += lam * beta[i]
            hess[i][i] += lam
        step = solve(hess, grad)
        beta = [bi - si for bi, si in zip(beta, step)]
        if max(abs(si) for si in step) < 1e-9:
            break
    # Raw units: score = bias + sum raw_i x_i.
    raw = [wi / s for wi, s in zip(beta[1:], sd)]
    return beta[0] - sum(r * m for r, m in zip(raw, mu)), raw


def logistic_gd(xs, ys, lam=0.01, steps=6000, rate=0.5):
    """The same regression by 6000 steps of gradient descent: how kShapeWeights was fitted (the
    weights agree with Newton's to about 0.3%; this reproduces the shipped ones to the digit)."""
    mu, sd = standardise(xs)
    zs = [[(x[i] - mu[i]) / sd[i] for i in range(len(mu))] for x in xs]
    pos = sum(ys) / len(ys)
    wt = [0.5 / pos if y else 0.5 / (1 - pos) for y in ys]
    w, b, n = [0.0] * len(mu), 0.0, len(ys)
    for _ in range(steps):
        gw, gb = [0.0] * len(w), 0.0
        for z, y, c in zip(zs, ys, wt):
            t = b + sum(wi * zi for wi, zi in zip(w, z))
            p = 1.0 / (1.0 + math.exp(-max(-50.0, min(50.0, t))))
            g = (p - y) * c
            gb += g
            for i, zi in enumerate(z):
                gw[i] += g * zi
        b -= rate * gb / n
        w = [wi - rate * (gi / n + lam * wi / n) for wi, gi in zip(w, gw)]
    # Raw units: score = bias + sum raw_i x_i.
    raw = [wi / s for wi, s in zip(w, sd)]
    return b - sum(r * m for r, m in zip(raw, mu)), raw


def score(model, x):
    bias, raw = model
    return bias + sum(r * v for r, v in zip(raw, x))


def balanced(rows, f, t=0.0):
    micro = [r for r in rows if r["label"] == "micro"]
    macro = [r for r in rows if r["label"] == "macro"]
    return (sum(f(r) <= t for r in micro) / len(micro) + sum(f(r) > t for r in macro) / len(macro)) / 2


def project(x, cols):
    return [x[i] for i in cols]


def cross_validated(rows, cols, lam=0.01, fit=logistic):
    accs = []
    for shuffle in range(3):
        order = rows[:]
        random.Random(shuffle).shuffle(order)
        for k in range(5):
            test = order[k::5]
            train = [r for i, r in enumerate(order) if i % 5 != k]
            m = fit([project(r["x"], cols) for r in train], [r["y"] for r in train], lam)
            accs.append(balanced(test, lambda r: score(m, project(r["x"], cols))))
    return sum(accs) / len(accs)


def best_threshold(rows, f):
    values = sorted({f(r) for r in rows})
    cuts = [(a + b) / 2 for a, b in zip(values, values[1:])]
    return max(((balanced(rows, f, t), t) for t in cuts))


def kind(s, band):
    return "macro" if s > band else "borderline" if s > -band else "micro"


def confusion(rows, verdict):
    print("| label | micro | borderline | macro | right |")
    print("|---|---|---|---|---|")
    for label in ("micro", "macro", "borderline"):
        rs = [r for r in rows if r["label"] == label]
        if not rs:
            continue
        counts = {k: sum(verdict(r) == k for r in rs) for k in ("micro", "borderline", "macro")}
        right = (f"{counts[label]} of {len(rs)} ({100 * counts[label] / len(rs):.0f}%)"
                 if label != "borderline" else "not scored")
        print(f"| {label} | {counts['micro']} | {counts['borderline']} | {counts['macro']} | {right} |")


def band_of(scores_micro, scores_macro, keep):
    """The band (lo, hi) on a 0.05 grid: lo the lowest grid point at or below which at least
    `keep` of the micro scores lie, hi the highest above which at least `keep` of the macro ones
    lie. Where the classes overlap more than that (hi < lo) there is no band: one threshold
    half-way, which keeps less than `keep` of one class (the study prints what it keeps)."""
    assert scores_micro and scores_macro and 0 < keep <= 1
    assert all(math.isfinite(v) for v in scores_micro + scores_macro)
    micro, macro = sorted(scores_micro), sorted(scores_macro)
    lo = math.ceil(micro[math.ceil(keep * len(micro)) - 1] / 0.05 - 1e-9) * 0.05
    hi = math.floor(macro[len(macro) - math.ceil(keep * len(macro))] / 0.05 + 1e-9) * 0.05
    if hi == macro[len(macro) - math.ceil(keep * len(macro))]:
        hi -= 0.05  # macro is strictly above hi
    return (lo, hi) if lo <= hi else ((lo + hi) / 2, (lo + hi) / 2)


def refit_study(path, shared_path):
    """Forward selection over verdict_candidates' statistics on every texture of its table, and
    each refit against the unchanged verdict (kShapeWeights) and the nine shared photos."""
    def read(p):
        with open(p) as f:
            rs = list(csv.DictReader(f, delimiter="\t"))
        for r in rs:
            r["y"] = 1.0 if r["label"] == "macro" else 0.0
        return rs
    fit = [r for r in read(path) if r["label"] != "borderline"]
    shared = read(shared_path)
    names = [c for c in fit[0] if c not in ("corpus", "name", "label", "half", "y")]
    for r in fit + shared:
        r["x"] = [float(r[c]) for c in names]
    print(f"## Candidate statistics, alone ({len(fit)} fit textures: balanced accuracy at the best "
          "threshold)\n")
    for i, n in enumerate(names):
        print(f"- {n}: {best_threshold(fit, lambda r: r['x'][i])[0]:.3f}")
    print("\n## Forward selection (5-fold cross-validated balanced accuracy; joins at +0.005)\n")
    chosen, best = [], 0.0
    while len(chosen) < len(names):
        trials = sorted(((cross_validated(fit, chosen + [i]), i) for i in range(len(names))
                         if i not in chosen), reverse=True)
        acc, i = trials[0]
        runners = ", ".join(f"{names[j]} {a:.3f}" for a, j in trials[1:4])
        if acc < best + 0.005:
            print(f"- + {names[i]}: {acc:.3f}, does not join (next: {runners})")
            break
        print(f"- + {names[i]}: {acc:.3f} (next: {runners})")
        chosen.append(i)
        best = acc

    def verdicts(model, cols, lo, hi, rows):
        s = [score(model, project(r["x"], cols)) for r in rows]
        return ["micro" if v <= lo else "macro" if v > hi else "borderline" for v in s]

    def summary(what, on_fit, on_shared):
        micro = [k for r, k in zip(fit, on_fit) if r["label"] == "micro"]
        macro = [k for r, k in zip(fit, on_fit) if r["label"] == "macro"]
        off = [f"{r['name']} ({k})" for r, k in zip(shared, on_shared) if k != r["label"]]
        print(f"- {what}: micro {micro.count('micro')} of {len(micro)} right "
              f"({micro.count('micro') / len(micro):.1%}), macro {macro.count('macro')} of "
              f"{len(macro)} ({macro.count('macro') / len(macro):.1%}), "
              f"{macro.count('micro')} macro called micro; shared photos called otherwise "
              f"than their kind: {off}")

    print("\n## Each on the whole fit set (in sample for the refits) and the shared photos\n")
    weights, band = shipped()
    unchanged, cols = (weights[0], weights[1:]), [names.index(s) for s in STATS]
    summary("the verdict unchanged (kShapeWeights, fitted on the first corpus and half the "
            "shapes corpus)", verdicts(unchanged, cols, -band, band, fit),
            verdicts(unchanged, cols, -band, band, shared))
    for label, cols in (("refit, its statistics", [names.index(s) for s in STATS]),
                        ("refit, the chosen statistics", chosen)):
        m = logistic([project(r["x"], cols) for r in fit], [r["y"] for r in fit])
        s_micro = [score(m, project(r["x"], cols)) for r in fit if r["label"] == "micro"]
        s_macro = [score(m, project(r["x"], cols)) for r in fit if r["label"] == "macro"]
        cv = cross_validated(fit, cols)
        for keep in (0.9, 0.92):
            lo, hi = band_of(s_micro, s_macro, keep)
            cut = (f"band [{lo:.2f}, {hi:.2f}]" if lo < hi else
                   f"one threshold {lo:.2f} (no band keeps {keep:.0%} of each)")
            summary(f"{label} ({', '.join(names[i] for i in cols)}; cross-validated {cv:.3f}), "
                    f"aimed at {keep:.0%}: {cut}", verdicts(m, cols, lo, hi, fit),
                    verdicts(m, cols, lo, hi, shared))


def scales_study(path):
    """kFineScaleOffset: the full resolution's score, less this, against the reduced whole's.
    Reads verdict_scales' table over the corpora's native sources and the shared photos (half
    "shared"). Fit: the first four corpora (all have been seen), borderline not scored; among
    offsets on a 0.25 grid from 0 to 6 that keep every shared photo's kind, the one with the
    best balanced accuracy, the largest of equals (a finer scale needs more evidence). Held out,
    fitted on by no choice: the fifth corpus (drawn before the choice) and the sixth (drawn
    after it), each reported with the offset chosen and with one scale. Each corpus is known by
    its directory's name (make_corpus.py native names it so); a table without both held-out
    corpora or without the shared photos is refused, so that neither joins the fit set by a
    name."""
    with open(path) as f:
        rows = [r for r in csv.DictReader(f, delimiter="\t")]
    for r in rows:
        r["s"] = [float(x.split(":")[1]) for x in r["scales"].split(",")]
    band = shipped()[1]

    def verdict(r, d):
        return kind(max([r["s"][0]] + [v - d for v in r["s"][1:]]), band)

    shared = [r for r in rows if r["half"] == "shared"]
    held = {c: [r for r in rows if os.path.basename(r["corpus"].rstrip("/")) == c]
            for c in ("fifth", "sixth")}
    for c, part in held.items():
        if not part:
            sys.exit(f"{path}: no rows of the {c} corpus (a directory named {c})")
    if not shared:
        sys.exit(f"{path}: no shared photos (half 'shared')")
    left_out = {id(r) for part in [shared, *held.values()] for r in part}
    fit = [r for r in rows if id(r) not in left_out and r["label"] != "borderline"]
    two = sum(len(r["s"]) > 1 for r in fit)
    print(f"## Fit: {len(fit)} native sources ({two} measured at two scales), "
          f"{len(shared)} shared photos\n")
    print("| offset | micro right | macro right | macro called micro | balanced | shared photos off |")
    print("|---|---|---|---|---|---|")
    best = None
    for d in [k / 4 for k in range(0, 25)] + [math.inf]:
        right = {lab: sum(verdict(r, d) == lab for r in fit if r["label"] == lab)
                 for lab in ("micro", "macro")}
        n = {lab: sum(r["label"] == lab for r in fit) for lab in ("micro", "macro")}
        called = sum(verdict(r, d) == "micro" for r in fit if r["label"] == "macro")
        acc = (right["micro"] / n["micro"] + right["macro"] / n["macro"]) / 2
        off = [r["name"] for r in shared if verdict(r, d) != r["label"]]
        if d == math.inf or d % 0.5 == 0 or not off:
            print(f"| {'one scale' if d == math.inf else d} | {right['micro']} of {n['micro']} | "
                  f"{right['macro']} of {n['macro']} | {called} | {acc:.3f} | "
                  f"{', '.join(off) or 'none'} |")
        if not off and d != math.inf and (best is None or acc >= best[0]):
            best = (acc, d)
    d = best[1]
    in_header = re.search(r"kFineScaleOffset = ([0-9.]+);", open(HEADER).read()).group(1)
    print(f"\nChosen: kFineScaleOffset = {d} (core/shape_verdict.h holds {in_header})")
    for corpus, part in held.items():
        print(f"\n## Held out: the {corpus} corpus's native sources, with the offset chosen\n")
        confusion(part, lambda r: verdict(r, d))
        print("\nWith one scale (the verdict before):\n")
        confusion(part, lambda r: verdict(r, math.inf))
        for label, k in (("macro", "micro"), ("micro", "macro"), ("macro", "borderline"),
                         ("micro", "borderline")):
            print(f"{label} called {k}:", [r["name"] for r in part
                                          if r["label"] == label and verdict(r, d) == k])


def main():
    if "--scales" in sys.argv:
        scales_study(sys.argv[sys.argv.index("--scales") + 1])
        return
    if "--candidates" in sys.argv:
        i = sys.argv.index("--candidates")
        refit_study(sys.argv[i + 1], sys.argv[i + 2])
        return
    rows = load(sys.argv[1])
    fit = [r for r in rows if (r["first"] or r["shapes"] and r["half"] == "fit")
           and r["label"] != "borderline"]

    print("## 1. Statistics, alone (fit set: threshold, balanced accuracy)\n")
    alone = []
    for i, s in enumerate(STATS):
        acc, t = best_threshold(fit, lambda r: r["x"][i])
        alone.append((acc, i))
        print(f"- {s}: excess > {t:.4f}: {acc:.3f}")
    order = [i for _, i in sorted(alone, reverse=True)]
    print("\n## Nested sets (5-fold cross-validated balanced accuracy on the fit set)\n")
    sets = [order[:k] for k in range(1, len(order) + 1)]
    cv = [(cross_validated(fit, cols, fit=logistic_gd), cols) for cols in sets]
    for acc, cols in cv:
        print(f"- {', '.join(STATS[i] for i in cols)}: {acc:.3f}")
    top = max(a for a, _ in cv)
    chosen = next(cols for a, cols in cv if a >= top - 0.005)
    print("\nIts L2 penalty, by the same cross-validation:")
    penalties = []
    for lam in (1.0, 0.1, 0.01):
        acc = cross_validated(fit, chosen, lam, fit=logistic_gd)
        penalties.append((acc, lam))
        print(f"- {lam}: {acc:.3f}")
    lam = max(penalties)[1]
    m = logistic_gd([project(r["x"], chosen) for r in fit], [r["y"] for r in fit], lam)
    weights = dict.fromkeys(STATS, 0.0)
    for i, w in zip(chosen, m[1]):
        weights[STATS[i]] = w
    print(f"\nChosen: {', '.join(STATS[i] for i in chosen)}")
    print("kShapeWeights{" + ", ".join(f"{v:.6f}" for v in [m[0]] + [weights[s] for s in STATS])
          + "}  (bias, tensor, tv, lines, specks)")

    def s_of(r):
        return score(m, project(r["x"], chosen))

    fit_macro = [r for r in fit if r["label"] == "macro"]
    def rates(b):
        return [sum(kind(s_of(r), b) == lab for r in fit if r["label"] == lab) /
                sum(r["label"] == lab for r in fit) for lab in ("micro", "macro")]

    band = max((b / 4 for b in range(0, 17) if min(rates(b / 4)) >= 0.9), default=0.0)
    if min(rates(band)) < 0.9:
        print("no band keeps 90% of each fit class right; band 0")
    print(f"kShapeBand = {band}")
    weights_h, band_h = shipped()
    same = (all(abs(a - b) < 5e-7 for a, b in zip(weights_h, [m[0]] + [weights[s] for s in STATS]))
            and band_h == band)
    print("core/shape_verdict.h holds " + ("these" if same else "OTHER constants: "
                                            + str((weights_h, band_h))))

    micro_rme = sorted(float(r["rme"]) for r in fit if r["label"] == "micro")
    rme_t = micro_rme[round(0.95 * (len(micro_rme) - 1))]
    acc, _ = best_threshold(fit, lambda r: float(r["rme"]))
    print(f"\n## RME threshold: {rme_t:.4f} (the RME alone separates micro from macro with a fit "
          f"balanced accuracy of {acc:.3f} at best)")
    for b in (0.0, 0.25, 0.5, 0.75, 1.0, 1.25):
        right = rates(b)
        called = sum(kind(s_of(r), b) == "micro" for r in fit_macro)
        print(f"- band {b}: fit micro right {right[0]:.2f}, macro right {right[1]:.2f}, "
              f"macro called micro {called}")

    print("\n## Fit set (as fitted)\n")
    confusion([r for r in rows if r["first"] or r["shapes"] and r["half"] == "fit"],
              lambda r: kind(s_of(r), band))
    if "--held-out" not in sys.argv:
        return
    for corpus, half in (("shapes", "held-out"), ("third", "held-out"), ("third", "fit"),
                         ("fourth", "held-out"), ("fourth", "fit")):
        part = [r for r in rows if r["corpus"].rstrip("/").endswith(corpus) and r["half"] == half]
        print(f"\n## The {corpus} corpus, its {half} half\n")
        confusion(part, lambda r: kind(s_of(r), band))
        for label in ("micro", "macro"):
            print(f"RME above {rme_t:.4f}: "
                  f"{sum(float(r['rme']) > rme_t for r in part if r['label'] == label)} of "
                  f"{sum(r['label'] == label for r in part)} {label}")
        for label, k in (("macro", "micro"), ("micro", "macro"), ("macro", "borderline"),
                         ("micro", "borderline")):
            print(f"{label} called {k}:", [r["name"] for r in part
                                          if r["label"] == label and kind(s_of(r), band) == k])


if __name__ == "__main__":
    main()
