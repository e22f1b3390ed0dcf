#!/usr/bin/env bash
# Time per sample of every integrator on the CPU backend and on the Vulkan device (`--backend
# gpu`), on the embedded cloud: the evidence for `--backend auto`'s choice on software devices
# (docs/results/speed.md). Each case renders twice, with S and 2S samples per pixel, and the
# marginal time per sample is (t(2S) - t(S)) / (S x pixels): pipeline builds and a driver's
# compile on first dispatch (lavapipe) are fixed costs and drop out.
# Run it twice and keep the second run: lavapipe caches its compile of a pipeline on disk, and
# the first run's S render pays for it.
# Usage: scripts/results/speed_integrators.sh [HOST] [OUT_DIR] [SIZE (image width and height, 96)]
set -euo pipefail
cd "$(dirname "$0")/../.."
host="${1:-target/release/host}"
out="${2:-docs/results/speed/integrators}"
mkdir -p "$out"
size="${3:-96}"
common=(--width "$size" --height "$size" --quiet)
cases=(
  "transmittance:8:"
  "free-flight:8:--integrator free-flight"
  "mis-jackknife:8:--integrator mis-jackknife"
  "direct:8:--integrator direct"
  "path:4:--integrator path"
  "restir:4:--integrator restir --lights random:64"
)
ms() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['elapsed_ms'])" "$1"; }
printf '| integrator | backend | ms at S spp | ms at 2S spp | ns per sample (marginal) |\n'
printf '|---|---|---|---|---|\n'
for c in "${cases[@]}"; do
  name="${c%%:*}"; rest="${c#*:}"; spp="${rest%%:*}"; args="${rest#*:}"
  for b in cpu gpu; do
    for k in 1 2; do
      # shellcheck disable=SC2086
      "$host" render --backend "$b" "${common[@]}" $args --spp $((spp * k)) \
        --out "$out/${name}_${b}_$k.exr" --json "$out/${name}_${b}_$k.json" >/dev/null 2>&1
    done
    a=$(ms "$out/${name}_${b}_1.json"); z=$(ms "$out/${name}_${b}_2.json")
    python3 -c "
a, z, s = $a, $z, $spp
print(f'| $name | $b | {a:.0f} | {z:.0f} | {(z - a) * 1e6 / (s * $size * $size):.0f} |')"
  done
done
