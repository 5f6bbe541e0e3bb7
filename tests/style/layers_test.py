#!/usr/bin/env python3
"""The layers as folders: every #include between them goes down, never up or sideways.

    core        pure math
    render      texton noise (core)
    api         request and response types (core, render's limits)
    server/io   files and formats (api, core, render's request types)
    server/store the texton, mix and image stores (io, api, core, and render: a store keeps
                textons prepared for rendering)
    server/app  the workflows without HTTP (store, io, render, api, core)
    server/http transport (app and everything below it)
    server/cli  the commands (app and below; `serve` alone starts the transport)

and nothing below server/http includes <httplib.h> (the CLI's `probe` is an HTTP client). Prints each wrong include; exit 1 if any.

    layers_test.py ROOT
"""
import os
import re
import sys

LAYERS = {
    "core": {"core"},
    "render": {"render", "core"},
    "api": {"api", "core", "render"},
    "server/io": {"server/io", "api", "core", "render"},
    "server/store": {"server/store", "server/io", "api", "core", "render"},
    "server/app": {"server/app", "server/store", "server/io", "render", "api", "core"},
    "server/http": {"server/http", "server/app", "server/store", "server/io", "render", "api",
                    "core"},
    "server/cli": {"server/cli", "server/app", "server/store", "server/io", "render", "api",
                   "core"},
}
BELOW_HTTP = {"core", "render", "api", "server/io", "server/store", "server/app"}
# The one command that starts the transport.
EXCEPTIONS = {("server/cli/serve_command.cpp", "server/http")}
INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]', re.M)


def layer_of(path):
    for layer in sorted(LAYERS, key=len, reverse=True):
        if path == layer or path.startswith(layer + "/"):
            return layer
    return None


def main():
    root = os.path.realpath(sys.argv[1])
    wrong, files = [], 0
    for layer in LAYERS:
        for d, _, names in os.walk(os.path.join(root, layer)):
            if "node_modules" in d:
                continue
            for name in sorted(names):
                if not name.endswith((".h", ".cpp")):
                    continue
                path = os.path.relpath(os.path.join(d, name), root)
                if layer_of(path) != layer:
                    continue  # server/io under server/: its own layer
                files += 1
                text = open(os.path.join(root, path), encoding="utf-8").read()
                for kind, target in INCLUDE.findall(text):
                    if kind == "<":
                        if target == "httplib.h" and layer in BELOW_HTTP:
                            wrong.append(f"{path}: <httplib.h> below server/http/")
                        continue
                    to = layer_of(target)
                    if to is None or to in LAYERS[layer] or (path, to) in EXCEPTIONS:
                        continue
                    wrong.append(f"{path}: includes {target} ({layer} -> {to})")
    for w in wrong:
        print("FAIL", w)
    print(f"{files} files, {len(wrong)} wrong includes")
    # Fewer files than the tree holds means the walk is wrong, not that the tree is clean.
    return 1 if wrong or files < 100 else 0


if __name__ == "__main__":
    sys.exit(main())
