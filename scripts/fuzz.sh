#!/usr/bin/env bash
# Runs the two libFuzzer targets (fuzz/README.md) for SECONDS each (default 60), from seed
# corpora made of the hostile-input files (tests/data/hostile), and prints each run's execution
# count. Needs build-fuzz (configured with clang and -DPM_FUZZ=ON). A crash, a leak, an input
# slower than 30 s or using more than 2 GB stops the run, leaves the input in fuzz-work/ and
# makes the script fail.
#   scripts/fuzz.sh [SECONDS] [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
build="${2:-build-fuzz}"
work="fuzz-work"
mkdir -p "$work/case" "$work/mesh"
cp tests/data/hostile/*/*.json "$work/case/"
for e in msh vtk vtu stl mesh; do cp tests/data/hostile/*/*."$e" "$work/mesh/"; done
export ASAN_OPTIONS="abort_on_error=1:detect_leaks=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export LSAN_OPTIONS="suppressions=$PWD/tests/thirdparty_lsan.supp:print_suppressions=0"
export OMP_NUM_THREADS=1
for target in fuzz_case_file fuzz_mesh_read; do
  corpus="$work/case"
  [ "$target" = fuzz_mesh_read ] && corpus="$work/mesh"
  log="$work/$target.log"
  "$build/fuzz/$target" -max_total_time="$seconds" -max_len=8192 -timeout=30 -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix="$work/$target-" "$corpus" > "$log" 2>&1 || {
    tail -40 "$log"
    echo "fuzz.sh: $target failed (input in $work/, log $log)" >&2
    exit 1
  }
  echo "$target: $(grep -m1 'stat::number_of_executed_units' "$log" | awk '{print $2}') executions in $seconds s"
done
