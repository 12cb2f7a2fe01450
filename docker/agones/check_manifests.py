#!/usr/bin/env python3
"""Validates the Agones manifests without a cluster.

No Kubernetes API server runs here, so this checks what one would reject and what would break
at run time: the shape of each object (known keys only, so a misspelt key fails instead of
being ignored), the values Agones accepts (port policies, protocols, health settings), and the
manifests against the product itself: every server flag exists in `terrain-server serve
--help`, every TERRAIN_* variable is one the server reads, ports, user and data directory are
the image's (docker/Dockerfile), health pings fit the health period, requests fit the limits,
and every mounted volume and claim is defined.

  check_manifests.py --server-bin PATH --dockerfile docker/Dockerfile MANIFEST...
  check_manifests.py ... --self-test    also prove each check catches a broken copy
"""
import argparse
import copy
import re
import subprocess
import sys

import yaml

# Keys Kubernetes and Agones accept at each place these manifests use (a subset of the API:
# the manifests stay minimal). "*" takes any key (labels, annotations).
ANY = "*"
RESOURCES = {"requests": {"cpu": str, "memory": str}, "limits": {"cpu": str, "memory": str}}
CONTAINER = {
    "name": str,
    "image": str,
    "args": [str],
    "env": [{"name": str, "value": str,
             "valueFrom": {"secretKeyRef": {"name": str, "key": str}}}],
    "ports": [{"name": str, "containerPort": int, "protocol": str}],
    "readinessProbe": {"httpGet": {"path": str, "port": int}, "periodSeconds": int},
    "livenessProbe": {"httpGet": {"path": str, "port": int}, "periodSeconds": int},
    "resources": RESOURCES,
    "volumeMounts": [{"name": str, "mountPath": str, "readOnly": bool}],
}
PVC_SPEC = {"accessModes": [str], "resources": {"requests": {"storage": str}},
            "storageClassName": str}
POD_TEMPLATE = {
    "metadata": {"labels": ANY, "annotations": ANY},
    "spec": {
        "terminationGracePeriodSeconds": int,
        "securityContext": {"runAsUser": int, "runAsGroup": int, "fsGroup": int,
                            "runAsNonRoot": bool},
        "containers": [CONTAINER],
        "volumes": [{"name": str,
                     "persistentVolumeClaim": {"claimName": str},
                     "ephemeral": {"volumeClaimTemplate": {"spec": PVC_SPEC}},
                     "emptyDir": ANY}],
    },
}
GAMESERVER_SPEC = {
    "ports": [{"name": str, "portPolicy": str, "containerPort": int, "protocol": str,
               "container": str}],
    "health": {"disabled": bool, "initialDelaySeconds": int, "periodSeconds": int,
               "failureThreshold": int},
    "template": POD_TEMPLATE,
}
METADATA = {"name": str, "labels": ANY, "annotations": ANY}
KINDS = {
    ("agones.dev/v1", "GameServer"): {"apiVersion": str, "kind": str, "metadata": METADATA,
                                      "spec": GAMESERVER_SPEC},
    ("agones.dev/v1", "Fleet"): {
        "apiVersion": str, "kind": str, "metadata": METADATA,
        "spec": {"replicas": int, "scheduling": str,
                 "strategy": {"type": str},
                 "template": {"metadata": METADATA, "spec": GAMESERVER_SPEC}}},
    ("v1", "PersistentVolumeClaim"): {"apiVersion": str, "kind": str, "metadata": METADATA,
                                      "spec": PVC_SPEC},
}


def shape(value, schema, path, problems):
    """Known keys and value types, recursively."""
    if schema is ANY:
        return
    if isinstance(schema, dict):
        if not isinstance(value, dict):
            problems.append(f"{path}: expected a mapping")
            return
        for key, item in value.items():
            if key not in schema:
                problems.append(f"{path}.{key}: unknown key (known: {', '.join(schema)})")
            else:
                shape(item, schema[key], f"{path}.{key}", problems)
    elif isinstance(schema, list):
        if not isinstance(value, list):
            problems.append(f"{path}: expected a list")
            return
        for i, item in enumerate(value):
            shape(item, schema[0], f"{path}[{i}]", problems)
    elif schema is int and (isinstance(value, bool) or not isinstance(value, int)):
        problems.append(f"{path}: expected an integer, got {value!r}")
    elif schema is not int and not isinstance(value, schema):
        problems.append(f"{path}: expected {schema.__name__}, got {value!r}")


def quantity(text, path, problems):
    """A Kubernetes cpu or memory quantity in base units (cores, bytes)."""
    units = {"m": 1e-3, "Ki": 2**10, "Mi": 2**20, "Gi": 2**30, "": 1}
    match = re.fullmatch(r"([0-9.]+)(m|Ki|Mi|Gi|)", str(text))
    if not match:
        problems.append(f"{path}: '{text}' is not a quantity this check knows")
        return None
    return float(match.group(1)) * units[match.group(2)]


class Product:
    """What the manifests must agree with: the server's flags and variables, the image."""

    def __init__(self, server_bin, dockerfile):
        help_text = subprocess.run([server_bin, "serve", "--help"], check=True,
                                   capture_output=True, text=True).stdout
        self.flags = set(re.findall(r"(--[a-z0-9-]+)", help_text))
        self.env = set(re.findall(r"Env:([A-Z0-9_]+)", help_text))
        top = subprocess.run([server_bin, "--help"], check=True, capture_output=True,
                             text=True).stdout
        self.env |= set(re.findall(r"Env:([A-Z0-9_]+)", top))
        text = open(dockerfile, encoding="utf-8").read()
        server_stage = text[text.index("AS server"):text.index("AS bot")]
        env = dict(re.findall(r"(TERRAIN_[A-Z_]+)=(\S+)", server_stage))
        self.data_dir = env["TERRAIN_DATA_DIR"]
        self.game_port = int(env["TERRAIN_PORT"])
        self.metrics_port = int(env["TERRAIN_METRICS_PORT"])
        self.uid = int(re.search(r"useradd [^\n]*--uid (\d+)", server_stage).group(1))


def check_gameserver(spec, path, product, claims, problems):
    for i, port in enumerate(spec.get("ports", [])):
        where = f"{path}.ports[{i}]"
        if port.get("portPolicy") not in ("Dynamic", "Static", "Passthrough", "None"):
            problems.append(f"{where}.portPolicy: '{port.get('portPolicy')}' is not an Agones policy")
        if port.get("protocol", "UDP") not in ("TCP", "UDP", "TCPUDP"):
            problems.append(f"{where}.protocol: '{port.get('protocol')}' is not TCP, UDP or TCPUDP")
        if port.get("protocol") != "TCP":
            problems.append(f"{where}.protocol: the terrain protocol is TCP (Agones defaults to UDP)")
        if port.get("containerPort") != product.game_port:
            problems.append(f"{where}.containerPort: the image serves on {product.game_port}")
    health = spec.get("health", {})
    if health.get("disabled"):
        problems.append(f"{path}.health.disabled: the server pings; leave health on")
    for key in ("initialDelaySeconds", "periodSeconds", "failureThreshold"):
        if health.get(key, 1) <= 0:
            problems.append(f"{path}.health.{key}: must be positive")
    pod = spec.get("template", {}).get("spec", {})
    grace = pod.get("terminationGracePeriodSeconds", 30)
    if grace < 10:
        problems.append(f"{path}.template.spec.terminationGracePeriodSeconds: {grace} s leaves "
                        "no time to drain (commit, snapshot, 2 s linger)")
    security = pod.get("securityContext", {})
    if security.get("runAsUser") != product.uid:
        problems.append(f"{path}.template.spec.securityContext.runAsUser: the image's user is "
                        f"{product.uid}")
    if security.get("fsGroup") is None:
        problems.append(f"{path}.template.spec.securityContext.fsGroup: needed for the journal "
                        "volume to be writable by the non-root user")
    volumes = {v["name"]: v for v in pod.get("volumes", [])}
    for v in volumes.values():
        claim = v.get("persistentVolumeClaim", {}).get("claimName")
        if claim is not None and claim not in claims:
            problems.append(f"{path}: volume '{v['name']}' claims '{claim}', not defined here")
    containers = pod.get("containers", [])
    if len(containers) != 1:
        problems.append(f"{path}.template.spec.containers: one server container expected")
    for c, container in enumerate(containers):
        where = f"{path}.template.spec.containers[{c}]"
        args = container.get("args", [])
        if not args or args[0] != "serve":
            problems.append(f"{where}.args: must start with the 'serve' subcommand")
        for arg in args:
            if arg.startswith("--") and arg not in product.flags:
                problems.append(f"{where}.args: {arg} is not a terrain-server serve flag")
        if "--agones" not in args:
            problems.append(f"{where}.args: --agones is needed for Ready and Health")
        if "--agones-health-ms" in args:
            every_ms = int(args[args.index("--agones-health-ms") + 1])
            if 2 * every_ms > 1000 * health.get("periodSeconds", 5):
                problems.append(f"{where}.args: health pings every {every_ms} ms do not fit two "
                                "in a health period")
        names = [e["name"] for e in container.get("env", [])]
        for name in names:
            if name.startswith("TERRAIN_") and name not in product.env:
                problems.append(f"{where}.env: {name} is not a variable terrain-server reads")
        if "TERRAIN_TOKEN_SECRET" not in names and "TERRAIN_TOKEN_SECRET_FILE" not in names:
            problems.append(f"{where}.env: no token secret (TERRAIN_TOKEN_SECRET[_FILE])")
        mounts = {m["mountPath"]: m["name"] for m in container.get("volumeMounts", [])}
        if product.data_dir not in mounts:
            problems.append(f"{where}.volumeMounts: the journal ({product.data_dir}) is not on "
                            "a volume")
        for mount_path, name in mounts.items():
            if name not in volumes:
                problems.append(f"{where}.volumeMounts: '{name}' is not a volume of the pod")
        for p in container.get("ports", []):
            if p.get("name") == "metrics" and p.get("containerPort") != product.metrics_port:
                problems.append(f"{where}.ports: metrics are on {product.metrics_port}")
        probe = container.get("readinessProbe", {}).get("httpGet")
        if probe and (probe.get("port") != product.metrics_port or probe.get("path") != "/readyz"):
            problems.append(f"{where}.readinessProbe: the server answers /readyz on "
                            f"{product.metrics_port}")
        resources = container.get("resources", {})
        if "requests" not in resources or "limits" not in resources:
            problems.append(f"{where}.resources: requests and limits both needed")
        for kind in ("cpu", "memory"):
            req = resources.get("requests", {}).get(kind)
            lim = resources.get("limits", {}).get(kind)
            if req is None or lim is None:
                continue
            r = quantity(req, f"{where}.resources.requests.{kind}", problems)
            lv = quantity(lim, f"{where}.resources.limits.{kind}", problems)
            if r is not None and lv is not None and r > lv:
                problems.append(f"{where}.resources: {kind} request {req} over its limit {lim}")


def check_documents(name, documents, product):
    problems = []
    claims = {d["metadata"]["name"] for d in documents
              if isinstance(d, dict) and d.get("kind") == "PersistentVolumeClaim"}
    for n, doc in enumerate(documents):
        path = f"{name}[{n}]"
        if not isinstance(doc, dict):
            problems.append(f"{path}: not a mapping")
            continue
        key = (doc.get("apiVersion"), doc.get("kind"))
        if key not in KINDS:
            problems.append(f"{path}: {key[0]} {key[1]} is not a kind these manifests use")
            continue
        shape(doc, KINDS[key], f"{path}", problems)
        if not doc.get("metadata", {}).get("name"):
            problems.append(f"{path}.metadata.name: missing")
        if key[1] == "GameServer":
            check_gameserver(doc.get("spec", {}), f"{path}.spec", product, claims, problems)
        elif key[1] == "Fleet":
            spec = doc.get("spec", {})
            if spec.get("replicas", 0) < 1:
                problems.append(f"{path}.spec.replicas: at least 1")
            if spec.get("scheduling", "Packed") not in ("Packed", "Distributed"):
                problems.append(f"{path}.spec.scheduling: Packed or Distributed")
            if spec.get("strategy", {}).get("type", "RollingUpdate") not in (
                    "RollingUpdate", "Recreate"):
                problems.append(f"{path}.spec.strategy.type: RollingUpdate or Recreate")
            check_gameserver(spec.get("template", {}).get("spec", {}), f"{path}.spec.template.spec",
                             product, claims, problems)
    return problems


def self_test(name, documents, product):
    """Each breakage must be caught: the checks can fail."""
    def game(docs):
        for d in docs:
            if d["kind"] == "GameServer":
                return d["spec"]
            if d["kind"] == "Fleet":
                return d["spec"]["template"]["spec"]
        raise AssertionError("no GameServer spec")

    def container(docs):
        return game(docs)["template"]["spec"]["containers"][0]

    def slow_pings(args):
        args[args.index("--agones-health-ms") + 1] = "4000"

    breakages = {
        "misspelt key": lambda d: game(d)["health"].update({"periodSecond": 5}),
        "unknown flag": lambda d: container(d)["args"].append("--agones-health"),
        "UDP game port": lambda d: game(d)["ports"][0].update({"protocol": "UDP"}),
        "wrong data dir": lambda d: container(d)["volumeMounts"][0].update({"mountPath": "/data"}),
        "request over limit": lambda d: container(d)["resources"]["requests"].update({"memory": "1Gi"}),
        "pings too slow": lambda d: slow_pings(container(d)["args"]),
        "unknown variable": lambda d: container(d)["env"].append({"name": "TERRAIN_PORTS", "value": "1"}),
        "root user": lambda d: game(d)["template"]["spec"]["securityContext"].update({"runAsUser": 0}),
    }
    missed = []
    for what, breakage in breakages.items():
        broken = copy.deepcopy(documents)
        breakage(broken)
        if not check_documents(name, broken, product):
            missed.append(what)
    return missed


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--server-bin", required=True)
    parser.add_argument("--dockerfile", required=True)
    parser.add_argument("--self-test", action="store_true")
    parser.add_argument("manifests", nargs="+")
    args = parser.parse_args()
    product = Product(args.server_bin, args.dockerfile)
    failed = False
    for name in args.manifests:
        with open(name, encoding="utf-8") as f:
            documents = [d for d in yaml.safe_load_all(f) if d is not None]
        problems = check_documents(name, documents, product)
        for p in problems:
            print(f"check_manifests: {p}")
        failed |= bool(problems)
        if args.self_test:
            missed = self_test(name, documents, product)
            for what in missed:
                print(f"check_manifests: self-test: {name}: a copy with '{what}' passed")
            failed |= bool(missed)
        print(f"check_manifests: {name}: {len(documents)} objects, "
              f"{'FAILED' if problems else 'ok'}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
