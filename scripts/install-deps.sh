#!/usr/bin/env bash
# Installs vgr's build and test dependencies from Debian bookworm packages, then the npm
# packages of the browser test (tests/browser: playwright-core, which drives Debian's
# chromium; it downloads no browser). Idempotent: packages already present are left alone;
# apt's lists are refreshed only when something is missing. Run as root (or through sudo).
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  build-essential cmake pkg-config ccache git
  libopencv-dev libeigen3-dev
  libaravis-dev aravis-tools libusb-1.0-0-dev
  libmodbus-dev mbpoll python3-pymodbus
  python3-serial-asyncio  # pymodbus 3.0 imports it at "from pymodbus.client import ..." but only Recommends it
  libboost-dev libspdlog-dev libfmt-dev libyaml-cpp-dev libcli11-dev nlohmann-json3-dev
  libsystemd-dev systemd
  prometheus-cpp-dev python3-prometheus-client  # vgrd's /metrics; the test parses it with the Python parser
  libmosquitto-dev mosquitto mosquitto-clients  # vgrd's MQTT sink; the test runs a broker and mosquitto_sub
  iproute2  # camera_multi_test adds 127.0.0.2 to lo for a second emulated camera
  libgtest-dev libgmock-dev libbenchmark-dev
  clang libclang-rt-14-dev
  chromium fonts-dejavu-core  # the commissioning page's browser test (headless) and its screenshots' text
)
# Node.js and npm for playwright-core (tests/browser): the machine's own when it has them
# (the CI image ships Node.js 20 with npm), Debian's otherwise (Node.js 18: playwright-core
# 1.61 is the last release that runs on it, which is why package.json pins it).
if ! command -v npm >/dev/null 2>&1; then PACKAGES+=(nodejs npm); fi

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

# The browser test's npm packages, exactly as package-lock.json pins them (npm ci), unless
# that very version is installed already.
want=$(sed -n 's/.*"playwright-core": "\([0-9.]*\)".*/\1/p' tests/browser/package.json)
have=$(sed -n 's/.*"version": "\([0-9.]*\)".*/\1/p' tests/browser/node_modules/playwright-core/package.json 2>/dev/null | head -1)
if [ "$want" != "$have" ]; then
  echo "install-deps: npm ci in tests/browser (playwright-core $want)"
  (cd tests/browser && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --no-audit --no-fund)
else
  echo "install-deps: playwright-core $have present"
fi
