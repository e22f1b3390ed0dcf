#!/usr/bin/env bash
# Where a kernel's time goes on lavapipe, instruction by instruction: runs `host bench --backend
# gpu` on the anchor scene (or any flags given), samples it with perf while the frames run,
# copies the driver's JIT-compiled code out of the process with gdb, and disassembles it, so
# `scripts/investigations/jit_profile.py OUT` can print the loops, blocks and instruction mix with their share
# of the samples. Development tool (needs perf, gdb, objdump; not run by CI).
# Usage: scripts/investigations/jit_profile.sh HOST_BINARY ESTIMATOR OUT_DIR [bench flags replacing the scene]
set -euo pipefail
HOST=${1:?path of the host binary}; EST=${2:?estimator, e.g. track-length}; OUT=${3:?output folder}
shift 3
for tool in perf gdb objdump; do
  command -v "$tool" >/dev/null || { echo "jit_profile: needs $tool (apt install linux-perf gdb binutils)" >&2; exit 2; }
done
mkdir -p "$OUT"
export VK_ICD_FILENAMES=${VK_ICD_FILENAMES:-$(ls /usr/share/vulkan/icd.d/lvp_icd*.json | head -1)}
VOL=${ANCHOR_VOLUME:-$HOME/.cache/author-anchor/vol/cloud256.vdb}
SCENE=("--volume" "$VOL" --density-scale 0.01 --camera 128,128,608 --look-at 128,128,128
  --fov 40 --width 512 --height 512 --n 10 --spp 2)
[ $# -gt 0 ] && SCENE=("$@")
# Enough frames to outlast the pipeline build, the wait and the sampling below.
"$HOST" bench --backend gpu "${SCENE[@]}" --reps "${REPS:-300}" --warmup 1 --estimators "$EST" \
  > "$OUT/bench.log" 2>&1 &
PID=$!
sleep "${WAIT_S:-8}"
kill -0 "$PID" 2>/dev/null || { echo "jit_profile: the bench ended early, see $OUT/bench.log" >&2; exit 1; }
perf record -F "${FREQ:-10000}" -p "$PID" -o "$OUT/perf.data" -- sleep "${SAMPLE_S:-4}" 2>/dev/null
# The JIT code: anonymous executable mappings (the vdso aside).
grep -E 'r-xp 00000000 00:00 0 *$' "/proc/$PID/maps" > "$OUT/maps.txt" || true
args=()
while read -r range _; do
  args+=(-ex "dump binary memory $OUT/jit_${range%-*}.bin 0x${range%-*} 0x${range#*-}")
done < "$OUT/maps.txt"
gdb -p "$PID" -batch "${args[@]}" > "$OUT/gdb.log" 2>&1 || true
kill "$PID" 2>/dev/null; wait "$PID" 2>/dev/null || true
perf script -i "$OUT/perf.data" -F ip,dso 2>/dev/null | awk '{print $1, $2}' | sort | uniq -c \
  | sort -rn > "$OUT/ips.txt"
for f in "$OUT"/jit_*.bin; do
  base=${f##*/jit_}; objdump -D -b binary -m i386:x86-64 --adjust-vma="0x${base%.bin}" "$f"
done > "$OUT/dis.txt"
echo "jit_profile: $(awk '{s+=$1} END {print s}' "$OUT/ips.txt") samples in $OUT; next: scripts/investigations/jit_profile.py $OUT"
