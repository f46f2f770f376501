#!/usr/bin/env bash
# Configures the one build folder both README commands use, with the one set of flags (CI's:
# Release, warnings as errors), so the test command reuses every object the cell command
# compiled. Extra arguments go to cmake.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DVGR_WERROR=ON "$@"
