#!/usr/bin/env bash
# ctest `soak_ci` (label integration): the CI-sized fault run of `vgr soak`
# (docs/robustness.md). ~150 s: every fault kind injected twice on a fixed schedule while a
# PLC triggers at 10 Hz and robots of every dialect poll. Passes when vgr soak exits 0
# (0 lost, 0 duplicated, 0 misdelivered, 0 late, robots and journal clean) AND its summary
# shows every fault kind at least twice (a fault that silently did nothing would pass
# otherwise).
#   tests/soak/soak_ci.sh BIN_DIR
set -uo pipefail
bin="$1"
work=$(mktemp -d /tmp/vgr-soak-ci-XXXXXX)
"$bin/vgr" soak --duration-s 150 --rate-hz 10 --faults schedule --fault-every-s 7 --warmup-s 10 --seed 1 \
  --work-dir "$work" --bin-dir "$bin" | tee "$work/stdout.txt"
rc=${PIPESTATUS[0]}
summary=$(tail -n 1 "$work/stdout.txt")
/usr/bin/python3 - "$summary" <<'PY'
import json, sys
s = json.loads(sys.argv[1])
bad = [k for k, n in s["faults"].items() if n < 2]
if bad:
    print("soak_ci: fault kinds injected fewer than twice:", bad)
    sys.exit(1)
for key in ("lost", "duplicated", "late", "wrong_trigger"):
    if s[key] != 0:
        print(f"soak_ci: {key} = {s[key]}")
        sys.exit(1)
print(f"soak_ci: {s['triggers']} triggers, {s['ok']} ok, typed {s['typed_errors']}, "
      f"interrupted {s['interrupted_by_kill']}, max latency {s['max_latency_ms']} ms, faults {s['faults']}")
PY
py=$?
if [ $rc -ne 0 ] || [ $py -ne 0 ]; then
  echo "soak_ci: FAILED (vgr soak exit $rc); logs kept in $work"
  exit 1
fi
rm -rf "$work"
