#!/usr/bin/env python3
"""Prints the `host bench` tables of docs/results/performance.md from the JSONs they come from:

  the default bench (CPU and lavapipe) and its goals  docs/results/speed/bench_cloud_default.json
  the NVIDIA H200 table                               docs/results/h200/bench_cloud_h200.json

Usage: scripts/results/bench_tables.py   (run by scripts/results_check.py)
"""
import json
import os

results = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "docs", "results")
GOALS = {
    "time jackknife / track-length": "time jackknife / track-length",
    "time jackknife / ratio": "time jackknife / ratio tracking",
    "time jackknife / unbiased-rm": "time jackknife / unbiased ray marching",
    "std^2*time jackknife / track-length": "std^2 x time jackknife / track-length",
}


def load(*path):
    with open(os.path.join(results, *path)) as f:
        return json.load(f)


def default_bench():
    d = load("speed", "bench_cloud_default.json")
    cpu = {r["estimator"]: r for r in d["rows"] if r["backend"] == "cpu"}
    gpu = {r["estimator"]: r for r in d["rows"] if r["backend"] != "cpu"}
    print("| estimator | CPU ms/frame | CPU ns/ray | lavapipe ms/frame (kernel) | lavapipe ns/ray | lookups/ray | variance | var x ns (CPU) |")
    print("|---|---|---|---|---|---|---|---|")
    for e, c in cpu.items():
        g = gpu[e]
        print(
            f"| {e} | {c['frame_ms_median']:.1f} | {c['ns_per_ray']:.0f} | "
            f"{g['frame_ms_median']:.1f} ({g['kernel_ms_median']:.1f}) | {g['ns_per_ray']:.0f} | "
            f"{c['samples_per_ray']:.2f} | {c['variance']:.5f} | {c['work_normalized_variance']:.3f} |"
        )
    print()
    print("| ratio | target | CPU | lavapipe |")
    print("|---|---|---|---|")
    goals = {}
    for g in d["goals"]:
        goals.setdefault(g["what"], {})[g["backend"]] = g
    for what, by in goals.items():
        cell = lambda g: f"{g['ratio']:.2f} {'yes' if g['met'] else 'no'}"
        print(f"| {GOALS[what]} | <= {by['cpu']['target']} | {cell(by['cpu'])} | {cell(by['gpu'])} |")


def h200():
    d = load("h200", "bench_cloud_h200.json")
    print("| estimator | ms/frame (kernel) | ns/ray | Mrays/s | lookups/ray | variance |")
    print("|---|---|---|---|---|---|")
    for r in d["rows"]:
        print(
            f"| {r['estimator']} | {r['frame_ms_median']:.1f} ({r['kernel_ms_median']:.1f}) | "
            f"{r['ns_per_ray']:.1f} | {r['rays_per_s'] / 1e6:.1f} | {r['samples_per_ray']:.2f} | "
            f"{r['variance']:.5f} |"
        )


if __name__ == "__main__":
    default_bench()
    print()
    h200()
