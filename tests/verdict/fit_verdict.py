#!/usr/bin/env python3
"""Chooses the micro/macro verdict's score and thresholds on the fit half of the corpus and
reports them on the held-out half. Reads the table of verdict_features.

  build/release/tests/verdict_features > features.tsv
  tests/verdict/fit_verdict.py features.tsv

Candidate scores: the current phase coherence (its index and each scale), each band's
log-kurtosis ratio against random phase in absolute value, and the largest of those over bands.
For each, the threshold that best separates the fit half's micro from its macro (balanced
accuracy; borderline textures are not scored). The best score's borderline band is that
threshold +- 25%: micro at or below 0.75 t, macro above 1.25 t (core/README.md, "Micro or macro").
"""
import csv
import sys


def scores(row):
    kr = [float(row[f"lr{s}"]) for s in (1, 2, 4, 8)]
    out = {"coherence": float(row["coherence"])}
    for s in ("c1", "c2", "c4"):
        out[f"coherence {s}"] = float(row[s])
    for s, v in zip((1, 2, 4, 8), kr):
        out[f"|log kurtosis ratio| sigma {s}"] = abs(v)
    out["max |log kurtosis ratio|, sigma 1-8"] = max(abs(v) for v in kr)
    out["max |log kurtosis ratio|, sigma 1-4"] = max(abs(v) for v in kr[:3])
    out["mean |log kurtosis ratio|, sigma 1-8"] = sum(abs(v) for v in kr) / 4
    return out


def best_threshold(pairs):
    """pairs: (score, is_macro). The threshold of best balanced accuracy (macro above it)."""
    values = sorted({s for s, _ in pairs})
    cuts = [(a + b) / 2 for a, b in zip(values, values[1:])]
    micro = [s for s, m in pairs if not m]
    macro = [s for s, m in pairs if m]
    best = None
    for t in cuts:
        acc = (sum(s <= t for s in micro) / len(micro) + sum(s > t for s in macro) / len(macro)) / 2
        if best is None or acc > best[1]:
            best = (t, acc)
    return best


def main():
    with open(sys.argv[1]) as f:
        rows = list(csv.DictReader(f, delimiter="\t"))
    fit = [r for r in rows if r["half"] == "fit" and r["label"] != "borderline"]
    held = [r for r in rows if r["half"] == "held-out"]
    print("| score | threshold (fit) | fit balanced accuracy | held-out balanced accuracy |")
    print("|---|---|---|---|")
    results = []
    for name in scores(fit[0]):
        t, acc = best_threshold([(scores(r)[name], r["label"] == "macro") for r in fit])
        hm = [r for r in held if r["label"] != "borderline"]
        micro = [r for r in hm if r["label"] == "micro"]
        macro = [r for r in hm if r["label"] == "macro"]
        hacc = (sum(scores(r)[name] <= t for r in micro) / len(micro) +
                sum(scores(r)[name] > t for r in macro) / len(macro)) / 2
        results.append((acc, name, t))
        print(f"| {name} | {t:.4f} | {acc:.3f} | {hacc:.3f} |")
    acc, name, t = max(results)
    lo, hi = 0.75 * t, 1.25 * t
    print(f"\nchosen on the fit half: {name} > {t:.4f} (fit balanced accuracy {acc:.3f}); "
          f"verdicts: micro <= {lo:.4f} < borderline <= {hi:.4f} < macro")

    def verdict(r):
        v = scores(r)[name]
        return "micro" if v <= lo else "macro" if v > hi else "borderline"
    for half in ("fit", "held-out"):
        part = [r for r in rows if r["half"] == half]
        print(f"\n{half} half (rows: label, columns: verdict)\n")
        print("| label | micro | borderline | macro | right |")
        print("|---|---|---|---|---|")
        for label in ("micro", "macro", "borderline"):
            rs = [r for r in part if r["label"] == label]
            n = {v: sum(verdict(r) == v for r in rs) for v in ("micro", "borderline", "macro")}
            right = f"{n[label]} of {len(rs)}" if label != "borderline" else "not scored"
            print(f"| {label} | {n['micro']} | {n['borderline']} | {n['macro']} | {right} |")
        missed = [r["name"] for r in part if r["label"] == "macro" and verdict(r) == "micro"]
        print(f"\nmacro called micro: {', '.join(missed) or 'none'}")


if __name__ == "__main__":
    main()
