#!/usr/bin/env bash
# Stops the one-node cluster of start-local-cluster.sh: slurmd, slurmctld (saving its state)
# and munged, by their pid files. Leaves packages and configs in place.
set -euo pipefail

stop() { # pidfile name
  local pid
  pid=$(cat "$1" 2>/dev/null || true)
  if [[ -n $pid ]] && kill -0 "$pid" 2>/dev/null; then
    kill "$pid"
    for _ in $(seq 20); do kill -0 "$pid" 2>/dev/null || break; sleep 0.5; done
    echo "stopped $2"
  fi
}
stop /run/slurmd.pid slurmd
stop /run/slurmctld.pid slurmctld
stop /run/munge/munged.pid munged
