#!/usr/bin/env bash
# Installs every Debian 12 package dome needs to build, test and run.
# Idempotent; run as root. See README.md ("Dependencies") for why each is here.
set -euo pipefail

packages=(
  build-essential cmake pkg-config git
  libzmq3-dev cppzmq-dev
  libprotobuf-dev protobuf-compiler
  libopencv-dev
  libeigen3-dev
  libspdlog-dev libfmt-dev
  libgtest-dev libgmock-dev
  libbenchmark-dev
  libcli11-dev
  libtiff-dev
  libembree-dev
  python3-open3d python3-scipy python3-numpy
  libmeshoptimizer-dev python3-skimage
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
