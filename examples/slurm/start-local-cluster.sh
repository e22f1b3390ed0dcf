#!/usr/bin/env bash
# Starts a one-node Slurm cluster on this machine (Debian/Ubuntu, as root, no systemd needed):
# installs slurm-wlm and munge if missing, writes /etc/slurm/slurm.conf for this host, starts
# munged, slurmctld and slurmd if they are not running, and waits until the node is idle.
# Safe to run again. Stop it with stop-local-cluster.sh. FORCE=1 overwrites a slurm.conf that
# this script did not write.
set -euo pipefail

[[ $(id -u) -eq 0 ]] || { echo "run as root" >&2; exit 1; }
MARK="# written by examples/slurm/start-local-cluster.sh"
CONF=/etc/slurm/slurm.conf

# 1. Packages.
if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge
fi

# 2. Munge: a key, its run directory, the daemon (started only if credentials fail).
if [[ ! -s /etc/munge/munge.key ]]; then
  if command -v mungekey >/dev/null; then mungekey --create --keyfile=/etc/munge/munge.key
  else create-munge-key -f; fi
  chown munge:munge /etc/munge/munge.key && chmod 400 /etc/munge/munge.key
fi
install -d -o munge -g munge -m 755 /run/munge
if ! munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
  runuser -u munge -- /usr/sbin/munged
  sleep 1
fi
munge -n | unmunge >/dev/null

# 3. slurm.conf for this host, with what `slurmd -C` finds (CPUs, sockets, memory).
NODE=$(hostname -s)
HW=$(slurmd -C | head -n1 | sed 's/^NodeName=[^ ]* //')
NEW=$(cat <<CONF
$MARK
ClusterName=local
SlurmctldHost=$NODE
SlurmUser=slurm
AuthType=auth/munge
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
# No cgroups, no accounting: works in containers and without systemd.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
# Cancel a job whose dependency can no longer be met (e.g. the merge after a failed shard).
SchedulerParameters=kill_invalid_depend
ReturnToService=2
NodeName=$NODE $HW State=UNKNOWN
PartitionName=local Nodes=$NODE Default=YES MaxTime=INFINITE State=UP
CONF
)
if [[ -e $CONF ]] && ! grep -qxF "$MARK" "$CONF" && [[ ${FORCE:-0} != 1 ]]; then
  echo "$CONF was not written by this script; FORCE=1 overwrites it" >&2; exit 1
fi
install -d -o slurm -g slurm /var/spool/slurmctld /var/log/slurm
install -d /var/spool/slurmd
if [[ ! -e $CONF ]] || [[ $(cat "$CONF") != "$NEW" ]]; then
  # A changed node or config: restart the daemons with it.
  for pidfile in /run/slurmd.pid /run/slurmctld.pid; do
    [[ -s $pidfile ]] && kill "$(cat "$pidfile")" 2>/dev/null && sleep 2 || true
  done
  printf '%s\n' "$NEW" > "$CONF"
fi

# 4. Daemons (they fork into the background; logs in /var/log/slurm/).
running() { [[ -s $1 ]] && kill -0 "$(cat "$1")" 2>/dev/null; }
running /run/slurmctld.pid || slurmctld
running /run/slurmd.pid || slurmd

# 5. Wait for the node to be idle (resume it if it came back down or drained).
for _ in $(seq 60); do
  state=$(sinfo -h -n "$NODE" -o %t 2>/dev/null || true)
  case $state in
    idle|mix|alloc) sinfo; exit 0 ;;
    down*|drain*|drng*) scontrol update NodeName="$NODE" State=RESUME || true ;;
  esac
  sleep 1
done
echo "node $NODE not idle after 60 s (state: ${state:-none}); see /var/log/slurm/" >&2
exit 1
