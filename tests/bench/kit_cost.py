#!/usr/bin/env python3
"""The CPU of one engine kit (GET kit.tar at an MNI not asked before), against admission's
model kit_work_s (server/http/image_routes.cpp): a x channels (a first form, a x channels x
r^2, was refuted by this table: r 32 and r 64 cost the same, the threshold tables dominate). Each exemplar is analysed at
r 32 and 64; exemplars are split by a rule fixed before any measurement: sorted by name, even
positions fit a (the mean of CPU / channels), odd ones report how far the model is from
their measured CPU. Prints a table.

  tests/bench/kit_cost.py [BINARY] [EXEMPLARS] [KITS_PER_EXEMPLAR]
"""
import http.client
import json
import os
import shutil
import subprocess
import sys
import tempfile

BINARY = sys.argv[1] if len(sys.argv) > 1 else "build/release/textond"
EXEMPLARS = sys.argv[2] if len(sys.argv) > 2 else "../shared/data/exemplars"
KITS = int(sys.argv[3]) if len(sys.argv) > 3 else 6
TICK = os.sysconf("SC_CLK_TCK")


def cpu_s(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK  # utime + stime


def main():
    data = tempfile.mkdtemp(prefix="textond-kit-cost-")
    proc = subprocess.Popen([BINARY, "serve", "--port", "0", "--data", data, "--log-level", "warn"],
                            stdout=subprocess.PIPE)
    port = int(proc.stdout.readline().decode().rsplit(":", 1)[1].strip("/\n "))
    names = sorted(n for n in os.listdir(EXEMPLARS) if n.endswith(".png"))
    rows = []
    try:
        c = http.client.HTTPConnection("127.0.0.1", port, timeout=600)
        for k, name, size in ((k, n, s) for k, n in enumerate(names) for s in (32, 64)):
            with open(os.path.join(EXEMPLARS, name), "rb") as f:
                c.request("POST", f"/v1/textons?size={size}", f.read(), {"Content-Type": "image/png"})
            r = c.getresponse()
            body = json.loads(r.read())
            tid, channels = body["id"], body["channels"]
            spent = []
            for m in range(KITS):
                before = cpu_s(proc.pid)
                c.request("GET", f"/v1/textons/{tid}/kit.tar?mni={11 + 17 * m}")
                r = c.getresponse()
                r.read()
                assert r.status == 200, r.status
                spent.append(cpu_s(proc.pid) - before)
            rows.append((name, "fit" if k % 2 == 0 else "report", size, channels,
                         sum(spent) / len(spent)))
    finally:
        proc.terminate()
        proc.wait()
        shutil.rmtree(data, ignore_errors=True)
    # The model: CPU = a x channels (each channel's tables and reference values).
    units = [(part, cpu, ch) for _, part, r, ch, cpu in rows]
    fit = [cpu / u for part, cpu, u in units if part == "fit"]
    a = sum(fit) / len(fit)
    print(f"| exemplar | part | r | channels | CPU a kit (s, mean of {KITS}) | model (s) | "
          "measured / model |")
    print("|---|---|---|---|---|---|---|")
    for name, part, r, ch, cpu in rows:
        model = a * ch
        print(f"| {name} | {part} | {r} | {ch} | {cpu:.3f} | {model:.3f} | {cpu / model:.2f} |")
    report = [cpu / (a * u) for part, cpu, u in units if part == "report"]
    print(f"\nfitted on {len(fit)} rows: a = {a:.3f} s a channel; held out ({len(report)} rows): "
          f"measured / model {min(report):.2f}-{max(report):.2f}")

if __name__ == "__main__":
    main()
