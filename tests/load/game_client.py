#!/usr/bin/python3
"""A game client flying a camera over the plane, as a terrain streamer does.

Each frame the camera moves, and the client wants the ring of tiles around it at three levels
(near, middle, far: LEVEL, LEVEL + 2, LEVEL + 4, the far rings covering 4 and 16 times the
ground). Tiles it holds in its LRU are used as they are, and revalidated with If-None-Match once
they are --revalidate-frames frames old (a 304 keeps them); the rest are fetched by a pool of
keep-alive connections. A 429 or 503 is retried after its Retry-After. A frame set is done when
every tile of the frame is in hand: its latency is what a player waits for a frame's ground.

Prints one line (and --json the same as JSON): frames, frame-set latency p50/p99, tiles fetched
per second, 304s, retries, errors, LRU hits. Exit status 1 when any tile failed after retries.

    game_client.py URL TEXTON_ID [--frames 120] [--ring 2] [--level 0] [--connections 8]
"""
import argparse
import collections
import http.client
import json
import math
import queue
import statistics
import sys
import threading
import time
import urllib.parse


class Connections:
    """Keep-alive HTTP/1.1 connections, one per worker thread."""

    def __init__(self, url):
        u = urllib.parse.urlsplit(url)
        self.host, self.port = u.hostname, u.port or 80
        self.local = threading.local()

    def get(self, path, headers):
        for attempt in range(2):  # a keep-alive connection the server closed: reconnect once
            conn = getattr(self.local, "conn", None)
            if conn is None:
                conn = self.local.conn = http.client.HTTPConnection(self.host, self.port, timeout=60)
            try:
                conn.request("GET", path, headers=headers)
                r = conn.getresponse()
                body = r.read()
                return r.status, r.getheader("ETag"), r.getheader("Retry-After"), body
            except (http.client.HTTPException, OSError):
                conn.close()
                self.local.conn = None
                if attempt:
                    raise
        raise AssertionError("unreachable")


class Client:
    def __init__(self, args):
        self.args = args
        self.conns = Connections(args.url)
        self.lru = collections.OrderedDict()  # path -> (etag, frame it was fetched in, bytes)
        self.frame_no = 0
        self.lock = threading.Lock()
        self.stats = collections.Counter()
        self.jobs = queue.Queue()
        for _ in range(args.connections):
            threading.Thread(target=self.worker, daemon=True).start()

    def path(self, level, x, y):
        return (f"/v1/textons/{self.args.texton}/tiles/{level}/{x}/{y}.png"
                f"?seed={self.args.seed}")

    def fetch(self, path, etag):
        headers = {"If-None-Match": etag} if etag else {}
        for attempt in range(1 + self.args.retries):
            status, new_etag, retry_after, body = self.conns.get(path, headers)
            if status not in (429, 503) or attempt == self.args.retries:
                return status, new_etag, body
            self.count("retries")
            try:  # delay-seconds; an HTTP-date (or nothing) waits a second
                delay = float(retry_after)
            except (TypeError, ValueError):
                delay = 1.0
            time.sleep(min(max(delay, 0.0), 10.0))
        raise AssertionError("unreachable")

    def worker(self):
        while True:
            path, etag, done = self.jobs.get()
            try:
                self.handle(path, etag)
            except Exception as e:  # counted; the frame must not wait forever
                self.count(f"status {type(e).__name__}")
                self.count("errors")
            finally:
                done.release()

    def handle(self, path, etag):
        try:
            status, new_etag, body = self.fetch(path, etag)
        except (http.client.HTTPException, OSError):
            status, new_etag, body = 0, None, b""
        with self.lock:
            if status == 200:
                self.stats["fetched"] += 1
                self.stats["bytes"] += len(body)
                self.put(path, new_etag, body)
            elif status == 304:
                self.stats["revalidated"] += 1
                held = self.lru.get(path)  # none if evicted meanwhile: fetched next time
                if held:
                    self.put(path, etag, held[2])
            else:
                self.stats["errors"] += 1
                self.stats[f"status {status}"] += 1

    def put(self, path, etag, body):
        self.lru[path] = (etag, self.frame_no, body)
        self.lru.move_to_end(path)
        while len(self.lru) > self.args.lru:
            self.lru.popitem(last=False)

    def count(self, what):
        with self.lock:
            self.stats[what] += 1

    def frame(self, cx, cy):
        """The tiles around texel (cx, cy) at three levels; returns when all are in hand."""
        wanted = []
        for k in range(3):
            level = self.args.level + 2 * k
            side = self.args.size * 2 ** level  # texels a tile spans
            tx, ty = math.floor(cx / side), math.floor(cy / side)
            r = self.args.ring
            wanted += [self.path(level, tx + i, ty + j) for j in range(-r, r + 1)
                       for i in range(-r, r + 1)]
        done = threading.Semaphore(0)
        sent = 0
        with self.lock:
            self.frame_no += 1
            for p in wanted:
                held = self.lru.get(p)
                if held and self.frame_no - held[1] < self.args.revalidate_frames:
                    self.stats["lru hits"] += 1
                    self.lru.move_to_end(p)
                    continue
                self.jobs.put((p, held[0] if held else None, done))
                sent += 1
        for _ in range(sent):
            done.acquire()
        return sent


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("url")
    ap.add_argument("texton")
    ap.add_argument("--frames", type=int, default=120)
    ap.add_argument("--ring", type=int, default=2, help="tiles each side of the camera (2: 5 x 5)")
    ap.add_argument("--level", type=int, default=0, help="the near ring's level")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--speed", type=float, default=48.0, help="texels the camera moves a frame")
    ap.add_argument("--connections", type=int, default=8)
    ap.add_argument("--lru", type=int, default=4096, help="tiles the client keeps")
    ap.add_argument("--revalidate-frames", type=int, default=30,
                    help="frames after which a held tile is revalidated (If-None-Match)")
    ap.add_argument("--retries", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()

    client = Client(args)
    latencies = []
    t0 = time.monotonic()
    cx, cy = 0.0, 0.0
    for f in range(args.frames):
        # A gentle curve: new ground ahead every frame, the rings behind kept by the LRU.
        heading = f * 0.02
        cx += args.speed * math.cos(heading)
        cy += args.speed * math.sin(heading)
        start = time.monotonic()
        client.frame(cx, cy)
        latencies.append((time.monotonic() - start) * 1000.0)
    wall = time.monotonic() - t0
    s = client.stats
    q = statistics.quantiles(latencies, n=100, method="inclusive")
    report = {
        "frames": args.frames, "frame_p50_ms": round(q[49], 1), "frame_p99_ms": round(q[98], 1),
        "tiles_per_s": round(s["fetched"] / wall, 1), "fetched": s["fetched"],
        "revalidated_304": s["revalidated"], "lru_hits": s["lru hits"], "retries": s["retries"],
        "errors": s["errors"], "mb": round(s["bytes"] / 1e6, 1), "wall_s": round(wall, 1),
        "failed": {k: v for k, v in s.items() if k.startswith("status ")},
    }
    if args.json:
        print(json.dumps(report))
    else:
        print(" ".join(f"{k}={v}" for k, v in report.items()))
    return 1 if s["errors"] else 0


if __name__ == "__main__":
    sys.exit(main())
