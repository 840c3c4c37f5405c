#!/usr/bin/env bash
# packmesh compare --engine slurm on a single-node Slurm (scripts/slurm-local.sh), end to end:
#   - a suite of 14 runs: three cases, each a matched-node group (bubble the reference,
#     gmsh-frontal or a method that fails, an unknown parameter, matched to it);
#   - the submission prints the runs array, the matched array (afterany) and the report job;
#     submitting again at once submits nothing (squeue --name) and names the same report job;
#   - one running task cancelled with scancel, another killed (SIGKILL to its batch step): the
#     report job lists the cancelled run as not finished (and the run matched to it as waiting)
#     and records the killed one as crashed with Slurm's state (FAILED, 0:9), its matched run
#     skipped; results.csv has every row, each run's host;
#   - submitting again resumes: exactly the cancelled run and the run matched to it;
#   - --retry-failed submits exactly the runs that did not succeed (the killed one, the run
#     matched to it, the three failing runs); the killed run then succeeds, the runs that had
#     succeeded are not run again (their records name the first submission's jobs);
#   - results.csv equals --engine local's for the same suite but for wall_s, host and time_s.*,
#     and report.md's tables equal local's but for the times.
# Usage errors of the options are checked first, without Slurm. Skipped (exit 77, with the
# reason) without the Slurm and munge packages, as another user than root, or when the cluster
# cannot start here. The cluster is stopped on every exit.
# Usage: test_compare_slurm.sh SOURCE_DIR PACKMESH
set -uo pipefail
src=${1:?usage: test_compare_slurm.sh SOURCE_DIR PACKMESH}
pm=${2:?usage: test_compare_slurm.sh SOURCE_DIR PACKMESH}
script=$src/scripts/slurm-local.sh
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
skip() { echo "SKIP: $*"; exit 77; }

# shellcheck source=tests/scripts/slurm_test_cluster.sh
. "$src/tests/scripts/slurm_test_cluster.sh" pm-compare-slurm

cat > "$tmp/suite.json" <<'EOF'
{
  "name": "slurm-e2e",
  "description": "The Slurm engine's end-to-end test: a matched-node group per case and a run that fails.",
  "cases": [{"input": "case:qi1", "name": "slow", "size": 0.02},
            {"input": "case:qi1", "size": 0.2},
            "case:qi3"],
  "methods": ["bubble", {"method": "gmsh-frontal", "cases": ["qi1", "qi3"]},
              {"method": "bubble", "label": "broken", "set": {"no_such_key": 1},
               "cases": ["slow", "qi1"]}],
  "seeds": [1, 2],
  "options": {"match_nodes": true, "reference": "bubble", "timeout_s": 120, "threads": 1}
}
EOF
suite=$tmp/suite.json
study=$tmp/study

# ---- usage, without Slurm --------------------------------------------------------------------
expect_code() { # expect_code CODE WHAT ARGS...
  local want=$1 what=$2
  shift 2
  "$pm" compare "$@" >"$tmp/out" 2>"$tmp/err"
  local rc=$?
  [ $rc -eq "$want" ] || fail "$what: exit $rc, not $want ($(cat "$tmp/err"))"
}
expect_code 2 "--wait without --engine slurm" "$suite" -o "$tmp/u" --wait
expect_code 2 "--slurm-opt without --engine slurm" "$suite" -o "$tmp/u" --slurm-opt "-p x"
expect_code 2 "--engine pbs" "$suite" -o "$tmp/u" --engine pbs
expect_code 2 "--jobs with --engine slurm" "$suite" -o "$tmp/u" --engine slurm --jobs 2
expect_code 2 "--collect with --retry-failed" "$suite" -o "$tmp/u" --collect --retry-failed
expect_code 2 "--slurm-opt with an open quote" "$suite" -o "$tmp/u" --engine slurm --slurm-opt "-p 'x"
expect_code 2 "--slurm-task -1" "$suite" -o "$tmp/u" --slurm-task -1
# Without Slurm's commands: one line naming what is missing, exit 1.
PATH=/nonexistent "$pm" compare "$suite" -o "$tmp/u" --engine slurm >"$tmp/out" 2>"$tmp/err"
rc=$?
[ $rc -eq 1 ] && grep -q "slurm-client" "$tmp/err" ||
  fail "--engine slurm without Slurm's commands: exit $rc, '$(cat "$tmp/err")'"

# ---- the cluster -----------------------------------------------------------------------------
for c in munged slurmctld slurmd srun sbatch squeue scancel sacct scontrol sinfo; do
  command -v "$c" >/dev/null 2>&1 || skip "$c is not installed (scripts/install-deps.sh installs Slurm and munge)"
done
[ "$(id -u)" -eq 0 ] || skip "slurm-local.sh runs the daemons as root; this runs as uid $(id -u)"
if ! started=$(bash "$script" start 2>"$tmp/start.err"); then
  cat "$tmp/start.err"
  skip "the single-node Slurm cannot start here: $(tail -n 1 "$tmp/start.err")"
fi
eval "$started"
node=$(sinfo -h -N -o '%N' | head -n 1)

# The status of every row of a study's results.csv, "row status" a line; the error of one row.
statuses() {
  python3 - "$1" <<'EOF'
import csv, sys
for r in csv.DictReader(open(sys.argv[1], newline="")):
    print(r["row"], r["status"])
EOF
}
cell() { # cell CSV ROW COLUMN
  python3 - "$@" <<'EOF'
import csv, sys
for r in csv.DictReader(open(sys.argv[1], newline="")):
    if r["row"] == sys.argv[2]:
        print(r[sys.argv[3]])
EOF
}
status_of() { statuses "$study/results.csv" | awk -v r="$1" '$1 == r { print $2 }'; }
count_status() { statuses "$study/results.csv" | awk -v s="$1" '$2 == s' | wc -l; }
json_field() { python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])' "$1" "$2"; }
names=
# Until none of the study's jobs is in the queue (at most $1 s).
drain() {
  local i
  for ((i = 0; i < $1 * 2; i++)); do
    [ -z "$(squeue -h --name="$names" 2>/dev/null)" ] && return 0
    sleep 0.5
  done
  fail "the study's jobs are still queued after $1 s: $(squeue -h -r --name="$names" -o '%i %T' | tr '\n' ' ')"
  return 1
}

# ---- submit; submit again at once ------------------------------------------------------------
# Held (sbatch --hold) until both submissions are made and checked: on a loaded machine the
# second submission can take longer than the slow runs, which would end before they are killed.
"$pm" compare "$suite" -o "$study" --engine slurm --slurm-opt "--hold" >"$tmp/sub1" 2>"$tmp/sub1.err" ||
  fail "the submission failed: $(cat "$tmp/sub1.err")"
"$pm" compare "$suite" -o "$study" --engine slurm >"$tmp/sub2" 2>"$tmp/sub2.err" ||
  fail "the second submission failed: $(cat "$tmp/sub2.err")"
cat "$tmp/sub1" "$tmp/sub2"
names=$(sed -n 's/^follow: squeue --name=//p' "$tmp/sub1")
[ -n "$names" ] || fail "the submission names no jobs to follow"
grep -q "14 runs: 0 finished, 0 pending or running in Slurm already, 14 submitted" "$tmp/sub1" ||
  fail "the first submission does not submit the 14 runs"
grep -q "^job [0-9]*: 6 runs, .*: the runs that can start now" "$tmp/sub1" ||
  fail "no array of the 6 reference runs"
grep -q "^job [0-9]*: 8 runs, .*afterany:[0-9]*: the runs matched to references" "$tmp/sub1" ||
  fail "no array of the 8 matched runs after the references"
report_job=$(sed -n 's/^job \([0-9]*\): the report.*/\1/p' "$tmp/sub1")
[ -n "$report_job" ] || fail "no report job"
grep -q ", 0 submitted" "$tmp/sub2" || fail "the second submission submitted runs again"
grep -q "^job $report_job: the report, queued already" "$tmp/sub2" ||
  fail "the second submission does not name the queued report job $report_job"

# ---- cancel one running task, kill another ---------------------------------------------------
# Each as soon as its task has started its run (the marker; the run takes seconds).
held=$(sed -n 's/^job \([0-9]*\): .*/\1/p' "$tmp/sub1" | tr '\n' ' ')
# shellcheck disable=SC2086  # one job id a word
scontrol release $held || fail "scontrol release $held failed"
# A marker's job ("12_3"), read without starting a Python at the moment that counts.
marker_job() { sed -n 's/^[[:space:]]*"job":[[:space:]]*"\([0-9_]*\)".*/\1/p' "$1"; }
cancelled='' killed='' t0=$SECONDS
for ((i = 0; i < 2400; i++)); do
  if [ -z "$cancelled" ] && [ -s "$study/runs/slow__bubble__s1/slurm.json" ]; then
    cancelled=$(marker_job "$study/runs/slow__bubble__s1/slurm.json")
    scancel "$cancelled" || fail "scancel $cancelled failed"
    echo "cancelled $cancelled, $((SECONDS - t0)) s after the release"
  fi
  if [ -z "$killed" ] && [ -s "$study/runs/slow__bubble__s2/slurm.json" ]; then
    killed=$(marker_job "$study/runs/slow__bubble__s2/slurm.json")
    scancel --batch --signal=KILL "$killed" || fail "scancel --batch --signal=KILL $killed failed"
    echo "killed $killed, $((SECONDS - t0)) s after the release"
  fi
  [ -n "$cancelled" ] && [ -n "$killed" ] && break
  sleep 0.05
done
[ -n "$cancelled" ] && [ -n "$killed" ] ||
  fail "the tasks of slow__bubble__s1 and s2 did not start within 120 s"
drain 240
[ -s "$study/report.md" ] || fail "the report job wrote no report.md"
[ "$(statuses "$study/results.csv" | wc -l)" -eq 14 ] ||
  fail "results.csv has $(statuses "$study/results.csv" | wc -l) rows, not 14"
[ "$(status_of slow__bubble__s1)" = pending ] ||
  fail "the cancelled run is '$(status_of slow__bubble__s1)', not pending"
cell "$study/results.csv" slow__bubble__s1 error | grep -q "CANCELLED" ||
  fail "the cancelled run's error does not say CANCELLED: $(cell "$study/results.csv" slow__bubble__s1 error)"
[ "$(status_of slow__broken__s1)" = pending ] ||
  fail "the run matched to the cancelled one is '$(status_of slow__broken__s1)', not pending"
cell "$study/results.csv" slow__broken__s1 error | grep -q "waits for its reference run slow__bubble__s1" ||
  fail "the run matched to the cancelled one does not wait for it: $(cell "$study/results.csv" slow__broken__s1 error)"
[ "$(status_of slow__bubble__s2)" = crashed ] ||
  fail "the killed run is '$(status_of slow__bubble__s2)', not crashed"
cell "$study/results.csv" slow__bubble__s2 error | grep -q "FAILED (exit code 0:9)" ||
  fail "the killed run's error does not give Slurm's state: $(cell "$study/results.csv" slow__bubble__s2 error)"
[ "$(status_of slow__broken__s2)" = skipped ] ||
  fail "the run matched to the killed one is '$(status_of slow__broken__s2)', not skipped"
[ "$(count_status ok)" -eq 8 ] || fail "$(count_status ok) runs ok after the first submission, not 8"
[ "$(count_status failed)" -eq 2 ] || fail "$(count_status failed) runs failed, not the 2 broken ones"
[ "$(cell "$study/results.csv" qi3__bubble__s1 host)" = "$node" ] ||
  fail "qi3__bubble__s1's host is '$(cell "$study/results.csv" qi3__bubble__s1 host)', not $node"
grep -q "^Runs ran on: $node (11 runs)\.$" "$study/report.md" ||
  fail "the report does not say the 11 runs ran on $node: $(grep 'Runs ran on' "$study/report.md")"
grep -q "^## Runs not finished" "$study/report.md" || fail "the report lists no run as not finished"

# ---- resume: exactly the cancelled run and the one matched to it -----------------------------
"$pm" compare "$suite" -o "$study" --engine slurm --wait >"$tmp/sub3" 2>"$tmp/sub3.err"
rc=$?
cat "$tmp/sub3" "$tmp/sub3.err"
[ $rc -eq 0 ] || fail "the resumed study's --wait exits $rc"
grep -q "14 runs: 12 finished, 0 pending or running in Slurm already, 2 submitted" "$tmp/sub3" ||
  fail "resuming does not submit exactly the 2 unfinished runs"
grep -q "pending, .* running, .* done, .* failed" "$tmp/sub3.err" || fail "--wait shows no counts"
drain 60
[ "$(status_of slow__bubble__s1)" = ok ] || fail "the resumed run is '$(status_of slow__bubble__s1)'"
[ "$(status_of slow__broken__s1)" = failed ] ||
  fail "the resumed matched run is '$(status_of slow__broken__s1)', not failed"
[ "$(status_of slow__bubble__s2)" = crashed ] || fail "resuming changed the crashed run"

# ---- --retry-failed: exactly the runs that did not succeed -----------------------------------
first_jobs=$(sed -n 's/^job \([0-9]*\): [0-9]* runs\{0,1\}, .*/\1/p' "$tmp/sub1" | tr '\n' ' ')
"$pm" compare "$suite" -o "$study" --engine slurm --wait --retry-failed >"$tmp/sub4" 2>"$tmp/sub4.err"
rc=$?
cat "$tmp/sub4"
[ $rc -eq 0 ] || fail "--retry-failed --wait exits $rc: $(cat "$tmp/sub4.err")"
grep -q "14 runs: 9 finished, 0 pending or running in Slurm already, 5 submitted" "$tmp/sub4" ||
  fail "--retry-failed does not submit exactly the 5 runs that did not succeed"
drain 60
retry_job=$(sed -n 's/^job \([0-9]*\): [0-9]* runs\{0,1\}, .*: the runs that can start now/\1/p' "$tmp/sub4")
[ "$(status_of slow__bubble__s2)" = ok ] || fail "the retried run is '$(status_of slow__bubble__s2)', not ok"
[ "$(json_field "$study/runs/slow__bubble__s2/status.json" slurm_job)" = "${retry_job}_2" ] ||
  fail "the retried run's record names job $(json_field "$study/runs/slow__bubble__s2/status.json" slurm_job), not ${retry_job}_2"
[ "$(status_of slow__broken__s2)" = failed ] ||
  fail "the run matched to the retried one is '$(status_of slow__broken__s2)', not failed"
[ "$(count_status ok)" -eq 10 ] || fail "$(count_status ok) runs ok after the retry, not 10"
[ "$(count_status failed)" -eq 4 ] || fail "$(count_status failed) runs failed after the retry, not the 4 broken ones"
for r in qi1__bubble__s1 qi1__gmsh-frontal__s2 qi3__bubble__s2 qi3__gmsh-frontal__s1; do
  j=$(json_field "$study/runs/$r/status.json" slurm_job)
  case " $first_jobs" in
    *" ${j%_*} "*) ;;
    *) fail "$r, which had succeeded, was run again (job $j; the first submission's: $first_jobs)" ;;
  esac
done

# ---- the same as --engine local --------------------------------------------------------------
"$pm" compare "$suite" -o "$tmp/local" --quiet >"$tmp/local.out" 2>&1 ||
  fail "the local study failed: $(cat "$tmp/local.out")"
python3 - "$tmp/local" "$study" "$node" <<'EOF' || fails=$((fails + 1))
import csv, re, sys
local, slurm, node = sys.argv[1:4]
def rows(d):
    return list(csv.DictReader(open(d + "/results.csv", newline="")))
def timeish(k):
    return k in ("wall_s", "host") or k.startswith("time_s")
a, b = rows(local), rows(slurm)
bad = []
if len(a) != len(b) or len(a) != 14:
    bad.append("results.csv: %d rows locally, %d with Slurm" % (len(a), len(b)))
if a and b and list(a[0].keys()) != list(b[0].keys()):
    bad.append("results.csv columns differ: %s / %s" % (list(a[0].keys()), list(b[0].keys())))
for x, y in zip(a, b):
    for k in x:
        if not timeish(k) and x[k] != y.get(k):
            bad.append("results.csv %s %s: local %r, Slurm %r" % (x["row"], k, x[k], y.get(k)))
    if y["status"] != "skipped" and y["host"] != node:
        bad.append("results.csv %s: host %r, not %r" % (y["row"], y["host"], node))
def report(d):
    """report.md without what names the invocation, the time, the folder and the hosts, with
    the cells of every time column blanked and every duration in seconds in the prose too
    (how long the pictures took to draw is measured on whichever machine drew them)."""
    out, head = [], None
    for line in open(d + "/report.md"):
        if ("Made on " in line or line.startswith("packmesh compare ") or
                "when run in the study folder" in line or line.startswith("Runs ran on:")):
            continue
        if line.startswith("|"):
            cells = line.strip().strip("|").split(" | ")
            if head is None:
                head = cells
            elif not set(line) <= set("|-: \n"):
                cells = ["" if "time" in h else c for h, c in zip(head, cells)]
            out.append(" | ".join(cells))
            continue
        head = None
        out.append(re.sub(r"[0-9]+(\.[0-9]+)? s\b", "# s", line.rstrip("\n")))
    return out
ra, rb = report(local), report(slurm)
for i, (x, y) in enumerate(zip(ra, rb)):
    if x != y:
        bad.append("report.md line %d: local %r, Slurm %r" % (i + 1, x, y))
if len(ra) != len(rb):
    bad.append("report.md: %d lines locally, %d with Slurm" % (len(ra), len(rb)))
for m in bad[:20]:
    print("FAIL:", m)
sys.exit(1 if bad else 0)
EOF

[ "$fails" -eq 0 ] && echo "test_compare_slurm: all checks passed"
exit $((fails > 0))
