#!/usr/bin/env bash
# ctest `package_deb` (label package): packages the tree CI already built (no compile),
# installs it with dpkg -i, checks the unit (systemd-analyze verify, silent), the user,
# the state directory, the paths, the conffiles, `vgrd --version` and `vgrd --check` of the
# packaged example as user vgr, then purges it and checks that only the user and the
# state directory's content could stay. Needs root; skipped (77) without it or when a vgr
# package is installed already (never touch a real installation).
#   tests/package/package_test.sh SOURCE_DIR BUILD_DIR
set -uo pipefail
src="$1"; build="$2"

if [ "$(id -u)" -ne 0 ]; then echo "package_deb: needs root (dpkg -i): skipped"; exit 77; fi
if dpkg-query -W -f='${Status}' vgr 2>/dev/null | grep -q "installed"; then
  echo "package_deb: a vgr package is installed on this machine: skipped"; exit 77
fi
exec 9>/tmp/vgr-package.lock
flock 9

work=$(mktemp -d)
user_existed=0
getent passwd vgr >/dev/null && user_existed=1
fails=0
check() {  # check "what" command...
  local what="$1"; shift
  if "$@" >/dev/null 2>&1; then echo "ok   $what"; else echo "FAIL $what"; fails=$((fails + 1)); fi
}
cleanup() {
  dpkg --purge vgr >/dev/null 2>&1 || true
  if [ $user_existed -eq 0 ] && getent passwd vgr >/dev/null; then
    userdel vgr 2>/dev/null || true
    getent group vgr >/dev/null && groupdel vgr 2>/dev/null || true
    rmdir /var/lib/vgr 2>/dev/null || true
  fi
  rm -rf "$work"
}
trap cleanup EXIT

t0=$(date +%s.%N)
deb=$("$src/scripts/build-deb.sh" "$build" "$work") || { echo "FAIL build-deb.sh"; exit 1; }
t1=$(date +%s.%N)
echo "package: $(basename "$deb"), $(du -k "$deb" | awk '{print $1}') kB, built in $(awk "BEGIN{printf \"%.1f\", $t1 - $t0}") s"
dpkg -i "$deb" > "$work/dpkg-i.log" 2>&1 || { echo "FAIL dpkg -i"; cat "$work/dpkg-i.log"; exit 1; }
t2=$(date +%s.%N)
echo "dpkg -i: $(awk "BEGIN{printf \"%.1f\", $t2 - $t1}") s"

unit=/usr/lib/systemd/system/vgrd.service
out=$(systemd-analyze verify "$unit" 2>&1); rc=$?
if [ $rc -eq 0 ] && [ -z "$out" ]; then echo "ok   systemd-analyze verify $unit (silent)"
else echo "FAIL systemd-analyze verify (exit $rc): $out"; fails=$((fails + 1)); fi

check "user vgr with home /var/lib/vgr" sh -c 'getent passwd vgr | cut -d: -f6 | grep -qx /var/lib/vgr'
check "/var/lib/vgr owned by vgr" sh -c '[ "$(stat -c %U /var/lib/vgr)" = vgr ]'
for f in /usr/bin/vgrd /usr/bin/vgr /usr/bin/vgr-sim-camera /usr/bin/vgr-sim-plc /usr/bin/vgr-sim-robot; do
  check "$f executable" test -x "$f"
done
for f in /etc/vgr/cell.yaml /etc/vgr/sim-calib/intrinsics.yaml /usr/lib/sysusers.d/vgr.conf /usr/lib/tmpfiles.d/vgr.conf \
         /usr/share/vgr/robot/VgrPick.mod /usr/share/vgr/robot/vgr_pick.script /usr/share/vgr/robot/VGR_PICK.ls \
         /usr/share/vgr/models/grasp/ggcnn.onnx /usr/share/doc/vgr/README.md; do
  check "$f present" test -f "$f"
done
check "/etc/vgr/cell.yaml is a conffile" sh -c "dpkg-query -W -f='\${Conffiles}' vgr | grep -q ' /etc/vgr/cell.yaml '"
check "journal in /var/lib/vgr" grep -q "journal: /var/lib/vgr/journal.jsonl" /etc/vgr/cell.yaml
want=$("$build/bin/vgrd" --version)
got=$(/usr/bin/vgrd --version)
echo "vgrd --version: $got"
check "vgrd --version = the build's ($want)" test "$got" = "$want"
check "vgr --version" sh -c '/usr/bin/vgr --version | grep -q "^vgr [0-9]"'
check "vgrd --check of /etc/vgr/cell.yaml as user vgr" runuser -u vgr -- /usr/bin/vgrd --check --config /etc/vgr/cell.yaml

dpkg -L vgr > "$work/files"
dpkg --purge vgr > "$work/purge.log" 2>&1 || { echo "FAIL dpkg --purge"; cat "$work/purge.log"; fails=$((fails + 1)); }
left=0
while read -r f; do
  [ -f "$f" ] && { echo "left after purge: $f"; left=$((left + 1)); }
done < "$work/files"
[ -e /etc/vgr ] && { echo "left after purge: /etc/vgr"; left=$((left + 1)); }
check "purge leaves no packaged file" test $left -eq 0
check "purge keeps the user vgr" sh -c 'getent passwd vgr'

if [ $fails -ne 0 ]; then echo "package_deb: $fails check(s) failed"; exit 1; fi
echo "package_deb: all checks passed"
