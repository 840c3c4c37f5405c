# shellcheck shell=bash
# Sourced by the tests that start a single-node Slurm with scripts/slurm-local.sh
# (test_slurm_local.sh, tests/compare/test_compare_slurm.sh):
#   . slurm_test_cluster.sh PREFIX
# makes a temporary folder $tmp (/tmp/PREFIX.XXXXXX) holding the cluster's state
# ($PM_SLURM_DIR), picks two free ports in a row ($PM_SLURM_PORT and the next, away from a system
# Slurm's 6817 and 6818 and the script's default), and sets traps that stop the cluster and
# remove the folder on every exit. The caller sets $script to slurm-local.sh first.
tmp=$(mktemp -d "/tmp/${1:?usage: . slurm_test_cluster.sh PREFIX}.XXXXXX")
export PM_SLURM_DIR=$tmp/slurm
port_busy() { (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }
for ((i = 0; i < 20; i++)); do
  PM_SLURM_PORT=$((20000 + RANDOM % 10000))
  port_busy "$PM_SLURM_PORT" || port_busy $((PM_SLURM_PORT + 1)) || break
done
export PM_SLURM_PORT
# shellcheck disable=SC2317  # run by the trap
cleanup() {
  bash "${script:?}" stop >/dev/null 2>&1
  rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
