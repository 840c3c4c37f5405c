#!/usr/bin/env bash
# scripts/slurm-local.sh runs a single-node Slurm here and stops exactly what it started:
#   - start answers with an export line, status exits 0, srun hostname answers with this node;
#   - a 3-task job array submitted with sbatch writes task ids 0, 1 and 2 within 60 s;
#   - stop leaves none of the daemons' pids alive, status then exits 1, a second stop is a no-op;
#   - a usage error exits 2.
# Skipped (exit 77, with the reason) without the Slurm and munge packages, as another user than
# root, or when the cluster cannot start on this machine. The cluster is stopped on every exit.
# Usage: test_slurm_local.sh SOURCE_DIR
set -uo pipefail
src=${1:?usage: test_slurm_local.sh SOURCE_DIR}
script=$src/scripts/slurm-local.sh
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
skip() { echo "SKIP: $*"; exit 77; }

bash "$script" nosuch 2>/dev/null
[ $? -eq 2 ] || fail "slurm-local.sh with an unknown command does not exit 2"

for c in munged slurmctld slurmd srun sbatch squeue sinfo; do
  command -v "$c" >/dev/null 2>&1 || skip "$c is not installed (scripts/install-deps.sh installs Slurm and munge)"
done
[ "$(id -u)" -eq 0 ] || skip "slurm-local.sh runs the daemons as root; this runs as uid $(id -u)"

pids=()
# shellcheck source=tests/scripts/slurm_test_cluster.sh
. "$src/tests/scripts/slurm_test_cluster.sh" pm-slurm-test

started=$(bash "$script" start 2>"$tmp/start.err")
rc=$?
if [ $rc -ne 0 ]; then
  cat "$tmp/start.err"
  skip "the single-node Slurm cannot start here: $(tail -n 1 "$tmp/start.err")"
fi
for d in munged slurmctld slurmd; do
  pid=$(cat "$PM_SLURM_DIR/$d.pid" 2>/dev/null) || { fail "no pid file for $d after start"; continue; }
  pids+=("$pid")
done
[ "$started" = "export SLURM_CONF=$PM_SLURM_DIR/slurm.conf" ] ||
  fail "start printed '$started', not the export line"
[ "$(bash "$script" env)" = "$started" ] || fail "env does not print start's export line"
eval "$started"
bash "$script" status >/dev/null || fail "status does not exit 0 while the cluster runs"

node=$(sinfo -h -N -o '%N' | head -n 1)
answer=$(timeout 30 srun -N1 hostname 2>&1)
[ "$answer" = "$(hostname -s)" ] || [ "$answer" = "$node" ] || [ "$answer" = "$(hostname)" ] ||
  fail "srun hostname answered '$answer', not '$(hostname -s)'"

# shellcheck disable=SC2016  # the task's shell expands it
job=$(cd "$tmp" && sbatch --parsable -a 0-2 -o "$tmp/task.%a.out" \
  --wrap 'echo "task $SLURM_ARRAY_TASK_ID"' 2>&1)
case "$job" in
  [0-9]*) ;;
  *) fail "sbatch did not submit the array: $job"; job= ;;
esac
if [ -n "$job" ]; then
  done_all=0
  for ((i = 0; i < 120; i++)); do
    if [ -z "$(squeue -h -j "$job" 2>/dev/null)" ] &&
       [ "$(cat "$tmp"/task.*.out 2>/dev/null | sort | tr '\n' ' ')" = "task 0 task 1 task 2 " ]; then
      done_all=1
      break
    fi
    sleep 0.5
  done
  [ $done_all -eq 1 ] ||
    fail "the array job $job did not write tasks 0, 1, 2 within 60 s: $(cat "$tmp"/task.*.out 2>/dev/null | tr '\n' ' ') (squeue: $(squeue -h -j "$job" 2>&1 | tr '\n' ' '))"
fi

bash "$script" stop || fail "stop failed"
for pid in "${pids[@]}"; do
  kill -0 "$pid" 2>/dev/null && fail "pid $pid of the cluster is still alive after stop"
done
# No process left that names the state folder (slurmscriptd, slurmstepd go with their daemons).
for f in /proc/[0-9]*/cmdline; do
  tr '\0' ' ' < "$f" 2>/dev/null | grep -qF "$PM_SLURM_DIR" && fail "still running after stop: ${f%/cmdline}: $(tr '\0' ' ' < "$f")"
done
ls "$PM_SLURM_DIR"/*.pid >/dev/null 2>&1 && fail "pid files left after stop: $(ls "$PM_SLURM_DIR"/*.pid)"
bash "$script" status >/dev/null 2>&1 && fail "status exits 0 after stop"
bash "$script" stop || fail "a second stop failed"

[ "$fails" -eq 0 ] && echo "test_slurm_local: all checks passed"
exit $((fails > 0))
