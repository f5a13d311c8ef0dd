#!/usr/bin/env bash
# HIL: `dualv sim --eds FILE --can vcan0` takes its drives' object dictionary from an EDS
# (CiA 306; sim/canopen/eds_dictionary.hpp). The shipped EDS of the emulated drive without
# its 60C2h sections gives drives that, on real SocketCAN, abort an SDO upload of 60C2h sub1
# with 06020000h (object does not exist, CiA 301 table 22):
#   601#40C2600100000000 -> 581#80C2600100000206
# while 6064h is still there (581#43 64 60 00 ...: 4 bytes), and `dualv eds-check` says the
# same EDS boots with the shipped configuration, 60C2h skipped as optional.
# Usage: dualv_sim_eds_hil.sh DUALV_BINARY CONFIG_YAML EDS
set -u
. "$(dirname "$0")/hil_lib.sh"
usage="usage: dualv_sim_eds_hil.sh DUALV_BINARY CONFIG_YAML EDS"
dualv=${1:?$usage}
config=${2:?$usage}
eds=${3:?$usage}
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dualv-sim-eds-hil.XXXXXX") || exit 1
sim_pid=
dump_pid=
cleanup() {
  [[ -n "$sim_pid" ]] && kill "$sim_pid" 2>/dev/null
  [[ -n "$dump_pid" ]] && kill "$dump_pid" 2>/dev/null
  rm -rf "$tmp"
}
trap cleanup EXIT
fail() {
  echo "FAIL: $*"
  echo "--- dualv sim output"; cat "$tmp/sim.log"
  echo "--- candump"; cat "$tmp/dump.log"
  exit 1
}

# The EDS without 60C2h: its sections dropped, [OptionalObjects] renumbered.
awk '
  /^\[/ { drop = ($0 ~ /^\[60C2/); opt = ($0 == "[OptionalObjects]") }
  drop { next }
  opt && /^SupportedObjects=/ { split($0, kv, "="); print "SupportedObjects=" kv[2] - 1; next }
  opt && /^[0-9]+=0x60C2$/ { next }
  opt && /^[0-9]+=/ { n++; sub(/^[0-9]+/, n) }
  { print }
' "$eds" >"$tmp/no-60c2.eds"
grep -q '^\[60C2' "$tmp/no-60c2.eds" && fail "60C2h still in the EDS"
"$dualv" eds-check "$tmp/no-60c2.eds" -c "$config" --node 1 >"$tmp/check.log" 2>&1 ||
  { cat "$tmp/check.log"; fail "eds-check refused the EDS without 60C2h"; }
grep -q "interpolation_period skipped (optional)" "$tmp/check.log" ||
  { cat "$tmp/check.log"; fail "eds-check did not report 60C2h as skipped"; }

candump -L vcan0 >"$tmp/dump.log" 2>&1 &
dump_pid=$!
"$dualv" sim --can vcan0 --config "$config" --eds "$tmp/no-60c2.eds" --exit-after 60 \
  --status-every 0 >"$tmp/sim.log" 2>&1 &
sim_pid=$!
wait_for "$tmp/sim.log" "drives booted" 10 || fail "dualv sim did not start"
grep -q "object dictionary from $tmp/no-60c2.eds" "$tmp/sim.log" || fail "--eds not taken"
# candump is live once it has seen the power-on boot-ups.
wait_for "$tmp/dump.log" " 704#00" 5 || fail "no power-on boot-up of node 4"

cansend vcan0 601#40C2600100000000
wait_for "$tmp/dump.log" " 581#80C2600100000206" 5 ||
  fail "60C2h sub1 upload not aborted with 06020000h"
cansend vcan0 601#4064600000000000
wait_for "$tmp/dump.log" " 581#43646000" 5 || fail "6064h upload not answered with 4 bytes"

kill -TERM "$sim_pid"
wait "$sim_pid"
sim_rc=$?
sim_pid=
[[ $sim_rc -eq 0 ]] || fail "dualv sim exited with $sim_rc on SIGTERM"
echo "PASS: dualv sim --eds: no 60C2h (06020000h), 6064h present, eds-check skips 60C2h"
