#!/usr/bin/env bash
# Installs vgr's dependencies from Debian bookworm packages. Idempotent: packages already
# present are left alone; apt's lists are refreshed only when something is missing. Run as
# root (or through sudo).
#
#   install-deps.sh          everything: build, run the cell, and every test's real peers
#                            (README command 2, CI), and the browser test's npm packages
#                            (tests/browser: playwright-core, which drives Debian's chromium;
#                            it downloads no browser)
#   install-deps.sh --cell   only what building and running the simulated cell needs
#                            (README command 1: no fuzzing compiler, no test peers)
set -euo pipefail
cd "$(dirname "$0")/.."

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
  libopen3d-dev       # vision/cloud/ (3D localization, docs/3d.md): the only target linking it
  libnanoflann-dev    # vision/cloud/: the ICP's exact 3-D k-d tree with a distance bound (header-only)
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
  chromium fonts-dejavu-core  # the commissioning page's browser test (headless) and its screenshots' text
)

PACKAGES=("${CELL_PACKAGES[@]}")
case "${1:-}" in
  --cell) ;;
  "") PACKAGES+=("${TEST_PACKAGES[@]}")
      # Node.js and npm for playwright-core: the machine's own when it has them (the CI image
      # ships Node.js 20 with npm), Debian's otherwise (Node.js 18: playwright-core 1.61 is the
      # last release that runs on it, which is why tests/browser/package.json pins it).
      if ! command -v npm >/dev/null 2>&1; then PACKAGES+=(nodejs npm); fi ;;
  *) echo "usage: $0 [--cell]" >&2; exit 2 ;;
esac

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
else
  echo "install-deps: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# The browser test's npm packages, exactly as tests/browser/package-lock.json pins them
# (npm ci), unless that very version is installed already. Not with --cell.
if [ -z "${1:-}" ]; then
  want=$(sed -n 's/.*"playwright-core": "\([0-9.]*\)".*/\1/p' tests/browser/package.json)
  have=""
  if [ -f tests/browser/node_modules/playwright-core/package.json ]; then
    have=$(sed -n 's/.*"version": "\([0-9.]*\)".*/\1/p' tests/browser/node_modules/playwright-core/package.json | head -1)
  fi
  if [ "$want" != "$have" ]; then
    echo "install-deps: npm ci in tests/browser (playwright-core $want)"
    (cd tests/browser && npm ci --no-audit --no-fund)
  else
    echo "install-deps: playwright-core $have present"
  fi
fi
