#!/usr/bin/env bash
# Installs the Debian 12 packages packmesh builds and runs with.
#
#   scripts/install-deps.sh            as root: runs apt-get; as another user: through sudo
#   scripts/install-deps.sh --print    prints the commands it would run, runs nothing
#
# A fresh Debian 12 machine run as root has no sudo, so the script never calls sudo as root and
# the README runs it without sudo. clang and libclang-rt-14-dev (libFuzzer) build the fuzz targets
# (fuzz/README.md); strace lets test_cli_outputs deliver a signal at each rename of a run (the
# test is skipped without it); python3-meshio reads packmesh's files back in test_mesh_meshio;
# groff-base renders the man pages in test_cli_man (groff -ww: no warning).
# python3-vtk9 and xvfb (xvfb-run, with xauth) draw scripts/quality_picture.py's off-screen
# pictures in test_quality_picture.
# python3-dev and python3-numpy build the Python module (python/), python3-pytest runs its tests
# and python3-matplotlib draws the box plot of its example.
# slurmctld, slurmd, slurm-client and munge run a single-node Slurm for test_slurm_local
# (scripts/slurm-local.sh).
# chromium loads report pages and players headless in their tests (tests/scripts/page_check.py);
# libjs-three is the three.js that a study's report copies beside itself for its 3D viewer.
# zlib1g-dev: the PNG encoder of a study's mesh pictures (compare/src/png.c).
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive

print=0
case "${1:-}" in
  "") ;;
  --print) print=1 ;;
  *) echo "install-deps.sh: unknown argument '$1' (usage: scripts/install-deps.sh [--print])" >&2
     exit 2 ;;
esac

packages=(
  build-essential cmake pkg-config
  libcgal-dev libgmp-dev libmpfr-dev libboost-dev
  libtet1.5-dev
  libembree-dev
  libgmsh-dev gmsh
  libmuparser-dev libcjson-dev libcmocka-dev zlib1g-dev
  gnuplot-nox
  clang libclang-rt-14-dev strace
  python3-meshio python3-numpy
  groff-base
  python3-vtk9 xvfb xauth
  python3-dev python3-pytest python3-matplotlib
  slurmctld slurmd slurm-client munge
  chromium libjs-three
)

elevate=()
if [ "$(id -u)" -ne 0 ]; then
  if [ "$print" -eq 0 ] && ! command -v sudo >/dev/null 2>&1; then
    echo "install-deps.sh: not running as root and sudo is not installed; run it as root" >&2
    exit 1
  fi
  elevate=(sudo)
fi

run() {
  if [ "$print" -eq 1 ]; then
    echo "$*"
  else
    "$@"
  fi
}

run "${elevate[@]}" apt-get update -qq
run "${elevate[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
  --no-install-recommends "${packages[@]}"
