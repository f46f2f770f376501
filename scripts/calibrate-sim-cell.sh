#!/usr/bin/env bash
# Calibrates the simulated cell the way a real eye-to-hand cell is commissioned
# (docs/calibration.md, "The simulated cell, calibrated like a real one"):
#   1. `vgr calibrate synth --kind cell` renders, for the cell's own camera, what the
#      integrator would put in front of it: a plate at varied tilts (intrinsics/), the plate
#      on the robot flange at N robot poses with the controller's reported poses (handeye/),
#      and the plate lying on the conveyor (plane/).
#   2. The camera emulator serves each set over GigE Vision; `vgr grab --save` takes the
#      frames through Aravis, as from a real camera.
#   3. `vgr calibrate intrinsics / handeye / plane` make the calibration files from the
#      grabbed frames (the robot poses matched to frames by the emulator's frame id).
# Usage: scripts/calibrate-sim-cell.sh [OUT_DIR]   (default config/examples/sim-calib; needs a
# built tree: BIN_DIR defaults to build/bin). Nothing else may serve GVCP on 127.0.0.1:3956.
set -euo pipefail
cd "$(dirname "$0")/.."
# Progress lines go to WORK/steps.log; on failure its tail says why.
fail() { echo "calibrate-sim-cell: $1 failed:" >&2; tail -5 "$WORK/steps.log" >&2; exit 1; }
BIN=${BIN_DIR:-build/bin}
OUT=${1:-config/examples/sim-calib}
WORK=$(mktemp -d /tmp/vgr-calib-sim.XXXXXX)
# The plate and the number of views (overridable for experiments: docs/calibration.md).
# A 15 x 10-square chessboard of 25 mm (A3-ish, for a 640 x 512 mm field of view; 14 x 9
# inner corners: one count even, so it has no 180-degree ambiguity), 30 views per set.
read -r -a PATTERN <<<"${VGR_CALIB_PATTERN:---pattern chessboard --cols 14 --rows 9 --square 25}"
VIEWS=${VGR_CALIB_VIEWS:-30}
mkdir -p "$OUT"

"$BIN/vgr" calibrate synth --kind cell --out "$WORK/synth" --views "$VIEWS" --seed 1 "${PATTERN[@]}" 2>>"$WORK/steps.log" || fail "vgr calibrate synth"

for set in intrinsics handeye plane; do
  n=$(find "$WORK/synth/$set" -name '*.png' | wc -l)
  "$BIN/vgr-sim-camera" --images "$WORK/synth/$set" >"$WORK/camera-$set.log" 2>&1 &
  cam=$!
  for _ in $(seq 100); do grep -q '"ready"' "$WORK/camera-$set.log" && break; sleep 0.1; done
  "$BIN/vgr" grab --camera VGR-SIM-0 --count "$n" --save "$WORK/grab/$set" --json 2>>"$WORK/steps.log" | tail -1 || fail "vgr grab ($set)"
  kill "$cam"
  wait "$cam" || true
done

# The emulator serves the folder's images in name order: frame id k shows image (k - 1) mod n.
# poses.txt names the synthetic images; name the grabbed frame that showed each instead.
n=$(grep -c '\.png' "$WORK/synth/handeye/poses.txt")
{
  grep -v '\.png' "$WORK/synth/handeye/poses.txt"
  for f in "$WORK/grab/handeye"/frame_*.png; do
    id=$((10#$(basename "$f" .png | sed 's/frame_//')))
    line=$(grep '\.png' "$WORK/synth/handeye/poses.txt" | sed -n "$(( (id - 1) % n + 1 ))p")
    echo "$(basename "$f") ${line#* }"
  done
} >"$WORK/grab/handeye/poses.txt"

"$BIN/vgr" calibrate intrinsics --images "$WORK/grab/intrinsics/*.png" "${PATTERN[@]}" --out "$OUT/intrinsics.yaml" --json 2>>"$WORK/steps.log" | tail -1 || fail "vgr calibrate intrinsics"
"$BIN/vgr" calibrate handeye --folder "$WORK/grab/handeye" --intrinsics "$OUT/intrinsics.yaml" --configuration eye-to-hand \
  "${PATTERN[@]}" --truth "$WORK/synth/handeye/truth.yaml" --out "$OUT/handeye.yaml" --json 2>>"$WORK/steps.log" | tail -1 || fail "vgr calibrate handeye"
"$BIN/vgr" calibrate plane --image "$(ls "$WORK"/grab/plane/frame_*.png | head -1)" --intrinsics "$OUT/intrinsics.yaml" \
  --handeye "$OUT/handeye.yaml" "${PATTERN[@]}" --out "$OUT/plane.yaml" --json 2>>"$WORK/steps.log" | tail -1 || fail "vgr calibrate plane"
rm -rf "$WORK"
echo "calibration files in $OUT"
