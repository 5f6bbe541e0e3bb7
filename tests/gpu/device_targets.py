#!/usr/bin/python3
"""The GPU targets from device_check.sh's raw outputs, as one table.

  device_targets.py GPU OUT_DIR
OUT_DIR holds bench.txt and bench_listed.txt (`textond bench render`) and results.txt
("gpu_tests_rc N" and "tiles BACKEND LEVEL TILES_PER_S P99_MS ERRORS CPU_MS_PER_TILE" lines).
Exits 1 when a target is missed, 0 when all hold.
"""
import os
import sys


def rows(path):
    """The bench's table rows as lists of cells."""
    if not os.path.exists(path):
        return []
    with open(path) as f:
        return [[c.strip() for c in line.strip().strip("|").split("|")]
                for line in f if line.startswith("| ") and not line.startswith("|---")]


def number(text):
    try:
        return float(text.rstrip("x"))
    except ValueError:
        return None


def frame(table, backend, label, column):
    """A frame row of r = 64: column 3 ms, 4 GPU ms, 5 ms as 8-bit."""
    for r in table:
        if len(r) == 8 and r[0] == backend and r[1] == "64" and r[2].startswith(label):
            return number(r[column])
    return None


def batch(table, backend, calls):
    """GPU ms a tile: of 64 calls ("64") or one batch ("one batch")."""
    for r in table:
        if len(r) == 5 and r[0] == backend and r[1] == calls:
            gpu = number(r[4])
            return None if gpu is None else gpu / 64
    return None


def main():
    gpu, out = sys.argv[1], sys.argv[2]
    bench, listed = rows(os.path.join(out, "bench.txt")), rows(os.path.join(out, "bench_listed.txt"))
    tests_rc, tiles = None, {}
    with open(os.path.join(out, "results.txt")) as f:
        for line in f:
            w = line.split()
            if w[0] == "gpu_tests_rc":
                tests_rc = int(w[1])
            elif w[0] == "tiles":
                tiles[(w[1], int(w[2]))] = [float(v) for v in w[3:7]]

    checks = []  # (target, measured, holds)

    def check(target, measured, holds):
        checks.append((target, measured, "yes" if holds else "NO"))

    def fmt(v, unit=""):
        return "-" if v is None else f"{v:.2f}{unit}"

    check("GPU tests pass (agreement with the CPU, both kernels)", f"rc {tests_rc}", tests_rc == 0)
    cpu0, gpu0, auto0 = (tiles.get((b, 0)) for b in ("cpu", gpu, "auto"))
    if cpu0 and gpu0:
        ratio = gpu0[0] / cpu0[0] if cpu0[0] else 0
        check(f"1. level-0 tiles/s: {gpu} >= 5x cpu (goal 10x)",
              f"{gpu0[0]:.0f} / {cpu0[0]:.0f} = {ratio:.2f}x", ratio >= 5)
        check(f"1. {gpu}: 0 errors, p99 <= 100 ms at 256 connections",
              f"{gpu0[2]:.0f} errors, p99 {gpu0[1]:.1f} ms", gpu0[2] == 0 and gpu0[1] <= 100)
        worst = min(((v[0] / gpu0[0], lvl) for (b, lvl), v in tiles.items()
                     if b == gpu and gpu0[0] > 0), default=(None, None))
        check(f"2. every level keeps >= 2/3 of {gpu}'s level-0 tiles/s",
              f"worst level {worst[1]}: {fmt(worst[0], 'x')}",
              worst[0] is not None and worst[0] >= 2 / 3)
        check(f"6. {gpu}: <= 1.0 CPU-ms a cold PNG tile", f"{gpu0[3]:.2f} ms", gpu0[3] <= 1.0)
        driver = tiles.get((f"{gpu}-driver-wait", 0))
        if driver:
            checks.append((f"(info) 6. CPU-ms a tile: fences polled (default) / the driver's wait",
                           f"{gpu0[3]:.2f} / {driver[3]:.2f} ms "
                           f"({gpu0[0]:.0f} / {driver[0]:.0f} tiles/s)", "-"))
    if auto0 and cpu0 and gpu0:
        best = max(cpu0[0], gpu0[0])
        check("5. auto >= 0.9x the faster of cpu and GL at level 0",
              f"{auto0[0]:.0f} vs {best:.0f}", auto0[0] >= 0.9 * best)
    k4, hd = frame(bench, gpu, "4K", 4), frame(bench, gpu, "HD", 4)
    k4_8 = frame(bench, gpu, "4K", 5)
    check("3. 4K frame at r 64: <= 3 ms of GPU time (goal 1)", fmt(k4, " ms"),
          k4 is not None and k4 <= 3)
    check("3. 4K as 8-bit end to end <= 15 ms", fmt(k4_8, " ms"), k4_8 is not None and k4_8 <= 15)
    check("3. 4K GPU time <= 5x HD's", f"{fmt(k4)} / {fmt(hd)}",
          k4 is not None and hd and k4 <= 5 * hd)
    lone, batched = batch(bench, gpu, "64"), batch(bench, gpu, "one batch")
    check("4. a batch of 64: GPU ms a tile <= a lone tile's", f"{fmt(batched)} vs {fmt(lone)}",
          lone is not None and batched is not None and batched <= lone)
    k4_listed = frame(listed, gpu, "4K", 4)
    checks.append(("(info) 4K GPU ms with the host-listed kernel", fmt(k4_listed, " ms"), "-"))
    for (b, lvl), v in sorted(tiles.items()):
        checks.append((f"(info) {b} level {lvl}", f"{v[0]:.0f} tiles/s, p99 {v[1]:.1f} ms, "
                       f"{v[2]:.0f} errors, {v[3]:.2f} CPU-ms/tile", "-"))
    print("| target | measured | holds |\n|---|---|---|")
    for target, measured, holds in checks:
        print(f"| {target} | {measured} | {holds} |")
    sys.exit(1 if any(h == "NO" for _, _, h in checks) else 0)


if __name__ == "__main__":
    main()
