# A private one-node Slurm cluster for the tests, sourced by tests/cluster.sh.
#
#   slurm_start DIR    starts munged, slurmctld and slurmd with everything
#                      (config, key, socket, state, spool, logs, pid files)
#                      under DIR, on ports 16817 and 16818, and exports
#                      SLURM_CONF; waits (at most 60 s) for the node to be
#                      idle. Returns non-zero, after the logs' tails and
#                      stopping what it started, when it cannot.
#   slurm_stop DIR     stops the daemons it started, by their process ids:
#                      SIGTERM, at most 10 s, then SIGKILL. Safe to call
#                      twice and from a trap.
#   slurm_wait JOB S   waits at most S seconds for JOB (every array task) to
#                      leave the queue; non-zero on timeout.
#   slurm_state JOB    the state of JOB or of each of its array tasks, one a
#                      line, as slurmctld remembers them (MinJobAge 600 s;
#                      there is no accounting database).
#
# Nothing outside DIR is changed. munged runs as root with --force and its
# own key and socket, and Slurm is pointed at the socket (AuthInfo). When
# munged cannot start, the cluster runs with AuthType=auth/none instead.
# Without cgroups: proctrack/linuxproc and task/none. KillWait is 5 s: a
# job that is cancelled or reaches its time limit gets SIGTERM, and SIGKILL
# 5 s later (checked here: scancel of a running array task delivers SIGTERM
# to its batch script, which `exec lancer` makes lancer itself).

SLURM_PORTS="16817 16818"

slurm_start() {
    sd=$1
    host=$(hostname -s)
    mkdir -p "$sd/state" "$sd/spool" "$sd/log"
    chmod 755 "$sd"
    mkdir -m 711 "$sd/munge"
    auth="AuthType=auth/none
CredType=cred/none"
    if command -v munged >/dev/null && head -c 1024 /dev/urandom >"$sd/munge/key" && chmod 600 "$sd/munge/key" &&
        munged --force --socket="$sd/munge/sock" --key-file="$sd/munge/key" --pid-file="$sd/munge/pid" \
            --log-file="$sd/log/munged.log" --seed-file="$sd/munge/seed" 2>"$sd/log/munged.err"; then
        for _ in 1 2 3 4 5 6 7 8 9 10; do [ -S "$sd/munge/sock" ] && break; sleep 0.2; done
        if munge -S "$sd/munge/sock" -n </dev/null | unmunge -S "$sd/munge/sock" >/dev/null 2>&1; then
            auth="AuthType=auth/munge
AuthInfo=socket=$sd/munge/sock
CredType=cred/munge"
        fi
    fi
    echo "$auth" | head -n 1 >"$sd/auth"
    cat >"$sd/slurm.conf" <<CONF
ClusterName=lancertest
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
SlurmctldPort=${SLURM_PORTS% *}
SlurmdPort=${SLURM_PORTS#* }
$auth
StateSaveLocation=$sd/state
SlurmdSpoolDir=$sd/spool
SlurmctldPidFile=$sd/slurmctld.pid
SlurmdPidFile=$sd/slurmd.pid
SlurmctldLogFile=$sd/log/slurmctld.log
SlurmdLogFile=$sd/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
SwitchType=switch/none
SchedulerType=sched/backfill
KillWait=5
MinJobAge=600
ReturnToService=2
NodeName=$host CPUs=$(nproc) RealMemory=1000 State=UNKNOWN
PartitionName=lancer Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
    export SLURM_CONF="$sd/slurm.conf"
    slurmctld -D -f "$SLURM_CONF" >"$sd/log/slurmctld.out" 2>&1 &
    echo $! >"$sd/slurmctld.bgpid"
    slurmd -D -f "$SLURM_CONF" >"$sd/log/slurmd.out" 2>&1 &
    echo $! >"$sd/slurmd.bgpid"
    i=0
    while [ $i -lt 120 ]; do
        if sinfo -h -o %t 2>/dev/null | grep -qx idle; then return 0; fi
        sleep 0.5
        i=$((i + 1))
    done
    echo "slurm: the node did not come up in 60 s; the logs' ends:" >&2
    tail -n 15 "$sd"/log/* >&2
    slurm_stop "$sd"
    return 1
}

slurm_stop() {
    sd=$1
    pids=""
    for f in "$sd/slurmd.bgpid" "$sd/slurmctld.bgpid" "$sd/munge/pid"; do
        [ -s "$f" ] && pids="$pids $(cat "$f")"
    done
    [ -n "$pids" ] || return 0
    # shellcheck disable=SC2086
    kill -TERM $pids 2>/dev/null
    i=0
    while [ $i -lt 50 ]; do
        alive=""
        for p in $pids; do kill -0 "$p" 2>/dev/null && alive="$alive $p"; done
        [ -z "$alive" ] && break
        sleep 0.2
        i=$((i + 1))
    done
    # shellcheck disable=SC2086
    [ -n "$alive" ] && kill -KILL $alive 2>/dev/null
    rm -f "$sd/slurmd.bgpid" "$sd/slurmctld.bgpid" "$sd/munge/pid"
    return 0
}

slurm_wait() {
    job=$1
    limit=$2
    start=$(date +%s)
    while squeue -h -j "$job" 2>/dev/null | grep -q .; do
        if [ $(($(date +%s) - start)) -ge "$limit" ]; then return 1; fi
        sleep 0.5
    done
    return 0
}

slurm_state() {
    scontrol -o show job "$1" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p'
}
