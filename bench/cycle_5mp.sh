#!/bin/bash
# vgrd's cycle at 2448x2048 with a `shape` job on the simulated cell (issue 20): trigger ->
# RESULT_VALID as the PLC sees it, camera transfer included, and the journal's split
# (grab_ms: trigger -> frame in memory, which for the emulator includes rendering the frame;
# locate_ms; total_ms). `vgr demo --method shape` teaches the job on the embedded 1280x1024
# cell; the same cell is then run at 2448x2048 (principal point moved to the centre, the
# pinhole `model` instead of the 1280x1024 calibration files, same focal length, so the part
# has the taught size). Run inside your network namespace (fixed ports):
#   ip netns exec vgr-NAME bench/cycle_5mp.sh build/bin OUT [CYCLES]
set -euo pipefail
bin=$1 out=$2 n=${3:-200}
mkdir -p "$out"
"$bin/vgr" demo --method shape --cycles 3 --quiet --work-dir "$out/teach" > /dev/null
/usr/bin/python3 - "$out" <<'PY'
import sys
out = sys.argv[1]
s = open(f"{out}/teach/sim-cell-taught.yaml").read()
a, b = s.index("calibration:\n  intrinsics"), s.index("modbus:")
s = s[:a] + s[b:]
for old, new in (("  cx: 639.5\n  cy: 511.5", "  cx: 1223.5\n  cy: 1023.5"),
                 ("  width: 1280\n  height: 1024", "  width: 2448\n  height: 2048")):
    assert old in s, old
    s = s.replace(old, new)
open(f"{out}/cell-5mp.yaml", "w").write(s)
PY
uptime > "$out/uptime.txt"
"$bin/vgr" demo --config "$out/cell-5mp.yaml" --cycles "$n" --quiet --work-dir "$out/run" | tail -1 > "$out/demo.json"
uptime >> "$out/uptime.txt"
/usr/bin/python3 - "$out" <<'PY'
import json, sys
out = sys.argv[1]
lines = [json.loads(l) for l in open(f"{out}/run/journal.jsonl") if l.strip()]
def pct(v, p):
    v = sorted(v)
    return v[max(0, min(len(v) - 1, round(p / 100 * (len(v) - 1))))]
res = json.load(open(f"{out}/demo.json"))
for key in ("grab_ms", "locate_ms", "total_ms"):
    v = [l[key] for l in lines]
    res[key] = {"p50": pct(v, 50), "p99": pct(v, 99), "max": max(v)}
v = [l["total_ms"] - l["grab_ms"] for l in lines]
res["total_minus_grab_ms"] = {"p50": pct(v, 50), "p99": pct(v, 99), "max": max(v)}
print(json.dumps(res))
PY
