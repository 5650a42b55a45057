#!/usr/bin/env bash
# CI step: a real one-node SLURM (slurmctld + slurmd + munge from Debian's packages) and a small
# study run through `jamlab run --cluster slurm`, compared bit for bit with a local run of the
# same study (every dataset and attribute of every sample file).
#
# Skips (exit 0, with a message) where SLURM cannot be had for reasons outside jamlab: no apt-get,
# not root, the packages cannot be installed, a SLURM controller already running on this machine,
# or JAMLAB_SKIP_SLURM=1. Fails (exit 1) if SLURM was installed but does not come up, if the
# SLURM run fails, if its samples differ from the local run's, or if the job logs are not in
# the run directory.
#
# Usage: .ci/slurm.sh   (from anywhere; uses $JAMLAB and $PYTHON, default .venv/bin/{jamlab,python})
# Leaves nothing running: the daemons it started are stopped by process id at exit.
# The configuration lives in $SLURM_CONF (under /var/spool/jamlab-slurm), never in /etc/slurm.
set -uo pipefail
cd "$(dirname "$0")/.."
REPO=$(pwd)
JAMLAB=${JAMLAB:-$REPO/.venv/bin/jamlab}
PYTHON=${PYTHON:-$REPO/.venv/bin/python}

skip() { echo "SLURM step skipped: $*"; exit 0; }
fail() { echo "SLURM step FAILED: $*${WORK:+ (runs kept in $WORK)}" >&2; exit 1; }

[ "${JAMLAB_SKIP_SLURM:-0}" = 1 ] && skip "JAMLAB_SKIP_SLURM=1"
command -v apt-get >/dev/null 2>&1 || skip "apt-get not available (not a Debian/Ubuntu machine)"
[ "$(id -u)" = 0 ] || skip "not root (installing and running SLURM needs root)"
if pgrep -x slurmctld >/dev/null 2>&1; then
    skip "a slurmctld is already running on this machine; not touching it"
fi

WORK=""
t_start=$(date +%s.%N)
elapsed() { "$PYTHON" -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.1f}')" \
    "$1" "$(date +%s.%N)"; }

# --- install ------------------------------------------------------------------------------------
PACKAGES="slurmctld slurmd slurm-client munge"
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null \
    || ! command -v sinfo >/dev/null || ! command -v munged >/dev/null; then
    export DEBIAN_FRONTEND=noninteractive
    if ! { apt-get update -qq && apt-get install -y -qq --no-install-recommends $PACKAGES; } \
        >/tmp/jamlab-slurm-apt.log 2>&1; then
        tail -5 /tmp/jamlab-slurm-apt.log
        skip "apt-get install $PACKAGES failed (log: /tmp/jamlab-slurm-apt.log)"
    fi
fi
echo "SLURM: slurmctld $(dpkg-query -W -f='${Version}' slurmctld) installed in $(elapsed "$t_start") s"

# --- configure ----------------------------------------------------------------------------------
HOST=$(hostname -s)
BASE=/var/spool/jamlab-slurm
mkdir -p "$BASE/ctld" "$BASE/d" "$BASE/log"
export SLURM_CONF=$BASE/slurm.conf
# the node's memory as slurmd sees it (with CR_Core_Memory a job's --mem must fit in it)
REAL_MEMORY=$(slurmd -C 2>/dev/null | tr ' ' '\n' | sed -n 's/^RealMemory=//p')
REAL_MEMORY=${REAL_MEMORY:-2000}
cat >"$SLURM_CONF" <<EOF
# one-node SLURM for jamlab's CI (written by .ci/slurm.sh)
ClusterName=jamlab-ci
SlurmctldHost=$HOST
SlurmUser=root
AuthType=auth/munge
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
DefMemPerCPU=1000
ReturnToService=2
SchedulerType=sched/backfill
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
StateSaveLocation=$BASE/ctld
SlurmdSpoolDir=$BASE/d
SlurmctldPidFile=$BASE/slurmctld.pid
SlurmdPidFile=$BASE/slurmd.pid
SlurmctldLogFile=$BASE/log/slurmctld.log
SlurmdLogFile=$BASE/log/slurmd.log
NodeName=$HOST CPUs=2 RealMemory=$REAL_MEMORY State=UNKNOWN
PartitionName=debug Nodes=$HOST Default=YES MaxTime=INFINITE State=UP
EOF

# --- start munge, slurmctld, slurmd -------------------------------------------------------------
STARTED=()
cleanup() {
    for pid in "${STARTED[@]}"; do kill "$pid" 2>/dev/null; done
    for pid in "${STARTED[@]}"; do
        for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    done
}
trap cleanup EXIT

if ! pgrep -x munged >/dev/null 2>&1; then
    if [ ! -s /etc/munge/munge.key ]; then
        (umask 077; dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none)
    fi
    chown munge:munge /etc/munge/munge.key && chmod 400 /etc/munge/munge.key
    mkdir -p /run/munge /var/log/munge /var/lib/munge
    chown munge:munge /run/munge /var/log/munge /var/lib/munge
    runuser -u munge -- /usr/sbin/munged || fail "munged did not start"
    for _ in $(seq 50); do [ -s /run/munge/munged.pid ] && break; sleep 0.1; done
    STARTED+=("$(cat /run/munge/munged.pid)")
fi
munge -n | unmunge >/dev/null || fail "munge does not work"

t_daemons=$(date +%s.%N)
slurmctld -D >"$BASE/log/slurmctld.stdout" 2>&1 &
STARTED+=("$!")
slurmd -D >"$BASE/log/slurmd.stdout" 2>&1 &
STARTED+=("$!")
state=""
for _ in $(seq 600); do
    state=$(sinfo -h -n "$HOST" -o %T 2>/dev/null | head -1)
    [ "$state" = idle ] && break
    sleep 0.1
done
if [ "$state" != idle ]; then
    tail -20 "$BASE/log/slurmctld.log" "$BASE/log/slurmd.log" >&2
    fail "node $HOST not idle after 60 s (state '$state')"
fi
echo "SLURM: node $HOST idle $(elapsed "$t_daemons") s after starting the daemons"
sinfo

# --- the same small study, locally and through SLURM --------------------------------------------
WORK=$(mktemp -d /tmp/jamlab-slurm-ci.XXXXXX)
cd "$WORK" || fail "cannot enter $WORK"
STUDY=(--phi 0.8 0.9 --n 64 --samples 2 --dim 3 --dgamma 1e-4 --gamma-max 2e-3 --seed 16)

t0=$(date +%s.%N)
"$JAMLAB" run "${STUDY[@]}" --out local --workers 2 || fail "local run failed"
echo "local run: $(elapsed "$t0") s"

t0=$(date +%s.%N)
timeout 900 "$JAMLAB" run "${STUDY[@]}" --out slurm --cluster slurm --slurm-jobs 2 --slurm-cores 1 \
    --slurm-processes 1 --slurm-memory 1GiB --slurm-queue debug \
    || { tail -20 slurm/slurm-logs/* >&2; fail "SLURM run failed"; }
echo "SLURM run: $(elapsed "$t0") s"

logs=$(find slurm/slurm-logs -name '*.out' 2>/dev/null | wc -l)
[ "$logs" -ge 1 ] || fail "no SLURM job log in the run directory (slurm/slurm-logs)"
stray=$(find "$WORK" -maxdepth 1 \( -name 'slurm-*.out' -o -name 'dask-worker*' \) | wc -l)
[ "$stray" = 0 ] || fail "SLURM logs written to the working directory, not the run directory"
echo "SLURM job logs in the run directory: $(ls slurm/slurm-logs | tr '\n' ' ')"

PYTHONPATH="$REPO/tests/runs${PYTHONPATH:+:$PYTHONPATH}" "$PYTHON" - local slurm <<'EOF' \
    || fail "the SLURM run differs from the local run"
import sys
from pathlib import Path

from runs_helpers import assert_same_runs, read_all, sample_files

local, slurm = Path(sys.argv[1]), Path(sys.argv[2])
assert_same_runs(local, slurm)
files = sample_files(local)
datasets = sum(len(read_all(p)[1]) for p in files.values())
print(f"SLURM run == local run bit for bit: {len(files)} samples, {datasets} datasets compared")
EOF
cd "$REPO" && rm -rf "$WORK"
echo "SLURM step passed in $(elapsed "$t_start") s"
