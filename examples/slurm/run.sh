#!/usr/bin/env bash
# Renders a scene on Slurm: a job array of shards (render-shards.sbatch), then a merge
# (merge.sbatch) that runs only if every shard succeeded; waits for both and prints the merged
# EXR's sha256. Run it from the directory the paths are relative to (the repository root):
#   SCENE=smoke.toml SPP=1024 examples/slurm/run.sh
# Settings (environment): HOST, SCENE, SPP (the scene's --spp), SAMPLES_PER_SHARD (a multiple
# of 256), SHARDS (folder), OUT (.exr), LOGS (folder, default out/slurm/logs).
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
export HOST=${HOST:-target/release/host} SCENE=${SCENE:-scene.toml} SPP=${SPP:-1024}
export SAMPLES_PER_SHARD=${SAMPLES_PER_SHARD:-256}
export SHARDS=${SHARDS:-out/slurm/shards} OUT=${OUT:-out/slurm/render.exr}
LOGS=${LOGS:-out/slurm/logs}
[[ -x $HOST ]] || { echo "no host binary at $HOST" >&2; exit 1; }
[[ -f $SCENE ]] || { echo "no scene file at $SCENE" >&2; exit 1; }

n=$(( (SPP + SAMPLES_PER_SHARD - 1) / SAMPLES_PER_SHARD ))
mkdir -p "$LOGS" "$SHARDS" "$(dirname "$OUT")"   # Slurm does not create the log folder
rm -f "$SHARDS"/shard-*.shard "$OUT"           # an earlier render's shards would be merged too

# Submit (--parsable prints "id" or "id;cluster").
array=$(sbatch --parsable --export=ALL --array="0-$((n - 1))" \
  --output="$LOGS/shard-%A_%a.out" "$here/render-shards.sbatch")
array=${array%%;*}
merge=$(sbatch --parsable --export=ALL --dependency="afterok:$array" \
  --output="$LOGS/merge-%j.out" "$here/merge.sbatch")
merge=${merge%%;*}
echo "submitted: array job $array ($n shards of $SAMPLES_PER_SHARD samples), merge job $merge"

# Wait until neither job is queued or running (no accounting here, so squeue, not sacct).
# A failed shard leaves the merge pending forever unless the cluster has kill_invalid_depend.
queued() { [[ -n $(squeue -h -j "$1" 2>/dev/null || true) ]]; }
while queued "$array" || queued "$merge"; do
  if squeue -h -j "$merge" -o %r 2>/dev/null | grep -q DependencyNeverSatisfied; then
    scancel "$merge"
  fi
  sleep 1
done

# Check: every shard's log ends with "shard i done", the merge's log and output exist.
for ((i = 0; i < n; i++)); do
  log=$LOGS/shard-${array}_$i.out
  if ! tail -n1 "$log" 2>/dev/null | grep -q "^shard $i done"; then
    echo "shard $i failed: see $log" >&2; exit 1
  fi
done
if [[ ! -s $OUT ]]; then
  echo "merge failed: no $OUT (see $LOGS/merge-$merge.out)" >&2; exit 1
fi
sha256sum "$OUT"
