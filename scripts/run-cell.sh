#!/usr/bin/env bash
# Installs the Debian packages, builds, and runs the simulated cell live on the embedded
# default config: camera emulator, vgrd, PLC simulator and two robot simulators as separate
# processes on 127.0.0.1, N cycles (default 50), one line per cycle and a JSON summary.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
./scripts/reserve-ports.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)"
exec build/bin/vgr demo --cycles "${1:-50}"
