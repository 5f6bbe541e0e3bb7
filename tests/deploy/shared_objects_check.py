#!/usr/bin/python3
"""What a client creates is read, deleted and bounded on every replica behind the edge, for any
deployment of two or more replicas on one Redis: the local edge test
(edge_replicas_test.py), the replicas load test, the compose and kube play tests.

  shared_objects_check.py EDGE_URL REPLICA_URL... [--exemplars DIR] [--rounds N]

Through the edge: two textons uploaded, a splat (RGBA weights) and a mix created. Then every route
of each, N times (20) from every replica directly and through the edge: all 200 with the same
bytes. A deletion through the edge reaches every replica (404 within --store-recheck-s, waited
for). Non-canonical spellings of a tile URL are 400 at the edge and at each replica. Prints one
line a check and exits non-zero on the first failure.
"""
import argparse
import http.client
import json
import os
import sys
import time
import urllib.parse

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from form_bytes import multipart  # noqa: E402
from png_bytes import rgba_png  # noqa: E402

HOST = "edge.test"  # one Host for all: TileJSON's absolute URLs come from it
SINGULAR = {"splats": "splat", "mixes": "mix"}


def request(base, method, path, body=None, headers=None, timeout=120):
    u = urllib.parse.urlsplit(base)
    c = http.client.HTTPConnection(u.hostname, u.port, timeout=timeout)
    c.request(method, path, body=body, headers={"Host": HOST, **(headers or {})})
    r = c.getresponse()
    data = r.read()
    c.close()
    return r.status, dict(r.getheaders()), data


def fail(why):
    raise SystemExit(f"FAIL: {why}")


def routes(kind, oid):
    """Every GET route of a splat or mix (openapi.yaml), with a few tile positions."""
    base = f"/v1/{kind}/{oid}"
    out = [base, f"{base}/tilejson.json", f"{base}/region.png?w=64&h=48&seed=3",
           f"{base}/tiles/0/0/1.png", f"{base}/tiles/2/-3/5.png?seed=9", f"{base}/tiles/1/4/4",
           f"{base}/map/0/1/1.png"]
    if kind == "splats":
        out.append(f"{base}/quality.png")
    return out


def same_everywhere(targets, path, rounds):
    first = None
    for _ in range(rounds):
        for t in targets:
            st, _, body = request(t, "GET", path)
            if st != 200:
                fail(f"{t}{path}: {st} {body[:200]!r}")
            if first is None:
                first = body
            elif body != first:
                fail(f"{t}{path}: other bytes than {targets[0]}")
    return first


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("edge")
    ap.add_argument("replicas", nargs="+")
    ap.add_argument("--exemplars", default=os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "shared", "data",
        "exemplars"))
    ap.add_argument("--rounds", type=int, default=20)
    ap.add_argument("--wait-s", type=float, default=60)
    a = ap.parse_args()
    targets = [a.edge, *a.replicas]

    ids = []
    for name, seed in (("etr_sand01.png", 41), ("etr_pebbles04.png", 42)):
        with open(os.path.join(a.exemplars, name), "rb") as f:
            st, _, body = request(a.edge, "POST", f"/v1/textons?size=16&iterations=5&seed={seed}",
                                  f.read(), {"Content-Type": "image/png"})
        if st not in (200, 201):
            fail(f"upload of {name} through the edge: {st} {body[:200]!r}")
        ids.append(json.loads(body)["id"])
    body, headers = multipart([("textons", f"{ids[0]},{ids[1]},{ids[0]}", None),
                               ("weights", rgba_png(16, 16, 5), "w.png"), ("scale", "8", None)])
    st, _, b = request(a.edge, "POST", "/v1/splats", body, headers)
    if st not in (200, 201):
        fail(f"splat through the edge: {st} {b[:200]!r}")
    splat = json.loads(b)["id"]
    st, _, b = request(a.edge, "POST", f"/v1/mixes?u={ids[0]}&v={ids[1]}&levels=3")
    if st not in (200, 201):
        fail(f"mix through the edge: {st} {b[:200]!r}")
    mix = json.loads(b)["id"]
    print(f"created through the edge: splat {splat[:12]}, mix {mix[:12]}")

    for kind, oid in (("splats", splat), ("mixes", mix)):
        for path in routes(kind, oid):
            same_everywhere(targets, path, a.rounds)
        print(f"every route of the {SINGULAR[kind]}, {a.rounds} times from the edge and "
              f"{len(a.replicas)} replicas: 200, the same bytes")

    # Item 5: one tile, one URL. The spellings that the edge would cache apart are refused.
    tile = f"/v1/splats/{splat}/tiles/0/0/1.png"
    for odd in (f"{tile}?seed=%37", f"{tile}?s%65ed=7", f"{tile}?seed=7&seed=7", f"{tile}?&seed=7",
                f"{tile}?seed=7&&", f"/v1/splats/{splat}/tiles/%30/0/1.png",
                f"/v1/splats/{splat}/tiles/0/0/1%2Epng", f"/v1%2Fsplats%2F{splat}/tiles/0/0/1.png",
                f"/v1/splats/{splat}%2Ftiles/0/0/1.png", f"/v1/splats/{splat}/tiles/0/0/1%402x.png",
                f"{tile}?seed=%3d7"):
        for t in targets:
            st, _, b = request(t, "GET", odd)
            if st != 400:
                fail(f"{t}{odd}: {st}, not 400 {b[:200]!r}")
    print("non-canonical spellings of a tile URL: 400 at the edge and at every replica")
    # The edge keys an image on its URI alone: a made-up Host is no new cache entry. (The load
    # test's edge caches only what asks X-Edge-Cache: on; the deployed one ignores the header.)
    tile = f"/v1/splats/{splat}/tiles/0/2/2.png"
    cached = {"X-Edge-Cache": "on"}
    request(a.edge, "GET", tile, headers=cached)
    st, h, _ = request(a.edge, "GET", tile, headers={**cached, "Host": "made-up.example"})
    if st != 200 or h.get("X-Cache-Status") != "HIT":
        fail(f"a tile asked with another Host: {st}, X-Cache-Status {h.get('X-Cache-Status')}")
    print("the edge caches an image once whatever the Host")

    # Item 7: deleted through the edge, gone on every replica.
    for kind, oid in (("splats", splat), ("mixes", mix)):
        st, _, b = request(a.edge, "DELETE", f"/v1/{kind}/{oid}")
        if st != 204:
            fail(f"DELETE /v1/{kind}/{oid} through the edge: {st} {b[:200]!r}")
        end = time.monotonic() + a.wait_s
        left = list(a.replicas)
        while left and time.monotonic() < end:
            left = [t for t in left if request(t, "GET", f"/v1/{kind}/{oid}")[0] != 404]
            time.sleep(0.2)
        if left:
            fail(f"the deleted {SINGULAR[kind]} is still served by {left}")
        for t in a.replicas:
            st, _, _ = request(t, "GET", f"/v1/{kind}/{oid}/tiles/3/3/3.png")
            if st != 404:
                fail(f"{t}: a new tile of the deleted {SINGULAR[kind]} answered {st}")
        st, _, _ = request(a.edge, "DELETE", f"/v1/{kind}/{oid}")
        if st != 404:
            fail(f"a second DELETE of the {SINGULAR[kind]} answered {st}")
    print("deleted through the edge: 404 on every replica, new tiles included")
    print("shared_objects_check: passed")


if __name__ == "__main__":
    main()
