#!/usr/bin/env python3
"""Prints the two CPU tables of docs/results/restir.md from the eval JSONs beside it:

  without reuse  docs/results/eval_restir_<lights>_<target>_<M>.json
  with reuse     docs/results/eval_restir_reuse_<lights>_<target>_<M>_<passes>_<mis>.json

Each JSON is one `host eval --integrators direct,restir --equal-time` (scripts/results/eval_restir.sh,
scripts/results/eval_restir_reuse.sh). SMAPE ratio: restir's SMAPE over `direct`'s with the same
shadow-ray estimator; var/sample: the squared ratio of restir's and direct's mean per-pixel
standard deviation (ratio shadow rays); cost/sample: restir's render time per sample over
direct's.

Usage: scripts/results/restir_tables.py   (run by scripts/results_check.py)
"""
import glob
import json
import os

results = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "docs", "results")
TARGETS = {"unshadowed": "unshadowed", "jackknife": "jackknife (N = 4)", "ratio": "ratio"}
ORDER = ["unshadowed", "jackknife", "ratio"]


def entries(path):
    with open(path) as f:
        return {e["name"]: e for e in json.load(f)["entries"]}


def smape_ratios(e):
    return (
        e["restir/ratio"]["smape"] / e["direct/ratio"]["smape"],
        e["restir/jackknife"]["smape"] / e["direct/jackknife"]["smape"],
    )


def per_spp(e):
    return e["elapsed_ms"] / e["spp"]


def without_reuse():
    rows = []
    for path in glob.glob(os.path.join(results, "eval_restir_[0-9]*.json")):
        lights, target, m = os.path.basename(path)[:-5].split("_")[2:]
        rows.append(((int(lights), ORDER.index(target), int(m)), path, lights, target, m))
    print("| lights | target | M | restir spp (ratio shadow rays) | SMAPE ratio, ratio shadow rays | SMAPE ratio, jackknife shadow rays |")
    print("|---|---|---|---|---|---|")
    for _, path, lights, target, m in sorted(rows):
        e = entries(path)
        r, j = smape_ratios(e)
        print(f"| {lights} | {TARGETS[target]} | {m} | {e['restir/ratio']['spp']} | {r:.2f} | {j:.2f} |")


def with_reuse(order):
    rows = []
    for path in glob.glob(os.path.join(results, "eval_restir_reuse_*.json")):
        lights, target, m, passes, mis = os.path.basename(path)[:-5].split("_")[3:]
        rows.append((lights, target, m, passes, mis, path))
    print("| lights | target | M | passes, MIS | restir spp (ratio rays) | var/sample | cost/sample | SMAPE ratio, ratio rays | SMAPE ratio, jackknife rays |")
    print("|---|---|---|---|---|---|---|---|---|")
    for lights, target, m, passes, mis, path in sorted(rows, key=order):
        e = entries(path)
        r, j = smape_ratios(e)
        rr, dr = e["restir/ratio"], e["direct/ratio"]
        var = (rr["mean_std"] / dr["mean_std"]) ** 2
        cost = per_spp(rr) / per_spp(dr)
        print(
            f"| {lights} | {TARGETS[target]} | {m} | {passes}, {mis} | {rr['spp']} | {var:.2f} | "
            f"{cost:.1f} | {r:.2f} | {j:.2f} |"
        )


def reuse_order(row):
    lights, target, m, passes, mis, _ = row
    return (int(lights), ORDER.index(target), mis != "pairwise" or False, -int(m), int(passes), mis)


if __name__ == "__main__":
    without_reuse()
    print()
    with_reuse(reuse_order)
