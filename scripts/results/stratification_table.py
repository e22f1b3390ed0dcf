#!/usr/bin/env python3
"""The rows of a table of docs/results/stratification.md from the JSONs that
scripts/results/variance_per_sample.py wrote: one row per file and JSON row, labelled by the
text before `=` in each argument.

    python3 scripts/results/stratification_table.py [--column NAME] "LABEL=FILE.json" ...

NAME heads the label column (default: render).
"""
import json
import sys


def main():
    args = sys.argv[1:]
    column = "render"
    if args[:1] == ["--column"]:
        column, args = args[1], args[2:]
    print(f"| {column} | Var(1 spp) | 64 x Var(mean of 64) | gain | image mean |")
    print("|---|---|---|---|---|")
    for arg in args:
        label, path = arg.split("=", 1)
        with open(path) as f:
            data = json.load(f)
        spp = data["spp"]
        for row in data["rows"]:
            one, many = row["spp1"], row[f"spp{spp}"]
            print(
                f"| {label} | {one['var_x_spp']:.4f} | {many['var_x_spp']:.4f} | "
                f"{row['gain']:.2f}x | {many['mean']:.4f} +- {many['mean_se']:.4f} |"
            )


if __name__ == "__main__":
    main()
