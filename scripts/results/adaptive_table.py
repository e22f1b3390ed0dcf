#!/usr/bin/env python3
"""Prints the adaptive super-voxel table rows of docs/results/adaptive.md (issue 17) from the JSONs that
scripts/results/eval_adaptive.sh writes to docs/results/adaptive/<volume>_<lookup>_<format>_<structure>.json,
in the order volume, lookup, format, structure (fixed16, fixed12, fixed8, adaptive).

Usage: scripts/results/adaptive_table.py [volumes] [lookups] [formats]   (space-separated lists)
"""
import json
import os
import sys

here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "docs", "results", "adaptive")
volumes = (sys.argv[1] if len(sys.argv) > 1 else "explosion cloud constant").split()
lookups = (sys.argv[2] if len(sys.argv) > 2 else "nearest stochastic trilinear").split()
formats = (sys.argv[3] if len(sys.argv) > 3 else "f32 bc4").split()
names = {"fixed16": "fixed 16^3", "fixed12": "fixed 12^3", "fixed8": "fixed 8^3", "adaptive": "adaptive"}
print("| volume | lookup | format | super-voxels | mean bias | mean abs bias | noise floor | excess "
      "| mean std | ms | reads/ray | table |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|")
for vol in volumes:
    for lookup in lookups:
        for fmt in formats:
            for s, name in names.items():
                path = os.path.join(here, f"{vol}_{lookup}_{fmt}_{s}.json")
                if not os.path.exists(path):
                    print(f"missing: {path}", file=sys.stderr)
                    continue
                j = json.load(open(path))
                e = next(e for e in j["estimators"] if e["name"] == "jackknife")
                sv = j["supervoxels"]
                r = sv["reads_per_ray"]
                table = sv["bc4_table_bytes"] if fmt == "bc4" else sv["table_bytes"]
                reads = f"{r['supervoxels']:.1f}"
                if s == "adaptive":
                    reads += f" ({r['bricks']:.1f})"
                excess = e["mean_abs_bias"] - e["abs_bias_noise_floor"]
                print(f"| {vol} | {lookup} | {fmt} | {name} | {e['mean_bias']:+.5f} | "
                      f"{e['mean_abs_bias']:.5f} | {e['abs_bias_noise_floor']:.5f} | {excess:.5f} | "
                      f"{e['mean_std']:.4f} | {e['elapsed_ms']:.0f} | {reads} | "
                      f"{table / 2**20:.3f} MiB |")
