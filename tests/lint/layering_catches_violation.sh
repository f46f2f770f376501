#!/bin/sh
# Passes only when scripts/check-layering.py FAILS on tests/lint/layering_fixture (a config/
# header that includes vision/) and names the file, the line and the rule.
# Usage: layering_catches_violation.sh <check-layering.py> <fixture dir>
checker=$1
fixture=$2
out=$("$checker" --root "$fixture" --known /dev/null 2>&1)
rc=$?
printf '%s\n' "$out"
if [ "$rc" -ne 1 ]; then
  echo "expected exit status 1 (a violation), got $rc" >&2
  exit 1
fi
expected='config/bad.hpp:5: config/ may not include vision/ ("vision/x.hpp")'
if ! printf '%s\n' "$out" | grep -qF "$expected"; then
  echo "expected the message: $expected" >&2
  exit 1
fi
if [ "$(printf '%s\n' "$out" | grep -c 'may not include')" -ne 1 ]; then
  echo "expected exactly one violation (allowed includes must pass)" >&2
  exit 1
fi
echo "ok: the checker fails on the deliberate cross-layer include"
