#!/usr/bin/env bash
# README command 1. Installs what building and running the cell needs, builds only the five
# programs the simulated cell runs (vgrd, vgr and the three simulators) in the build folder
# and with the flags of the test command (scripts/configure.sh), and runs the simulated cell
# live on the embedded default config: camera emulator, vgrd, PLC simulator and robot
# simulators as separate processes on 127.0.0.1, N cycles (default 50), one line per cycle
# and a JSON summary. Measured times: docs/plant.md, "A fast first start".
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh --cell
./scripts/reserve-ports.sh
./scripts/configure.sh
cmake --build build -j"$(nproc)" --target vgrd vgr vgr-sim-camera vgr-sim-plc vgr-sim-robot
exec build/bin/vgr demo --cycles "${1:-50}"
