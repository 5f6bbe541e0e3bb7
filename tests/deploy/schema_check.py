"""Kubernetes objects against the API schema, offline: the typed models of the Kubernetes Python
client (Debian's python3-kubernetes, generated from the API's OpenAPI document) name every field,
its type and which fields are required, and its API classes which group serves which kind. A kind
under the wrong group or version, an unknown or misspelt field, a wrong type, a missing
required field or a value outside an enumeration is an error, as the API server's strict field
validation would report it.

The client in Debian 12 is 22.6 (Kubernetes 1.22). It predates autoscaling/v2, which is
autoscaling/v2beta2 promoted with the same fields, so autoscaling/v2 is checked against v2beta2.
"""
import re

import kubernetes
from kubernetes import client

_CONFIG = client.Configuration()
_CONFIG.client_side_validation = True
_PRIMITIVES = {"str": str, "bool": bool, "int": int, "float": (int, float), "datetime": str,
               "date": str}
# Quantities (resources' limits and requests) are strings or numbers in the API; the client
# types them as strings.
_QUANTITY_MAPS = {"V1ResourceRequirements"}


def version():
    return kubernetes.__version__


def _snake(name):
    return re.sub(r"(?<!^)(?=[A-Z])", "_", name).lower()


def _served(group, version, kind):
    """Whether the API group and version serve the kind: the client's {Group}{Version}Api has
    its create call (apps/v1 Deployment: AppsV1Api.create_namespaced_deployment; v1 is core)."""
    api = getattr(client, "".join(p.capitalize() for p in (group or "core").split(".")[0].split("-"))
                  + version.capitalize() + "Api", None)
    return api is not None and any(hasattr(api, f"create{ns}_{_snake(kind)}")
                                   for ns in ("_namespaced", ""))


def model_for(api_version, kind):
    group, _, version = api_version.rpartition("/")
    for v in [version] + (["v2beta2"] if api_version == "autoscaling/v2" else []):
        cls = getattr(client, v[0].upper() + v[1:] + kind, None)
        if cls is not None and _served(group, v, kind):
            return cls
    return None


def _check(value, typ, path, owner, errors):
    if typ == "object":  # IntOrString and Quantity here (no raw extensions in our manifests)
        if isinstance(value, bool) or not isinstance(value, (str, int, float)):
            errors.append(f"{path}: an int or a string expected, got {value!r}")
        return
    m = re.fullmatch(r"list\[(.+)\]", typ)
    if m:
        if not isinstance(value, list):
            errors.append(f"{path}: a list expected, got {type(value).__name__}")
            return
        for i, v in enumerate(value):
            _check(v, m.group(1), f"{path}[{i}]", owner, errors)
        return
    m = re.fullmatch(r"dict\(str, (.+)\)", typ)
    if m:
        if not isinstance(value, dict):
            errors.append(f"{path}: a map expected, got {type(value).__name__}")
            return
        for k, v in value.items():
            inner = m.group(1)
            if owner in _QUANTITY_MAPS and isinstance(v, (int, float)):
                continue
            _check(v, inner, f"{path}.{k}", owner, errors)
        return
    if typ in _PRIMITIVES:
        ok = isinstance(value, _PRIMITIVES[typ]) and not (typ != "bool" and isinstance(value, bool))
        if not ok:
            errors.append(f"{path}: {typ} expected, got {value!r}")
        return
    cls = getattr(client, typ, None)
    if cls is None:
        errors.append(f"{path}: no model {typ} in the client")
        return
    _check_model(value, cls, path, errors)


def _check_model(value, cls, path, errors):
    if not isinstance(value, dict):
        errors.append(f"{path}: an object ({cls.__name__}) expected, got {value!r}")
        return
    by_json = {j: a for a, j in cls.attribute_map.items()}
    for key in value:
        if key not in by_json:
            errors.append(f"{path}.{key}: unknown field of {cls.__name__}")
    for key, attr in by_json.items():
        if key in value and value[key] is not None:
            _check(value[key], cls.openapi_types[attr], f"{path}.{key}", cls.__name__, errors)
    # Required fields and enumerations: the model's own setters, given the values as written.
    kwargs = {a: value.get(j) for j, a in by_json.items()}
    try:
        cls(local_vars_configuration=_CONFIG, **kwargs)
    except (ValueError, TypeError) as e:
        errors.append(f"{path}: {cls.__name__}: {e}")


def errors(doc):
    """The schema errors of one object (a dict as loaded from YAML), as 'Kind/name.path: ...'."""
    api_version, kind = doc.get("apiVersion", ""), doc.get("kind", "")
    name = f"{kind}/{(doc.get('metadata') or {}).get('name', '?')}"
    cls = model_for(api_version, kind)
    if cls is None:
        return [f"{name}: no {api_version} {kind} in the Kubernetes API"]
    out = []
    _check_model(doc, cls, name, out)
    return out
