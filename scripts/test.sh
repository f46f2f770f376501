#!/usr/bin/env bash
# Installs the Debian packages, builds with warnings as errors and runs every test through
# ctest (unit tests, then integration tests against the camera emulator over Aravis,
# mbpoll, pymodbus and raw TCP; they bind fixed loopback ports and run one at a time).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
./scripts/reserve-ports.sh
./scripts/configure.sh  # the same folder and flags as README command 1: nothing it built is built again
cmake --build build -j"$(nproc)"
ctest --test-dir build --output-on-failure --timeout 600

# Fuzzers (tests/fuzz/, docs/fuzzing.md): a second build dir with clang, libFuzzer, ASan and
# UBSan, only the fuzz targets; each runs VGR_FUZZ_SECONDS (20) from an empty corpus.
# No -Werror here: clang's extra warnings on code g++ already checks with -Werror above.
cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DVGR_FUZZ=ON -DVGR_SANITIZE=ON
cmake --build build-fuzz -j"$(nproc)" --target vgr_fuzzers
ctest --test-dir build-fuzz -L fuzz --output-on-failure
