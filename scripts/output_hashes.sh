#!/usr/bin/env bash
# SHA-256 of a fixed set of outputs (render EXRs of every estimator and integrator on both
# backends, `host eval` images, every study's JSON), to prove that a refactoring changes no bit.
#
#   scripts/output_hashes.sh            compare with docs/output_hashes.txt (exit 1 on a difference)
#   scripts/output_hashes.sh --record   write docs/output_hashes.txt
#
# HOST=path/to/host overrides the binary (default: target/release/host, built if missing).
# Timing fields (JSON `elapsed_ms`, ...) are never hashed: only images and study numbers.
set -euo pipefail
cd "$(dirname "$0")/.."
record=0
case "${1:-}" in
  --record) record=1 ;;
  "") ;;
  *) echo "usage: $0 [--record]" >&2; exit 2 ;;
esac
host="${HOST:-target/release/host}"
if [ ! -x "$host" ]; then
  cargo build --release -p host
fi
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
list="$out/hashes.txt"
: > "$list"

# name, then host arguments; the output file is hashed under the name.
hash_file() { # name file
  printf '%s %s\n' "$1" "$(sha256sum "$2" | cut -d' ' -f1)" >> "$list"
}

# Independent samples for the long list (the default sampler, sobol, has its own entries below).
small=(--resolution 48 --width 24 --height 20 --spp 3 --seed 7 --quiet --sampler independent)
estimators=(jackknife naive naive-m1 jackknife-adaptive jackknife-mean jackknife-uniform
  biased-rm biased-rm2 unbiased-rm unbiased-rm2 track-length ratio regular)
integrators=(free-flight equiangular mis-jackknife mis-naive combined-jackknife combined-naive
  miller mis-power direct path restir)
backends=(cpu)
if "$host" render --backend gpu "${small[@]}" --out "$out/probe_gpu.exr" >/dev/null 2>&1; then
  backends+=(gpu)
else
  echo "output_hashes: no Vulkan device; hashing the CPU backend only" >&2
fi
for backend in "${backends[@]}"; do
  for volume in cloud explosion; do
    for lookup in nearest stochastic; do
      for e in "${estimators[@]}"; do
        f="$out/r.exr"
        "$host" render --backend "$backend" --volume "$volume" --lookup "$lookup" \
          --estimator "$e" "${small[@]}" --out "$f" >/dev/null
        # Both backends must give the same bytes: one name for both.
        hash_file "render/$volume/$lookup/$e" "$f"
      done
    done
    for i in "${integrators[@]}"; do
      f="$out/r.exr"
      "$host" render --backend "$backend" --volume "$volume" --lookup nearest \
        --integrator "$i" "${small[@]}" --out "$f" >/dev/null
      hash_file "render/$volume/integrator/$i" "$f"
    done
  done
done
# More than one 256-sample block: the blocks' exact totals (engine/src/render/exact.rs), on each backend.
for backend in "${backends[@]}"; do
  f="$out/r.exr"
  "$host" render --backend "$backend" --volume cloud --resolution 48 --width 8 --height 6 \
    --spp 600 --seed 7 --quiet --sampler independent --out "$f" >/dev/null
  hash_file "render/cloud/blocks/jackknife-600spp" "$f"
done
# The default sampler (sobol): a transmittance render, each integrator family, and more than one
# sample block, on each backend.
for backend in "${backends[@]}"; do
  sobol=(--backend "$backend" --volume cloud --lookup nearest --resolution 48 --width 24
    --height 20 --spp 3 --seed 7 --quiet --out "$out/r.exr")
  "$host" render "${sobol[@]}" >/dev/null
  hash_file "render/cloud/sobol/transmittance" "$out/r.exr"
  for i in free-flight mis-jackknife direct path restir; do
    "$host" render "${sobol[@]}" --integrator "$i" >/dev/null
    hash_file "render/cloud/sobol/$i" "$out/r.exr"
  done
  "$host" render --backend "$backend" --volume cloud --resolution 48 --width 8 --height 6 \
    --spp 600 --seed 7 --quiet --integrator path --out "$out/r.exr" >/dev/null
  hash_file "render/cloud/sobol/path-600spp" "$out/r.exr"
done
"$host" eval --backend cpu --volume cloud --resolution 48 --width 16 --height 16 --spp 8 \
  --estimators jackknife,ratio,unbiased-rm --out-dir "$out/eval" --quiet >/dev/null
for f in "$out"/eval/*.exr; do hash_file "eval/$(basename "$f")" "$f"; done
"$host" eval --backend cpu --volume cloud --resolution 48 --width 12 --height 12 --spp 4 \
  --reference-spp 8 --integrators mis-jackknife,miller --out-dir "$out/evali" --quiet >/dev/null
for f in "$out"/evali/*.exr; do hash_file "eval-integrators/$(basename "$f")" "$f"; done

study() { # name, then arguments
  local name="$1"
  shift
  "$host" study "$name" "$@" --json "$out/s.json" --plot "$out/s.png" --quiet >/dev/null
  hash_file "study/$name" "$out/s.json"
}
study normal --trials 20000 --sweep-trials 2000
study distributions --trials 5000 --points 4
study profile --trials 5000
study table1 --trials 2000
study histogram --trials 5000
study convergence --trials 500 --points 4
study mis-bias --trials 500 --nx 4 --ny 4

sort -o "$list" "$list"
# Names hashed on both backends must agree: a GPU/CPU difference is a failure in itself.
if [ "$(cut -d' ' -f1 "$list" | uniq -d | wc -l)" -ne 0 ]; then
  dups="$(sort -u "$list" | cut -d' ' -f1 | uniq -d)"
  if [ -n "$dups" ]; then
    echo "output_hashes: GPU and CPU differ for:" >&2
    echo "$dups" >&2
    exit 1
  fi
  sort -u -o "$list" "$list"
fi
if [ "$record" = 1 ]; then
  cp "$list" docs/output_hashes.txt
  echo "recorded $(wc -l < "$list") hashes in docs/output_hashes.txt"
  exit 0
fi
if diff -u docs/output_hashes.txt "$list"; then
  echo "output_hashes: all $(wc -l < "$list") outputs identical to docs/output_hashes.txt"
else
  echo "output_hashes: outputs differ from docs/output_hashes.txt (see the diff above)" >&2
  exit 1
fi
