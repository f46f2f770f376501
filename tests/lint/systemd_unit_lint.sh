#!/usr/bin/env bash
# systemd-analyze verify only warns on typos (exit 0): fail on any output at all.
# The unit's /usr/bin/vgrd is pointed at the build tree so the executable check passes.
set -u
unit="$1"; vgrd="$2"
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
echo "vgrd.service: clean"
