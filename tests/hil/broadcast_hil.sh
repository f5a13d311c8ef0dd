#!/usr/bin/env bash
# HIL (issue 15): the broadcast bus layout over real SocketCAN (vcan0, through run_in_vcan.sh)
# between two processes, with the SHIPPED configuration but for one key, can.bus_layout:
# broadcast (no widened deadline, 1 kHz, the shipped inhibit times):
#   `dualv sim --can vcan0`  four emulated drives (the master maps them: one 200h RPDO with
#                            every torque, own slice + dummies; TPDO1 position; TPDO3
#                            statusword on change)
#   `dualv run --can vcan0`  the controller, the paper program (retimed variant)
# Checks:
#   1. boot: the drives boot with the broadcast layout (the master's bus-load line names it)
#   2. wire (candump -l, check_broadcast_wire.py): only the broadcast layout's frames, one
#      200h frame before every SYNC, no torque above the limit, every drive's statusword seen
#      (and Operation enabled seen when the run completed), TPDO3s within their inhibit bound
#   3. refusal: `dualv sim --no-dummy-mapping` (drives that cannot map dummy entries): the
#      master refuses to boot, naming the drive and the mapping object
#   4. the run: completes (exit 0); if the guest cannot keep the 1 kHz timing (its ms-scale
#      stalls trip the deadline or staleness watchdogs, as in foreign_drive_hil.sh), the test
#      asserts what does not depend on that timing (1-3) and says so in a NOTE.
# Needs can-utils (candump). Usage: broadcast_hil.sh DUALV_BINARY CONFIG_YAML [PROGRAM_YAML]
# KEEP=1 keeps the work folder.
set -u
. "$(dirname "$0")/hil_lib.sh"
usage="usage: broadcast_hil.sh DUALV_BINARY CONFIG_YAML [PROGRAM_YAML]"
dualv=${1:?$usage}
config_in=${2:?$usage}
program=${3:-$(dirname "$config_in")/paper.yaml}
here=$(cd "$(dirname "$0")" && pwd)
py=/usr/bin/python3
[[ -x $py ]] || py=python3
command -v candump >/dev/null || { echo "FAIL: candump not found (install can-utils)"; exit 1; }
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dualv-broadcast-hil.XXXXXX") || exit 1

sim_pid='' dump_pid=''
# shellcheck disable=SC2317  # invoked by the EXIT trap
cleanup() {
  for p in $sim_pid $dump_pid; do kill "$p" 2>/dev/null; done
  if [[ -n "${KEEP:-}" ]]; then echo "kept $tmp"; else rm -rf "$tmp"; fi
}
trap cleanup EXIT
failed=0
fail() {
  echo "FAIL: $*"
  failed=1
}
show() {
  for f in "$@"; do echo "--- $f (tail)"; tail -n 40 "$f" 2>/dev/null; done
}

# The shipped configuration with the broadcast layout: one key changed, nothing else.
config=$tmp/dualv-broadcast.yaml
sed -e 's/^  bus_layout: per_drive /  bus_layout: broadcast /' "$config_in" >"$config"
grep -Eq '^  bus_layout: broadcast ' "$config" ||
  { echo "FAIL: could not set can.bus_layout: broadcast in $config_in (format changed?)"; exit 1; }
[[ $(diff "$config_in" "$config" | grep -c '^>') -eq 1 ]] ||
  { echo "FAIL: the overlay changed more than can.bus_layout"; exit 1; }

# --- 1, 2, 4: the paper program with the broadcast layout ---------------------------------
mkdir -p "$tmp/dump"
(cd "$tmp/dump" && exec candump -l -r 8388608 vcan0) >"$tmp/candump.log" 2>&1 &
dump_pid=$!
for ((i = 0; i < 100; ++i)); do
  compgen -G "$tmp/dump/candump-*.log" >/dev/null && break
  sleep 0.05
done
"$dualv" sim --can vcan0 --config "$config" --exit-after 600 --status-every 0 --plant-step-nominal \
  >"$tmp/sim.log" 2>&1 &
sim_pid=$!
wait_for "$tmp/sim.log" "drives booted" 10 || fail "dualv sim did not start"
stdbuf -oL "$dualv" run --can vcan0 --config "$config" -p "$program" --variant retimed \
  --no-plots -o "$tmp/run" >"$tmp/run.log" 2>&1
run_rc=$?
kill -TERM "$sim_pid" 2>/dev/null
wait "$sim_pid"
sim_pid=
sleep 0.2
kill -INT "$dump_pid" 2>/dev/null
wait "$dump_pid" 2>/dev/null
dump_pid=
capture=$(compgen -G "$tmp/dump/candump-*.log" | head -n 1)

echo "=== broadcast layout: dualv run --can vcan0 exit $run_rc"
grep -E "CAN bus load|drives booted|^(loop:|bus:)|STOPPED|stop" "$tmp/run.log" | head -n 20

booted=1
grep -q "drives booted" "$tmp/run.log" || { booted=0; fail "boot: the drives did not boot"; }
grep -q "CAN bus load: 4 drives, broadcast layout" "$tmp/run.log" ||
  fail "boot: the bus-load line does not name the broadcast layout"

if [[ -z "$capture" || ! -s "$capture" ]]; then
  fail "wire: no candump log"
else
  expect=()
  [[ $run_rc -eq 0 ]] && expect=(--expect-enabled)
  "$py" "$here/check_broadcast_wire.py" --config "$config" "${expect[@]}" "$capture" ||
    fail "wire: not the broadcast layout (see above)"
fi

if [[ $booted -eq 1 && $run_rc -ne 0 ]]; then
  timing=0
  # One or more timing causes, e.g. "safety stop (stale feedback, consecutive deadline misses)".
  grep -Eq "safety stop \(((consecutive deadline misses|deadline miss|stale feedback|drive lost)(, )?)+\)" \
    "$tmp/run.log" && timing=1
  # The drives stopped on their own before the program could start, because the host was
  # silent for longer than their 1016h / RPDO deadline while the guest stalled (EMCY 8130h /
  # 8250h), or the host lost their heartbeats in a stall (issue 12's loop start-up; the same
  # happens with the per-drive layout: hil_foreign_drive then passes with its NOTE).
  grep -Eq "cycle 0 .*safety stop \(drive fault\)|refused the start: a stop is latched" \
    "$tmp/run.log" && grep -Eq "EMCY (8130|8250)h|heartbeat timed out" "$tmp/run.log" && timing=1
  if [[ $timing -eq 1 ]]; then
    guest_timing "run: dualv run --can exited $run_rc on the loop's timing watchdogs"
    echo "NOTE: the run stopped on host timing in the guest (exit $run_rc, see above); boot and wire" \
      "were checked"
  else
    fail "run: dualv run --can exited $run_rc"
  fi
fi

# --- 3: drives that cannot map dummy entries -----------------------------------------------
"$dualv" sim --can vcan0 --config "$config" --no-dummy-mapping --exit-after 600 --status-every 0 \
  >"$tmp/nodummy.sim.log" 2>&1 &
sim_pid=$!
wait_for "$tmp/nodummy.sim.log" "drives booted" 10 || fail "refusal: dualv sim did not start"
"$dualv" run --can vcan0 --config "$config" -p "$program" --variant retimed --no-plots \
  -o "$tmp/nodummy" >"$tmp/nodummy.run.log" 2>&1
nd_rc=$?
kill -TERM "$sim_pid" 2>/dev/null
wait "$sim_pid"
sim_pid=
echo "=== drives without dummy mapping: dualv run --can vcan0 exit $nd_rc"
grep -E "dummy" "$tmp/nodummy.run.log" | head -n 3
[[ $nd_rc -ne 0 ]] || fail "refusal: dualv run booted drives that cannot map dummy entries"
grep -q "node 1 (can.drives\[0\]) refuses the CiA 301 dummy mapping entry 0003h" "$tmp/nodummy.run.log" ||
  fail "refusal: the error does not name the drive and the dummy entry"
grep -q "1601h sub2" "$tmp/nodummy.run.log" || fail "refusal: the error does not name 1601h sub2"

if [[ $failed -ne 0 ]]; then
  show "$tmp/run.log" "$tmp/sim.log" "$tmp/nodummy.run.log"
  exit 1
fi
echo "broadcast HIL: boots with the broadcast layout, the wire is that layout, torque within the limit," \
  "every drive's state seen; drives without dummy mapping refused by name (run exit $run_rc)"
exit 0
