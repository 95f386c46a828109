#!/usr/bin/env bash
# Installs the peer tools the benchmarks in bench/ compare against (not needed to build or test pg):
# COLMAP (pg-track), CGAL (pg-remesh), Open3D and OpenCV's Python bindings (pg-merge, flow), mrcal (pg-calib).
# Safe to run twice.
set -euo pipefail
packages=(colmap libcgal-dev python3-open3d libopen3d-dev python3-opencv mrcal python3-mrcal)
missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then missing+=("$p"); fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-bench-peers: all present"
  exit 0
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
