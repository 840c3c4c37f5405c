#!/usr/bin/env bash
# Starts and stops a single-node Slurm cluster on this machine, for tests that submit jobs
# through Slurm (the test test_slurm_local).
#
#   scripts/slurm-local.sh start     starts munged, slurmctld and slurmd; prints
#                                    "export SLURM_CONF=..." (eval "$(scripts/slurm-local.sh start)")
#   scripts/slurm-local.sh stop      stops exactly the daemons start started (by their pid files)
#   scripts/slurm-local.sh status    exit 0 and sinfo's table when it runs, 1 otherwise
#   scripts/slurm-local.sh env       prints the export line
#
# Debian 12's slurmctld, slurmd, slurm-client and munge (scripts/install-deps.sh) are run as
# root without systemd. Everything lives in one folder, $PM_SLURM_DIR (default
# /tmp/packmesh-slurm): slurm.conf, the munge key, socket, pid and log, the controller's state,
# slurmd's spool, the logs and pid files. The cluster has one node, this machine (hostname -s)
# with its CPUs and a little under its memory, and one partition, debug. Its own munge socket
# and ports ($PM_SLURM_PORT for slurmctld, default 16817, and the next one for slurmd) keep it
# apart from a system Slurm or munge; start refuses ports already in use. start waits up to 30 s
# for the node to be idle and srun to answer; otherwise it prints the logs' tails, stops what it
# started and exits 1 with one line naming what failed. Usage errors exit 2.
set -euo pipefail

dir=${PM_SLURM_DIR:-/tmp/packmesh-slurm}
conf=$dir/slurm.conf
ctld_port=${PM_SLURM_PORT:-16817}
case "$ctld_port" in
  ''|*[!0-9]*) echo "slurm-local.sh: PM_SLURM_PORT='$ctld_port' is not a port number" >&2; exit 2 ;;
esac
slurmd_port=$((10#$ctld_port + 1))
daemons=(slurmd slurmctld munged)   # the order stop stops them in

usage() {
  echo "slurm-local.sh: $1 (usage: scripts/slurm-local.sh start|stop|status|env)" >&2
  exit 2
}

die() {
  echo "slurm-local.sh: $*" >&2
  exit 1
}

pidfile() { echo "$dir/$1.pid"; }

# Whether something listens on local port $1.
port_busy() { (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }

# The pid recorded for daemon $1 when that process is alive, else nothing.
live_pid() {
  local f pid
  f=$(pidfile "$1")
  [ -r "$f" ] || return 0
  pid=$(tr -dc 0-9 < "$f")
  [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null && echo "$pid"
  return 0
}

stop_all() {
  local d pid i
  for d in "${daemons[@]}"; do
    pid=$(live_pid "$d")
    if [ -n "$pid" ]; then
      kill -TERM "$pid" 2>/dev/null || true
      for ((i = 0; i < 100; i++)); do
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.1
      done
      if kill -0 "$pid" 2>/dev/null; then
        kill -KILL "$pid" 2>/dev/null || true
        sleep 0.2
      fi
    fi
    rm -f "$(pidfile "$d")"
  done
}

logs_tail() {
  local f
  for f in "$dir"/log/*.log; do
    [ -s "$f" ] || continue
    echo "--- tail of $f" >&2
    tail -n 15 "$f" >&2
  done
}

# Prints the logs, stops what was started and exits 1 naming $1.
fail_start() {
  logs_tail
  stop_all
  die "start: $*"
}

write_conf() {
  local host cpus mem_kb mem_mb
  host=$(hostname -s)
  cpus=$(nproc)
  mem_kb=$(awk '/^MemTotal:/ { print $2 }' /proc/meminfo)
  mem_mb=$((mem_kb * 9 / 10 / 1024))
  cat > "$conf" <<CONF
# Written by scripts/slurm-local.sh: a single-node cluster for packmesh's tests.
ClusterName=packmesh-local
SlurmctldHost=$host
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/munge.socket
StateSaveLocation=$dir/ctld
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$dir/log/jobcomp.txt
SchedulerType=sched/backfill
SlurmctldTimeout=30
SlurmdTimeout=30
MinJobAge=300
NodeName=$host CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
}

# Waits up to 5 s for daemon $1's pid file to name a live process.
wait_pid() {
  local i
  for ((i = 0; i < 50; i++)); do
    [ -z "$(live_pid "$1")" ] || return 0
    sleep 0.1
  done
  fail_start "$1 did not come up (no live pid in $(pidfile "$1") after 5 s)"
}

start_munge() {
  local key=$dir/munge/munge.key i
  mkdir -p "$dir/munge"
  chmod 0700 "$dir/munge"
  if [ ! -s "$key" ]; then
    dd if=/dev/urandom of="$key" bs=1 count=1024 status=none
  fi
  chown root:root "$key"
  chmod 0400 "$key"
  # As root munged wants --force; its own socket, key, pid, seed and log files keep it apart
  # from a system munge.
  munged --force --socket="$dir/munge/munge.socket" --key-file="$key" \
    --pid-file="$dir/munged.pid" --seed-file="$dir/munge/munged.seed" \
    --log-file="$dir/log/munged.log" >> "$dir/log/munged.log" 2>&1 ||
    fail_start "munged did not start"
  for ((i = 0; i < 50; i++)); do
    [ -n "$(live_pid munged)" ] && [ -S "$dir/munge/munge.socket" ] && return 0
    sleep 0.1
  done
  fail_start "munged did not come up (no pid or socket after 5 s)"
}

start() {
  local d i p c state deadline
  for d in "${daemons[@]}"; do
    [ -z "$(live_pid "$d")" ] || die "start: $d already runs (pid $(live_pid "$d")) for $dir; stop it first"
  done
  for c in munged slurmctld slurmd srun sinfo; do
    command -v "$c" >/dev/null 2>&1 ||
      die "start: $c is not installed (apt-get install slurmctld slurmd slurm-client munge)"
  done
  [ "$(id -u)" -eq 0 ] || die "start: the daemons run as root; run as root"
  for p in "$ctld_port" "$slurmd_port"; do
    ! port_busy "$p" || die "start: port $p is in use (set PM_SLURM_PORT to another port)"
  done
  mkdir -p "$dir/log" "$dir/ctld" "$dir/spool"
  export SLURM_CONF=$conf
  start_munge
  write_conf
  slurmctld -f "$conf" >> "$dir/log/slurmctld.log" 2>&1 || fail_start "slurmctld did not start"
  wait_pid slurmctld
  slurmd -f "$conf" >> "$dir/log/slurmd.log" 2>&1 || fail_start "slurmd did not start"
  wait_pid slurmd
  # Each sinfo is bounded: without a controller it would retry for minutes.
  state=
  deadline=$((SECONDS + 30))
  while [ "$SECONDS" -lt "$deadline" ]; do
    sleep 0.5
    [ -n "$(live_pid slurmctld)" ] || fail_start "slurmctld exited (log/slurmctld.log)"
    [ -n "$(live_pid slurmd)" ] || fail_start "slurmd exited (log/slurmd.log)"
    state=$(timeout 5 sinfo -h -N -o '%T' 2>/dev/null | head -n 1) || true
    case "$state" in idle*|mixed*|allocated*) break ;; esac
  done
  case "$state" in idle*|mixed*|allocated*) ;;
    *) fail_start "the node is not idle after 30 s (sinfo says '${state:-nothing}')" ;; esac
  timeout 30 srun -N1 -t 1 hostname > /dev/null 2>> "$dir/log/srun.log" ||
    fail_start "srun -N1 hostname did not answer within 30 s"
  echo "export SLURM_CONF=$conf"
}

status() {
  local d
  for d in "${daemons[@]}"; do
    [ -n "$(live_pid "$d")" ] || { echo "slurm-local.sh: $d is not running ($dir)" >&2; return 1; }
  done
  SLURM_CONF=$conf timeout 10 sinfo || return 1
}

[ $# -eq 1 ] || usage "one command expected"
case "$1" in
  start) start ;;
  stop) stop_all ;;
  status) status ;;
  env) echo "export SLURM_CONF=$conf" ;;
  *) usage "unknown command '$1'" ;;
esac
