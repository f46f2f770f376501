#!/usr/bin/env bash
# Installs the Debian packages, builds with warnings as errors and runs every test through
# ctest (unit tests, then integration tests against the camera emulator over Aravis,
# mbpoll, pymodbus and raw TCP; they bind fixed loopback ports and run one at a time).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DVGR_WERROR=ON
cmake --build build -j"$(nproc)"
ctest --test-dir build --output-on-failure --timeout 600
