#!/usr/bin/env bash
# The fixed-brick baselines of issue 17 (adaptive super-voxels): the jackknife with nearest
# lookups against the exact (regular-tracking) reference at 1024 estimates per pixel, with
# 16^3 (the paper's), 12^3 (its pragmatic fix for the explosion) and 8^3 bricks, on the three
# embedded volumes. Writes docs/results/eval_bricks_<B>_<volume>.json and prints excess bias
# (mean |bias| minus its noise floor) and time. Usage: scripts/results/eval_bricks.sh [host binary]
set -euo pipefail
cd "$(dirname "$0")/../.."
host=${1:-target/release/host}
mkdir -p docs/results
echo "| volume | bricks | mean bias | mean abs bias | noise floor | excess | ms | lookups/ray | brick table |"
echo "|---|---|---|---|---|---|---|---|---|"
for vol in cloud explosion constant; do
  for b in 16 12 8; do
    json="docs/results/eval_bricks_${b}_$vol.json"
    "$host" eval --volume "$vol" --lookup nearest --brick-size "$b" --estimators jackknife \
      --width 128 --height 128 --spp 1024 --backend cpu --out-dir "out/eval_bricks_${b}_$vol" \
      --json "$json" -q >/dev/null 2>&1
    python3 - "$json" "$vol" "$b" <<'PY'
import json, sys
path, vol, b = sys.argv[1:]
j = json.load(open(path))
e = next(e for e in j["estimators"] if e["name"] == "jackknife")
bricks = (256 + int(b) - 1) // int(b)
print(f"| {vol} | {b}^3 | {e['mean_bias']:+.5f} | {e['mean_abs_bias']:.5f} | "
      f"{e['abs_bias_noise_floor']:.5f} | {e['mean_abs_bias'] - e['abs_bias_noise_floor']:.5f} | "
      f"{e['elapsed_ms']:.0f} | {e['mean_samples_per_ray']:.2f} | {bricks ** 3 * 20 / 2**20:.2f} MiB |")
PY
  done
done
