#!/usr/bin/env bash
# Installs vgr's build and test dependencies from Debian bookworm packages. Idempotent:
# packages already present are left alone; apt's lists are refreshed only when something
# is missing. Run as root (or through sudo).
set -euo pipefail

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
)

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
