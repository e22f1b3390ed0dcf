#!/usr/bin/env bash
# BC4-compressed super-voxel statistics (issue 17, `--supervoxel-format bc4`, the paper's setting)
# against f32 ones: the jackknife with nearest lookups against the exact (regular-tracking)
# reference at 1024 estimates per pixel, 16^3 and 12^3 bricks, on the three embedded volumes.
# Writes docs/results/eval_<format>_<B>_<volume>.json and prints excess bias (mean |bias| minus its
# noise floor), std and time. Usage: scripts/results/eval_bc4.sh [host binary]
set -euo pipefail
cd "$(dirname "$0")/../.."
host=${1:-target/release/host}
mkdir -p docs/results
echo "| volume | bricks | format | mean bias | mean abs bias | noise floor | excess | mean std | ms | brick table |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for vol in cloud explosion constant; do
  for b in 16 12; do
    for fmt in f32 bc4; do
      json="docs/results/eval_${fmt}_${b}_$vol.json"
      "$host" eval --volume "$vol" --lookup nearest --brick-size "$b" --supervoxel-format "$fmt" \
        --estimators jackknife --width 128 --height 128 --spp 1024 --backend cpu \
        --out-dir "out/eval_${fmt}_${b}_$vol" --json "$json" -q >/dev/null 2>&1
      python3 - "$json" "$vol" "$b" "$fmt" <<'PY'
import json, math, sys
path, vol, b, fmt = sys.argv[1:]
j = json.load(open(path))
e = next(e for e in j["estimators"] if e["name"] == "jackknife")
n = (256 + int(b) - 1) // int(b)
# f32: 20 bytes per brick; bc4: 8 bytes per 4x4 block of one slice and statistic, 4-byte slots.
table = n ** 3 * 20 if fmt == "f32" else 4 * 8 * math.ceil(n / 4) ** 2 * n + 4 * n ** 3
print(f"| {vol} | {b}^3 | {fmt} | {e['mean_bias']:+.5f} | {e['mean_abs_bias']:.5f} | "
      f"{e['abs_bias_noise_floor']:.5f} | {e['mean_abs_bias'] - e['abs_bias_noise_floor']:.5f} | "
      f"{e['mean_std']:.4f} | {e['elapsed_ms']:.0f} | {table / 2**20:.3f} MiB |")
PY
    done
  done
done
