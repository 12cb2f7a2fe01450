#!/usr/bin/env python3
"""Markdown tables of a lod_bench run (runs.csv): per scenario, every method at one tau; and the
cheapest way each method reaches a measured error. Used by lod_report.sh (out/lod/tables.md)."""
import csv
import sys
from collections import defaultdict


def fmt(v, digits=2):
    v = float(v)
    if v == 0:
        return "0"
    if abs(v) >= 1000:
        return f"{v:,.0f}"
    return f"{v:.{digits}g}" if abs(v) < 0.01 else f"{v:.{digits}f}"


def main(path, tau="1"):
    rows = list(csv.DictReader(open(path)))
    out = []
    scenarios = []
    for r in rows:
        key = (r["map"], r["flight"])
        if key not in scenarios:
            scenarios.append(key)
    out.append(f"### Every scenario at tau = {tau} px, no cap\n")
    out.append("| map | flight | method | CPU ms p50 / p99 | triangles p50 | upload KB/frame mean "
               "| screen error max / p99 px | bound px | pixels off | PSNR dB | popping | LOD change "
               "| over tau | rebuilds | open edges |")
    out.append("| --- " * 15 + "|")
    for m, f in scenarios:
        for r in rows:
            if r["map"] != m or r["flight"] != f or r["cap"] != "0":
                continue
            if r["tau"] != tau and r["method"] != "full_mesh":
                continue
            out.append(
                f"| {m} | {f} | {r['method']} | {fmt(r['cpu_p50_ms'])} / {fmt(r['cpu_p99_ms'])} "
                f"| {fmt(r['triangles_p50'])} | {fmt(float(r['upload_mean_bytes']) / 1024, 3)} "
                f"| {fmt(r['error_max_px'])} / {fmt(r['error_p99_px'])} | {fmt(r['bound_max_px'])} "
                f"| {float(r['image_diff_mean']) * 100:.3f} % | {fmt(r['psnr_mean_db'], 3)} "
                f"| {float(r['popping_mean']) * 100:.3f} % "
                f"| {float(r['lod_change_mean']) * 100:.4f} % | {r['frames_over_tau']}/{r['measured_frames']} "
                f"| {r['rebuilds']} | {r['open_edges']} |")
    # capped runs
    capped = [r for r in rows if r["cap"] != "0"]
    if capped:
        out.append("\n### A triangle cap that binds\n")
        out.append("| map | flight | method | tau | cap | triangles p50 / max | CPU ms p50 / p99 "
                   "| bound px | screen error max px | frames capped | rebuilds |")
        out.append("| --- " * 11 + "|")
        for r in capped:
            out.append(
                f"| {r['map']} | {r['flight']} | {r['method']} | {r['tau']} | {r['cap']} "
                f"| {fmt(r['triangles_p50'])} / {fmt(r['triangles_max'])} "
                f"| {fmt(r['cpu_p50_ms'])} / {fmt(r['cpu_p99_ms'])} | {fmt(r['bound_max_px'])} "
                f"| {fmt(r['error_max_px'])} | {r['frames_capped']} | {r['rebuilds']} |")
    # per method and scenario: the cheapest run whose measured p99 is within 0.5 px
    out.append("\n### What a measured screen error of at most 0.5 px (p99 of triangles) costs\n")
    out.append("| map | flight | method | tau | CPU ms p50 | triangles p50 | upload KB/frame |")
    out.append("| --- " * 7 + "|")
    for m, f in scenarios:
        best = defaultdict(lambda: None)
        for r in rows:
            if r["map"] != m or r["flight"] != f or r["cap"] != "0":
                continue
            if float(r["error_p99_px"]) > 0.5:
                continue
            b = best[r["method"]]
            if b is None or float(r["triangles_p50"]) < float(b["triangles_p50"]):
                best[r["method"]] = r
        for method in ("split_merge", "split_merge_morph", "split_only", "chunked", "full_mesh"):
            if not any(r["map"] == m and r["flight"] == f and r["method"] == method for r in rows):
                continue  # not run in this scenario
            r = best[method]
            if r is None:
                out.append(f"| {m} | {f} | {method} | none within 0.5 px | | | |")
                continue
            out.append(
                f"| {m} | {f} | {method} | {r['tau']} | {fmt(r['cpu_p50_ms'])} "
                f"| {fmt(r['triangles_p50'])} | {fmt(float(r['upload_mean_bytes']) / 1024, 3)} |")
    print("\n".join(out))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else "1")
