#!/bin/bash
# The shape matcher against a baseline build, on the real-parts scenes of vgr-bench-locate
# (--scene gear|plate: 2448x2048, 450 px part, 8 clutter shapes, 2:1 lighting gradient,
# noise sigma 5), in one run: for every case the baseline and this build run back to back on
# the same images (same seed), pinned with taskset, under nice 19 (the machine is shared).
# Prints nothing; writes OUT/<case>.{old,new}.txt (the bench tables) and OUT/uptime.txt.
#   bench/shape_compare.sh NEW_BENCH OLD_BENCH OUT [IMAGES]
# NEW_BENCH: build/bin/vgr-bench-locate; OLD_BENCH: vgr-bench-locate of the baseline (e.g.
# main's vision/ built with this bench/locate_bench.cpp and sim/shape_scenes.cpp; without
# --profile and --scale-*). docs/performance.md has the figures.
set -euo pipefail
new=$1 old=$2 out=$3 n=${4:-30}
mkdir -p "$out"
uptime > "$out/uptime.txt"
both() {  # case cpus args...
  local name=$1 cpus=$2
  shift 2
  nice -n 19 taskset -c "$cpus" "$old" "$@" > "$out/$name.old.txt" 2>&1
  nice -n 19 taskset -c "$cpus" "$new" "$@" --profile > "$out/$name.new.txt" 2>&1
}
for scene in gear plate; do
  both ${scene}_full_1core 1 --scene $scene --images "$n" --methods shape --param workers=1
  both ${scene}_60_1core 1 --scene $scene --images "$n" --range 60 --methods shape --param workers=1
  both ${scene}_full_2core 0,1 --scene $scene --images "$n" --methods shape --param workers=2
  # shape (workers 2 on the one core) and orb-ransac in one process on the same images
  nice -n 19 taskset -c 1 "$new" --scene $scene --images "$n" --methods shape orb-ransac > "$out/${scene}_full_orb.new.txt" 2>&1
  nice -n 19 taskset -c 1 "$new" --scene $scene --images "$n" --range 60 --methods shape orb-ransac > "$out/${scene}_60_orb.new.txt" 2>&1
  nice -n 19 taskset -c 1 "$new" --scene $scene --images "$n" --scale-min 0.8 --scale-max 1.2 --methods shape \
    --param workers=1 --profile > "$out/${scene}_scale08_12_1core.new.txt" 2>&1
done
nice -n 19 taskset -c 1 "$new" --scene gear --images "$n" --scale-min 0.5 --scale-max 1.5 --part-scale-min 0.6 \
  --part-scale-max 1.4 --methods shape --param workers=1 --profile > "$out/gear_scale05_15_1core.new.txt" 2>&1
uptime >> "$out/uptime.txt"
