#!/usr/bin/env bash
# Comparison of all methods on the same rendered sets (docs/localization.md).
set -u
B="$(cd "$(dirname "$0")/.." && pwd)/build/bin"
$B/vgr sim render --out flat --count 50 --seed 31 --part flat --angle-range 60 --noise 5 > /dev/null
$B/vgr sim render --out multi --count 50 --seed 32 --part multi --levels 3 --angle-range 60 --noise 5 > /dev/null
for set in flat multi; do
  g=$(sed -n 's/^grasp: {x_px: \([0-9.]*\), y_px: \([0-9.]*\)}.*/\1,\2/p' $set/template.yaml)
  echo "$set grasp $g"
  for m in moments hu sift orb-ransac orb-prosac orb-adk contour-weighted shape; do
    rm -rf job-$set-$m
    $B/vgr teach --image $set/template.png --grasp "$g" --regions $set/template.yaml --method $m --min-score 0.3 --out job-$set-$m > teach-$set-$m.log 2>&1 || { echo "$set $m teach failed: $(tail -1 teach-$set-$m.log)"; continue; }
    echo "$set $m $($B/vgr eval --job job-$set-$m --dataset $set --json 2>/dev/null | tail -1)"
  done
done
