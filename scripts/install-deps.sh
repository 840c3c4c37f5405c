#!/usr/bin/env bash
# Installs the Debian 12 packages packmesh builds and runs with. Run as root (or with sudo).
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
  gnuplot-nox
