#!/usr/bin/python3
"""Two more families of micro/macro candidates, each comparing an exemplar with syntheses of its
own Gaussian model (core/README.md "Micro or macro", the refit studies): nearest-neighbour tests
on patches, and the geometry of excursion sets (Minkowski functionals). Prints, a statistic a row,
the AUC (the probability that a macro texture's value exceeds a micro one's) on each labelled
corpus and on all six, the micro crops' 95th percentile, and the value on each of the nine shared
photos; with --features, also the shipped verdict's four statistics refitted with and without each
family's best, scored on each corpus by a fit on the other five.

  tests/verdict/synthesis_null_study.py ../shared/data/exemplars [--features features.tsv]

features.tsv: build/release/tests/verdict_features over the six corpora (fit_verdict.py's usage).
Needs numpy (/usr/bin/python3) and oiiotool (openimageio-tools), which turns every crop into a
PPM under a temporary directory; about 8 minutes on 2 cores. Each crop: grey level, box-reduced to
about 256 pixels, its periodic component (Moisan), centred.

Patches: 4 ADSN syntheses of its periodogram (fixed seed); 8 x 8 patches on a grid (step 8 at
full scale, 4 at half scale):
  nnratio: log of the median distance from the synthesis's lower-half patches to the exemplar's
           upper-half patches over the same from the exemplar's own lower half;
  henze:   Henze's two-sample statistic, the share of pooled patches whose nearest neighbour is
           from their own image, less 0.5;
  nnnorm:  nnratio on patches with their mean removed and their norm divided out.
Excursion sets: the crop's grey levels mapped by rank onto a standard normal (its marginal made
Gaussian), and 4 ADSN syntheses of that image's periodogram, so that the syntheses share its
marginal and its spectrum and differ only in geometry; both blurred by a Gaussian of sigma 1 (_s1)
or 2 (_s2); at 17 thresholds from -2 to 2, the Euler characteristic (8-connected, on the torus)
and the perimeter of {u > t}:
  chiabs:  log((sum |chi| of the syntheses + 1) / (sum |chi| of the exemplar + 1)): fewer
           components and holes than a Gaussian field of the same spectrum;
  perlog:  log(perimeter of the syntheses / perimeter of the exemplar): shorter outlines.
"""
import csv
import glob
import math
import os
import subprocess
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)))
CORPORA = {"first": ROOT, "shapes": ROOT + "/shapes", "third": ROOT + "/third",
           "fourth": ROOT + "/fourth", "fifth": ROOT + "/fifth", "sixth": ROOT + "/sixth"}
SHARED = ["skimage_gravel", "skimage_grass", "mypaint_HR_DecoPaper", "etr_floor01",
          "etr_pebbles04", "etr_sand01", "mypaint_HR_Cork", "skimage_brick", "etr_pave02"]


def to_ppm(src, dst):
    """The crop as an 8-bit RGB PPM; a grey one's channel three times (oiiotool fills a channel
    it does not find with zeros)."""
    info = subprocess.run(["oiiotool", "--info", "-v", src], capture_output=True, text=True)
    names = [n.strip() for line in info.stdout.splitlines() if "channel list:" in line
             for n in line.split(":", 1)[1].split(",")]
    if not names:
        raise RuntimeError("oiiotool could not read " + src)
    ch = "R,G,B" if {"R", "G", "B"} <= set(names) else ",".join([names[0]] * 3)
    if subprocess.run(["oiiotool", src, "--ch", ch, "-d", "uint8", "-o", dst],
                      capture_output=True).returncode != 0:
        raise RuntimeError("oiiotool could not convert " + src)


def read_ppm(path):
    data = open(path, "rb").read()
    fields, i = [], 0
    while len(fields) < 4:
        while data[i:i + 1].isspace():
            i += 1
        j = i
        while not data[j:j + 1].isspace():
            j += 1
        fields.append(data[i:j])
        i = j
    w, h = int(fields[1]), int(fields[2])
    return np.frombuffer(data[i + 1:i + 1 + w * h * 3], np.uint8).reshape(h, w, 3) / 255.0


def periodic(u):
    h, w = u.shape
    v = np.zeros_like(u)
    v[0, :] += u[-1, :] - u[0, :]
    v[-1, :] += u[0, :] - u[-1, :]
    v[:, 0] += u[:, -1] - u[:, 0]
    v[:, -1] += u[:, 0] - u[:, -1]
    den = (2 * np.cos(2 * np.pi * np.arange(h)[:, None] / h) +
           2 * np.cos(2 * np.pi * np.arange(w)[None, :] / w) - 4)
    den[0, 0] = 1
    s = np.fft.fft2(v) / den
    s[0, 0] = 0
    return u - np.real(np.fft.ifft2(s))


def box(u, f):
    if f <= 1:
        return u
    h, w = u.shape[0] // f, u.shape[1] // f
    return u[:h * f, :w * f].reshape(h, f, w, f).mean(axis=(1, 3))


def patches(u, p, step):
    return np.array([u[y:y + p, x:x + p].ravel() for y in range(0, u.shape[0] - p + 1, step)
                     for x in range(0, u.shape[1] - p + 1, step)])


def nearest(q, d):
    dist = (q * q).sum(1)[:, None] + (d * d).sum(1)[None, :] - 2 * q @ d.T
    return np.sqrt(np.maximum(dist.min(1), 0))


def henze(a, b):
    pooled = np.vstack([a, b])
    sq = (pooled * pooled).sum(1)
    dist = sq[:, None] + sq[None, :] - 2 * pooled @ pooled.T
    np.fill_diagonal(dist, np.inf)
    j = dist.argmin(1)
    return ((np.arange(len(pooled)) < len(a)) == (j < len(a))).mean() - 0.5


def normed(p):
    p = p - p.mean(1, keepdims=True)
    return p / (np.linalg.norm(p, axis=1, keepdims=True) + 1e-6)


def statistics(path):
    g = read_ppm(path).mean(2)
    u = periodic(box(g, max(1, min(g.shape) // 256)))
    u = u - u.mean()
    rng = np.random.default_rng(12345)
    spectrum = np.fft.fft2(u)
    syn = [np.real(np.fft.ifft2(spectrum * np.fft.fft2(rng.standard_normal(u.shape)))) /
           np.sqrt(u.size) for _ in range(4)]
    sd = u.std() + 1e-12
    out = {}
    for scale in (1, 2):
        uu, ss = box(u, scale) / sd, [box(s, scale) / sd for s in syn]
        step, half = (8 if scale == 1 else 4), uu.shape[0] // 2
        top, low = patches(uu[:half], 8, step), patches(uu[half:], 8, step)
        own = np.median(nearest(low, top))
        other = np.mean([np.median(nearest(patches(s[half:], 8, step), top)) for s in ss])
        out["nnratio_s%d" % scale] = np.log(other / own) if own > 0 else np.nan
        whole = patches(uu, 8, step)
        out["henze_s%d" % scale] = np.mean([henze(whole, patches(s, 8, step)) for s in ss[:2]])
        own_n = np.median(nearest(normed(low), normed(top)))
        other_n = np.mean([np.median(nearest(normed(patches(s[half:], 8, step)), normed(top)))
                           for s in ss])
        out["nnnorm_s%d" % scale] = np.log(other_n / own_n) if own_n > 0 else np.nan
    out.update(excursion_statistics(u, np.random.default_rng(7)))
    return out


_QUANTILES = {}


def normal_quantiles(n):
    """Phi^-1((k + 0.5) / n), k < n: the values a rank takes in a Gaussianised image."""
    if n not in _QUANTILES:
        p = (np.arange(n) + 0.5) / n
        x = np.sqrt(2) * np.sign(p - 0.5) * np.sqrt(-np.log(4 * p * (1 - p)))  # a start
        erf = np.vectorize(math.erf)
        for _ in range(30):  # Newton on Phi(x) = p
            x = x - (0.5 * (1 + erf(x / np.sqrt(2))) - p) / (np.exp(-x * x / 2) / np.sqrt(2 * np.pi))
        _QUANTILES[n] = x
    return _QUANTILES[n]


def blur(u, sigma):
    fy, fx = np.fft.fftfreq(u.shape[0])[:, None], np.fft.fftfreq(u.shape[1])[None, :]
    g = np.exp(-2 * (np.pi * sigma) ** 2 * (fx ** 2 + fy ** 2))
    return np.real(np.fft.ifft2(np.fft.fft2(u) * g))


def excursion_curves(a):
    """Euler characteristic and perimeter of {a > t} at 17 thresholds, a standardised."""
    a = (a - a.mean()) / a.std()
    chi, per = [], []
    for t in np.linspace(-2, 2, 17):
        b = a > t
        up, left = np.roll(b, 1, 0), np.roll(b, 1, 1)
        vertices = (b | up | left | np.roll(up, 1, 1)).sum()
        chi.append(vertices - (b | up).sum() - (b | left).sum() + b.sum())
        per.append((b != up).sum() + (b != left).sum())
    return np.array(chi, float), np.array(per, float)


def excursion_statistics(u, rng):
    g = np.empty(u.size)
    g[np.argsort(u.ravel(), kind="stable")] = normal_quantiles(u.size)
    g = g.reshape(u.shape)
    spectrum = np.fft.fft2(g)
    syn = [np.real(np.fft.ifft2(spectrum * np.fft.fft2(rng.standard_normal(u.shape)))) /
           np.sqrt(u.size) for _ in range(4)]
    out = {}
    for sigma in (1, 2):
        chi, per = excursion_curves(blur(g, sigma))
        null = [excursion_curves(blur(s, sigma)) for s in syn]
        chi_null = np.mean([c for c, _ in null], 0)
        per_null = np.mean([p for _, p in null], 0)
        out["chiabs_s%d" % sigma] = np.log((np.abs(chi_null).sum() + 1) / (np.abs(chi).sum() + 1))
        out["perlog_s%d" % sigma] = np.log(per_null.sum() / per.sum())
    return out


def auc(pos, neg):
    pos, neg = np.array(pos)[:, None], np.array(neg)[None, :]
    return (pos > neg).mean() + 0.5 * (pos == neg).mean()


def main():
    shared_dir = sys.argv[1]
    work = tempfile.mkdtemp(prefix="synthesis-null-study-")
    jobs = []  # (corpus, name, label, source)
    for corpus, d in CORPORA.items():
        for r in csv.DictReader(open(d + "/corpus.tsv"), delimiter="\t"):
            stem = d + "/corpus/" + r["name"]
            src = stem + ".png" if os.path.exists(stem + ".png") else stem + ".jpg"
            jobs.append((corpus, r["name"], r["label"], src))
    jobs += [("shared", n, "", os.path.join(shared_dir, n + ".png")) for n in SHARED]
    ppms = [os.path.join(work, "%s__%s.ppm" % (c, n)) for c, n, _, _ in jobs]
    with ProcessPoolExecutor() as ex:
        list(ex.map(to_ppm, [j[3] for j in jobs], ppms))
        stats = list(ex.map(statistics, ppms, chunksize=4))
    for f in glob.glob(work + "/*.ppm"):
        os.remove(f)
    os.rmdir(work)
    names = list(stats[0])
    print("statistic\t" + "\t".join(CORPORA) + "\tall six\tmicro p95\t" + "\t".join(SHARED))
    for x in names:
        row, macro_all, micro_all = [], [], []
        for corpus in CORPORA:
            macro = [s[x] for (c, _, l, _), s in zip(jobs, stats) if c == corpus and l == "macro"]
            micro = [s[x] for (c, _, l, _), s in zip(jobs, stats) if c == corpus and l == "micro"]
            macro, micro = [v for v in macro if v == v], [v for v in micro if v == v]
            macro_all += macro
            micro_all += micro
            row.append("%.3f" % auc(macro, micro))
        shared = {n: s[x] for (c, n, _, _), s in zip(jobs, stats) if c == "shared"}
        print("\t".join([x] + row + ["%.3f" % auc(macro_all, micro_all),
                                     "%.3f" % np.percentile(micro_all, 95)] +
                        ["%.3f" % shared[n] for n in SHARED]))
    if "--features" in sys.argv:
        refits(sys.argv[sys.argv.index("--features") + 1], jobs, stats)


def refits(features, jobs, stats):
    """The shipped verdict's four statistics refitted (fit_verdict.py's balanced logistic
    regression), alone and with each candidate added: per corpus, fitted on the other five and
    scored with the verdict's band of +-0.25."""
    sys.path.insert(0, ROOT)
    import fit_verdict as fv
    extra = {(c, n): s for (c, n, _, _), s in zip(jobs, stats)}
    rows = []
    for r in fv.load(features):
        corpus = r["corpus"].rstrip("/").split("/")[-1]
        corpus = "first" if corpus == "verdict" else corpus
        if r["label"] in ("micro", "macro") and (corpus, r["name"]) in extra:
            r["c"], r["extra"] = corpus, extra[(corpus, r["name"])]
            rows.append(r)
    print("\nrefit, each corpus scored by a fit on the other five: micro right, macro right, "
          "macro called micro (of %d micro, %d macro)" %
          (sum(r["label"] == "micro" for r in rows), sum(r["label"] == "macro" for r in rows)))
    shipped = [float(r["score"]) for r in rows]
    for added in [[], ["chiabs_s1"], ["perlog_s1"], ["chiabs_s1", "perlog_s1"], ["henze_s1"],
                  ["nnratio_s1"]]:
        score = {}
        for corpus in CORPORA:
            train = [r for r in rows if r["c"] != corpus]
            model = fv.logistic([r["x"] + [r["extra"][a] for a in added] for r in train],
                                [r["y"] for r in train], 0.01)
            for i, r in enumerate(rows):
                if r["c"] == corpus:
                    score[i] = fv.score(model, r["x"] + [r["extra"][a] for a in added])
        print_counts("four + " + (",".join(added) or "nothing"), rows, score)
    print_counts("shipped (as fitted)", rows, dict(enumerate(shipped)))


def print_counts(name, rows, score):
    micro = sum(score[i] <= -0.25 for i, r in enumerate(rows) if r["label"] == "micro")
    macro = sum(score[i] > 0.25 for i, r in enumerate(rows) if r["label"] == "macro")
    lost = sum(score[i] <= -0.25 for i, r in enumerate(rows) if r["label"] == "macro")
    print("%-34s %d\t%d\t%d" % (name, micro, macro, lost))


if __name__ == "__main__":
    main()
