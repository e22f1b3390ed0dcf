#!/usr/bin/env bash
# Issue 19's spatial-reuse measurement: `direct` against `restir` with spatial reuse under 256
# and 4096 random point lights in the embedded cloud at equal time (`host eval --equal-time`:
# every entry gets direct/ratio's render time), for the three targets of restir (jackknife T̂,
# unshadowed T̂ = 1, ratio-tracking T̂), M candidates, P reuse passes of k = 3 neighbours within
# 16 pixels with pairwise MIS (and the balance heuristic for the jackknife target). Final shadow
# rays: ratio tracking (unbiased) and the jackknife. Reference: direct with ratio-tracking shadow
# rays at 1024 spp. Writes docs/results/eval_restir_reuse_<lights>_<target>_<M>_<P>_<mis>.json
# and prints a table (SMAPE ratio: restir over direct with the same shadow rays).
# Usage: scripts/results/eval_restir_reuse.sh [host binary] [backend]
# Environment: WIDTH (square image, default 128), SPP (default 64), REF (reference spp, default
# 1024), CONFIGS ("target M passes mis" entries separated by ';', default the table below), DIR
# (where the JSON go, default docs/results). The H200 table of docs/results/restir.md:
#   WIDTH=512 DIR=docs/results/h200 CONFIGS="unshadowed 8 1 pairwise;unshadowed 8 2 pairwise;..."
#   scripts/results/eval_restir_reuse.sh target/release/host gpu
set -euo pipefail
cd "$(dirname "$0")/../.."
host=${1:-target/release/host}
backend=${2:-cpu}
width=${WIDTH:-128}
spp=${SPP:-64}
ref=${REF:-1024}
dir=${DIR:-docs/results}
mkdir -p "$dir"
echo "| lights | target | M | passes | MIS | shadow rays | spp direct / restir | SMAPE direct | SMAPE restir | ratio | ratio at budget | restir mean bias +- se |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
run() {
  local lights=$1 target=$2 m=$3 passes=$4 mis=$5
  local name="eval_restir_reuse_${lights}_${target}_${m}_${passes}_${mis}"
  local json="$dir/$name.json"
  # Reuse flags only with reuse (host refuses them without).
  local reuse=(--restir-passes "$passes")
  if [ "$passes" -gt 0 ]; then
    reuse+=(--restir-neighbours 3 --restir-radius 16 --restir-mis "$mis")
  fi
  "$host" eval --volume cloud --integrators direct,restir --estimators ratio,jackknife \
    --env none --lights "random:$lights" --restir-target "$target" --restir-candidates "$m" \
    "${reuse[@]}" \
    --equal-time --width "$width" --height "$width" --spp "$spp" --reference-spp "$ref" \
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
if [ -n "${CONFIGS:-}" ]; then
  IFS=';' read -ra configs <<<"$CONFIGS"
  for c in "${configs[@]}"; do
    for lights in 256 4096; do
      # shellcheck disable=SC2086 # "target M passes mis", split on purpose
      run "$lights" $c
    done
  done
  exit 0
fi
for lights in 256 4096; do
  for target in jackknife unshadowed ratio; do
    for passes in 1 2; do
      run "$lights" "$target" 8 "$passes" pairwise
    done
  done
  run "$lights" jackknife 8 1 balance
  run "$lights" jackknife 4 2 pairwise
done
