#!/usr/bin/python3
"""Contract test: every operation of api/openapi.yaml, with requests generated from the document
itself, against a real `textond serve`. For each operation: every path-parameter value the
document names (every format), then each optional parameter present alone with each of its
values (every enum value; minimum, default, examples and small maxima of numbers; both booleans),
every documented request body type, and for POST /v1/textons every documented multipart part:
the exemplar alone and material sets of every non-empty subset of the maps in three part orders.

Each answer must be documented for its operation (status listed), never 5xx, of a documented
content type, and a JSON answer must validate against the schema its status documents. A
documented query parameter is never refused as unknown_parameter, and every query parameter the
document names for other operations but not for this one is; and each operation's parser, asked
a field nobody documents, lists in its refusal exactly the fields the document names for it (the
parsers and the document agree route by route, both ways).

usage: contract_test.py TEXTOND_BINARY EXEMPLAR_DIR OPENAPI_YAML
Prints a line per operation and "N passed, M failed" (N, M: operations); exits non-zero on any
failure. Uses Debian's python3-yaml and python3-jsonschema.
"""
import http.client
import itertools
import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import threading
from concurrent.futures import ThreadPoolExecutor

import jsonschema
import yaml

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from png_bytes import pattern_png, rgba_png  # noqa: E402
from form_bytes import multipart  # noqa: E402

MAPS = ["albedo", "height", "roughness", "ao", "metallic"]
CLIENTS = 4
# A query field no operation documents: its refusal lists what the route's parser takes.
PROBE = "zz_undocumented"
# Numbers whose maximum is a cost, not a value to try (16384 x 16384 regions).
COSTLY = {"w", "h", "width", "height", "limit"}


class Contract:
    def __init__(self, spec, base_port):
        self.spec = spec
        self.port = base_port
        self.local = threading.local()  # one keep-alive connection per client thread
        self.lock = threading.Lock()
        self.failures = {}  # operation -> [messages]
        self.sent = {}  # operation -> count

    @property
    def conn(self):
        return getattr(self.local, "conn", None)

    @conn.setter
    def conn(self, value):
        self.local.conn = value

    # --- the document ---
    def resolve(self, node):
        while isinstance(node, dict) and "$ref" in node:
            target = self.spec
            for part in node["$ref"].lstrip("#/").split("/"):
                target = target[part]
            node = target
        return node

    def parameters(self, path, method):
        ops = self.spec["paths"][path]
        params = [self.resolve(p) for p in ops.get("parameters", [])]
        params += [self.resolve(p) for p in ops[method].get("parameters", [])]
        return params

    def values(self, param):
        s = self.resolve(param.get("schema", {}))
        if "enum" in s:
            return list(s["enum"])
        t = s.get("type")
        if t == "boolean":
            return [True, False]
        vals = []
        for k in ("minimum", "default"):
            if k in s:
                vals.append(s[k])
        vals += s.get("examples", [])
        if "example" in s:
            vals.append(s["example"])
        if "maximum" in s and param["name"] not in COSTLY:
            vals.append(s["maximum"])
        if t in ("integer", "number") and not vals:
            vals = [0]
        out = []
        for v in vals:
            if v not in out:
                out.append(v)
        return out

    # --- the wire ---
    def send(self, method, target, body=None, headers=None):
        for attempt in range(2):
            try:
                if self.conn is None:
                    self.conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=120)
                self.conn.request(method, target, body=body, headers=headers or {})
                r = self.conn.getresponse()
                data = r.read()
                if r.getheader("Connection", "").lower() == "close":
                    self.conn.close()
                    self.conn = None
                return r.status, {k.lower(): v for k, v in r.getheaders()}, data
            except (http.client.HTTPException, OSError):
                if self.conn:
                    self.conn.close()
                self.conn = None
                if attempt:
                    raise
        raise AssertionError("unreachable")

    def fail(self, op, message):
        with self.lock:
            self.failures.setdefault(op, []).append(message)
        print(f"FAIL {op}: {message}", file=sys.stderr)

    def check(self, path, method, target, status, headers, body):
        op = f"{method.upper()} {path}"
        with self.lock:
            self.sent[op] = self.sent.get(op, 0) + 1
        what = f"{method.upper()} {target[:160]} -> {status}"
        if status >= 500:
            self.fail(op, f"{what}: {body[:200]!r}")
            return
        responses = self.spec["paths"][path][method]["responses"]
        answer = responses.get(str(status), responses.get("default"))
        if answer is None:
            self.fail(op, f"{what}: status not documented ({sorted(responses)}) {body[:200]!r}")
            return
        answer = self.resolve(answer)
        content = answer.get("content")
        if not content or status == 304 or method == "head":
            return
        ctype = headers.get("content-type", "").split(";")[0].strip()
        documented = [c for c in content
                      if c == ctype or (c.endswith("/*") and ctype.startswith(c[:-1]))]
        if not documented:
            self.fail(op, f"{what}: content type {ctype!r} not documented ({list(content)})")
            return
        schema = content[documented[0]].get("schema")
        if ctype == "application/json" and schema:
            full = dict(self.resolve(schema))
            full["components"] = self.spec["components"]
            try:
                jsonschema.Draft202012Validator(
                    full, format_checker=jsonschema.FormatChecker()).validate(json.loads(body))
            except (jsonschema.ValidationError, json.JSONDecodeError) as e:
                self.fail(op, f"{what}: schema: {str(e).splitlines()[0]}")

    def exchange(self, path, method, target, body=None, headers=None):
        status, h, data = self.send(method.upper(), target, body, headers)
        self.check(path, method, target, status, h, data)
        return status, h, data


def query_text(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float) and v.is_integer():
        return str(int(v))
    return str(v)


def main():
    binary, exemplar_dir, spec_path = sys.argv[1:4]
    with open(spec_path, encoding="utf-8") as f:
        spec = yaml.safe_load(f)
    data = tempfile.mkdtemp(prefix="textond-contract-")
    proc = subprocess.Popen([binary, "serve", "--port", "0", "--data", data, "--backend", "cpu",
                             "--log-level", "warn"], stdout=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        port = int(line.strip().rstrip("/").rsplit(":", 1)[1])
        c = Contract(spec, port)
        ok = run(c, spec, exemplar_dir)
    finally:
        proc.terminate()
        proc.wait(timeout=30)
        shutil.rmtree(data, ignore_errors=True)
    ops = [f"{m.upper()} {p}" for p, o in spec["paths"].items() for m in o
           if m in ("get", "post", "delete", "put", "patch")]
    failed = 0
    for op in ops:
        if op not in c.sent:
            c.fail(op, "no request was sent")
        bad = c.failures.get(op, [])
        failed += bool(bad)
        print(f"{'FAIL' if bad else 'ok  '} {op}: {c.sent.get(op, 0)} requests"
              + (f", {len(bad)} failures" if bad else ""))
    if proc.returncode != 0:
        print(f"FAIL: server exit status {proc.returncode}")
        failed += 1
    print(f"{len(ops) - failed} passed, {failed} failed")
    return 1 if failed or not ok else 0


def run(c, spec, exemplar_dir):
    with open(os.path.join(exemplar_dir, "etr_sand01.png"), "rb") as f:
        sand = f.read()
    with open(os.path.join(exemplar_dir, "etr_pebbles04.png"), "rb") as f:
        pebbles = f.read()
    analysis = "size=16&iterations=5"

    def upload(body, headers, query=analysis):
        st, _, b = c.exchange("/v1/textons", "post", "/v1/textons?" + query, body, headers)
        return json.loads(b)["id"] if st in (200, 201) else None

    plain = upload(sand, {"Content-Type": "image/png"})
    other = upload(pebbles, {"Content-Type": "image/png"})
    if not plain or not other:
        print("FAIL: the exemplars did not upload", file=sys.stderr)
        return False

    # Multipart: the exemplar alone, then every non-empty subset of the maps in three orders
    # (given, reversed, rotated): 201 or 200, and each map served.
    body, headers = multipart([("exemplar", sand, "e.png"), ("size", "16", None),
                               ("iterations", "5", None)])
    c.exchange("/v1/textons", "post", "/v1/textons", body, headers)
    images = {"albedo": pebbles}
    for i, name in enumerate(MAPS[1:]):
        images[name] = pattern_png(256, 256, i)
    def material_set(order):
        parts = [(m, images[m], m + ".png") for m in order]
        parts += [("size", "16", None), ("iterations", "5", None)]
        body, headers = multipart(parts)
        st, _, b = c.exchange("/v1/textons", "post", "/v1/textons", body, headers)
        if st not in (200, 201):
            c.fail("POST /v1/textons", f"material set {order}: {st} {b[:200]!r}")
            return None
        sid = json.loads(b)["id"]
        for m in order:
            target = f"/v1/textons/{sid}/tiles/0/0/0.png?map={m}"
            st, _, b = c.exchange("/v1/textons/{id}/tiles/{z}/{x}/{y}.{format}", "get", target)
            if st != 200:
                c.fail("GET /v1/textons/{id}/tiles/{z}/{x}/{y}.{format}",
                       f"set {order}, map {m}: {st} {b[:200]!r}")
        return sid if len(order) == len(MAPS) else None

    orders = []
    for n in range(1, len(MAPS) + 1):
        for subset in itertools.combinations(MAPS, n):
            orders += sorted({subset, tuple(reversed(subset)), subset[1:] + subset[:1]})
    # Clients at once: the server is the bottleneck of a sequential run (it waits on each answer).
    with ThreadPoolExecutor(CLIENTS) as pool:
        sets = list(pool.map(material_set, orders))  # every task's exception surfaces here
    full_set = next((sid for sid in sets if sid), None)
    # Mixes: a ramp (no body) and a mask.
    st, _, b = c.exchange("/v1/mixes", "post", f"/v1/mixes?u={plain}&v={other}&levels=3")
    mix = json.loads(b)["id"] if st in (200, 201) else None
    c.exchange("/v1/mixes", "post", f"/v1/mixes?u={plain}&v={other}&levels=3",
               pattern_png(32, 32, 9), {"Content-Type": "image/png"})
    c.exchange("/v1/mixes", "post", f"/v1/mixes?u={plain}&v={other}&levels=3&scale=2",
               pattern_png(32, 32, 9), {"Content-Type": "application/octet-stream"})

    # Splats: an RGBA weight image (four layers, and two of its channels for two), two images for
    # five layers, and rules on the material set's height.
    def post_splat(parts):
        body, headers = multipart(parts)
        st, _, b = c.exchange("/v1/splats", "post", "/v1/splats", body, headers)
        if st not in (200, 201):
            c.fail("POST /v1/splats", f"{[p[0] for p in parts]}: {st} {b[:200]!r}")
            return None
        return json.loads(b)["id"]
    four = ",".join([plain, other, plain, other])
    splat = post_splat([("textons", four, None), ("weights", rgba_png(8, 8, 1), "w.png"),
                        ("scale", "32", None), ("x0", "-128", None), ("y0", "-64.5", None)])
    post_splat([("textons", f"{plain},{other}", None), ("weights", rgba_png(8, 8, 3), "w.png")])
    post_splat([("textons", four + "," + plain, None), ("weights", rgba_png(8, 8, 2), "w.png"),
                ("weights2", pattern_png(8, 8, 3), "w2.png"), ("scale", "16", None)])
    if full_set:
        rules = json.dumps({"height": full_set, "strength": 4, "height_soft": 0.05,
                            "slope_soft": 5, "layers": [{"height": [None, 0.5]},
                                                        {"height": [0.5, None],
                                                         "slope": [0, 45]}]})
        post_splat([("textons", f"{plain},{other}", None), ("rules", rules, None)])

    bodies = {
        "application/json": json.dumps({"points": [[0, 0, 0], [10.5, -3, 2]],
                                        "normals": [[0, 0, 1], [0, 1, 0]]}).encode(),
        "application/octet-stream": struct.pack("<12f", 0, 0, 0, 0, 0, 1, 10.5, -3, 2, 0, 1, 0),
        "model/obj": b"v -1 -1 0\nv 1 -1 0\nv 0 1 0.5\nvn 0 0 1\nf 1//1 2//1 3//1\n",
        "image/png": pattern_png(32, 32, 3),
        "image/*": sand,
        "multipart/form-data": None,  # above
    }
    def base_query(path, params):
        """The fields every request to `path` carries: its required ones, and a small frame for
        mesh.png (a 512 x 512 preview costs seconds of CPU; the fields' checks do not depend on
        the frame, and width and height themselves still take each of their values)."""
        if path == "/v1/mixes":
            return {"u": plain, "v": other, "levels": 3}
        query = {p["name"]: c.values(p)[0] for p in params
                 if p["in"] == "query" and p.get("required")}
        if path.endswith("/mesh.png"):
            query.update({"width": 64, "height": 64})
        return query

    path_values = {"z": [0, -1, 3], "x": [0, -3, 4000000000], "y": [0, 7]}
    variants = []  # arguments of send_variant, sent by CLIENTS threads
    for path, ops in spec["paths"].items():
        for method, op in ops.items():
            if method not in ("get", "post", "delete"):
                continue
            if method == "delete":
                continue  # last, on a texton of its own
            params = c.parameters(path, method)
            ids = ([mix] if path.startswith("/v1/mixes/") else
                   [splat] if path.startswith("/v1/splats/") else [plain, full_set])
            path_params = [p for p in params if p["in"] == "path" and p["name"] != "id"]
            optional = [p for p in params if p["in"] in ("query", "header")
                        and not p.get("required")]
            required = base_query(path, params)
            if path in ("/v1/textons", "/v1/splats") and method == "post":
                continue  # the uploads above
            content = list(op.get("requestBody", {}).get("content", {}).keys()) or [None]
            for tid in ids:
                # Every combination of the path's own values (format, z, x, y) once.
                choices = [[(p["name"], v) for v in (c.values(p) if p["name"] not in path_values
                                                     else path_values[p["name"]])]
                           for p in path_params]
                combos = list(itertools.product(*choices)) or [()]
                first = combos[0]
                for combo in combos:
                    variants.append((c, path, method, tid, dict(combo), dict(required), None,
                                     content))
                for p in optional:
                    for v in c.values(p):
                        variants.append((c, path, method, tid, dict(first), dict(required),
                                         (p, v), content))
    # The other direction: a query field documented for some operation but not for this one is
    # refused as unknown_parameter, so that the document and the parsers (api/noise_fields.h and
    # api/requests.cpp's allow-lists) name the same fields route by route. Uploads are left out:
    # their fields are form fields too, and tests/server covers them.
    universe = {}
    for path, ops in spec["paths"].items():
        for method in ops:
            if method in ("get", "post", "delete"):
                for p in c.parameters(path, method):
                    if p["in"] == "query":
                        universe.setdefault(p["name"], (c.values(p) or ["x"])[0])
    for path, ops in spec["paths"].items():
        for method in ops:
            if method not in ("get", "post") or (path, method) == ("/v1/textons", "post"):
                continue
            params = c.parameters(path, method)
            documented = {p["name"] for p in params if p["in"] == "query"}
            if not documented:
                continue
            required = base_query(path, params)
            first = {p["name"]: (path_values.get(p["name"]) or c.values(p))[0]
                     for p in params if p["in"] == "path" and p["name"] != "id"}
            content = list(ops[method].get("requestBody", {}).get("content", {}).keys()) or [None]
            tid = (mix if path.startswith("/v1/mixes/") else
                   splat if path.startswith("/v1/splats/") else plain)
            for name in sorted(set(universe) - documented):
                variants.append((c, path, method, tid, dict(first), dict(required),
                                 ({"in": "query", "name": name, "undocumented": True},
                                  universe[name]), content))
            # And from the code's side: a name no operation documents is refused with the list
            # of what the parser takes, which must be what the document names here. A field the
            # code gains and the document does not (a new noise parameter, say) fails here.
            variants.append((c, path, method, tid, dict(first), dict(required),
                             ({"in": "query", "name": PROBE, "undocumented": True,
                               "documented": documented}, "1"), content))
    with ThreadPoolExecutor(CLIENTS) as pool:
        list(pool.map(lambda a: send_variant(*a), variants))
    # Bodies: every documented content type of every operation with a body.
    for path, ops in spec["paths"].items():
        for method, op in ops.items():
            if method != "post" or path in ("/v1/textons", "/v1/mixes", "/v1/splats"):
                continue
            for ctype in op.get("requestBody", {}).get("content", {}):
                body = bodies.get(ctype)
                if path == "/v1/sign":
                    body = json.dumps({"urls": [f"/v1/textons/{plain}/tilejson.json"],
                                       "expires_in": 60}).encode()
                target = path.replace("{id}", plain)
                c.exchange(path, method, target, body, {"Content-Type": ctype})
    # DELETE last: a texton, a mix and a splat of their own, then the same id again (404).
    doomed = upload(sand, {"Content-Type": "image/png"}, "size=16&iterations=5&seed=99")
    for _ in range(2):
        c.exchange("/v1/textons/{id}", "delete", f"/v1/textons/{doomed}")
    st, _, b = c.exchange("/v1/mixes", "post", f"/v1/mixes?u={plain}&v={other}&levels=2")
    if st in (200, 201):
        doomed_mix = json.loads(b)["id"]
        for _ in range(2):
            c.exchange("/v1/mixes/{id}", "delete", f"/v1/mixes/{doomed_mix}")
    doomed_splat = post_splat([("textons", f"{plain},{other}", None),
                               ("weights", rgba_png(4, 4, 7), "w.png")])
    if doomed_splat:
        for _ in range(2):
            c.exchange("/v1/splats/{id}", "delete", f"/v1/splats/{doomed_splat}")
    return True


def send_variant(c, path, method, tid, path_args, query, extra, content):
    headers = {}
    if extra:
        p, v = extra
        if p["in"] == "header":
            headers[p["name"]] = query_text(v)
        else:
            query[p["name"]] = v
    target = path.replace("{id}", tid or "0" * 64)
    for k, v in path_args.items():
        target = target.replace("{" + k + "}", query_text(v))
    if query:
        target += "?" + "&".join(f"{k}={query_text(v)}" for k, v in query.items())
    ctype = content[0]
    body = None
    if method == "post":
        body = {
            "application/json": json.dumps({"points": [[0, 0, 0]], "normals": [[0, 0, 1]]}).encode(),
            "model/obj": b"v -1 -1 0\nv 1 -1 0\nv 0 1 0.5\nf 1 2 3\n",
            "application/octet-stream": b"",
            "image/png": None,
        }.get(ctype, b"")
        if path == "/v1/sign":
            body = json.dumps({"urls": [target]}).encode()
        if body is not None:
            headers["Content-Type"] = ctype
        else:
            body = b""
            headers["Content-Length"] = "0"
    status, _, answer = c.exchange(path, method, target, body, headers)
    if not extra or extra[0]["in"] != "query":
        return
    try:
        code = json.loads(answer)["error"]["code"] if status == 400 else None
    except (ValueError, KeyError, TypeError):
        code = None
    op = f"{method.upper()} {path}"
    if "documented" in extra[0] and code == "unknown_parameter":
        takes = json.loads(answer)["error"]["message"].split("this endpoint takes ", 1)[-1]
        takes = {n.strip() for n in takes.rstrip(")").split(",") if n.strip() not in ("", "none")}
        # With a body, what a parser takes may depend on it (a mix's mask takes scale, its
        # ramp dx, dy and width): there the code may take less than the document names.
        missing = extra[0]["documented"] - takes if content[0] is None else set()
        if takes - extra[0]["documented"] or missing:
            c.fail(op, f"the parser takes {sorted(takes - extra[0]['documented'])} that the "
                       f"document does not name here, and the document names {sorted(missing)} "
                       f"that the parser does not take")
    if extra[0].get("undocumented") and code != "unknown_parameter":
        c.fail(op, f"{target}: {extra[0]['name']} is not documented here, yet the answer was "
                   f"{status} {answer[:160]!r}, not unknown_parameter")
    elif not extra[0].get("undocumented") and code == "unknown_parameter":
        c.fail(op, f"{target}: documented parameter {extra[0]['name']} refused: {answer[:160]!r}")


if __name__ == "__main__":
    sys.exit(main())
