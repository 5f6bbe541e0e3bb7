#!/usr/bin/env python3
"""deploy/base as written, started by `podman kube play`, then a tile through the edge.

`kubectl kustomize deploy/base` renders the manifests; podman 4.3 plays Deployments, their
ConfigMaps and PersistentVolumeClaims. What a cluster would add is stood in for here, and only
that (each stand-in is a function below, named for what it replaces):
  - cluster DNS: every pod gets hostAliases for the Service names the manifests use;
  - the headless Service's records in the edge's upstream list: the textond pod's address
    (Debian's nginx 1.22 has no `resolve`; the official 1.28 image of the manifests has);
  - configMap keys mounted by subPath (podman 4.3 mounts the whole map as a directory): files;
  - containerPorts: unpublished (podman 4.3 publishes each on the host, and two pods use 8080);
  - the StatefulSet (podman plays no StatefulSet): a Deployment with the same pod template, its
    volumeClaimTemplates as PersistentVolumeClaims owned by its fsGroup (podman ignores fsGroup);
  - images: the textond image built here and the stand-ins for Redis and nginx.
Not played (kube play has no such kinds): Namespace, Service, HorizontalPodAutoscaler,
PodDisruptionBudget. Every object, played or not, is checked against the Kubernetes API schema
(schema_check.py) first.

Pass: each pod's readiness probe as written (textond's and the edge's HTTP GETs, Redis's exec),
podman playing every replica as a pod; an upload and a tile through an edge pod (X-Cache-Status
from nginx), and the same tile bytes from both textond pods (one reads the texton from Redis).

    tests/deploy/kube_play_test.py HOST_TEXTOND EXEMPLAR_DIR
"""
import copy
from http.client import HTTPException
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.request

import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
import schema_check  # noqa: E402

IMAGES = {
    "registry.example.com/textond:0.1.0": "localhost/textond:local",
    "redis:7.0-bookworm": "localhost/textond-standin/redis:7.0-bookworm",
    "nginx:1.28-bookworm": "localhost/textond-standin/nginx:1.22-bookworm",
}
NOT_PLAYED = {"Namespace", "Service", "HorizontalPodAutoscaler", "PodDisruptionBudget"}


def sh(*cmd, check=True, **kw):
    return subprocess.run(cmd, check=check, capture_output=True, text=True, **kw)


def statefulset_as_deployment(doc):
    """podman plays no StatefulSet: the same pod template as a Deployment, its claims as PVCs."""
    claims = []
    dep = copy.deepcopy(doc)
    dep["kind"] = "Deployment"
    spec = dep["spec"]
    spec.pop("serviceName", None)
    template = spec.pop("volumeClaimTemplates", [])
    volumes = spec["template"]["spec"].setdefault("volumes", [])
    for claim in template:
        name = f"{claim['metadata']['name']}-{doc['metadata']['name']}-0"
        # The kubelet hands the volume to the pod's fsGroup; podman ignores fsGroup and takes
        # the owner from these annotations.
        ctx = spec["template"]["spec"].get("securityContext", {})
        owner = {f"volume.podman.io/{k}": str(ctx[f]) for k, f in (("uid", "runAsUser"), ("gid", "fsGroup"))
                 if f in ctx}
        claims.append({"apiVersion": "v1", "kind": "PersistentVolumeClaim",
                       "metadata": {"name": name, "annotations": owner}, "spec": claim["spec"]})
        volumes.append({"name": claim["metadata"]["name"],
                        "persistentVolumeClaim": {"claimName": name}})
    return claims + [dep]


def cluster_dns_as_host_aliases(doc, aliases):
    doc["spec"]["template"]["spec"]["hostAliases"] = [
        {"ip": ip, "hostnames": names} for ip, names in aliases.items()]


def headless_service_as_addresses(configmap, addresses, port):
    """The edge's upstream list: the headless Service's records, which a cluster's DNS serves."""
    configmap["data"]["upstream-servers.conf"] = (
        "# kube_play_test.py: the textond pods, in place of the headless Service's DNS records\n"
        + "".join(f"server {ip}:{port} max_fails=0;\n" for ip in addresses))


def local_images(doc):
    for c in doc["spec"]["template"]["spec"]["containers"]:
        c["image"] = IMAGES.get(c["image"], c["image"])


def configmap_subpaths_as_files(doc, configmaps, directory):
    """podman 4.3 mounts a configMap volume as a directory even with subPath; the kubelet
    projects the one key as a file. Each such mount becomes a hostPath file holding that key."""
    spec = doc["spec"]["template"]["spec"]
    sources = {v["name"]: v["configMap"]["name"] for v in spec.get("volumes", []) if "configMap" in v}
    for c in spec["containers"]:
        for m in c.get("volumeMounts", []):
            if m["name"] not in sources or "subPath" not in m:
                continue
            key = m.pop("subPath")
            path = os.path.join(directory, f"{sources[m['name']]}-{key}")
            with open(path, "w") as f:
                f.write(configmaps[sources[m["name"]]]["data"][key])
            m["name"] = f"{m['name']}-{key.replace('.', '-')}"
            spec["volumes"].append({"name": m["name"], "hostPath": {"path": path, "type": "File"}})


def pod_network_ports(doc):
    """podman 4.3 publishes every containerPort on the host (two pods on 8080 collide); a pod
    network publishes none. Named probe ports are resolved first (http_probe)."""
    for c in doc["spec"]["template"]["spec"]["containers"]:
        c["_ports"] = c.pop("ports", [])


def wait(what, probe, seconds=int(os.environ.get("WAIT", 120))):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        try:
            if probe():
                return
        except (OSError, ValueError, HTTPException):  # not up yet, half an answer
            pass
        time.sleep(0.5)
    raise SystemExit(f"FAIL: {what} within {seconds} s")


def http(url, data=None, headers=None):
    req = urllib.request.Request(url, data=data, headers=headers or {})
    with urllib.request.urlopen(req, timeout=60) as r:
        return r.status, dict(r.headers), r.read()


def http_probe(ip, container, probe):
    get = probe["httpGet"]
    port = get["port"]
    if isinstance(port, str):
        port = next(p["containerPort"] for p in container["_ports"] if p.get("name") == port)
    return lambda: http(f"http://{ip}:{port}{get['path']}")[0] == 200


def main():
    host_bin, exemplars = os.path.realpath(sys.argv[1]), os.path.realpath(sys.argv[2])
    # kubectl >= 1.21 embeds kustomize v4+, which deploy/base needs (`labels`); Debian 12's
    # kubernetes-client is 1.20.
    kubectl = sh("kubectl", "version", "--client", check=False).stdout
    m = re.search(r"Kustomize Version: v(\d+)", kubectl)
    if not m or int(m.group(1)) < 4:
        print("SKIP: kube play needs kubectl with kustomize v4+ to render deploy/base")
        sys.exit(77)
    rendered = sh("kubectl", "kustomize", os.path.join(ROOT, "deploy/base")).stdout
    docs = [d for d in yaml.safe_load_all(rendered) if d]
    errors = [e for d in docs for e in schema_check.errors(d)]
    if errors:
        raise SystemExit("FAIL: against the Kubernetes API schema:\n  " + "\n  ".join(errors))
    print(f"{len(docs)} objects valid against the Kubernetes API schema "
          f"(python3-kubernetes {schema_check.version()})")

    subprocess.run(["bash", os.path.join(HERE, "podman_setup.sh")], check=True)
    t0 = time.monotonic()
    subprocess.run(["bash", os.path.join(HERE, "build_images.sh"), host_bin], check=True)
    print(f"images built in {time.monotonic() - t0:.0f} s")

    net = f"textond-kube{os.getpid()}"
    subnet = f"10.{90 + os.getpid() % 60}.{os.getpid() % 250}"
    by_kind = {}
    for d in docs:
        by_kind.setdefault(d["kind"], []).append(d)
    services = {s["metadata"]["name"]: s for s in by_kind.get("Service", [])}
    configmaps = {d["metadata"]["name"]: d for d in by_kind.get("ConfigMap", [])}
    ns = by_kind["Namespace"][0]["metadata"]["name"]
    played = []
    for d in docs:
        if d["kind"] == "StatefulSet":
            played += statefulset_as_deployment(d)
        elif d["kind"] not in NOT_PLAYED:
            played.append(d)
    # podman plays each replica as a pod, {name}-pod-{i}, and gives --ip to them in file order.
    pods = []  # (deployment, pod name, address)
    for d in played:
        if d["kind"] == "Deployment":
            for i in range(d["spec"].get("replicas", 1)):
                pods.append((d, f"{d['metadata']['name']}-pod-{i}", f"{subnet}.{10 + len(pods)}"))
    addresses = {}
    for d, _, ip in pods:
        addresses.setdefault(d["metadata"]["name"], []).append(ip)
    redis_set = by_kind["StatefulSet"][0]
    redis_svc = redis_set["spec"]["serviceName"]
    pod0 = f"{redis_set['metadata']['name']}-0.{redis_svc}"
    aliases = {  # a Service's name to one of its pods, as cluster DNS would answer
        addresses[redis_set["metadata"]["name"]][0]:
            [pod0, f"{pod0}.{ns}", f"{pod0}.{ns}.svc.cluster.local", redis_svc],
        addresses["textond"][0]: [f"{n}.{ns}.svc.cluster.local" for n in ("textond", "textond-headless")],
        addresses["textond-edge"][0]: [f"textond-edge.{ns}.svc.cluster.local"],
    }
    files = tempfile.mkdtemp(prefix=f"{net}-")
    port = services["textond-headless"]["spec"]["ports"][0]["port"]
    for d in played:
        if d["kind"] == "ConfigMap" and d["metadata"]["name"].startswith("textond-edge"):
            headless_service_as_addresses(d, addresses["textond"], port)
    for d in played:
        if d["kind"] == "Deployment":
            local_images(d)
            cluster_dns_as_host_aliases(d, aliases)
            pod_network_ports(d)
            configmap_subpaths_as_files(d, configmaps, files)
    playfile = os.path.join(os.environ.get("TMPDIR", "/tmp"), f"{net}.yaml")
    with open(playfile, "w") as f:
        out = copy.deepcopy(played)
        for d in out:
            for c in d.get("spec", {}).get("template", {}).get("spec", {}).get("containers", []):
                c.pop("_ports", None)
        yaml.safe_dump_all(out, f)

    for d in played:  # claims and configMap volumes left by an earlier run that was killed
        if d["kind"] in ("PersistentVolumeClaim", "ConfigMap"):
            sh("podman", "volume", "rm", "-f", d["metadata"]["name"], check=False)
    try:
        sh("podman", "network", "create", "--subnet", f"{subnet}.0/24", net)
        t1 = time.monotonic()
        cmd = ["podman", "kube", "play", "--network", net]
        for _, _, ip in pods:
            cmd += ["--ip", ip]
        out = sh(*cmd, playfile, check=False)
        if out.returncode:
            raise SystemExit(f"FAIL: podman kube play:\n{out.stdout}{out.stderr}")
        for d, pod, ip in pods:
            for c in d["spec"]["template"]["spec"]["containers"]:
                probe = c.get("readinessProbe")
                ctr = f"{pod}-{c['name']}"
                if not probe:
                    raise SystemExit(f"FAIL: {ctr} has no readiness probe (every container needs one)")
                if "httpGet" in probe:
                    check = http_probe(ip, c, probe)
                else:
                    check = (lambda ctr=ctr, argv=probe["exec"]["command"]:
                             sh("podman", "exec", ctr, *argv, check=False).returncode == 0)
                try:
                    wait(f"{ctr} ready", check)
                except SystemExit:
                    out = sh("podman", "logs", "--tail", "20", ctr, check=False)
                    print(f"{ctr}:\n{out.stdout[-2000:]}{out.stderr[-2000:]}")
                    raise
        print(f"{len(pods)} pods ready {time.monotonic() - t1:.1f} s after kube play: "
              + ", ".join(pod for _, pod, _ in pods))
        # Ready (200) includes degraded: a replica serves what it holds while Redis is down.
        # The replicas started before Redis; uploads need them connected to it.
        for ip in addresses["textond"]:
            wait(f"textond at {ip} connected to Redis", lambda ip=ip: not json.loads(
                http(f"http://{ip}:8080/readyz")[2])["degraded"])
        edge = f"http://{addresses['textond-edge'][0]}:8080"
        with open(os.path.join(exemplars, "etr_sand01.png"), "rb") as f:
            status, _, body = http(f"{edge}/v1/textons?size=16&iterations=5", f.read(),
                                   {"Content-Type": "image/png"})
        if status != 201:
            raise SystemExit(f"FAIL: upload through the edge answered {status}")
        tid = json.loads(body)["id"]
        status, headers, png = http(f"{edge}/v1/textons/{tid}/tiles/0/2/-1.png?seed=4")
        if status != 200 or not png.startswith(b"\x89PNG") or "X-Cache-Status" not in headers:
            raise SystemExit(f"FAIL: tile through the edge: {status} {headers}")
        # Both replicas serve it, the one that did not analyse it through Redis: same bytes.
        for ip in addresses["textond"]:
            if http(f"http://{ip}:8080/v1/textons/{tid}/tiles/0/2/-1.png?seed=4")[2] != png:
                raise SystemExit(f"FAIL: the replica at {ip} serves other bytes than the edge")
        print(f"upload and tile through the edge ({len(png)} bytes, X-Cache-Status "
              f"{headers['X-Cache-Status']}), the same bytes from both textond pods")
        # A splat and a mix through the edge, read 20 times from both pods, deleted everywhere.
        subprocess.run([sys.executable, os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                     "shared_objects_check.py"), edge,
                        *[f"http://{ip}:8080" for ip in addresses["textond"]],
                        "--exemplars", exemplars], check=True)
        print("kube_play_test: passed")
    finally:
        if os.environ.get("KEEP"):  # debugging: leave it up
            print(f"KEEP: {playfile} is up on {net}")
        else:
            tear_down(playfile, net, played, files)


def tear_down(playfile, net, played, files):
    sh("podman", "kube", "down", playfile, check=False)
    sh("podman", "network", "rm", "-f", net, check=False)
    # podman keeps claims and configMap volumes after `kube down`
    for v in [d["metadata"]["name"] for d in played
              if d["kind"] in ("PersistentVolumeClaim", "ConfigMap")]:
        sh("podman", "volume", "rm", "-f", v, check=False)
    if os.path.exists(playfile):
        os.unlink(playfile)
    shutil.rmtree(files, ignore_errors=True)


if __name__ == "__main__":
    main()
