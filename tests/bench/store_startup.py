#!/usr/bin/python3
"""Start-up and memory of `textond serve` against the size of its store (the target:
readiness within 1 s at any store size, memory bounded by the metadata cache), in one run: an
empty store first (the baseline), then COUNT textons.

The textons are one small analysis written under COUNT ids: the bytes of its file with the id in
its metadata replaced (the coefficient checksum does not cover the id, and the store checks that
the id inside names the file), so every file is a valid texton of its own id.

Prints a table: time to the first 200 from /readyz, resident memory when ready, a listing's first
page and a page from the middle (limit 1000), the metadata of 2,000 textons read one by one
(first sight: each file read and verified), the memory after them and after 10,000 more reads
by four clients (with --meta-cache 2000: the memory must level off). With --check, exits non-zero
unless the listing walks every texton exactly once in id order (the CTest smoke, no timing).

usage: store_startup.py TEXTOND EXEMPLAR_PNG [COUNT] [--check]
"""
import http.client
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor

CACHE = 2000  # --meta-cache: small, so that the reads below pass it several times
READS = 12000


def rss_mb(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return -1.0


def fill(binary, exemplar, data, count):
    os.makedirs(os.path.join(data, "textons"), exist_ok=True)
    if count == 0:
        return []
    one = os.path.join(data, "one.exr")
    out = subprocess.run([binary, "analyze", exemplar, "--size", "16", "--iterations", "5",
                          "-o", one], check=True, capture_output=True, text=True).stdout
    first = json.loads(out)["id"]
    with open(one, "rb") as f:
        template = f.read()
    os.remove(one)
    assert template.count(first.encode()) >= 1, "the file does not hold its id as text"
    rng = random.Random(7)
    ids = sorted({"%064x" % rng.getrandbits(256) for _ in range(count)})
    parts = template.split(first.encode())
    for tid in ids:
        with open(os.path.join(data, "textons", tid + ".exr"), "wb") as f:
            f.write(tid.encode().join(parts))
    return ids


def get(port, path):
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    c.request("GET", path)
    r = c.getresponse()
    body = r.read()
    c.close()
    return r.status, body


def measure(binary, data, cache):
    t0 = time.monotonic()
    proc = subprocess.Popen([binary, "serve", "--port", "0", "--data", data, "--backend", "cpu",
                             "--log-level", "warn", "--no-access-log", "--meta-cache", str(cache)],
                            stdout=subprocess.PIPE, text=True)
    port = int(proc.stdout.readline().strip().rstrip("/").rsplit(":", 1)[1])
    while True:
        try:
            if get(port, "/readyz")[0] == 200:
                break
        except OSError:
            pass
        time.sleep(0.002)
    ready_s = time.monotonic() - t0
    return proc, port, ready_s


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    check = "--check" in sys.argv
    binary, exemplar = args[0], args[1]
    count = int(args[2]) if len(args) > 2 else 100000
    rows = []
    ok = True
    for n in (0, count):
        data = tempfile.mkdtemp(prefix="textond-store-bench-")
        try:
            t = time.monotonic()
            ids = fill(binary, exemplar, data, n)
            fill_s = time.monotonic() - t
            proc, port, ready_s = measure(binary, data, CACHE)
            try:
                time.sleep(0.5)
                ready_rss = rss_mb(proc.pid)
                t = time.monotonic()
                st, body = get(port, "/v1/textons?limit=1000")
                first_ms = (time.monotonic() - t) * 1000
                page = json.loads(body) if st == 200 else {}
                mid_ms = 0.0
                if ids:
                    t = time.monotonic()
                    get(port, f"/v1/textons?limit=1000&after={ids[len(ids) // 2]}")
                    mid_ms = (time.monotonic() - t) * 1000
                sample = random.Random(3).sample(ids, min(READS if not check else 200, len(ids)))
                t = time.monotonic()
                bad = sum(get(port, f"/v1/textons/{tid}")[0] != 200 for tid in sample[:2000])
                meta_ms = (time.monotonic() - t) * 1000 / max(1, min(2000, len(sample)))
                after_rss = rss_mb(proc.pid)
                # Four clients read the rest: the memory must level off at the cache's budget.
                with ThreadPoolExecutor(4) as pool:
                    bad += sum(st != 200 for st, _ in
                               pool.map(lambda i: get(port, f"/v1/textons/{i}"), sample[2000:]))
                more_rss = rss_mb(proc.pid)
                if check:  # the whole listing, page by page: every id once, in order
                    seen, after = [], ""
                    while True:  # pages of 300: several, and a short last one
                        st, body = get(port, "/v1/textons?limit=300" +
                                       (f"&after={after}" if after else ""))
                        items = json.loads(body)["items"]
                        seen += [i["id"] for i in items]
                        if len(items) < 300:
                            break
                        after = items[-1]["id"]
                    if seen != ids or bad:
                        print(f"FAIL: the listing gave {len(seen)} ids of {len(ids)} "
                              f"(in order: {seen == sorted(seen)}); {bad} metadata reads failed")
                        ok = False
            finally:
                proc.terminate()
                proc.wait(timeout=30)
            rows.append((n, fill_s, ready_s, ready_rss, first_ms, mid_ms, meta_ms, after_rss,
                         more_rss))
        finally:
            shutil.rmtree(data, ignore_errors=True)
    base = rows[0]
    print(f"--meta-cache {CACHE}; listing pages of 1000; metadata reads: 2,000 one by one, then "
          f"up to {READS - 2000} by four clients")
    print("| textons | ready s | / empty | RSS ready MB | first page ms | middle page ms "
          "| metadata ms each (first sight) | RSS after 2,000 reads MB | RSS after all MB |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n, _, ready_s, ready_rss, first_ms, mid_ms, meta_ms, after_rss, more_rss in rows:
        print(f"| {n} | {ready_s:.3f} | {ready_s / base[2]:.2f}x | {ready_rss:.0f} | "
              f"{first_ms:.1f} | {mid_ms:.1f} | {meta_ms:.2f} | {after_rss:.0f} | "
              f"{more_rss:.0f} |")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
