#!/usr/bin/env bash
# Issue 19's measurement: `direct` (point lights drawn by power) against `restir` (point lights
# resampled from M candidates) under 256 and 4096 random point lights in the embedded cloud, at
# equal time (`host eval --equal-time`: every entry gets direct/ratio's render time), for the
# three targets of restir (jackknife T̂, unshadowed T̂ = 1, ratio-tracking T̂) with M = 8 and 32
# candidates. Final shadow rays: ratio tracking (unbiased) and the jackknife. Reference: direct
# with ratio-tracking shadow rays at 1024 spp. Writes docs/results/eval_restir_<lights>_<target>_<M>.json
# and prints a table (SMAPE ratio: restir over direct with the same shadow rays).
# Usage: scripts/results/eval_restir.sh [host binary] [backend]
set -euo pipefail
cd "$(dirname "$0")/../.."
host=${1:-target/release/host}
backend=${2:-cpu}
mkdir -p docs/results
echo "| lights | target | M | shadow rays | spp direct / restir | SMAPE direct | SMAPE restir | ratio | restir mean bias +- se |"
echo "|---|---|---|---|---|---|---|---|---|"
for lights in 256 4096; do
  for target in jackknife unshadowed ratio; do
    for m in 8 32; do
      json="docs/results/eval_restir_${lights}_${target}_$m.json"
      "$host" eval --volume cloud --integrators direct,restir --estimators ratio,jackknife \
        --env none --lights "random:$lights" --restir-target "$target" --restir-candidates "$m" \
        --equal-time --width 128 --height 128 --spp 64 --reference-spp 1024 \
        --backend "$backend" --out-dir "out/eval_restir_${lights}_${target}_$m" --json "$json" \
        -q >/dev/null 2>&1
      python3 - "$json" "$lights" "$target" "$m" <<'PY'
import json, sys
path, lights, target, m = sys.argv[1:]
e = {x["name"]: x for x in json.load(open(path))["entries"]}
for s in ["ratio", "jackknife"]:
    d, r = e[f"direct/{s}"], e[f"restir/{s}"]
    print(f"| {lights} | {target} | {m} | {s} | {d['spp']} / {r['spp']} | {d['smape']:.4f} | "
          f"{r['smape']:.4f} | {r['smape'] / d['smape']:.2f} | "
          f"{r['mean_bias']:+.5f} +- {r['mean_bias_se']:.5f} |")
PY
    done
  done
done
