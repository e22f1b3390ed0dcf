#!/usr/bin/env bash
# Adaptive super-voxels (issue 17, `--supervoxels adaptive`) against fixed bricks of 16^3, 12^3
# and 8^3: the jackknife against the reference of `host eval` (exact regular tracking for
# nearest lookups) at 1024 estimates per pixel, 128x128 px, CPU, on the three embedded volumes;
# f32 and bc4 statistics with nearest lookups, f32 with stochastic and trilinear lookups.
# Writes docs/results/adaptive/<volume>_<lookup>_<format>_<structure>.json and prints excess
# bias (mean |bias| minus its noise floor), std, time, super-voxel reads per ray and table size.
# Usage: scripts/results/eval_adaptive.sh [host binary] [volumes] [lookups] [formats] [structures]
# (structures: fixed16 fixed12 fixed8 adaptive, or adaptive:CELL:RATIO[:OCCUPANCY] on 16^3
# bricks).
set -euo pipefail
cd "$(dirname "$0")/../.."
host=${1:-target/release/host}
volumes=${2:-cloud explosion constant}
lookups=${3:-nearest}
formats=${4:-f32 bc4}
structures=${5:-fixed16 fixed12 fixed8 adaptive}
out=docs/results/adaptive
mkdir -p "$out"
echo "| volume | lookup | format | super-voxels | mean bias | mean abs bias | noise floor | excess | mean std | ms | reads/ray (bricks) | table |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
for vol in $volumes; do
  for lookup in $lookups; do
    for fmt in $formats; do
      for s in $structures; do
        case $s in
          fixed*) flags=(--brick-size "${s#fixed}") ;;
          adaptive) flags=(--brick-size 16 --supervoxels adaptive) ;;
          adaptive:*)
            IFS=: read -r _ cell ratio occupancy <<<"$s"
            flags=(--brick-size 16 --supervoxels adaptive --cell-size "$cell" --split-ratio "$ratio")
            if [ -n "${occupancy:-}" ]; then flags+=(--split-occupancy "$occupancy"); fi ;;
          *) echo "unknown structure $s" >&2; exit 2 ;;
        esac
        json="$out/${vol}_${lookup}_${fmt}_${s//:/_}.json"
        "$host" eval --volume "$vol" --lookup "$lookup" --supervoxel-format "$fmt" "${flags[@]}" \
          --estimators jackknife --width 128 --height 128 --spp 1024 --backend cpu \
          --out-dir "out/adaptive/${vol}_${lookup}_${fmt}_${s//:/_}" --json "$json" -q >/dev/null
        python3 - "$json" "$vol" "$lookup" "$fmt" "$s" <<'PY'
import json, sys
path, vol, lookup, fmt, s = sys.argv[1:]
j = json.load(open(path))
e = next(e for e in j["estimators"] if e["name"] == "jackknife")
sv = j["supervoxels"]
r = sv["reads_per_ray"]
table = sv["bc4_table_bytes"] if fmt == "bc4" else sv["table_bytes"]
print(f"| {vol} | {lookup} | {fmt} | {s} | {e['mean_bias']:+.5f} | {e['mean_abs_bias']:.5f} | "
      f"{e['abs_bias_noise_floor']:.5f} | {e['mean_abs_bias'] - e['abs_bias_noise_floor']:.5f} | "
      f"{e['mean_std']:.4f} | {e['elapsed_ms']:.0f} | {r['supervoxels']:.1f} ({r['bricks']:.1f}) | "
      f"{table / 2**20:.3f} MiB |")
PY
      done
    done
  done
done
