#!/usr/bin/env bash
# The telescoping comparison of docs/results/transmittance.md (issue 62): on each embedded volume,
# the jackknife against Misso et al.'s telescoping series (ours, unbiased), the form Cycles 5.0
# ships (truncated, biased), Kettunen et al.'s unbiased ray marching and ratio tracking, on the
# CPU (timings comparable there), against regular tracking. Writes
# docs/results/eval_telescoping_<volume>.json; tables: scripts/results/eval_tables.py --merit.
# Usage: scripts/results/eval_telescoping.sh [host binary]
set -euo pipefail
host=${1:-target/release/host}
for vol in cloud explosion constant; do
  "$host" eval --volume "$vol" --backend cpu --lookup nearest \
    --estimators jackknife,telescoping,telescoping-cycles,unbiased-rm,ratio \
    --width 128 --height 128 --spp 256 --out-dir "out/eval_telescoping_$vol" \
    --json "docs/results/eval_telescoping_$vol.json" -q
done
