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
BIN=${BIN_DIR:-build/bin}
OUT=${1:-config/examples/sim-calib}
WORK=$(mktemp -d /tmp/vgr-calib-sim.XXXXXX)
PATTERN=(--pattern chessboard --cols 9 --rows 6 --square 20)
mkdir -p "$OUT"

"$BIN/vgr" calibrate synth --kind cell --out "$WORK/synth" --views 20 --seed 1 "${PATTERN[@]}" 2>/dev/null

for set in intrinsics handeye plane; do
  n=$(find "$WORK/synth/$set" -name '*.png' | wc -l)
  "$BIN/vgr-sim-camera" --images "$WORK/synth/$set" >"$WORK/camera-$set.log" 2>&1 &
  cam=$!
  for _ in $(seq 100); do grep -q '"ready"' "$WORK/camera-$set.log" && break; sleep 0.1; done
  "$BIN/vgr" grab --camera VGR-SIM-0 --count "$n" --save "$WORK/grab/$set" --json | tail -1
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

"$BIN/vgr" calibrate intrinsics --images "$WORK/grab/intrinsics/*.png" "${PATTERN[@]}" --out "$OUT/intrinsics.yaml" --json 2>/dev/null | tail -1
"$BIN/vgr" calibrate handeye --folder "$WORK/grab/handeye" --intrinsics "$OUT/intrinsics.yaml" --configuration eye-to-hand \
  "${PATTERN[@]}" --truth "$WORK/synth/handeye/truth.yaml" --out "$OUT/handeye.yaml" --json 2>/dev/null | tail -1
"$BIN/vgr" calibrate plane --image "$(ls "$WORK"/grab/plane/frame_*.png | head -1)" --intrinsics "$OUT/intrinsics.yaml" \
  --handeye "$OUT/handeye.yaml" "${PATTERN[@]}" --out "$OUT/plane.yaml" --json | tail -1
rm -rf "$WORK"
echo "calibration files in $OUT"
