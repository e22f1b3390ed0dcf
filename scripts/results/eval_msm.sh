#!/usr/bin/env bash
# The moment-shadow-map comparison of docs/results/shadows.md (issue 18): on each embedded volume under a
# delta sun, jackknife / ratio / track-length shadow rays against four- and six-moment shadow
# maps at 128 and 512 texels per side, in the `direct` integrator, with a 1024-spp ratio-tracking
# reference and the paired exact-shadow image. Writes docs/results/eval_msm_<volume>.json and
# the insets docs/images/msm_insets_<volume>.png. Usage: scripts/results/eval_msm.sh [host binary]
set -euo pipefail
host=${1:-target/release/host}
for vol in cloud explosion constant; do
  out=out/eval_msm_$vol
  "$host" eval --integrators direct --volume "$vol" --env none --sun 0.7,0.6,-0.45,3,0 \
    --estimators jackknife,ratio,track-length,msm4:128,msm4:512,msm6:128,msm6:512 \
    --lookup nearest --width 128 --height 128 --spp 64 --reference-spp 1024 --backend cpu \
    --exposure 2 --out-dir "$out" --json "docs/results/eval_msm_$vol.json" -q
  cp "$out/direct-insets.png" "docs/images/msm_insets_$vol.png"
done
