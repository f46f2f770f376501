#!/usr/bin/env bash
# The simulated cell's robot ports 50010-50019 (vgr soak adds 50013, 50014; 50013 is also
# the fourth robot of `vgr demo --classes`) lie inside Linux's ephemeral port range
# (net.ipv4.ip_local_port_range, 32768-60999 on Debian): any outgoing connection on the
# machine may be given one of them as its local port, and vgrd's bind on it then fails
# with "Address already in use" although nothing listens there (seen once in CI: four
# Modbus/soak tests in a row could not start vgrd). Reserving them keeps the kernel from
# handing them out; listeners can still bind them. Needs root; without it, says so and
# goes on. A real cell with robot ports in that range wants the same setting
# (docs/protocols.md).
set -euo pipefail
f=/proc/sys/net/ipv4/ip_local_reserved_ports
want=50010-50019
if [ ! -w "$f" ]; then
  echo "reserve-ports: cannot write $f (not root?); ports $want stay in the ephemeral range" >&2
  exit 0
fi
current=$(cat "$f")
case ",$current," in
  *",$want,"*) ;;
  *) echo "${current:+$current,}$want" >"$f" ;;
esac
