#!/usr/bin/python3
"""Packaging and deployment checked against the real server (no Docker engine, no cluster here).

    deploy_test.py TEXTOND_BINARY REPO_ROOT

- Every kustomization (deploy/base, deploy/overlays/*) renders with `kubectl kustomize` and
  parses; the Deployment's ports, probes, env and labels agree with the Services, HPA, PDB, the
  edge's upstream and the Redis StatefulSet.
- Every TEXTOND_* variable the manifests or compose set is a real `textond serve` flag, and the
  real binary, started with the ConfigMap's environment (a local redis-server standing in for the
  StatefulSet), answers 200 on every probe path at the container port's flag; the Dockerfile's
  HEALTHCHECK command passes against it and fails against a closed port.
- The edge's nginx config passes `nginx -t` (Debian's nginx, with the replicas as static
  servers: its 1.22 lacks `resolve`).
- The Dockerfile: stages, non-root user (the same uid as the pod's securityContext), EXPOSE and
  the port variable, HEALTHCHECK, the install script's modes; its runtime package list covers
  every library the built binary needs (NEEDED and dlopen'ed).
- Every object of every kustomization against the Kubernetes API schema (schema_check.py): the
  HPA, PDB and Services, which `podman kube play` (kube_play_test.py) cannot run, included.
- docker/compose.yaml (and its GPU override) validates with docker-compose: two replicas with
  a data directory each, Redis, and the edge on deploy/base's config with the replicas upstream.
"""
import copy
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import unittest
import urllib.request

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
import schema_check  # noqa: E402
from local_ports import free_port  # noqa: E402

BINARY = os.path.abspath(sys.argv[1])
ROOT = os.path.abspath(sys.argv[2])
DEPLOY = os.path.join(ROOT, "deploy")
KUSTOMIZATIONS = ["base"] + ["overlays/" + d for d in sorted(os.listdir(os.path.join(DEPLOY, "overlays")))]
BASE_IMAGE_PACKAGES = {"libc6", "libstdc++6", "libgcc-s1"}  # in debian:bookworm-slim
DLOPENED = ["libOSMesa.so.8", "libEGL.so.1"]  # render/gl/osmesa_backend.cpp, render/gl/egl_backend.cpp


def kustomize_usable():
    """kubectl >= 1.21 embeds kustomize v4+, which these kustomizations need (`labels`,
    inline `patches`); Debian 12's kubernetes-client is 1.20 (kustomize v2)."""
    if not shutil.which("kubectl"):
        return False
    out = subprocess.run(["kubectl", "version", "--client"], capture_output=True, text=True).stdout
    m = re.search(r"Kustomize Version: v(\d+)", out)
    return bool(m) and int(m.group(1)) >= 4


KUSTOMIZE = kustomize_usable()


def render(kustomization):
    if KUSTOMIZE:
        out = subprocess.run(["kubectl", "kustomize", os.path.join(DEPLOY, kustomization)],
                             check=True, capture_output=True, text=True).stdout
        return [d for d in yaml.safe_load_all(out) if d]
    return render_base_by_hand(kustomization)


def render_base_by_hand(kustomization):
    """Without a usable kustomize: the base's resources and generated ConfigMaps, namespaced."""
    if kustomization != "base":
        raise unittest.SkipTest(f"{kustomization}: needs kubectl with kustomize v4+")
    base = os.path.join(DEPLOY, "base")
    with open(os.path.join(base, "kustomization.yaml")) as f:
        k = yaml.safe_load(f)
    docs = []
    for r in k["resources"]:
        with open(os.path.join(base, r)) as f:
            docs += [d for d in yaml.safe_load_all(f) if d]
    for g in k["configMapGenerator"]:
        data = {}
        for env in g.get("envs", []):
            with open(os.path.join(base, env)) as f:
                data.update(line.split("=", 1) for line in f.read().splitlines() if "=" in line)
        for path in g.get("files", []):
            with open(os.path.join(base, path)) as f:
                data[os.path.basename(path)] = f.read()
        docs.append({"kind": "ConfigMap", "metadata": {"name": g["name"]}, "data": data})
    for d in docs:
        if d["kind"] != "Namespace":
            d["metadata"]["namespace"] = k["namespace"]
    return docs


def find(docs, kind, name):
    # ConfigMaps from a generator carry a content hash suffix.
    hits = [d for d in docs if d["kind"] == kind and
            re.fullmatch(re.escape(name) + r"(-[a-z0-9]{10})?", d["metadata"]["name"])]
    assert len(hits) == 1, f"{kind} {name}: {len(hits)} found"
    return hits[0]


def serve_flags():
    """The flags `textond serve --help` documents, as their TEXTOND_* variable names."""
    text = subprocess.run([BINARY, "serve", "--help"], check=True, capture_output=True,
                          text=True).stdout
    flags = re.findall(r"^\s+(--[a-z][a-z0-9-]*)", text, re.M)
    flags += re.findall(r",\s+(--[a-z][a-z0-9-]*)", text)
    return {"TEXTOND_" + f[2:].upper().replace("-", "_") for f in flags}


def get(url, timeout=5):
    try:
        with urllib.request.urlopen(url, timeout=timeout) as r:
            return r.status, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()


class Server:
    """The real binary with a given environment (and no flags but `serve`)."""

    def __init__(self, env):
        full = {k: v for k, v in os.environ.items() if not k.startswith("TEXTOND_")}
        full.update(env)
        self.proc = subprocess.Popen([BINARY, "serve"], env=full, stdout=subprocess.PIPE,
                                     stderr=subprocess.DEVNULL, text=True)
        line = self.proc.stdout.readline()
        m = re.search(r":(\d+)/", line)
        assert m, f"server did not start: {line!r}"
        self.port = int(m.group(1))

    def stop(self):
        self.proc.send_signal(signal.SIGTERM)
        code = self.proc.wait(timeout=30)
        self.proc.stdout.close()
        return code


class Redis:
    def __init__(self, directory):
        self.port = free_port()
        self.proc = subprocess.Popen(["redis-server", "--port", str(self.port), "--bind",
                                      "127.0.0.1", "--dir", directory, "--save", ""],
                                     stdout=subprocess.DEVNULL)
        for _ in range(200):
            if subprocess.run(["redis-cli", "-p", str(self.port), "ping"], capture_output=True,
                              text=True).stdout.strip() == "PONG":
                return
            time.sleep(0.02)
        raise RuntimeError("redis-server did not start")

    def stop(self):
        self.proc.terminate()
        self.proc.wait(timeout=10)


def dockerfile_stages(path):
    """[(stage name, [(INSTRUCTION, arguments)])], continuation lines joined."""
    stages, lines, current = [], [], ""
    with open(path) as f:
        text = f.read()
    for raw in text.splitlines():
        line = raw.rstrip("\n")
        if not current and (not line.strip() or line.lstrip().startswith("#")):
            continue
        if line.endswith("\\"):
            current += line[:-1] + " "
            continue
        lines.append(current + line)
        current = ""
    for line in lines:
        word, _, rest = line.strip().partition(" ")
        word = word.upper()
        if word == "FROM":
            m = re.match(r"(\S+)(?:\s+AS\s+(\S+))?$", rest.strip(), re.I)
            stages.append((m.group(2) or m.group(1), [("FROM", m.group(1))]))
        else:
            stages[-1][1].append((word, rest.strip()))
    return stages


def install_script_packages(mode):
    """The packages docker/install-deps.sh installs in a mode, read from its arrays."""
    with open(os.path.join(ROOT, "docker/install-deps.sh")) as f:
        text = f.read()
    arrays = {}
    for name, body in re.findall(r"^(\w+)=\(\n?(.*?)\n?\)$", text, re.M | re.S):
        words = []
        for line in body.splitlines():
            words += line.split("#")[0].split()
        arrays[name] = set(words)
    return arrays[mode]


def package_of(path):
    out = subprocess.run(["dpkg", "-S", os.path.realpath(path)], capture_output=True, text=True)
    if out.returncode != 0:  # merged /usr: dpkg knows the /lib path
        out = subprocess.run(["dpkg", "-S", os.path.realpath(path).replace("/usr/lib/", "/lib/")],
                             capture_output=True, text=True)
    assert out.returncode == 0, f"no package owns {path}"
    return out.stdout.split(":")[0]


class Manifests(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.rendered = {}
        for k in KUSTOMIZATIONS:
            try:
                cls.rendered[k] = render(k)
            except unittest.SkipTest as e:
                print(f"skipping {k}: {e}", file=sys.stderr)
        cls.flags = serve_flags()

    def overlay(self, name):
        if name not in self.rendered:
            self.skipTest(f"{name} needs kubectl with kustomize v4+")
        return self.rendered[name]

    def test_every_kustomization_renders_and_names_known_kinds(self):
        for k, docs in self.rendered.items():
            kinds = {d["kind"] for d in docs}
            self.assertTrue({"Deployment", "Service", "ConfigMap", "HorizontalPodAutoscaler",
                             "PodDisruptionBudget"} <= kinds, (k, kinds))
            for d in docs:
                self.assertEqual(d["metadata"].get("namespace", "textond"), "textond", k)

    def test_deployment_agrees_with_flags_services_and_autoscaling(self):
        for k, docs in self.rendered.items():
            with self.subTest(kustomization=k):
                dep = find(docs, "Deployment", "textond")
                pod = dep["spec"]["template"]
                labels = pod["metadata"]["labels"]
                c = next(c for c in pod["spec"]["containers"] if c["name"] == "textond")
                config = find(docs, "ConfigMap", "textond-config")["data"]
                env = set(config) | {e["name"] for e in c.get("env", [])}
                unknown = {v for v in env if v.startswith("TEXTOND_")} - self.flags
                self.assertFalse(unknown, f"not textond serve flags: {unknown}")
                ports = {p["name"]: p["containerPort"] for p in c["ports"]}
                self.assertEqual(ports["http"], int(config["TEXTOND_PORT"]))
                self.assertEqual(config["TEXTOND_HOST"], "0.0.0.0")
                # The API key comes from an optional Secret (deploy/README.md "Hostile clients"),
                # never from the ConfigMap.
                self.assertIn({"secretRef": {"name": "textond-secrets", "optional": True}},
                              c["envFrom"])
                self.assertNotIn("TEXTOND_API_KEY", config)
                self.assertEqual(c["readinessProbe"]["httpGet"]["path"], "/readyz")
                self.assertEqual(c["livenessProbe"]["httpGet"]["path"], "/healthz")
                for probe in ("readinessProbe", "livenessProbe", "startupProbe"):
                    self.assertIn(c[probe]["httpGet"]["port"], ports, probe)
                for res in ("requests", "limits"):
                    self.assertIn("cpu", c["resources"][res])
                    self.assertIn("memory", c["resources"][res])
                mounts = {m["mountPath"] for m in c["volumeMounts"]}
                self.assertIn(config["TEXTOND_DATA"], mounts)
                self.assertEqual(pod["spec"]["securityContext"]["runAsUser"], 10001)
                # Services and budgets select these pods, on the named port.
                for svc in [d for d in docs if d["kind"] == "Service"
                            and d["metadata"]["name"].startswith("textond")
                            and d["metadata"]["name"] not in ("textond-redis", "textond-edge")]:
                    self.assertTrue(svc["spec"]["selector"].items() <= labels.items())
                    self.assertTrue(all(p["targetPort"] in ports for p in svc["spec"]["ports"]))
                pdb = find(docs, "PodDisruptionBudget", "textond")
                self.assertTrue(pdb["spec"]["selector"]["matchLabels"].items() <= labels.items())
                self.assertLess(pdb["spec"]["minAvailable"], dep["spec"]["replicas"])
                hpa = find(docs, "HorizontalPodAutoscaler", "textond")
                self.assertEqual(hpa["spec"]["scaleTargetRef"]["name"], dep["metadata"]["name"])
                self.assertEqual(hpa["spec"]["metrics"][0]["resource"]["name"], "cpu")
                self.assertGreaterEqual(hpa["spec"]["minReplicas"], pdb["spec"]["minAvailable"] + 1)

    def test_store_url_names_the_redis_statefulset(self):
        docs = self.rendered["base"]
        config = find(docs, "ConfigMap", "textond-config")["data"]
        sts = find(docs, "StatefulSet", "textond-redis")
        host, port = re.match(r"redis://([^:/]+):(\d+)", config["TEXTOND_STORE"]).groups()
        self.assertEqual(host, f"{sts['metadata']['name']}-0.{sts['spec']['serviceName']}")
        redis = sts["spec"]["template"]["spec"]["containers"][0]
        self.assertEqual(int(port), redis["ports"][0]["containerPort"])
        self.assertIn("noeviction", redis["args"])  # textons must never be evicted
        self.assertIn("--appendonly", redis["args"])

    def test_external_redis_overlay_drops_the_statefulset_for_a_secret(self):
        ext = self.overlay("overlays/external-redis")
        self.assertFalse([d for d in ext if d["kind"] == "StatefulSet"])
        c = find(ext, "Deployment", "textond")["spec"]["template"]["spec"]["containers"][0]
        store = next(e for e in c["env"] if e["name"] == "TEXTOND_STORE")
        self.assertIn("secretKeyRef", store["valueFrom"])

    def test_every_object_matches_the_kubernetes_api_schema(self):
        """What `podman kube play` cannot run (HPA, PDB, Services) is checked here, with the rest."""
        names = ["base"] + [f"overlays/{o}" for o in sorted(os.listdir(os.path.join(DEPLOY, "overlays")))]
        for name in names if KUSTOMIZE else ["base"]:
            docs = render(name)
            if not KUSTOMIZE:  # the hand rendering's ConfigMaps carry no apiVersion
                docs = [d for d in docs if d["kind"] != "ConfigMap"]
            kinds = {d["kind"] for d in docs}
            self.assertTrue({"HorizontalPodAutoscaler", "PodDisruptionBudget"} <= kinds, name)
            for d in docs:
                self.assertEqual(schema_check.errors(d), [], name)
        # and the check can fail: a misspelt field, a missing required one, a wrong type
        hpa = copy.deepcopy(find(render("base"), "HorizontalPodAutoscaler", "textond"))
        hpa["spec"]["minReplica"] = hpa["spec"].pop("minReplicas")
        del hpa["spec"]["maxReplicas"]
        hpa["spec"]["metrics"][0]["resource"]["name"] = 5
        errors = " ".join(schema_check.errors(hpa))
        for word in ("minReplica: unknown field", "max_replicas", "name: str expected"):
            self.assertIn(word, errors)
        core_deployment = copy.deepcopy(find(render("base"), "Deployment", "textond"))
        core_deployment["apiVersion"] = "v1"  # Deployments are the apps group's
        self.assertIn("no v1 Deployment", " ".join(schema_check.errors(core_deployment)))

    def test_gpu_overlay_asks_for_a_gpu_and_egl(self):
        docs = self.overlay("overlays/gpu")
        spec = find(docs, "Deployment", "textond")["spec"]["template"]["spec"]
        self.assertIn("nvidia.com/gpu.present", spec["nodeSelector"])
        c = spec["containers"][0]
        self.assertEqual(c["resources"]["limits"]["nvidia.com/gpu"], 1)
        self.assertEqual(c["resources"]["limits"]["memory"], "1536Mi")  # the base's, merged
        self.assertEqual(find(docs, "ConfigMap", "textond-config")["data"]["TEXTOND_BACKEND"], "egl")
        help_text = subprocess.run([BINARY, "serve", "--help"], capture_output=True, text=True).stdout
        self.assertIn("egl", re.search(r"--backend.*", help_text).group(0))

    def test_edge_hashes_on_the_texton_id_over_the_headless_service(self):
        docs = self.rendered["base"]
        edge = find(docs, "ConfigMap", "textond-edge")["data"]
        self.assertRegex(edge["edge.conf"], r"hash \$texton_id consistent;")
        headless = find(docs, "Service", "textond-headless")
        self.assertEqual(headless["spec"]["clusterIP"], "None")
        m = re.search(r"server (\S+):(\d+) resolve max_fails=0;", edge["upstream-servers.conf"])
        self.assertEqual(m.group(1), f"textond-headless.textond.svc.cluster.local")
        self.assertEqual(int(m.group(2)), headless["spec"]["ports"][0]["port"])
        dep = find(docs, "Deployment", "textond-edge")
        mounts = {v["subPath"] for v in dep["spec"]["template"]["spec"]["containers"][0]["volumeMounts"]
                  if "subPath" in v}
        self.assertEqual(mounts, set(edge))

    def test_edge_keeps_upstream_connections_less_long_than_textond(self):
        edge = find(self.rendered["base"], "ConfigMap", "textond-edge")["data"]["edge.conf"]
        upstream = re.search(r"upstream textond \{(.*?)\}", edge, re.S).group(1)
        nginx_s = int(re.search(r"keepalive_timeout (\d+)s;", upstream).group(1))
        help_text = subprocess.run([BINARY, "serve", "--help"], capture_output=True, text=True).stdout
        textond_s = int(re.search(r"--keep-alive-timeout.*\[(\d+)\]", help_text).group(1))
        self.assertLess(nginx_s, textond_s)

    def test_edge_config_passes_nginx_t(self):
        docs = self.rendered["base"]
        edge = find(docs, "ConfigMap", "textond-edge")["data"]
        with tempfile.TemporaryDirectory() as d:
            os.makedirs(os.path.join(d, "cache"))
            os.makedirs(os.path.join(d, "logs"))
            conf = edge["edge.conf"].replace("/etc/nginx/textond/", d + "/").replace(
                "/var/cache/nginx/", d + "/cache/")
            files = {
                "edge.conf": conf,
                "settings.conf": edge["settings.conf"],
                "upstream-servers.conf": "server 127.0.0.1:18081;\nserver 127.0.0.1:18082;\n",
                "nginx.conf": f"pid {d}/nginx.pid;\nerror_log stderr;\nevents {{}}\nhttp {{\n"
                              f"include {d}/settings.conf;\ninclude {d}/edge.conf;\n}}\n",
            }
            for name, text in files.items():
                with open(os.path.join(d, name), "w") as f:
                    f.write(text)
            out = subprocess.run(["/usr/sbin/nginx", "-t", "-p", d, "-c", d + "/nginx.conf"],
                                 capture_output=True, text=True)
            self.assertEqual(out.returncode, 0, out.stderr)


class RealServer(unittest.TestCase):
    def test_configmap_environment_serves_every_probe_path(self):
        docs = render("base")
        config = dict(find(docs, "ConfigMap", "textond-config")["data"])
        c = find(docs, "Deployment", "textond")["spec"]["template"]["spec"]["containers"][0]
        with tempfile.TemporaryDirectory() as d:
            redis = Redis(d)
            try:
                # The pod's environment, with what only a cluster has replaced by local stand-ins.
                env = dict(config)
                env["TEXTOND_HOST"] = "127.0.0.1"
                env["TEXTOND_PORT"] = "0"
                env["TEXTOND_DATA"] = os.path.join(d, "data")
                env["TEXTOND_STORE"] = re.sub(r"//[^/]+", f"//127.0.0.1:{redis.port}",
                                              config["TEXTOND_STORE"])
                env["TEXTOND_WEB_DIR"] = os.path.join(os.path.dirname(BINARY), "web")
                server = Server(env)
                try:
                    base = f"http://127.0.0.1:{server.port}"
                    paths = [c[p]["httpGet"]["path"]
                             for p in ("readinessProbe", "livenessProbe", "startupProbe")]
                    paths.append(find(docs, "Deployment", "textond")["spec"]["template"]
                                 ["metadata"]["annotations"]["prometheus.io/path"])
                    paths += ["/", "/static/leaflet/leaflet.js"]  # the page, from TEXTOND_WEB_DIR
                    for path in paths:
                        status, body = get(base + path)
                        self.assertEqual(status, 200, (path, body))
                    import json
                    ready = json.loads(get(base + "/readyz")[1])
                    self.assertTrue(ready["shared_store"]["up"], ready)
                    self.assertFalse(ready["degraded"])
                    # The image's HEALTHCHECK command, against it and against a closed port.
                    # It follows TEXTOND_PORT, as serve does.
                    health = self.healthcheck()
                    env = dict(os.environ, TEXTOND_PORT=str(server.port))
                    self.assertEqual(subprocess.run([BINARY] + health[1:], env=env).returncode, 0)
                    env["TEXTOND_PORT"] = str(free_port())
                    self.assertEqual(subprocess.run([BINARY] + health[1:], env=env,
                                                    capture_output=True).returncode, 1)
                finally:
                    self.assertEqual(server.stop(), 0)
            finally:
                redis.stop()

    def healthcheck(self):
        stages = dict(dockerfile_stages(os.path.join(ROOT, "docker/Dockerfile")))
        hc = dict(stages["runtime"])["HEALTHCHECK"]
        cmd = re.search(r"CMD\s+(\[.*\])", hc).group(1)
        argv = yaml.safe_load(cmd)
        self.assertEqual(argv, ["textond", "probe"])  # its default URL follows TEXTOND_PORT
        return argv


class Packaging(unittest.TestCase):
    def test_dockerfile_shape(self):
        stages = dockerfile_stages(os.path.join(ROOT, "docker/Dockerfile"))
        names = [s for s, _ in stages]
        self.assertEqual(names, ["build", "runtime"])
        build, runtime = (dict(i) | {"_all": i} for _, i in stages)
        for stage in (build, runtime):
            self.assertTrue(stage["FROM"].startswith("debian:bookworm"), stage["FROM"])
        self.assertTrue(any(k == "RUN" and "install-deps.sh --build" in v for k, v in build["_all"]))
        # The runtime stage holds what the binary loads, gathered in the build stage from the
        # runtime packages (docker/runtime_closure.sh), not the packages themselves.
        self.assertTrue(any(k == "RUN" and "install-deps.sh --runtime" in v
                            for k, v in build["_all"]))
        self.assertTrue(any(k == "RUN" and "runtime_closure.sh" in v for k, v in build["_all"]))
        self.assertTrue(any(k == "COPY" and "--from=build /opt/closure/" in v
                            for k, v in runtime["_all"]))
        for k, v in runtime["_all"]:
            if k == "COPY" and "--from=" in v:
                self.assertIn(re.search(r"--from=(\S+)", v).group(1), names)
        user = runtime["USER"].split(":")[0]
        self.assertNotIn(user, ("0", "root"))
        self.assertEqual(int(user), 10001)  # the pod's runAsUser (deploy/base)
        env = dict(re.findall(r"(TEXTOND_\w+)=(\S+)", runtime["ENV"]))
        self.assertEqual(runtime["EXPOSE"], env["TEXTOND_PORT"])
        self.assertEqual(env["TEXTOND_HOST"], "0.0.0.0")
        self.assertIn(env["TEXTOND_DATA"], runtime["VOLUME"])
        self.assertFalse(set(env) - serve_flags())
        with open(os.path.join(ROOT, ".dockerignore")) as f:
            ignore = f.read().split()
        self.assertIn("build/", ignore)
        self.assertIn("**/node_modules/", ignore)

    def test_runtime_packages_cover_what_the_binary_loads(self):
        runtime = install_script_packages("runtime")
        needed = re.findall(r"NEEDED\s+(\S+)", subprocess.run(
            ["objdump", "-p", BINARY], check=True, capture_output=True, text=True).stdout)
        ldd = dict(re.findall(r"^\s*(\S+) => (\S+)", subprocess.run(
            ["ldd", BINARY], check=True, capture_output=True, text=True).stdout, re.M))
        paths = [ldd[n] for n in needed]
        cache = subprocess.run(["/sbin/ldconfig", "-p"], capture_output=True, text=True).stdout
        for lib in DLOPENED:
            m = re.search(rf"^\s*{re.escape(lib)} .*=> (\S+)", cache, re.M)
            self.assertTrue(m, f"{lib} is not installed here")
            paths.append(m.group(1))
        owners = {package_of(p) for p in paths}
        missing = owners - runtime - BASE_IMAGE_PACKAGES
        self.assertFalse(missing, f"the binary needs {missing}: add them to install-deps.sh's runtime list")
        build = install_script_packages("build")
        self.assertIn("libhiredis-dev", build)

    @unittest.skipUnless(shutil.which("docker-compose"), "docker-compose is not installed")
    def test_compose_file_validates(self):
        base = ["-f", os.path.join(ROOT, "docker/compose.yaml")]
        gpu = base + ["-f", os.path.join(ROOT, "docker/compose.gpu.yaml")]
        for files in (base, gpu):
            out = subprocess.run(["docker-compose"] + files + ["config"], capture_output=True,
                                 text=True)
            self.assertEqual(out.returncode, 0, out.stderr)
            conf = yaml.safe_load(out.stdout)
            replicas = [conf["services"][f"textond-{i}"] for i in (1, 2)]
            volumes = set()
            for textond in replicas:
                self.assertEqual(textond["build"]["dockerfile"], "docker/Dockerfile")
                ours = {k for k in textond["environment"] if k.startswith("TEXTOND_")}
                self.assertTrue(ours <= serve_flags(), ours - serve_flags())
                self.assertTrue(textond["environment"]["TEXTOND_STORE"].startswith("redis://redis:"))
                volumes |= {v.split(":")[0] for v in textond["volumes"]}
                if files is gpu:
                    self.assertEqual(textond["environment"]["TEXTOND_BACKEND"], "egl")
                    devices = textond["deploy"]["resources"]["reservations"]["devices"]
                    self.assertEqual(devices[0]["driver"], "nvidia")
            # Each replica cleans up its own unfinished writes: no shared data directory.
            self.assertEqual(len(volumes), 2)
            self.assertIn("redis", conf["services"])
            edge = conf["services"]["edge"]
            mounts = {v.split(":")[1]: v.split(":")[0] for v in edge["volumes"]}
            self.assertTrue(mounts["/etc/nginx/conf.d/default.conf"].endswith("deploy/base/nginx/edge.conf"))
            upstreams = open(mounts["/etc/nginx/textond/upstream-servers.conf"]).read()
            for i in (1, 2):
                self.assertRegex(upstreams, rf"(?m)^server textond-{i}:8080\b")


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
