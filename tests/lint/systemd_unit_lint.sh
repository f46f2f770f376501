#!/usr/bin/env bash
# The unit: `systemd-analyze verify` only warns on typos (exit 0), so fail on any output at
# all; and `systemd-analyze security` (offline) must rate its exposure at 2.0 or below
# (issue 19: 4.0 before the hardening of systemd/README.md).
# The unit's /usr/bin/vgrd is pointed at the build tree so the executable check passes.
set -u
unit="$1"; vgrd="$2"
max_exposure=2.0
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
sed -e "s|/usr/bin/vgrd|$vgrd|g" "$unit" > "$tmp/vgrd.service"
out=$(systemd-analyze verify "$tmp/vgrd.service" 2>&1)
rc=$?
if [ $rc -ne 0 ] || [ -n "$out" ]; then
  echo "systemd-analyze verify (exit $rc):"
  echo "$out"
  exit 1
fi
sec=$(systemd-analyze security --offline=true --no-pager "$tmp/vgrd.service" 2>&1)
level=$(printf '%s\n' "$sec" | sed -n 's/.*Overall exposure level for vgrd.service: \([0-9.]*\).*/\1/p')
if [ -z "$level" ]; then
  echo "systemd-analyze security printed no exposure level:"
  echo "$sec"
  exit 1
fi
if awk -v l="$level" -v m="$max_exposure" 'BEGIN { exit !(l > m) }'; then
  echo "vgrd.service: exposure $level > $max_exposure (systemd-analyze security --offline=true):"
  printf '%s\n' "$sec" | grep '✗'
  exit 1
fi
echo "vgrd.service: clean, exposure $level (<= $max_exposure)"
