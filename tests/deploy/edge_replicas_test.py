#!/usr/bin/python3
"""The deployment's shape on this machine, without containers: Redis, two textond replicas on it
(--store) and the nginx edge of deploy/base (deploy/local/edge-files.sh), then
shared_objects_check.py through the edge and against each replica (issue 43 items 1, 5, 7), and
the readiness probe of a replica that never wrote against a full Redis (item 8).

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
import urllib.request

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


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
