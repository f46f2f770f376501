#!/usr/bin/env bash
# Installs vgr's dependencies from Debian bookworm packages. Idempotent: packages already
# present are left alone; apt's lists are refreshed only when something is missing. Run as
# root (or through sudo).
#
#   install-deps.sh          everything: build, run the cell, and every test's real peers
#                            (README command 2, CI)
#   install-deps.sh --cell   only what building and running the simulated cell needs
#                            (README command 1: no fuzzing compiler, no test peers)
set -euo pipefail

# Building vgr and running the simulated cell (vgrd, vgr, the simulators). GoogleTest is
# here too: it is small, and the build configures the tests either way, so that commands 1
# and 2 share one build folder with the same flags.
CELL_PACKAGES=(
  build-essential cmake pkg-config ccache git
  libopencv-dev libeigen3-dev
  libaravis-dev aravis-tools libusb-1.0-0-dev
  libmodbus-dev
  libboost-dev libspdlog-dev libfmt-dev libyaml-cpp-dev libcli11-dev nlohmann-json3-dev
  libsystemd-dev systemd
  prometheus-cpp-dev  # vgrd's /metrics (prometheus-cpp's core)
  libmosquitto-dev    # vgrd's MQTT sink
  libgtest-dev libgmock-dev
)

# The tests' real peers and the fuzzers' compiler.
TEST_PACKAGES=(
  mbpoll python3-pymodbus
  python3-serial-asyncio  # pymodbus 3.0 imports it at "from pymodbus.client import ..." but only Recommends it
  python3-prometheus-client  # the metrics test parses /metrics with the Python parser
  mosquitto mosquitto-clients  # the MQTT test runs a broker and mosquitto_sub
  iproute2  # camera_multi_test adds 127.0.0.2 to lo for a second emulated camera
  clang libclang-rt-14-dev  # libFuzzer + ASan/UBSan (tests/fuzz)
)

PACKAGES=("${CELL_PACKAGES[@]}")
case "${1:-}" in
  --cell) ;;
  "") PACKAGES+=("${TEST_PACKAGES[@]}") ;;
  *) echo "usage: $0 [--cell]" >&2; exit 2 ;;
esac

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "install-deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
