#!/usr/bin/python3
"""Every shared exemplar uploaded to a real `textond serve` as a raw body and as multipart; every
JSON answer validated against the schemas of api/openapi.yaml (JSON Schema 2020-12, as OpenAPI
3.1 uses). Also checks that every $ref of the document resolves and that the served document is
the file in the repository.

usage: openapi_schema_test.py TEXTOND_BINARY EXEMPLAR_DIR OPENAPI_YAML
Uses Debian's python3-yaml and python3-jsonschema (docker/install-deps.sh installs them).
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import urllib.error
import urllib.request
import uuid

import jsonschema
import yaml

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from png_bytes import rgba_png  # noqa: E402

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what, file=sys.stderr)


def request(base, method, path, body=None, headers=None):
    req = urllib.request.Request(base + path, data=body, method=method, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=120) as r:
            return r.status, dict(r.headers), r.read()
    except urllib.error.HTTPError as e:
        return e.code, dict(e.headers), e.read()


def multipart(fields, file_field, filename, data):
    boundary = uuid.uuid4().hex
    parts = []
    for k, v in fields.items():
        parts.append(f'--{boundary}\r\nContent-Disposition: form-data; name="{k}"\r\n\r\n{v}\r\n'.encode())
    parts.append((f'--{boundary}\r\nContent-Disposition: form-data; name="{file_field}"; '
                  f'filename="{filename}"\r\nContent-Type: image/png\r\n\r\n').encode() + data + b"\r\n")
    parts.append(f"--{boundary}--\r\n".encode())
    return b"".join(parts), {"Content-Type": f"multipart/form-data; boundary={boundary}"}


def all_refs(node):
    if isinstance(node, dict):
        for k, v in node.items():
            if k == "$ref" and isinstance(v, str):
                yield v
            else:
                yield from all_refs(v)
    elif isinstance(node, list):
        for v in node:
            yield from all_refs(v)


def main():
    binary, exemplar_dir, spec_path = sys.argv[1:4]
    with open(spec_path, encoding="utf-8") as f:
        spec_text = f.read()
    spec = yaml.safe_load(spec_text)
    check(spec.get("openapi", "").startswith("3.1"), "the document is OpenAPI 3.1")
    for ref in set(all_refs(spec)):
        node = spec
        for part in ref.lstrip("#/").split("/"):
            node = node.get(part) if isinstance(node, dict) else None
        check(ref.startswith("#/") and node is not None, f"$ref {ref} resolves")
    for path, ops in spec["paths"].items():
        for method, op in ops.items():
            if method in ("get", "post", "delete"):
                check(op.get("responses"), f"{method} {path} documents its responses")

    def validator(name):
        schema = dict(spec["components"]["schemas"][name])
        schema["components"] = spec["components"]  # so '#/components/...' resolves
        return jsonschema.Draft202012Validator(schema, format_checker=jsonschema.FormatChecker())

    def validate(name, body, what):
        try:
            validator(name).validate(json.loads(body))
        except (jsonschema.ValidationError, json.JSONDecodeError) as e:
            check(False, f"{what}: {name} schema: {str(e).splitlines()[0]}")

    def validate_route(method, path, status, body, what):
        # The schema the spec gives this route's answer, named or inline.
        answer = spec["paths"][path][method.lower()]["responses"][str(status)]
        if "$ref" in answer:
            answer = spec["components"]["responses"][answer["$ref"].split("/")[-1]]
        schema = dict(answer["content"]["application/json"]["schema"])
        schema["components"] = spec["components"]
        try:
            jsonschema.Draft202012Validator(schema, format_checker=jsonschema.FormatChecker()).validate(
                json.loads(body))
        except (jsonschema.ValidationError, json.JSONDecodeError) as e:
            check(False, f"{what}: {method} {path} {status} schema: {str(e).splitlines()[0]}")

    data = tempfile.mkdtemp(prefix="textond-schema-")
    proc = subprocess.Popen([binary, "serve", "--port", "0", "--data", data, "--backend", "cpu",
                             "--log-level", "warn"], stdout=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        base = line.strip().split(" on ")[-1].rstrip("/")
        check(base.startswith("http://127.0.0.1:"), f"server printed its URL ({line!r})")

        status, _, served = request(base, "GET", "/v1/openapi.yaml")
        check(status == 200 and served.decode() == spec_text, "the served spec is api/openapi.yaml")

        s, _, b = request(base, "GET", "/healthz")
        check(s == 200, "healthz")
        validate_route("GET", "/healthz", 200, b, "healthz")

        tids = []
        names = sorted(n for n in os.listdir(exemplar_dir) if n.endswith(".png"))
        check(len(names) >= 9, f"found the shared exemplars ({len(names)})")
        for name in names:
            with open(os.path.join(exemplar_dir, name), "rb") as f:
                img = f.read()
            q = "?size=32&iterations=10"
            s1, h1, b1 = request(base, "POST", "/v1/textons" + q, img, {"Content-Type": "image/png"})
            check(s1 == 201, f"{name}: raw upload creates ({s1} {b1[:200]!r})")
            validate("Texton", b1, f"{name} raw upload")
            tid = json.loads(b1)["id"] if s1 in (200, 201) else ""
            check(h1.get("Location") == f"/v1/textons/{tid}", f"{name}: Location header")
            s2, _, b2 = request(base, "POST", "/v1/textons" + q, img, {"Content-Type": "image/png"})
            check(s2 == 200 and json.loads(b2)["id"] == tid, f"{name}: raw upload again is 200, same id")
            body, headers = multipart({"size": "32", "iterations": "10"}, "exemplar", name, img)
            s3, _, b3 = request(base, "POST", "/v1/textons", body, headers)
            check(s3 == 200 and json.loads(b3)["id"] == tid, f"{name}: multipart, same pixels, same id ({s3})")
            validate("Texton", b3, f"{name} multipart")
            body, headers = multipart({"size": "32", "iterations": "10", "seed": "7"}, "exemplar", name, img)
            s4, _, b4 = request(base, "POST", "/v1/textons", body, headers)
            check(s4 == 201 and json.loads(b4)["id"] != tid, f"{name}: multipart with another seed creates ({s4})")
            validate("Texton", b4, f"{name} multipart created")
            s5, _, b5 = request(base, "GET", f"/v1/textons/{tid}")
            check(s5 == 200, f"{name}: metadata")
            validate("Texton", b5, f"{name} metadata")
            s6, _, b6 = request(base, "GET", f"/v1/textons/{tid}/status")
            validate("AnalysisStatus", b6, f"{name} status")
            s7, _, b7 = request(base, "GET", f"/v1/textons/{tid}/tilejson.json?seed=3")
            validate("TileJson", b7, f"{name} tilejson")
            s8, _, b8 = request(base, "GET", f"/v1/textons/{tid}/quality.json?seed=3")
            check(s8 == 200, f"{name}: quality report ({s8})")
            validate_route("GET", "/v1/textons/{id}/quality.json", 200, b8, f"{name} quality")
            tids.append(tid)

        s, _, b = request(base, "GET", "/v1/textons?limit=5")
        page = json.loads(b)
        check(s == 200 and len(page["items"]) == 5 and page["total"] == 2 * len(names), "list pages")
        validate_route("GET", "/v1/textons", 200, b, "list")
        for item in page["items"]:
            validate("Texton", json.dumps(item), "list item")

        # A mix of two of them: created, known, fetched, its TileJSON.
        mix_q = f"/v1/mixes?u={tids[0]}&v={tids[1]}&levels=3"
        s, _, b = request(base, "POST", mix_q)
        check(s == 201, f"mix creates ({s} {b[:200]!r})")
        validate_route("POST", "/v1/mixes", 201, b, "mix created")
        mid = json.loads(b)["id"] if s == 201 else "none"
        s, _, b = request(base, "POST", mix_q)
        check(s == 200, f"the same mix again is 200 ({s})")
        validate_route("POST", "/v1/mixes", 200, b, "mix known")
        s, _, b = request(base, "GET", f"/v1/mixes/{mid}")
        check(s == 200, f"mix metadata ({s})")
        validate_route("GET", "/v1/mixes/{id}", 200, b, "mix metadata")
        s, _, b = request(base, "GET", f"/v1/mixes/{mid}/tilejson.json?seed=3")
        check(s == 200, f"mix tilejson ({s})")
        validate_route("GET", "/v1/mixes/{id}/tilejson.json", 200, b, "mix tilejson")

        # A splat of two of them by an RGBA weight image: created, known, fetched, TileJSON.
        boundary = uuid.uuid4().hex
        form = [(f'--{boundary}\r\nContent-Disposition: form-data; name="textons"\r\n\r\n'
                 f'{tids[0]},{tids[1]}\r\n').encode()]
        for field, data in (("weights", rgba_png(4, 4, 1)),):
            form.append((f'--{boundary}\r\nContent-Disposition: form-data; name="{field}"; '
                         f'filename="w.png"\r\nContent-Type: image/png\r\n\r\n').encode() +
                        data + b"\r\n")
        form.append(f"--{boundary}--\r\n".encode())
        headers = {"Content-Type": f"multipart/form-data; boundary={boundary}"}
        s, _, b = request(base, "POST", "/v1/splats", b"".join(form), headers)
        check(s == 201, f"splat creates ({s} {b[:200]!r})")
        validate_route("POST", "/v1/splats", 201, b, "splat created")
        sid = json.loads(b)["id"] if s == 201 else "none"
        s, _, b = request(base, "POST", "/v1/splats", b"".join(form), headers)
        check(s == 200, f"the same splat again is 200 ({s})")
        validate_route("POST", "/v1/splats", 200, b, "splat known")
        s, _, b = request(base, "GET", f"/v1/splats/{sid}")
        check(s == 200, f"splat metadata ({s})")
        validate_route("GET", "/v1/splats/{id}", 200, b, "splat metadata")
        s, _, b = request(base, "GET", f"/v1/splats/{sid}/tilejson.json?seed=3")
        check(s == 200, f"splat tilejson ({s})")
        validate_route("GET", "/v1/splats/{id}/tilejson.json", 200, b, "splat tilejson")

        # Surface noise as JSON.
        points = {"points": [[0, 0, 0], [10.5, -3, 2]], "normals": [[0, 0, 1], [0, 1, 0]]}
        s, _, b = request(base, "POST", f"/v1/textons/{tids[0]}/surface?seed=2",
                          json.dumps(points).encode(), {"Content-Type": "application/json"})
        check(s == 200, f"surface ({s} {b[:200]!r})")
        validate_route("POST", "/v1/textons/{id}/surface", 200, b, "surface colours")
        check(s != 200 or len(json.loads(b)["colors"]) == 2, "one colour a point")

        # Signing, on a server that does not sign: the URLs back as they are.
        s, _, b = request(base, "POST", "/v1/sign",
                          json.dumps({"urls": [f"/v1/textons/{tids[0]}/tilejson.json"]}).encode(),
                          {"Content-Type": "application/json"})
        check(s == 200, f"sign ({s} {b[:200]!r})")
        validate_route("POST", "/v1/sign", 200, b, "sign")

        s, _, b = request(base, "GET", "/readyz")
        validate("Readiness", b, "readyz")
        for path in ("/v1/textons/nope", "/v1/textons/" + "a" * 64, "/nothing"):
            s, _, b = request(base, "GET", path)
            check(s in (400, 404), f"{path} is an error")
            validate("Error", b, f"error body of {path}")
        s, _, b = request(base, "POST", "/v1/textons", b"not an image", {"Content-Type": "image/png"})
        check(s == 415, "text upload is 415")
        validate("Error", b, "error body of a bad upload")
    finally:
        proc.terminate()
        proc.wait(timeout=30)
        shutil.rmtree(data, ignore_errors=True)
    check(proc.returncode == 0, f"server exits 0 on SIGTERM ({proc.returncode})")
    if failures:
        print(f"{len(failures)} failure(s)", file=sys.stderr)
        return 1
    print("openapi schema test: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
