#!/usr/bin/env bash
# Installs the Debian 12 packages MorseGS needs (skips those already installed).
# Run as root (or with sudo available). Idempotent.
set -euo pipefail
PKGS=(
  build-essential cmake ninja-build pkg-config clang libclang-rt-14-dev
  libopenvdb-dev libboost-iostreams-dev libopenvdb-tools python3-openvdb
  libopenimageio-dev openimageio-tools libembree-dev libtbb-dev
  libassimp-dev libcjson-dev libcairo2-dev libqhull-dev zlib1g-dev libzstd-dev libminizip-dev libwebp-dev
  libgudhi-dev python3-gudhi libphat-dev python3-phat python3-numpy
  python3-dev python3-venv python3-setuptools python3-wheel
  libopencv-core-dev python3-pot python3-pil
  libopenmpi-dev openmpi-bin
  netgen-doc gmsh-doc assimp-testmodels python3-open3d
  libcgal-dev libgmp-dev libmpfr-dev libeigen3-dev
  chromium blender
)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PKGS[@]} packages present"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "setup: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
