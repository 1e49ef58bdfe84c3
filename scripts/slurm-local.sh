#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for testing hydrofit's Slurm executor.
#
#   scripts/slurm-local.sh up DIR     install (Debian: slurm-wlm, munge) if needed, write
#                                     DIR/slurm.conf, start munged, slurmctld and slurmd;
#                                     prints `export SLURM_CONF=DIR/slurm.conf`
#   scripts/slurm-local.sh down DIR   stop the daemons it started (by the PIDs it recorded)
#
# No systemd: the daemons run in the foreground of background shells, their PIDs in DIR. The
# node is `idle` within a second or two of `up`.
set -euo pipefail

cmd=${1:?usage: slurm-local.sh up|down DIR}
dir=$(realpath -m "${2:?usage: slurm-local.sh up|down DIR}")

# Root for the installation and munge's key and socket; sudo when not root already.
as_root() {
    if [[ $(id -u) == 0 ]]; then "$@"; else sudo "$@"; fi
}

down() {
    for d in slurmd slurmctld munged; do
        if [[ -f "$dir/$d.pid" ]]; then
            pid=$(cat "$dir/$d.pid")
            as_root kill "$pid" 2>/dev/null || true
            for _ in $(seq 30); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
            as_root kill -9 "$pid" 2>/dev/null || true
            rm -f "$dir/$d.pid"
        fi
    done
}

if [[ $cmd == down ]]; then
    down
    exit 0
fi
[[ $cmd == up ]] || { echo "usage: slurm-local.sh up|down DIR" >&2; exit 2; }

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null
fi

mkdir -p "$dir"/{state,spool,log}
host=$(hostname -s)
# Munge: a key, and its socket directory owned by the munge user.
if ! as_root test -s /etc/munge/munge.key; then
    as_root dd if=/dev/urandom bs=1 count=1024 of=/etc/munge/munge.key 2>/dev/null
fi
as_root chown munge:munge /etc/munge/munge.key
as_root chmod 400 /etc/munge/munge.key
as_root mkdir -p /run/munge /var/log/munge /var/lib/munge
as_root chown munge:munge /run/munge /var/log/munge /var/lib/munge
if ! pgrep -x munged >/dev/null; then
    as_root su -s /bin/sh munge -c "munged --foreground" >"$dir/log/munged.out" 2>&1 &
    # Ready when it answers (a socket file may be left from an earlier daemon).
    for _ in $(seq 100); do
        munge -n </dev/null 2>/dev/null | unmunge >/dev/null 2>&1 && break
        sleep 0.1
    done
    # The daemon's own PID (the shell's child is su).
    pgrep -n -x munged >"$dir/munged.pid"
fi

node=$(slurmd -C | head -1)
mem=$(awk '/MemTotal/ {print int($2 / 1024 * 0.8)}' /proc/meminfo)
node=$(sed -E "s/RealMemory=[0-9]+/RealMemory=$mem/" <<<"$node")
cat >"$dir/slurm.conf" <<EOF
ClusterName=hydrofit-test
SlurmctldHost=$host(127.0.0.1)
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
SchedulerType=sched/backfill
ReturnToService=2
MinJobAge=86400
DependencyParameters=kill_invalid_depend
JobCompType=jobcomp/filetxt
JobCompLoc=$dir/log/jobcomp.txt
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.daemon.pid
SlurmdPidFile=$dir/slurmd.daemon.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
SlurmUser=root
$node State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$dir/slurm.conf
slurmctld -D -f "$SLURM_CONF" >"$dir/log/slurmctld.out" 2>&1 &
echo $! >"$dir/slurmctld.pid"
sleep 0.5
slurmd -D -f "$SLURM_CONF" >"$dir/log/slurmd.out" 2>&1 &
echo $! >"$dir/slurmd.pid"
for _ in $(seq 100); do
    if sinfo -h -o %t 2>/dev/null | grep -qx idle; then
        echo "export SLURM_CONF=$SLURM_CONF"
        exit 0
    fi
    sleep 0.2
done
echo "slurm-local.sh: the node did not come up; logs in $dir/log" >&2
down
exit 1
