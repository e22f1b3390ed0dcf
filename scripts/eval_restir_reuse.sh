#!/usr/bin/env bash
# Issue 19's spatial-reuse measurement: `direct` against `restir` with spatial reuse under 256
# and 4096 random point lights in the embedded cloud at equal time (`host eval --equal-time`:
# every entry gets direct/ratio's render time), for the three targets of restir (jackknife T̂,
# unshadowed T̂ = 1, ratio-tracking T̂), M candidates, P reuse passes of k = 3 neighbours within
# 16 pixels with pairwise MIS (and the balance heuristic for the jackknife target). Final shadow
# rays: ratio tracking (unbiased) and the jackknife. Reference: direct with ratio-tracking shadow
# rays at 1024 spp. Writes docs/results/eval_restir_reuse_<lights>_<target>_<M>_<P>_<mis>.json
# and prints a table (SMAPE ratio: restir over direct with the same shadow rays).
# Usage: scripts/eval_restir_reuse.sh [host binary] [backend]
set -euo pipefail
cd "$(dirname "$0")/.."
host=${1:-target/release/host}
backend=${2:-cpu}
mkdir -p docs/results
echo "| lights | target | M | passes | MIS | shadow rays | spp direct / restir | SMAPE direct | SMAPE restir | ratio | ratio at budget | restir mean bias +- se |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
run() {
  local lights=$1 target=$2 m=$3 passes=$4 mis=$5
  local name="eval_restir_reuse_${lights}_${target}_${m}_${passes}_${mis}"
  local json="docs/results/$name.json"
  "$host" eval --volume cloud --integrators direct,restir --estimators ratio,jackknife \
    --env none --lights "random:$lights" --restir-target "$target" --restir-candidates "$m" \
    --restir-passes "$passes" --restir-neighbours 3 --restir-radius 16 --restir-mis "$mis" \
    --equal-time --width 128 --height 128 --spp 64 --reference-spp 1024 \
    --backend "$backend" --out-dir "out/$name" --json "$json" -q >/dev/null 2>&1
  python3 - "$json" "$lights" "$target" "$m" "$passes" "$mis" <<'PY'
import json, sys
path, lights, target, m, passes, mis = sys.argv[1:]
e = {x["name"]: x for x in json.load(open(path))["entries"]}
# "at budget": each calibrated entry's SMAPE moved to the exact budget (calibration.smape_at_budget).
at = lambda x: (x.get("calibration") or {}).get("smape_at_budget", x["smape"])
for s in ["ratio", "jackknife"]:
    d, r = e[f"direct/{s}"], e[f"restir/{s}"]
    print(f"| {lights} | {target} | {m} | {passes} | {mis} | {s} | {d['spp']} / {r['spp']} | "
          f"{d['smape']:.4f} | {r['smape']:.4f} | {r['smape'] / d['smape']:.2f} | "
          f"{at(r) / at(d):.2f} | {r['mean_bias']:+.5f} +- {r['mean_bias_se']:.5f} |")
PY
}
for lights in 256 4096; do
  for target in jackknife unshadowed ratio; do
    for passes in 1 2; do
      run "$lights" "$target" 8 "$passes" pairwise
    done
  done
  run "$lights" jackknife 8 1 balance
  run "$lights" jackknife 4 2 pairwise
done
