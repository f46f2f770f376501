#!/usr/bin/env bash
# Calibrates the simulated 3D cell (config/examples/sim-cell-3d.yaml) the way a depth
# camera's eye-to-hand cell is commissioned (docs/calibration.md, "Depth cameras"):
#   1. `vgr calibrate synth --kind handeye-cloud` renders the sphere target on the robot
#      flange at N robot poses, seen by the cell's depth camera (640 x 480, f = 800 px as the
#      3D scenes' camera), 0.3 mm depth noise, with the controller's reported poses (robot
#      noise 0.05 mm / 0.01 deg) and the truth (truth.yaml: where the camera really is).
#   2. `vgr calibrate handeye --cloud` makes handeye.yaml from the depth images (paper 003's
#      point-cloud registration among the methods), its residuals inside.
# The truth is kept next to it (sim-calib-3d/truth.yaml): `vgr demo --3d` scores the cell's
# poses against the truth in the robot base frame, so a calibration error shows in its figures.
# Usage: scripts/calibrate-sim-cell-3d.sh [OUT_DIR]   (default config/examples/sim-calib-3d;
# needs a built tree: BIN_DIR defaults to build/bin).
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN_DIR:-build/bin}
OUT=${1:-config/examples/sim-calib-3d}
WORK=$(mktemp -d /tmp/vgr-calib-sim3d.XXXXXX)
VIEWS=${VGR_CALIB_VIEWS:-15}
mkdir -p "$OUT"
"$BIN/vgr" calibrate synth --kind handeye-cloud --configuration eye-to-hand --depth-focal 800 --views "$VIEWS" \
  --seed 1 --out "$WORK/set" >"$WORK/synth.log" 2>&1 || { tail -5 "$WORK/synth.log" >&2; exit 1; }
"$BIN/vgr" calibrate handeye --cloud --folder "$WORK/set" --configuration eye-to-hand --truth "$WORK/set/truth.yaml" \
  --out "$OUT/handeye.yaml" | tee "$WORK/handeye.log"
cp "$WORK/set/truth.yaml" "$OUT/truth.yaml"
rm -rf "$WORK"
echo "calibrate-sim-cell-3d: $OUT/handeye.yaml and $OUT/truth.yaml"
