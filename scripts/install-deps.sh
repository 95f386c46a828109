#!/usr/bin/env bash
# Installs every build, test and benchmark dependency of pg from Debian 12 packages.
# Safe to run twice: packages already present are skipped.
set -euo pipefail

packages=(
  build-essential cmake ninja-build ccache pkg-config
  libopencv-dev libeigen3-dev libceres-dev libsuitesparse-dev
  libopenvdb-dev libboost-iostreams-dev libopenmesh-dev
  libopenexr-dev libimath-dev libcli11-dev nlohmann-json3-dev libtbb-dev
  ocl-icd-opencl-dev opencl-clhpp-headers pocl-opencl-icd clinfo
  libgtest-dev libbenchmark-dev
  clang-14 libclang-rt-14-dev
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${#missing[@]} packages: ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
