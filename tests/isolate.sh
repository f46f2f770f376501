#!/usr/bin/env bash
# Runs one test command in a network namespace of its own (a fresh loopback, nothing else),
# so integration tests that bind the simulated cell's fixed ports (Modbus 1502, robots
# 50010-50019, the camera's GVCP 3956, ...) can run side by side: ctest -j. The namespace is
# made here and removed on exit. Needs root and iproute2; tests/CMakeLists.txt uses this
# script only when both are there (else the integration tests run one at a time).
set -u
name="vgrt-$$-${RANDOM}"
if ! ip netns add "$name" 2>/dev/null; then
  echo "isolate.sh: cannot create network namespace $name (root and iproute2 needed)" >&2
  exit 1
fi
trap 'ip netns delete "$name" 2>/dev/null' EXIT
ip netns exec "$name" ip link set lo up
# The robot ports lie in the ephemeral range: reserve them in this namespace too
# (scripts/reserve-ports.sh says why; the setting is per namespace).
ip netns exec "$name" sh -c 'echo 50010-50019 > /proc/sys/net/ipv4/ip_local_reserved_ports' 2>/dev/null
ip netns exec "$name" "$@"
