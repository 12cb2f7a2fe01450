#!/usr/bin/env python3
"""Where a battle's crater frame goes: runs client_battle_bench under `perf record` and groups
the self time by the tessellator part it is spent in (BENCHMARKS.md, "Where a battle's crater
frame goes"). Grouping is by symbol name (the function's own, before its parameters); an inlined
callee counts where it was inlined.

    python3 tests/bench/crater_profile.py [--flight hover|cross] [--bench build/release/tests/client_battle_bench]
"""
import argparse
import re
import subprocess
import sys
import tempfile

GROUPS = [
    ("bounds: block re-bounds, centre windows, heights, packing",
     ["BlockBounds", "BoundsUpdate", "fillCellHeights", "BoundsCodec::pack", "nextafter",
      "StaleBlocks"]),
    ("policy: candidate heap, pricing, evaluate, the cull sweep",
     ["CandidateHeap", "SplitMerge", "extentOf", "PolicyMesh", "pointOf", "BoundsCodec::unpack",
      "refreshCandidate", "ViewMetric", "boxOf", "priority", "screenError"]),
    ("walk and emission: splits, merges, index slots, vertex reads",
     ["TileMesh", "idOf", "parentsActive", "vertexAt", "hasActiveChild", "activate",
      "deactivate", "splitTriangles", "indicesOf", "splitGain", "canActivate", "resolve",
      "tileKey", "emit", "markUsed", "DiamondSpace", "TileVertexArrays", "BlockPool",
      "materialise", "attachGrain", "TileEmitter", "LatticeIds"]),
    ("terrain apply, both sides",
     ["gridNumerators", "PointwiseOp", "findPatch", "Terrain::", "XXH3", "lattice",
      "DetailBlocks", "patch", "Patch"]),
]


def classify(text):
    for name, keys in GROUPS:
        if any(k in text for k in keys):
            return name
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--flight", default="hover", choices=["hover", "cross"])
    ap.add_argument("--shots", type=int, default=2000)
    ap.add_argument("--bench", default="build/release/tests/client_battle_bench")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        data = f"{tmp}/perf.data"
        run = subprocess.run(
            ["perf", "record", "-F", "499", "-o", data, a.bench, "--shots", str(a.shots),
             "--flight", a.flight], capture_output=True, text=True)
        if run.returncode != 0:
            sys.exit(f"crater_profile: perf record failed:\n{run.stderr}")
        print(run.stdout.splitlines()[1] if len(run.stdout.splitlines()) > 1 else run.stdout)
        report = subprocess.run(
            ["perf", "report", "-i", data, "--no-children", "--sort", "symbol", "--stdio"],
            capture_output=True, text=True, check=True).stdout
    shares = {name: 0.0 for name, _ in GROUPS}
    other = 0.0
    for line in report.splitlines():
        m = re.match(r"\s+([0-9.]+)%\s+\[[.k]\]\s+(\S.*?)\s+-\s+-", line) or \
            re.match(r"\s+([0-9.]+)%\s+\[[.k]\]\s+(\S.*)$", line)
        if not m:
            continue
        share, symbol = float(m.group(1)), m.group(2)
        # the function's own name first (a parameter type names another part), then the rest
        group = classify(symbol.split("(")[0]) or classify(symbol)
        if group:
            shares[group] += share
        else:
            other += share
    for name, share in shares.items():
        print(f"{share:5.1f} %  {name}")
    print(f"{other:5.1f} %  other")


if __name__ == "__main__":
    main()
