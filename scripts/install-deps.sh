#!/usr/bin/env bash
# Installs the Debian 12 packages packmesh builds and runs with. Run as root (or with sudo).
# clang and libclang-rt-14-dev (libFuzzer) build the fuzz targets (fuzz/README.md); strace lets
# test_cli_outputs deliver a signal at each rename of a run (the test is skipped without it).
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends \
  build-essential cmake pkg-config \
  libcgal-dev libgmp-dev libmpfr-dev libboost-dev \
  libtet1.5-dev \
  libembree-dev \
  libgmsh-dev gmsh \
  libmuparser-dev libcjson-dev libcmocka-dev \
  gnuplot-nox \
  clang libclang-rt-14-dev strace
