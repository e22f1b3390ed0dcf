#!/usr/bin/env bash
# The lookup-mode comparison of docs/results/adaptive.md (issue 17, `--lookup trilinear`): the jackknife and
# ratio tracking with stochastic and trilinear lookups on the cloud and the explosion, each
# against a ratio-tracking reference of the same lookup. Writes
# docs/results/eval_lookup_<lookup>_<volume>.json. Usage: scripts/results/eval_lookups.sh [host binary]
set -euo pipefail
host=${1:-target/release/host}
for vol in cloud explosion; do
  for lookup in stochastic trilinear; do
    "$host" eval --volume "$vol" --lookup "$lookup" --estimators jackknife,ratio \
      --width 128 --height 128 --spp 64 --reference-spp 1024 --backend cpu \
      --out-dir "out/eval_lookup_${lookup}_$vol" --json "docs/results/eval_lookup_${lookup}_$vol.json" -q
  done
done
