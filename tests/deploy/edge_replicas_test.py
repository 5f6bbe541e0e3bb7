#!/usr/bin/python3
"""The deployment's shape on this machine, without containers: Redis, two textond replicas on it
(--store) and the nginx edge of deploy/base (deploy/local/edge-files.sh), then
shared_objects_check.py through the edge and against each replica,
the readiness probe of a replica that never wrote against a full Redis (item 8), damaged values
in Redis, and last a Redis outage behind the edge.

  edge_replicas_test.py TEXTOND EXEMPLARS_DIR
Prints what it checked and "N passed, M failed"; exits non-zero on a failure.
"""
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
sys.path.insert(0, os.path.join(HERE, "..", "support"))
from local_ports import free_port  # noqa: E402


def wait(what, probe, seconds=30):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        try:
            if probe():
                return
        except OSError:
            pass
        time.sleep(0.1)
    raise SystemExit(f"FAIL: {what} never happened")


def redis(port, *args):
    """One command over RESP (values of any size, which redis-cli's argv does not take)."""
    s = socket.create_connection(("127.0.0.1", port))
    parts = [a if isinstance(a, bytes) else str(a).encode() for a in args]
    s.sendall(b"*%d\r\n" % len(parts) + b"".join(b"$%d\r\n%s\r\n" % (len(p), p) for p in parts))
    f = s.makefile("rb")
    line = f.readline()
    if line.startswith(b"$") and int(line[1:]) >= 0:
        f.read(int(line[1:]) + 2)
    s.close()
    return line.strip()


def http(url, method="GET", body=None, headers=None):
    req = urllib.request.Request(url, data=body, method=method, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=60) as r:
            return r.status, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()


def post_exemplar(url, exemplars, name, query="size=16&iterations=5", headers=None):
    """POSTs a shared exemplar to `url` as a texton upload: (status, body)."""
    with open(os.path.join(exemplars, name), "rb") as f:
        return http(f"{url}/v1/textons?{query}", "POST", f.read(),
                    {"Content-Type": "image/png", **(headers or {})})


def damaged_values(rport, edge, replicas, tmp, exemplars, b_pid):
    """The review's attacks on the shared store: each is refused once,
    for what it is, without reading what cannot be held, and a fixed or recreated value serves."""
    import hashlib
    from form_bytes import multipart
    from png_bytes import rgba_png
    a, b = replicas
    ids = []
    for name, seed in (("etr_sand01.png", 51), ("etr_pebbles04.png", 52)):
        st, body = post_exemplar(a, exemplars, name, f"size=16&iterations=5&seed={seed}")
        assert st in (200, 201), body
        ids.append(json.loads(body)["id"])
    # A mix whose levels are 2 MB of noise under a matching checksum: refused (500), never
    # fetched, kept or quarantined again.
    fake = "f" * 64
    junk = os.urandom(2 << 20)
    redis(rport, "HSET", f"textond:v1:mix:{fake}", ".exr", junk, ".exr.sha256",
          hashlib.sha256(junk).hexdigest())
    sts = [http(f"{b}/v1/mixes/{fake}")[0] for _ in range(5)]
    assert sts == [500] * 5, sts
    left = [f for f in os.listdir(os.path.join(tmp, "data-b", "mixes")) if fake in f]
    quarantine = os.path.join(tmp, "data-b", "mixes", "quarantine")
    kept = os.listdir(quarantine) if os.path.isdir(quarantine) else []
    assert not left and not kept, (left, kept)
    print("a damaged mix under a matching checksum: 500 five times, fetched once, nothing kept")
    # A splat whose metadata's checksum is damaged: 500; repaired: served again.
    body, headers = multipart([("textons", f"{ids[0]},{ids[1]}", None),
                               ("weights", rgba_png(8, 8, 3), "w.png")])
    st, made = http(f"{a}/v1/splats", "POST", body, headers)
    assert st in (200, 201), made
    sid = json.loads(made)["id"]
    key = f"textond:v1:splat:{sid}"
    good = subprocess.run(["redis-cli", "-p", str(rport), "HGET", key, ".json.sha256"],
                          capture_output=True, text=True).stdout.strip()
    redis(rport, "HSET", key, ".json.sha256", "0" * 64)
    assert http(f"{b}/v1/splats/{sid}")[0] == 500
    redis(rport, "HSET", key, ".json.sha256", good)
    st, got = http(f"{b}/v1/splats/{sid}")
    assert st == 200, (st, got[:200])
    print("a splat refused for its checksum is served again once the checksum is right")
    # Deleted on b, created again on a at once: 201, and stored for every replica.
    assert http(f"{b}/v1/splats/{sid}", "DELETE")[0] == 204
    st, again = http(f"{a}/v1/splats", "POST", body, headers)
    assert st == 201, (st, again[:200])
    wait("the splat created again reaches b", lambda: http(f"{b}/v1/splats/{sid}")[0] == 200)
    print("a splat deleted on one replica and created again on the other: 201, served by both")
    mix = f"{a}/v1/mixes?u={ids[0]}&v={ids[1]}&levels=2&width=801"
    st, got = http(mix, "POST")
    assert st in (200, 201), got[:200]
    mid = json.loads(got)["id"]
    assert http(f"{a}/v1/mixes/{mid}")[0] == 200
    assert http(f"{b}/v1/mixes/{mid}", "DELETE")[0] == 204
    st, got = http(mix, "POST")
    assert st == 201, (st, got[:200])
    wait("the mix created again reaches b", lambda: http(f"{b}/v1/mixes/{mid}")[0] == 200)
    print("a mix deleted on one replica and created again on the other: 201, served by both")
    # A checksum field of 400 kB and a field name of 1 MB: refused unread.
    redis(rport, "HSET", f"textond:v1:texton:{'d' * 64}", "file", "x", "sha256", "s" * 400000)
    redis(rport, "ZADD", "textond:v1:ids", 0, "d" * 64)
    st, got = http(f"{b}/v1/textons/{'d' * 64}")
    assert st == 500 and b"not read" in got, (st, got[:200])
    redis(rport, "HSET", key, b"n" * (1 << 20) + b".sha256", "x")
    st, got = http(f"{b}/v1/splats/{sid}/tiles/4/0/0.png")
    assert st in (200, 500), (st, got[:200])  # b may still hold its copy; a fresh fetch refuses
    redis(rport, "HSET", f"textond:v1:mix:{'c' * 64}", ".exr", "x", b"n" * (1 << 20), "y")
    st, got = http(f"{b}/v1/mixes/{'c' * 64}")
    assert st == 500 and b"cannot hold" in got, (st, got[:200])
    print("a 400 kB checksum and a 1 MB field name: refused unread")
    # A key of another type: that id is refused (500), the list and the store stay up.
    redis(rport, "SET", f"textond:v1:texton:{'e' * 64}", "junk")
    redis(rport, "ZADD", "textond:v1:ids", 0, "e" * 64)
    st, got = http(f"{b}/v1/textons?limit=50")
    assert st == 200, (st, got[:200])
    assert http(f"{b}/v1/textons/{'e' * 64}")[0] == 500
    assert not get_json(b + "/readyz")["degraded"]
    print("a key of another type: 500 for its id, the list 200, the store up")
    # A member of the id index that no id can be (60 MB): left out by Redis, never received.
    redis(rport, "ZADD", "textond:v1:ids", 0, b"0" * (60 << 20))
    pid = b_pid
    def rss():
        with open(f"/proc/{pid}/status") as f:
            return int(next(l for l in f if l.startswith("VmRSS:")).split()[1]) // 1024
    before = rss()
    for _ in range(3):
        assert http(f"{b}/v1/textons?limit=1000")[0] == 200
    assert rss() - before < 40, (before, rss())
    redis(rport, "ZREM", "textond:v1:ids", b"0" * (60 << 20))
    print("a 60 MB member of the id index: left out, the list 200 without its memory")
    # Metadata past what a list reads (64 KiB an item, 8 MiB a page): skipped or left to the
    # next page, which the answer names.
    for i in range(150):
        tid = "%064x" % (i + 1)
        redis(rport, "HSET", f"textond:v1:texton:{tid}", "meta", "{" + " " * (60 << 10) + "}")
        redis(rport, "ZADD", "textond:v1:ids", 0, tid)
    st, got = http(f"{b}/v1/textons?limit=1000")
    page = json.loads(got)
    assert st == 200 and page["next"], (st, got[:300])
    print("150 metadata of 60 KiB: the page ends at 8 MiB and names the next")
    # The id index of another type: the list says so (500, not an empty 200), an upload is
    # refused before anything is written (500, the store still up), and once the index is
    # right again the same upload is stored and listed at once.
    redis(rport, "DEL", "textond:v1:ids")
    redis(rport, "SET", "textond:v1:ids", "junk")
    st, got = http(f"{b}/v1/textons")
    assert st == 500, (st, got[:200])
    with open(os.path.join(exemplars, "etr_floor01.png"), "rb") as f:
        floor = f.read()
    upload = f"{a}/v1/textons?size=16&iterations=5&seed=53"
    st, got = http(upload, "POST", floor, {"Content-Type": "image/png"})
    assert st == 500, (st, got[:200])
    assert not get_json(a + "/readyz")["degraded"]
    redis(rport, "DEL", "textond:v1:ids")
    st, got = http(upload, "POST", floor, {"Content-Type": "image/png"})
    assert st == 201, (st, got[:200])
    st, got = http(f"{b}/v1/textons")
    assert st == 200 and json.loads(got)["total"] == 1, (st, got[:300])
    print("an id index of another type: list 500, upload 500 with nothing written; fixed: 201")


def redis_outage(redis_proc, edge, replicas, exemplars):
    """Redis away: a list answers 503 on both replicas, and that answer does not take them out of
    the edge's ring (it had: every request, tiles of textons both replicas hold, 502 for 10 s)."""
    a, b = replicas
    st, body = post_exemplar(a, exemplars, "etr_sand01.png", "size=16&iterations=5&seed=61")
    assert st in (200, 201), body
    tid = json.loads(body)["id"]
    wait("both replicas hold the texton",
         lambda: all(http(f"{r}/v1/textons/{tid}")[0] == 200 for r in replicas))
    redis_proc.terminate()
    redis_proc.wait(20)
    for _ in range(3):  # nginx counts a 503 as a failure on every try but the last
        st, got = http(f"{edge}/v1/textons")
        assert st == 503 and b"store_unavailable" in got, (st, got[:200])
    sts = [http(f"{edge}/v1/textons/{tid}/tiles/0/{x}/3.png")[0] for x in range(8)]
    assert sts == [200] * 8, sts
    assert http(f"{edge}/healthz")[0] == 200
    print("Redis away: the list 503 through the edge three times, then 8 cold tiles 200 (no "
          "replica left the ring)")


def kit_after_delete(edge, replicas, exemplars):
    """A texton's engine kit, cached on both replicas, is 404 on the replica that did not take the
    DELETE as soon as its metadata is (it had been served for 40 s and more: the kit answered from
    the image cache before asking the store)."""
    a, b = replicas
    st, body = post_exemplar(edge, exemplars, "etr_pebbles04.png",
                             "size=16&iterations=5&seed=67")
    assert st in (200, 201), body
    tid = json.loads(body)["id"]
    kits = [http(f"{r}/v1/textons/{tid}/kit.tar") for r in replicas]
    assert [k[0] for k in kits] == [200, 200] and kits[0][1] == kits[1][1], \
        [k[0] for k in kits]
    assert http(f"{a}/v1/textons/{tid}", "DELETE")[0] == 204
    wait("the other replica sees the delete", lambda: http(f"{b}/v1/textons/{tid}")[0] == 404)
    for url in (b, edge):
        for method in ("GET", "HEAD"):
            st, _ = http(f"{url}/v1/textons/{tid}/kit.tar", method)
            assert st == 404, f"{method} {url} kit.tar after the delete: {st}"
    print("a kit cached on both replicas: 404 on the other one and through the edge once the "
          "texton is deleted")


def ranges_through_the_edge(edge, replicas, exemplars):
    """A Range through the edge is 206 with its bytes, whether the edge has the tile or not (it
    answered 200 with the whole tile: nginx serves ranges only of an upstream that says it takes
    them, and textond said Accept-Ranges on HEAD answers alone)."""
    st, body = post_exemplar(edge, exemplars, "etr_sand01.png", "size=16&iterations=5&seed=71")
    assert st in (200, 201), body
    tid = json.loads(body)["id"]
    st, whole = http(f"{replicas[0]}/v1/textons/{tid}/tiles/0/3/3.png")
    assert st == 200, st
    for attempt in ("a miss", "a hit"):
        req = urllib.request.Request(f"{edge}/v1/textons/{tid}/tiles/0/3/3.png",
                                     headers={"Range": "bytes=100-199"})
        with urllib.request.urlopen(req, timeout=60) as r:
            got = (r.status, r.headers.get("Content-Range"), r.read())
        assert got == (206, f"bytes 100-199/{len(whole)}", whole[100:200]), \
            f"{attempt}: {got[0]} {got[1]} {len(got[2])} bytes"
    print("a Range through the edge: 206 with those bytes, on a miss and on a hit")


def async_status_on_the_other_replica(edge, replicas, exemplars):
    """An upload that polls (202) is answered for by either replica: the one that does not run the
    analysis gives the state the other publishes (it had said 404 for the whole analysis, which
    the edge sends it half the time: the POST is spread by request, the status by the id)."""
    a, b = replicas
    st, body = post_exemplar(a, exemplars, "mypaint_HR_Cork.png",
                             "size=64&iterations=400&seed=71", {"Prefer": "respond-async"})
    assert st == 202, (st, body[:200])
    status = json.loads(body)["links"]["status"]
    seen = []
    end = time.monotonic() + 120
    while time.monotonic() < end:
        st, got = http(f"{b}{status}")
        state = json.loads(got).get("state") if st == 200 else st
        if not seen or seen[-1] != state:
            seen.append(state)
        if state == "done" or st != 200:
            break
        time.sleep(0.05)
    assert seen[-1] == "done" and all(s in ("queued", "running", "done") for s in seen), seen
    assert len(seen) > 1, f"the analysis ended before the other replica was asked: {seen}"
    print(f"an upload polled on the other replica: {' -> '.join(map(str, seen))}")


def get_json(url):
    with urllib.request.urlopen(url, timeout=10) as r:
        return json.loads(r.read())


def main():
    binary, exemplars = sys.argv[1], sys.argv[2]
    for tool in ("redis-server", "/usr/sbin/nginx"):
        if not shutil.which(tool):
            subprocess.run(["bash", os.path.join(ROOT, "docker", "install-deps.sh")], check=True)
    tmp = tempfile.mkdtemp(prefix="textond-edge-replicas-")
    os.chmod(tmp, 0o755)  # nginx workers drop root and walk into it for their cache
    procs = []
    nginx_conf = os.path.join(tmp, "edge", "nginx.conf")
    passed = failed = 0
    try:
        rport = free_port()
        os.makedirs(os.path.join(tmp, "redis"))
        procs.append(subprocess.Popen(
            ["redis-server", "--port", str(rport), "--bind", "127.0.0.1", "--save", "",
             "--dir", os.path.join(tmp, "redis"), "--maxmemory-policy", "noeviction"],
            stdout=subprocess.DEVNULL))
        cli = ["redis-cli", "-p", str(rport)]
        wait("redis", lambda: subprocess.run(cli + ["ping"], capture_output=True).stdout
             .strip() == b"PONG")
        replicas = []
        for name in ("a", "b"):
            log = open(os.path.join(tmp, f"{name}.log"), "w+")
            p = subprocess.Popen([binary, "serve", "--port", "0", "--data",
                                  os.path.join(tmp, f"data-{name}"), "--store",
                                  f"redis://127.0.0.1:{rport}", "--store-recheck-s", "1"],
                                 stdout=subprocess.PIPE, stderr=log)
            procs.append(p)
            line = p.stdout.readline().decode()
            assert "listening on" in line, line
            replicas.append(line.rsplit(" ", 1)[1].strip().rstrip("/"))
        nport = free_port()
        subprocess.run([os.path.join(ROOT, "deploy", "local", "edge-files.sh"),
                        os.path.join(tmp, "edge"), f"127.0.0.1:{nport}",
                        *[u.split("//", 1)[1] for u in replicas]], check=True,
                       env={**os.environ, "WORKER_PROCESSES": "1"})
        subprocess.run(["/usr/sbin/nginx", "-p", os.path.join(tmp, "edge"), "-c", nginx_conf],
                       check=True)
        edge = f"http://127.0.0.1:{nport}"
        wait("the edge", lambda: urllib.request.urlopen(edge + "/nginx-healthz").status == 200)

        check = subprocess.run([sys.executable, os.path.join(HERE, "shared_objects_check.py"),
                                edge, *replicas, "--exemplars", exemplars, "--wait-s", "30"])
        if check.returncode == 0:
            passed += 1
        else:
            failed += 1

        # Item 8: a replica that never wrote sees a nearly full Redis in its readiness probe,
        # and an evicting one; both clear when Redis has room again under noeviction.
        ok = True
        used = int([l for l in subprocess.run(cli + ["info", "memory"], capture_output=True,
                                                  text=True).stdout.splitlines()
                    if l.startswith("used_memory:")][0].split(":")[1])
        for setting, degraded in ((["maxmemory", str(used + (1 << 20))], True),
                                  (["maxmemory", "0"], False),
                                  (["maxmemory-policy", "allkeys-lru"], True),
                                  (["maxmemory-policy", "noeviction"], False)):
            subprocess.run(cli + ["config", "set", *setting], check=True, capture_output=True)
            ready = get_json(replicas[1] + "/readyz")
            if ready["degraded"] != degraded:
                print(f"FAIL: Redis {setting}: /readyz says degraded {ready['degraded']}: "
                      f"{json.dumps(ready['shared_store'])}")
                ok = False
            else:
                print(f"Redis {' '.join(setting)}: /readyz degraded {degraded}"
                      + (f" ({ready['shared_store'].get('error')})" if degraded else ""))
        passed, failed = (passed + 1, failed) if ok else (passed, failed + 1)
        for what, check in (
                ("damaged values in the shared store",
                 lambda: damaged_values(rport, edge, replicas, tmp, exemplars, procs[2].pid)),
                ("an upload's status on the other replica",
                 lambda: async_status_on_the_other_replica(edge, replicas, exemplars)),
                ("a kit after a delete on the other replica",
                 lambda: kit_after_delete(edge, replicas, exemplars)),
                ("a Range through the edge",
                 lambda: ranges_through_the_edge(edge, replicas, exemplars)),
                # last: it stops Redis
                ("a Redis outage behind the edge",
                 lambda: redis_outage(procs[0], edge, replicas, exemplars))):
            try:
                check()
                passed += 1
            except AssertionError as e:
                print(f"FAIL: {what}: {e}")
                failed += 1
    finally:
        if os.path.exists(os.path.join(tmp, "edge", "nginx.pid")):
            subprocess.run(["/usr/sbin/nginx", "-p", os.path.join(tmp, "edge"), "-c", nginx_conf,
                            "-s", "quit"], capture_output=True)
        for p in procs:
            p.terminate()
        for p in procs:
            try:
                p.wait(20)
            except subprocess.TimeoutExpired:
                p.kill()
        if failed:
            log = os.path.join(tmp, "edge", "error.log")
            if os.path.exists(log):
                with open(log) as f:
                    print("--- the edge's error log, last lines:\n" + "".join(f.readlines()[-10:]))
            for name in ("a", "b"):
                with open(os.path.join(tmp, f"{name}.log")) as f:
                    print(f"--- replica {name}, last lines:\n" + "".join(f.readlines()[-15:]))
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"{passed} passed, {failed} failed")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
