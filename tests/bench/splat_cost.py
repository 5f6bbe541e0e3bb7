#!/usr/bin/env python3
"""Cold splat tiles over HTTP against cold tiles of one texton (a K = 4 splat tile at
most 4.5x a one-texton tile): one server on the CPU backend, one client asking distinct level-0
256x256 PNG tiles in turn; splats of K = 2 and 4 layers of that texton with even weights (a 2 x 2
RGBA weight image), so every layer shows in every tile. The three are asked in turn, tile by
tile, so that the machine's drift hits them alike; medians, two rounds. Prints a table.

  tests/bench/splat_cost.py [BINARY] [EXEMPLARS] [TILES]
"""
import http.client
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import uuid

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from png_bytes import grey_png  # noqa: E402

BINARY = sys.argv[1] if len(sys.argv) > 1 else "build/release/textond"
EXEMPLARS = sys.argv[2] if len(sys.argv) > 2 else "../shared/data/exemplars"
TILES = int(sys.argv[3]) if len(sys.argv) > 3 else 150


def form(parts):
    boundary = uuid.uuid4().hex
    out = b""
    for name, data, filename in parts:
        out += f'--{boundary}\r\nContent-Disposition: form-data; name="{name}"'.encode()
        if filename:
            out += f'; filename="{filename}"\r\nContent-Type: image/png'.encode()
        out += b"\r\n\r\n" + (data if isinstance(data, bytes) else data.encode()) + b"\r\n"
    return out + f"--{boundary}--\r\n".encode(), {
        "Content-Type": f"multipart/form-data; boundary={boundary}"}


def main():
    data = tempfile.mkdtemp(prefix="textond-splat-cost-")
    proc = subprocess.Popen([BINARY, "serve", "--port", "0", "--data", data, "--backend", "cpu",
                             "--log-level", "warn", "--no-access-log"], stdout=subprocess.PIPE)
    try:
        port = int(proc.stdout.readline().decode().rsplit(":", 1)[1].strip("/\n "))
        c = http.client.HTTPConnection("127.0.0.1", port, timeout=600)

        def ask(method, path, body=None, headers=None):
            c.request(method, path, body=body, headers=headers or {})
            r = c.getresponse()
            return r.status, r.read()

        with open(os.path.join(EXEMPLARS, "mypaint_HR_Cork.png"), "rb") as f:
            status, body = ask("POST", "/v1/textons?size=64", f.read(),
                               {"Content-Type": "image/png"})
        assert status in (200, 201), body
        tid = json.loads(body)["id"]
        splats = {}
        for k in (2, 4):
            weights = grey_png(2, 2, lambda y: bytes([255] * 8), colour_type=6)  # RGBA, all 1
            body, headers = form([("textons", ",".join([tid] * k), None),
                                  ("weights", weights, "w.png")])
            status, answer = ask("POST", "/v1/splats", body, headers)
            assert status in (200, 201), answer
            splats[k] = json.loads(answer)["id"]

        def one_ms(path):
            t0 = time.perf_counter()
            status, _ = ask("GET", path)
            assert status == 200
            return (time.perf_counter() - t0) * 1000

        print("| round | texton ms | K = 2 ms | ratio | K = 4 ms | ratio |\n|---|---|---|---|---|---|")
        for rnd in range(2):
            ms = {"plain": [], 2: [], 4: []}
            for x in range(TILES):
                ms["plain"].append(one_ms(f"/v1/textons/{tid}/tiles/0/{x}/{rnd}.png"))
                for k in (2, 4):
                    ms[k].append(one_ms(f"/v1/splats/{splats[k]}/tiles/0/{x}/{rnd}.png"))
            plain, two, four = (statistics.median(ms[key]) for key in ("plain", 2, 4))
            print(f"| {rnd + 1} | {plain:.2f} | {two:.2f} | {two / plain:.2f}x | {four:.2f} | "
                  f"{four / plain:.2f}x |")
    finally:
        proc.terminate()
        proc.wait(timeout=30)
        shutil.rmtree(data, ignore_errors=True)


if __name__ == "__main__":
    main()
