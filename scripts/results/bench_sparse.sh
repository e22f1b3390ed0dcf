#!/usr/bin/env bash
# The sparse-volume series of issue 15: OpenVDB-written files with 15 % of their 16^3 blocks
# occupied over growing bounding boxes (256^3 .. the Disney cloud's 993x675x1224), plus two voxels
# at opposite corners of a 1000^3 box. For each file: `host bench --sweep-files` (load + pack
# time, pool, ns/ray of jackknife and ratio tracking on both backends, JSON), then a standalone
# `host render` on the CPU and on the GPU (peak resident memory of the whole process from
# /usr/bin/time, and whether the two EXRs are the same bytes; lavapipe's times are in the JSON, the
# standalone GPU render's time is mostly pipeline creation).
#
#   scripts/results/bench_sparse.sh [DIR]     files go to DIR (default target/sparse-series), made once
#   HOST=path/to/host scripts/results/bench_sparse.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
dir=${1:-target/sparse-series}
host=${HOST:-target/release/host}
[ -x "$host" ] || cargo build --release -p host
mkdir -p "$dir"
if [ ! -f "$dir/sparse_disney.vdb" ]; then
  /usr/bin/python3 scripts/fixtures/make_sparse_volumes.py series "$dir"
fi
[ -f "$dir/two.vdb" ] || /usr/bin/python3 scripts/fixtures/make_sparse_volumes.py two "$dir/two.vdb"
files=("$dir"/sparse_256.vdb "$dir"/sparse_half.vdb "$dir"/sparse_three_quarters.vdb \
  "$dir"/sparse_disney.vdb "$dir"/two.vdb)
list=$(IFS=,; echo "${files[*]}")
mkdir -p docs/results
"$host" bench --backend both --width 128 --height 128 --spp 4 --reps 3 --warmup 1 \
  --estimators jackknife --sweep-estimators jackknife,ratio --sweep-files "$list" \
  --json docs/results/bench_sparse.json --quiet

echo
echo "| file | bbox | peak RSS (cpu render) | prepare ms | pool MiB | cpu render ms | cpu == gpu EXR |"
echo "|---|---|---|---|---|---|---|"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for f in "${files[@]}"; do
  for b in cpu gpu; do
    /usr/bin/time -f "%M" -o "$out/$b.rss" "$host" --backend "$b" --width 256 --height 256 \
      --spp 4 --volume "$f" --out "$out/$b.exr" --json "$out/$b.json" --quiet >/dev/null
  done
  same=$(cmp -s "$out/cpu.exr" "$out/gpu.exr" && echo yes || echo NO)
  python3 - "$f" "$out" "$same" <<'PY'
import json, sys
f, out, same = sys.argv[1:]
c = json.load(open(f"{out}/cpu.json"))
rss = int(open(f"{out}/cpu.rss").read().split()[-1]) / 1024
d = c["dims"]
print(f"| {f.split('/')[-1]} | {'x'.join(map(str, d))} | {rss:.0f} MB | {c['prepare_ms']:.0f} | "
      f"{c['pool_bytes'] / 2**20:.1f} | {c['elapsed_ms']:.0f} | {same} |")
PY
done
