#!/usr/bin/env python3
"""Checks that the results pages' tables are what their generators print from the JSONs beside
them: every table row a generator prints must appear, character for character, in its page.
A page edited by hand, or a JSON re-recorded without regenerating its page, fails here.

Usage: scripts/results_check.py   (run by scripts/test.sh; exits 1 naming each missing row)

Pages and generators:
  docs/results/transmittance.md  scripts/results/eval_tables.py docs/results/eval_{cloud,explosion,constant}.json,
                                 and --merit docs/results/eval_telescoping_{cloud,explosion,constant}.json
  docs/results/scattering.md     scripts/results/eval_tables.py docs/results/eval_integrators_cloud.json
  docs/results/direct.md         scripts/results/eval_tables.py docs/results/eval_{direct,path}_cloud.json
  docs/results/shadows.md        scripts/results/eval_tables.py docs/results/eval_msm_{cloud,explosion,constant}.json
  docs/results/restir.md         scripts/results/restir_tables.py (the two CPU tables)
  docs/results/performance.md    scripts/results/bench_tables.py (the default bench, its goals, the H200)
  docs/results/peers.md          scripts/results/peers/equal_time_table.py docs/results/peers/equal_time_{10,60}s*.json
  docs/results/adaptive.md       scripts/results/adaptive_table.py (its f32 nearest rows appear in the
                                 page's first adaptive table without the lookup and format columns)
  docs/results/stratification.md scripts/results/stratification_table.py (the escape table)
"""
import os
import subprocess
import sys

root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
results = os.path.join(root, "docs", "results")


def rows(command):
    """The table rows (not headers' rules) a generator prints."""
    out = subprocess.run(
        [sys.executable] + command, cwd=root, check=True, capture_output=True, text=True
    ).stdout
    return [
        line
        for line in out.splitlines()
        if line.startswith("|") and not line.startswith("|---")
    ]


def condensed_adaptive(row):
    """An adaptive_table.py row of f32 nearest lookups as the page's first table shows it."""
    cells = row.split(" | ")
    if len(cells) > 3 and cells[1] == "nearest" and cells[2] == "f32":
        return " | ".join([cells[0]] + cells[3:])
    return row


checks = [
    (
        "transmittance.md",
        ["scripts/results/eval_tables.py"]
        + [f"docs/results/eval_{v}.json" for v in ("cloud", "explosion", "constant")],
        lambda r: r,
    ),
    (
        "transmittance.md",
        ["scripts/results/eval_tables.py", "--merit"]
        + [f"docs/results/eval_telescoping_{v}.json" for v in ("cloud", "explosion", "constant")],
        lambda r: r,
    ),
    (
        "scattering.md",
        ["scripts/results/eval_tables.py", "docs/results/eval_integrators_cloud.json"],
        lambda r: r,
    ),
    (
        "direct.md",
        ["scripts/results/eval_tables.py"]
        + [f"docs/results/eval_{i}_cloud.json" for i in ("direct", "path")],
        lambda r: r,
    ),
    (
        "shadows.md",
        ["scripts/results/eval_tables.py"]
        + [f"docs/results/eval_msm_{v}.json" for v in ("cloud", "explosion", "constant")],
        lambda r: r,
    ),
    ("restir.md", ["scripts/results/restir_tables.py"], lambda r: r),
    ("performance.md", ["scripts/results/bench_tables.py"], lambda r: r),
    (
        "peers.md",
        ["scripts/results/peers/equal_time_table.py"]
        + [f"docs/results/peers/equal_time_10s{x}.json" for x in ("", "_ratio", "_n4", "_n2")],
        lambda r: r,
    ),
    (
        "peers.md",
        ["scripts/results/peers/equal_time_table.py"]
        + [f"docs/results/peers/equal_time_10s_roulette{x}.json" for x in ("", "_ratio")],
        lambda r: r,
    ),
    (
        "peers.md",
        [
            "scripts/results/peers/equal_time_table.py",
            "docs/results/peers/equal_time_10s_roulette_peers.json",
        ],
        lambda r: r,
    ),
    (
        "peers.md",
        [
            "scripts/results/peers/equal_time_table.py",
            "docs/results/peers/equal_time_10s_constant_peers.json",
        ],
        lambda r: r,
    ),
    (
        "peers.md",
        ["scripts/results/peers/equal_time_table.py"]
        + [f"docs/results/peers/equal_time_10s_constant{x}.json" for x in ("", "_probe")],
        lambda r: r,
    ),
    (
        "peers.md",
        [
            "scripts/results/peers/equal_time_table.py",
            "--budget",
            "60",
            "docs/results/peers/equal_time_60s_constant_peers.json",
        ],
        lambda r: r,
    ),
    (
        "peers.md",
        [
            "scripts/results/peers/equal_time_table.py",
            "--budget",
            "60",
            "docs/results/peers/equal_time_60s_cycles50_peers.json",
        ],
        lambda r: r,
    ),
    ("adaptive.md", ["scripts/results/adaptive_table.py"], condensed_adaptive),
    (
        "stratification.md",
        [
            "scripts/results/stratification_table.py",
            "--column",
            "flights decided against T̂",
            "none (`path` as it is)=docs/results/stratification/escape_base.json",
            "the camera ray's=docs/results/stratification/escape_sf0.json",
            "every vertex's=docs/results/stratification/escape_sf.json",
        ],
        lambda r: r,
    ),
]

missing = 0
for page, command, shown in checks:
    text = open(os.path.join(results, page)).read()
    generated = rows(command)
    # A table's header row stands once per table; the data rows must all be there.
    absent = [r for r in generated if shown(r) not in text]
    for r in absent:
        print(f"docs/results/{page}: a row of `{' '.join(command)}` is missing:\n  {shown(r)}")
    missing += len(absent)
    if not generated:
        print(f"docs/results/{page}: `{' '.join(command)}` printed no rows")
        missing += 1
if missing:
    print(
        f"results_check: {missing} generated rows missing; regenerate the tables with the "
        "commands above and paste them into the pages"
    )
    sys.exit(1)
print(f"results_check: {len(checks)} pages match their generators")
