#!/usr/bin/env bash
# tools/farm/slurm/local-cluster.sh -- a one-machine Slurm cluster (Debian 12's slurm-wlm
# 22.05 with munge), started as root without systemd, for trying the farm scripts and for
# CI's farm leg. Not for production: one node, no accounting, no cgroups.
#
#   tools/farm/slurm/local-cluster.sh start [STATE_DIR]   # default /tmp/strata-slurm
#   tools/farm/slurm/local-cluster.sh stop  [STATE_DIR]
#
# `start` writes STATE_DIR/slurm.conf (this host as controller and as the one compute node,
# with all its CPUs), starts munged, slurmctld and slurmd, waits until the node is idle, and
# prints the line to export SLURM_CONF. Install first: apt-get install slurm-wlm munge.
set -euo pipefail

action=${1:-}
state=${2:-/tmp/strata-slurm}
log() { printf '[local-cluster] %s\n' "$*" >&2; }
die() { printf '[local-cluster] error: %s\n' "$*" >&2; exit 1; }

# Whether any of these processes still runs (a zombie has exited: init reaps it in its own time).
running() {
    (($#)) && ps -o stat= -p "$(IFS=,; echo "$*")" 2>/dev/null | grep -qv '^Z'
}

stop() {
    # Jobs first: a job's slurmstepd (and what it runs) outlives slurmd.
    if pgrep -f -- "-f $state/slurm.conf" >/dev/null; then
        SLURM_CONF=$state/slurm.conf scancel --user="$(id -un)" 2>/dev/null || true
        for _ in $(seq 50); do
            [[ -z $(SLURM_CONF=$state/slurm.conf squeue -h 2>/dev/null) ]] && break
            sleep 0.1
        done
    fi
    local pids=()
    for pidfile in "$state"/slurmd.pid "$state"/slurmctld.pid "$state"/munged.pid; do
        if [[ -f $pidfile ]]; then pids+=("$(cat "$pidfile")"); fi
    done
    # Daemons whose pid files are gone: found by the configuration they were started with.
    mapfile -t -O "${#pids[@]}" pids < <(pgrep -f -- "-f $state/slurm.conf" || true
        pgrep -f -- "--socket $state/munge/munge.socket" || true)
    if ((${#pids[@]})); then kill "${pids[@]}" 2>/dev/null || true; fi
    # Until they have exited: a cluster started next needs the ports, and start refuses to
    # run beside a live slurmctld (slurmctld takes a second or so to save its state).
    for _ in $(seq 100); do
        running "${pids[@]}" || break
        sleep 0.1
    done
    if running "${pids[@]}"; then log "still running after 10 s: ${pids[*]}"; fi
    log "stopped (state in $state)"
}

case $action in
    start) ;;
    stop) stop; exit 0 ;;
    *) die "usage: $0 start|stop [STATE_DIR]" ;;
esac

[[ $(id -u) -eq 0 ]] || die "run as root: slurmd starts jobs as their user"
for tool in munged slurmctld slurmd sinfo; do
    command -v "$tool" >/dev/null || die "$tool not found: apt-get install slurm-wlm munge"
done
host=$(hostname -s)
cpus=$(nproc)
# The ports below must be free: another cluster (or one left running) would take the jobs.
# (Zombies do not count: they hold no port, and init may take a while to reap them.)
if pgrep -r D,R,S,T,t -x 'slurm(ctld|d)' >/dev/null; then
    die "a slurmctld or slurmd is already running on this machine (pgrep -a slurm); stop it first"
fi
mkdir -p "$state"/{spool,ctld,log,munge}
chmod 700 "$state/munge"

# munge: the key the package made, or a new one; its socket in the state directory.
key=/etc/munge/munge.key
if [[ ! -s $key ]]; then
    mkdir -p /etc/munge
    dd if=/dev/urandom of="$key" bs=1 count=1024 status=none
    chmod 400 "$key"
fi
socket="$state/munge/munge.socket"
munged --force --key-file "$key" --socket "$socket" --pid-file "$state/munged.pid" \
    --log-file "$state/log/munged.log" --seed-file "$state/munge/seed"

cat >"$state/slurm.conf" <<EOF
# Written by tools/farm/slurm/local-cluster.sh: one machine, controller and node.
ClusterName=strata-local
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/spool
SlurmctldPidFile=$state/slurmctld.pid
SlurmdPidFile=$state/slurmd.pid
SlurmctldLogFile=$state/log/slurmctld.log
SlurmdLogFile=$state/log/slurmd.log
SlurmctldPort=16817
SlurmdPort=16818
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
# Slurm does not retry a failed array task by itself (issue 31: merge --check finds it).
JobRequeue=0
NodeName=$host CPUs=$cpus State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF="$state/slurm.conf"
slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"
for _ in $(seq 100); do
    if sinfo -h -o '%t' 2>/dev/null | grep -qx idle; then
        log "up: node $host with $cpus CPUs, partition local (logs in $state/log)"
        echo "export SLURM_CONF=$SLURM_CONF"
        exit 0
    fi
    sleep 0.1
done
sinfo >&2 || true
tail -n 20 "$state/log/slurmctld.log" "$state/log/slurmd.log" >&2 || true
die "the node did not come up within 10 s"
