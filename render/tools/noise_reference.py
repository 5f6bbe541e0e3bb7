#!/usr/bin/env python3
"""Independent reference of render/NOISE_SPEC.md, written from the page and nothing else.

Integers and IEEE doubles only, no numpy, no speed: it evaluates the level-0 field straight from
its definition (section 5) and the box-filtered levels as averages of level-0 values, never
through the tables the backends use. Its output, render/noise_vectors.json, is what the C++ and
GLSL implementations are tested against:

    python3 render/tools/noise_reference.py > render/noise_vectors.json
"""
import json
import math

M32 = 0xFFFFFFFF


def mix32(x):
    x &= M32
    x ^= x >> 16
    x = (x * 0x7FEB352D) & M32
    x ^= x >> 15
    x = (x * 0x846CA68B) & M32
    x ^= x >> 16
    return x


def absorb(h, w):
    return mix32(h ^ (w & M32))


def lo(v):
    return v & M32


def hi(v):
    return (v >> 32) & M32  # Python's >> on negatives is arithmetic: two's complement halves


def cell_key(seed, cx, cy):
    h = mix32(lo(seed) ^ 0x6A09E667)
    for w in (hi(seed), lo(cx), hi(cx), lo(cy), hi(cy)):
        h = absorb(h, w)
    return h


def pixel_key(seed, k, px, py):
    h = mix32(lo(seed) ^ 0xBB67AE85)
    for w in (hi(seed), k & M32, lo(px), hi(px), lo(py), hi(py)):
        h = absorb(h, w)
    return h


class Stream:
    def __init__(self, key):
        self.state = key

    def next(self):
        self.state = (self.state + 0x9E3779B9) & M32
        return mix32(self.state)


def exp_neg(mu):
    x = mu / 1024.0
    s = 1.0
    term = 1.0
    for n in range(1, 17):
        term = term * (-x) / n
        s = s + term
    for _ in range(10):
        s = s * s
    return s


def thresholds(mu):
    e = exp_neg(mu)
    p = e
    f = e
    out = []
    j = 0
    while len(out) < 256:
        if j > 0:
            p = p * mu / j
            f = f + p
        t = math.floor(f * 4294967296.0)
        if t >= 4294967295:
            break
        out.append(t)
        j += 1
    return out


def cell_size(r):
    return max(1, (5 * r + 4) // 8)


def poisson_count(d0, table):
    return sum(1 for t in table if t <= d0)


def cell_points(seed, cx, cy, a, table, period=None):
    kx, ky = (cx, cy) if period is None else (cx % period[0], cy % period[1])
    s = Stream(cell_key(seed, kx, ky))
    n = poisson_count(s.next(), table)
    pts = []
    for _ in range(n):
        dx, dy, de = s.next(), s.next(), s.next()
        qx, fx = (dx * a) >> 32, ((dx * a) & M32) >> 8
        qy, fy = (dy * a) >> 32, ((dy * a) & M32) >> 8
        eps = 1 if (de >> 31) == 0 else -1
        pts.append((cx * a + qx, fx, cy * a + qy, fy, eps))
    return pts


def psi(t, order):
    if order == 1:
        return max(0.0, 1.0 - abs(t))
    return 1.0 if 0.0 <= t < 1.0 else 0.0


def texton_h(alpha, r, order, y1, y2):
    """h(y) of section 5, per channel, straight from the sum over the support."""
    out = []
    for plane in alpha:
        acc = 0.0
        for k2 in range(r):
            w2 = psi(y2 - k2, order)
            if w2 == 0.0:
                continue
            for k1 in range(r):
                w1 = psi(y1 - k1, order)
                if w1 != 0.0:
                    acc += plane[k2 * r + k1] * w1 * w2
        out.append(acc)
    return out


def field0(tex, seed, mni, X1, X2, period=None):
    """f(X) at a real point X (texels), summing every point whose texton reaches X."""
    r, order = tex["size"], tex["order"]
    a = cell_size(r)
    lam = mni / (r * r)
    table = thresholds(lam * a * a)
    acc = [0.0] * len(tex["alpha"])
    for cy in range(math.floor((X2 - r - 1) / a), math.floor((X2 + 1) / a) + 1):
        for cx in range(math.floor((X1 - r - 1) / a), math.floor((X1 + 1) / a) + 1):
            for (bx, fx, by, fy, eps) in cell_points(seed, cx, cy, a, table, period):
                # Integer part first: X and b are exact, far from the origin too.
                y1 = (X1 - bx) - fx / 2.0**24
                y2 = (X2 - by) - fy / 2.0**24
                if -1 < y1 < r and -1 < y2 < r:
                    hv = texton_h(tex["alpha"], r, order, y1, y2)
                    acc = [s + eps * v for s, v in zip(acc, hv)]
    scale = 1.0 / math.sqrt(lam)
    return [m + scale * s for m, s in zip(tex["mean"], acc)]


def pixel(tex, seed, mni, level, px, py):
    if level <= 0:
        s = 2**-level
        return field0(tex, seed, mni, px / s, py / s)
    st = 2**level
    tot = None
    for dy in range(st):
        for dx in range(st):
            v = field0(tex, seed, mni, st * px + dx, st * py + dy)
            tot = v if tot is None else [p + q for p, q in zip(tot, v)]
    return [t / (st * st) for t in tot]


def normals(seed, level, px, py, channels):
    s = Stream(pixel_key(seed, level, px, py))
    out = []
    while len(out) < channels:
        u1 = ((s.next() >> 8) + 1) / 2.0**24
        u2 = (s.next() >> 8) / 2.0**24
        rr = math.sqrt(-2.0 * math.log(u1))
        out.append(rr * math.cos(2.0 * math.pi * u2))
        out.append(rr * math.sin(2.0 * math.pi * u2))
    return out[:channels]


def test_texton(r, channels, order):
    # Coefficients are multiples of 1/64 so that they are exact in float32 as well.
    alpha = []
    for c in range(channels):
        plane = []
        for y in range(r):
            for x in range(r):
                v = ((x * 7 + y * 13 + c * 5) % 17 - 8) / 64.0
                plane.append(v)
        alpha.append(plane)
    mean = [0.25, 0.5, 0.75][:channels]
    return {"size": r, "channels": channels, "order": order, "mean": mean, "alpha": alpha}


def main():
    seeds = [0, 1, 2, 1024, 0xFFFFFFFF, 0x100000000, 0xDEADBEEFCAFEF00D]
    cells = [(0, 0), (1, 0), (0, 1), (-1, -1), (1024, 0), (2**40, -(2**40)), (-(2**62), 2**62 - 1)]
    doc = {
        "spec": "textond-noise/1",
        "generator": "render/tools/noise_reference.py",
        "mix32": [[x, mix32(x)] for x in [0, 1, 2, 0x80000000, 0xFFFFFFFF, 0x12345678, 0x9E3779B9]],
        "cell_key": [[s, cx, cy, cell_key(s, cx, cy)] for s in seeds for (cx, cy) in cells],
        "pixel_key": [[s, k, px, py, pixel_key(s, k, px, py)]
                      for s in seeds for k in (-4, 0, 7, 24) for (px, py) in cells[:4]],
        "stream": [[key, [d for d in (lambda st: [st.next() for _ in range(8)])(Stream(key))]]
                   for key in [0, 1, 0xFFFFFFFF, cell_key(7, 3, -5)]],
        "exp_neg": [[mu, exp_neg(mu)] for mu in [0.0, 0.390625, 1.0, 11.71875, 78.125, 100.0]],
        "cell_size": [[r, cell_size(r)] for r in [1, 2, 8, 16, 32, 48, 64, 100, 128, 256]],
        "thresholds": [],
        "cell_points": [],
        "normals": [[s, k, px, py, normals(s, k, px, py, 3)]
                    for s in seeds[:2] + seeds[4:] for k in (6, 24) for (px, py) in cells[:4]],
        "textons": [],
        "field": [],
    }
    for mni in [1.0, 5.0, 30.0, 200.0]:
        for r in [8, 64]:
            a = cell_size(r)
            mu = mni / (r * r) * a * a
            doc["thresholds"].append({"mni": mni, "r": r, "mu": mu, "table": thresholds(mu)})
    for (seed, mni, r, cx, cy, period) in [(0, 30.0, 64, 0, 0, None), (5, 30.0, 64, -3, 7, None),
                                            (5, 1.0, 64, 2, 2, None), (9, 200.0, 16, 1, -1, None),
                                            (3, 30.0, 64, 2**40, -(2**40), None),
                                            (3, 30.0, 64, 7, -1, [4, 3]),
                                            (0xDEADBEEFCAFEF00D, 30.0, 64, -3, -7, None),
                                            (0x100000000, 30.0, 16, -1, 0, None)]:
        a = cell_size(r)
        table = thresholds(mni / (r * r) * a * a)
        doc["cell_points"].append({"seed": seed, "mni": mni, "r": r, "cx": cx, "cy": cy,
                                   "period": period,
                                   "points": [list(p) for p in cell_points(seed, cx, cy, a, table,
                                                                           period)]})
    textons = [test_texton(8, 3, 1), test_texton(8, 1, 0)]
    doc["textons"] = textons
    cases = [(0, 30.0, 0, 0, 0), (0, 30.0, 0, 5, -3), (7, 5.0, 0, -17, 40), (7, 30.0, -2, 9, -6),
             (11, 30.0, 1, 3, 4), (11, 30.0, 2, -2, 1), (1, 30.0, 0, 2**40, -(2**40)),
             (1, 30.0, -1, -(2**41) + 3, 2**41 + 1),
             # The seed's high 32 bits (section 2 absorbs all 64) and negative cells.
             (0xFFFFFFFF, 30.0, 0, -7, -2), (0x100000000, 30.0, 0, -3, 5),
             (0xDEADBEEFCAFEF00D, 30.0, 1, -40, -33), (0xDEADBEEFCAFEF00D, 5.0, -2, 6, -11)]
    for ti, tex in enumerate(textons):
        for (seed, mni, level, px, py) in cases:
            doc["field"].append({"texton": ti, "seed": seed, "mni": mni, "level": level,
                                 "x": px, "y": py, "value": pixel(tex, seed, mni, level, px, py)})
    print(json.dumps(doc, indent=1))


if __name__ == "__main__":
    main()
