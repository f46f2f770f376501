#!/usr/bin/env bash
# Builds the Debian package `vgr` from a build tree that is already compiled:
#   scripts/build-deb.sh [BUILD_DIR [OUT_DIR]]      (defaults: build, .)
# From a clean checkout: scripts/install-deps.sh, configure + build the five programs
# (see README.md), then this. It compiles nothing: it stages `cmake --install BUILD_DIR
# --prefix /usr --strip` and wraps the staging folder with dpkg-deb, adding the control
# file (Depends from dpkg-shlibdeps), the conffiles and the maintainer scripts.
#
# Why dpkg-deb and not CPack DEB or debhelper: CPack runs the `preinstall` target, which
# builds `all` (a second compile in CI), and puts CMAKE_INSTALL_SYSCONFDIR under /usr/etc
# unless the tree was configured with the /usr prefix (PITFALLS.md); debhelper's
# `dh --buildsystem=cmake` configures and builds again in its own folder. Staging the
# existing tree packages exactly what CI tested. Layout: docs/plant.md, cmake/VgrInstall.cmake.
set -euo pipefail

src=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$src/build}" && pwd)
out=$(mkdir -p "${2:-.}" && cd "${2:-.}" && pwd)

for prog in vgrd vgr vgr-sim-camera vgr-sim-plc vgr-sim-robot; do
  [ -x "$build/bin/$prog" ] || { echo "build-deb: $build/bin/$prog is missing: build it first" >&2; exit 2; }
done

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
stage="$work/stage"
DESTDIR="$stage" cmake --install "$build" --prefix /usr --strip > "$work/install.log"

# "vgrd 0.1.0-gf659ba9-dirty" -> Debian version 0.1.0+gf659ba9+dirty (no '-': a native package).
upstream=$("$build/bin/vgrd" --version | awk '{print $2}')
version=${upstream//-/+}
arch=$(dpkg --print-architecture)

# Shared-library dependencies of the programs, as dh_shlibdeps would compute them.
mkdir -p "$work/shlibs/debian"
printf 'Source: vgr\n\nPackage: vgr\nArchitecture: any\n' > "$work/shlibs/debian/control"
depends=$(cd "$work/shlibs" && dpkg-shlibdeps -O "${stage}"/usr/bin/* 2>/dev/null | sed -n 's/^shlibs:Depends=//p')

mkdir -p "$stage/DEBIAN"
installed_kb=$(du -sk "$stage" | awk '{print $1}')
cat > "$stage/DEBIAN/control" <<CONTROL
Package: vgr
Version: $version
Architecture: $arch
Maintainer: vgr developers <vgr@localhost>
Section: misc
Priority: optional
Installed-Size: $installed_kb
Depends: $depends, systemd | systemd-standalone-sysusers
Description: vision-guided robotics daemon, tool and simulators
 vgrd takes a trigger from a PLC (Modbus TCP) or a robot, grabs an image from a GigE
 Vision camera, locates the parts and serves their poses to robot controllers (ABB,
 FANUC, UR), the PLC, a journal, Prometheus (/metrics) and MQTT. vgr is the offline
 tool (calibration, teaching, evaluation); vgr-sim-* emulate the camera, PLC and robots.
CONTROL

# Every file under /etc is a conffile: dpkg keeps the operator's edits on upgrade.
(cd "$stage" && find etc -type f | sed 's|^|/|' | sort) > "$stage/DEBIAN/conffiles"

cat > "$stage/DEBIAN/postinst" <<'SCRIPT'
#!/bin/sh
set -e
if [ "$1" = configure ]; then
  # The account and the state directory (systemd-sysusers and systemd-tmpfiles work
  # without a running systemd).
  systemd-sysusers /usr/lib/sysusers.d/vgr.conf
  systemd-tmpfiles --create /usr/lib/tmpfiles.d/vgr.conf
  # Enabled but not started: the example cell.yaml needs editing for a real cell first.
  if command -v deb-systemd-helper >/dev/null 2>&1; then
    deb-systemd-helper unmask vgrd.service >/dev/null || true
    if deb-systemd-helper --quiet was-enabled vgrd.service; then
      deb-systemd-helper enable vgrd.service >/dev/null || true
    else
      deb-systemd-helper update-state vgrd.service >/dev/null || true
    fi
  fi
  if [ -d /run/systemd/system ]; then
    systemctl --system daemon-reload >/dev/null || true
    # An upgrade restarts a running vgrd.
    if systemctl is-active --quiet vgrd.service; then systemctl restart vgrd.service || true; fi
  fi
fi
exit 0
SCRIPT

cat > "$stage/DEBIAN/prerm" <<'SCRIPT'
#!/bin/sh
set -e
if [ -d /run/systemd/system ] && [ "$1" = remove ]; then
  systemctl stop vgrd.service >/dev/null 2>&1 || true
fi
exit 0
SCRIPT

cat > "$stage/DEBIAN/postrm" <<'SCRIPT'
#!/bin/sh
set -e
if [ -d /run/systemd/system ]; then systemctl --system daemon-reload >/dev/null || true; fi
if [ "$1" = purge ]; then
  if command -v deb-systemd-helper >/dev/null 2>&1; then deb-systemd-helper purge vgrd.service >/dev/null || true; fi
  # The user vgr and what /var/lib/vgr holds (journals, archives) stay: they are the
  # plant's data, not the package's.
  rmdir --ignore-fail-on-non-empty /etc/vgr/sim-calib /etc/vgr 2>/dev/null || true
fi
exit 0
SCRIPT
chmod 755 "$stage/DEBIAN/postinst" "$stage/DEBIAN/prerm" "$stage/DEBIAN/postrm"

deb="$out/vgr_${version}_${arch}.deb"
dpkg-deb --root-owner-group -Zxz --build "$stage" "$deb" > /dev/null
echo "$deb"
