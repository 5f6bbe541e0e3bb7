#!/usr/bin/env python3
"""Chooses the micro/macro verdict (core/shape_verdict.h) and the RME threshold of the page's
wording on the fit halves, and reports them on the held-out half. Reads verdict_features' table.

  build/release/tests/verdict_features tests/verdict tests/verdict/shapes > features.tsv
  tests/verdict/fit_verdict.py features.tsv              # the choice, on the fit set
  tests/verdict/fit_verdict.py features.tsv --held-out   # and the held-out half's table

The fit set: the whole first corpus (tests/verdict: its held-out half has been seen) and the fit
half of the shapes corpus (tests/verdict/shapes); borderline textures are not scored. The
held-out set: the shapes corpus's held-out half, scored once after the choice.

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
import random
import sys

STATS = ("tensor", "tv", "lines", "specks")


def load(path):
    with open(path) as f:
        rows = list(csv.DictReader(f, delimiter="\t"))
    for r in rows:
        r["shapes"] = r["corpus"].rstrip("/").endswith("shapes")
        r["x"] = [float(r[s]) - float(r[s + "_null"]) for s in STATS]
        r["y"] = 1.0 if r["label"] == "macro" else 0.0
    return rows


def standardise(xs):
    n = len(xs)
    mu = [sum(x[i] for x in xs) / n for i in range(len(xs[0]))]
    sd = [math.sqrt(sum((x[i] - mu[i]) ** 2 for x in xs) / n) or 1.0 for i in range(len(mu))]
    return mu, sd


def logistic(xs, ys, lam=0.01, steps=6000, rate=0.5):
    """Balanced-class logistic regression by gradient descent on standardised inputs."""
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


def cross_validated(rows, cols, lam=0.01):
    accs = []
    for shuffle in range(3):
        order = rows[:]
        random.Random(shuffle).shuffle(order)
        for k in range(5):
            test = order[k::5]
            train = [r for i, r in enumerate(order) if i % 5 != k]
            m = logistic([project(r["x"], cols) for r in train], [r["y"] for r in train], lam)
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


def main():
    rows = load(sys.argv[1])
    fit = [r for r in rows if (not r["shapes"] or r["half"] == "fit") and r["label"] != "borderline"]
    held = [r for r in rows if r["shapes"] and r["half"] == "held-out"]

    print("## 1. Statistics, alone (fit set: threshold, balanced accuracy)\n")
    alone = []
    for i, s in enumerate(STATS):
        acc, t = best_threshold(fit, lambda r: r["x"][i])
        alone.append((acc, i))
        print(f"- {s}: excess > {t:.4f}: {acc:.3f}")
    order = [i for _, i in sorted(alone, reverse=True)]
    print("\n## Nested sets (5-fold cross-validated balanced accuracy on the fit set)\n")
    sets = [order[:k] for k in range(1, len(order) + 1)]
    cv = [(cross_validated(fit, cols), cols) for cols in sets]
    for acc, cols in cv:
        print(f"- {', '.join(STATS[i] for i in cols)}: {acc:.3f}")
    top = max(a for a, _ in cv)
    chosen = next(cols for a, cols in cv if a >= top - 0.005)
    print("\nIts L2 penalty, by the same cross-validation:")
    penalties = []
    for lam in (1.0, 0.1, 0.01):
        acc = cross_validated(fit, chosen, lam)
        penalties.append((acc, lam))
        print(f"- {lam}: {acc:.3f}")
    lam = max(penalties)[1]
    m = logistic([project(r["x"], chosen) for r in fit], [r["y"] for r in fit], lam)
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
    confusion([r for r in rows if not r["shapes"] or r["half"] == "fit"],
              lambda r: kind(s_of(r), band))
    if "--held-out" not in sys.argv:
        return
    print("\n## Held-out half of the shapes corpus\n")
    confusion(held, lambda r: kind(s_of(r), band))
    print(f"\nRME above {rme_t:.4f} on the held-out half: "
          f"{sum(float(r['rme']) > rme_t for r in held if r['label'] == 'micro')} of "
          f"{sum(r['label'] == 'micro' for r in held)} micro, "
          f"{sum(float(r['rme']) > rme_t for r in held if r['label'] == 'macro')} of "
          f"{sum(r['label'] == 'macro' for r in held)} macro")
    print("\nHeld-out macro called micro:",
          [r["name"] for r in held if r["label"] == "macro" and kind(s_of(r), band) == "micro"])
    print("Held-out micro called macro:",
          [r["name"] for r in held if r["label"] == "micro" and kind(s_of(r), band) == "macro"])


if __name__ == "__main__":
    main()
