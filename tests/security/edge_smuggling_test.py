#!/usr/bin/python3
"""Request smuggling through the shipped nginx edge (deploy/base/nginx, made local by
deploy/local/edge-files.sh as `make run-edge` does): smugglers send GET, HEAD, OPTIONS and DELETE
requests carrying Content-Length or chunked bodies that hold a hidden request (
a cold tile, tagged X-Request-Id: smuggled-N), while ordinary clients on keep-alive connections fetch tiles no
one else asks for; first, each attack is followed at once by an ordinary request, which nginx
sends down the upstream connection the attack just freed. Every ordinary client must get exactly
the answer to its own request: the
bytes textond gives for that URL, never a smuggled request's X-Request-Id, and the edge's pooled
upstream connections must never deliver a hidden request's answer.

usage: edge_smuggling_test.py TEXTOND EXEMPLARS_DIR
Prints "N passed, M failed" (checks); exits non-zero on any failure.
"""
import http.client
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from local_ports import free_port  # noqa: E402

BINARY = sys.argv[1] if len(sys.argv) > 1 else "build/release/textond"
EXEMPLARS = sys.argv[2] if len(sys.argv) > 2 else "../shared/data/exemplars"
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CLIENTS, REQUESTS, SMUGGLERS, ATTACKS = 6, 25, 3, 20

failures = []
passed = 0


def check(cond, what):
    global passed
    if cond:
        passed += 1
    else:
        failures.append(what)
        print("FAIL:", what, file=sys.stderr)


def wait_port(port, seconds=20):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            return True
        except OSError:
            time.sleep(0.1)
    return False


def hidden(n, tid):
    # A cold tile: its answer comes a few milliseconds late, after nginx has put the upstream
    # connection back in its pool, which is when a stale answer reaches the next client.
    return (f"GET /v1/textons/{tid}/tiles/0/{n}/{n}.png?seed={n} HTTP/1.1\r\nHost: x\r\n"
            f"X-Request-Id: smuggled-{n}\r\n\r\n").encode()


def attacks(tid):
    """Raw requests, each hiding one request in a body the method should not have."""
    out = []
    for n in range(ATTACKS):
        body = hidden(n, tid)
        method = ("GET", "HEAD", "OPTIONS", "DELETE")[n % 4]
        path = "/healthz" if method != "DELETE" else f"/v1/textons/{'0' * 64}"
        head = f"{method} {path} HTTP/1.1\r\nHost: x\r\n".encode()
        if n % 2:
            out.append(head + b"Transfer-Encoding: chunked\r\n\r\n" + b"%x\r\n" % len(body) + body +
                       b"\r\n0\r\n\r\n")
        else:
            out.append(head + b"Content-Length: %d\r\n\r\n" % len(body) + body)
    return out


def smuggle(port, payloads, seen):
    for p in payloads:
        try:
            s = socket.create_connection(("127.0.0.1", port), timeout=10)
            s.sendall(p)
            s.settimeout(3)
            got = b""
            while True:
                c = s.recv(65536)
                if not c:
                    break
                got += c
                # One answer read whole is enough: the edge keeps the connection open.
                head, _, rest = got.partition(b"\r\n\r\n")
                length = [l for l in head.split(b"\r\n") if l.lower().startswith(b"content-length:")]
                if length and len(rest) >= int(length[0].split(b":")[1]):
                    break
                if len(got) > (4 << 20):
                    break
            s.close()
        except OSError:
            continue
        seen.append(got)


def client(port, tid, k, results):
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    for i in range(REQUESTS):
        url = f"/v1/textons/{tid}/tiles/0/{k}/{i}.png?seed={1000 + k}"
        try:
            conn.request("GET", url)
            r = conn.getresponse()
            body = r.read()
            results.append((url, r.status, r.getheader("X-Request-Id", ""), body))
        except (OSError, http.client.HTTPException) as e:
            results.append((url, -1, str(e), b""))
            conn.close()
            conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    conn.close()


SECURITY_HEADERS = ("X-Content-Type-Options", "Referrer-Policy", "X-Frame-Options",
                    "Content-Security-Policy")


def headers_of(port, method, path, extra=b""):
    """Status and header lines (name lower-cased, repeats kept) of one raw request."""
    s = socket.create_connection(("127.0.0.1", port), timeout=30)
    s.sendall(f"{method} {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n".encode() + extra +
              b"\r\n")
    got = b""
    while b"\r\n\r\n" not in got:
        c = s.recv(65536)
        if not c:
            break
        got += c
    s.close()
    lines = got.split(b"\r\n\r\n", 1)[0].decode("latin-1").split("\r\n")
    status = int(lines[0].split()[1]) if len(lines[0].split()) > 1 else None
    return status, [(k.strip().lower(), v.strip()) for k, v in
                    (l.split(":", 1) for l in lines[1:] if ":" in l)]


def check_security_headers(edge_port, app_port, tid):
    """Each answer through the edge, nginx's own errors included, carries textond's security
    headers once, with textond's values."""
    _, direct = headers_of(app_port, "GET", "/")
    want = {k.lower(): v for k, v in direct if k in [h.lower() for h in SECURITY_HEADERS]}
    check(len(want) == len(SECURITY_HEADERS), f"textond sends its security headers ({want})")
    cases = [("GET", "/", b""), ("GET", f"/v1/textons/{tid}/tiles/0/0/0.png", b""),
             ("GET", f"/v1/textons/{tid}/tiles/0/0/0.png", b""),  # a cache hit
             ("GET", f"/v1/textons/{'0' * 64}", b""), ("GET", "/nginx-healthz", b""),
             # nginx's own 400, before any location
             ("POST", "/v1/textons", b"Content-Length: 1\r\nContent-Length: 2\r\n")]
    for method, path, extra in cases:
        status, hs = headers_of(edge_port, method, path, extra)
        for name in SECURITY_HEADERS:
            values = [v for k, v in hs if k == name.lower()]
            check(values == [want.get(name.lower())],
                  f"{method} {path} ({status}) through the edge: {name} once, as textond sends it "
                  f"(got {values})")


def main():
    tmp = tempfile.mkdtemp(prefix="textond-edge-")
    os.chmod(tmp, 0o755)  # nginx's workers drop root and write their cache below it
    edge_dir = os.path.join(tmp, "edge")
    data = os.path.join(tmp, "data")
    app_port, edge_port = free_port(), free_port()
    server = subprocess.Popen([BINARY, "serve", "--host", "127.0.0.1", "--port", str(app_port),
                               "--data", data, "--backend", "cpu", "--log-level", "warn"],
                              stdout=subprocess.DEVNULL)
    env = {**os.environ, "LOAD_TEST": "1", "WORKER_PROCESSES": "2"}
    subprocess.run([os.path.join(ROOT, "deploy/local/edge-files.sh"), edge_dir,
                    f"127.0.0.1:{edge_port}", f"127.0.0.1:{app_port}"], check=True, env=env)
    nginx = ["/usr/sbin/nginx", "-p", edge_dir, "-c", os.path.join(edge_dir, "nginx.conf")]
    try:
        check(wait_port(app_port), "textond listens")
        subprocess.run(nginx, check=True)
        check(wait_port(edge_port), "the edge listens")
        with open(os.path.join(EXEMPLARS, "etr_sand01.png"), "rb") as f:
            png = f.read()
        c = http.client.HTTPConnection("127.0.0.1", edge_port, timeout=60)
        c.request("POST", "/v1/textons?size=16&iterations=5", png, {"Content-Type": "image/png"})
        r = c.getresponse()
        tid = json.loads(r.read())["id"]
        c.close()

        check_security_headers(edge_port, app_port, tid)

        # In turn: an attack, then at once an ordinary request. nginx hands the upstream
        # connection it just freed (the attack's) to the next request, while textond would still
        # be rendering the hidden one: where bodies are read as requests, this client gets it.
        victim = http.client.HTTPConnection("127.0.0.1", edge_port, timeout=60)
        turns = []
        for n, attack in enumerate(attacks(tid)):
            smuggle(edge_port, [attack], [])
            url = f"/v1/textons/{tid}/tiles/1/{n}/{-1 - n}.png?seed=77"
            victim.request("GET", url)
            r = victim.getresponse()
            turns.append((url, r.status, r.getheader("X-Request-Id", ""), r.read()))
        victim.close()
        direct = http.client.HTTPConnection("127.0.0.1", app_port, timeout=60)
        crossed = 0
        for url, status, rid, body in turns:
            direct.request("GET", url)
            ref = direct.getresponse().read()
            if status != 200 or body != ref or "smuggled" in rid:
                crossed += 1
                print(f"  after an attack {url}: {status} id {rid} {len(body)} B "
                      f"(expected {len(ref)} B)", file=sys.stderr)
        check(crossed == 0, f"a request right after each attack got its own answer ({crossed} "
                            f"of {len(turns)} did not)")

        results = [[] for _ in range(CLIENTS)]
        seen = [[] for _ in range(SMUGGLERS)]
        payloads = attacks(tid)
        threads = [threading.Thread(target=client, args=(edge_port, tid, k, results[k]))
                   for k in range(CLIENTS)]
        threads += [threading.Thread(target=smuggle,
                                     args=(edge_port, payloads[j::SMUGGLERS], seen[j]))
                    for j in range(SMUGGLERS)]
        [t.start() for t in threads]
        [t.join() for t in threads]

        # The reference: each URL's bytes from textond itself, after the run.
        direct = http.client.HTTPConnection("127.0.0.1", app_port, timeout=60)
        wrong = 0
        for k, rs in enumerate(results):
            check(len(rs) == REQUESTS, f"client {k} got {len(rs)} answers for {REQUESTS}")
            for url, status, rid, body in rs:
                direct.request("GET", url)
                ref = direct.getresponse().read()
                ok = status == 200 and body == ref and not rid.startswith("smuggled")
                wrong += not ok
                if not ok:
                    print(f"  client {k} {url}: {status} id {rid} {len(body)} B "
                          f"(expected {len(ref)} B)", file=sys.stderr)
        check(wrong == 0, f"every client got the answer to its own request ({wrong} wrong)")
        # The smugglers' hidden requests were never answered, to them or anyone.
        answered = sum(b"smuggled-" in g for gs in seen for g in gs)
        check(answered == 0, f"no hidden request was answered ({answered})")
        statuses = [g.split(b"\r\n", 1)[0] for gs in seen for g in gs]
        check(all(s.startswith(b"HTTP/1.1 4") for s in statuses),
              f"every smuggling attempt was refused with a 4xx ({set(statuses)})")
        check(server.poll() is None, "textond is alive")
    finally:
        subprocess.run(nginx + ["-s", "quit"], stderr=subprocess.DEVNULL)
        server.terminate()
        try:
            server.wait(20)
        except subprocess.TimeoutExpired:
            server.kill()
        time.sleep(0.5)
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"{passed} passed, {len(failures)} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
