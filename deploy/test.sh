#!/usr/bin/env bash
# Installs dependencies, builds dome and runs every test (ctest). Run as root on
# Debian 12 from the repository root: `bash deploy/test.sh`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/install-deps.sh
jobs=$(nproc)
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$jobs"
cd build && ctest --output-on-failure -j"$jobs"
