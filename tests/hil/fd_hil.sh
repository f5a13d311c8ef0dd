#!/usr/bin/env bash
# HIL (issue 15): the CAN FD bus layout over real SocketCAN (vcan0 with MTU 72, through
# run_in_vcan.sh) between two processes, with the SHIPPED configuration but for one key,
# can.bus_layout: fd (no widened deadline, 1 kHz):
#   `dualv sim --can vcan0`  four emulated CAN FD drives (the master maps them: one 16-byte FD
#                            RPDO on 200h with every controlword + torque, own slice +
#                            dummies; TPDO1 statusword + position as FD frames)
#   `dualv run --can vcan0`  the controller, the paper program (retimed variant)
# Checks:
#   1. an interface without CAN FD (vcan0 at its default MTU 16): `dualv run` and `dualv sim`
#      refuse to open it, naming it and the command that sets MTU 72
#   2. boot: the drives boot with the fd layout (the master's bus-load line names it)
#   3. wire (candump -l, check_fd_wire.py): only the fd layout's frames (FD with BRS for the
#      PDOs, classic SYNC), one 200h FD frame before every SYNC, no torque above the limit,
#      every drive's statusword seen (Operation enabled when the run completed)
#   4. refusal: `dualv sim --no-fd` (classic drives, PDOs end at 8 bytes): the master refuses
#      to boot, naming the drive and the FD mapping
#   5. the run: completes (exit 0); if the guest cannot keep the 1 kHz timing, the test asserts
#      what does not depend on it (1-4) and says so in a NOTE (as broadcast_hil.sh).
# Needs can-utils (candump) and root in the guest (ip link). Usage: fd_hil.sh DUALV_BINARY
# CONFIG_YAML [PROGRAM_YAML]. KEEP=1 keeps the work folder.
set -u
. "$(dirname "$0")/hil_lib.sh"
usage="usage: fd_hil.sh DUALV_BINARY CONFIG_YAML [PROGRAM_YAML]"
dualv=${1:?$usage}
config_in=${2:?$usage}
program=${3:-$(dirname "$config_in")/paper.yaml}
here=$(cd "$(dirname "$0")" && pwd)
py=/usr/bin/python3
[[ -x $py ]] || py=python3
command -v candump >/dev/null || { echo "FAIL: candump not found (install can-utils)"; exit 1; }
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dualv-fd-hil.XXXXXX") || exit 1

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

# The shipped configuration with the fd layout: one key changed, nothing else.
config=$tmp/dualv-fd.yaml
sed -e 's/^  bus_layout: per_drive /  bus_layout: fd /' "$config_in" >"$config"
grep -Eq '^  bus_layout: fd ' "$config" ||
  { echo "FAIL: could not set can.bus_layout: fd in $config_in (format changed?)"; exit 1; }

set_mtu() { ip link set vcan0 down && ip link set vcan0 mtu "$1" && ip link set vcan0 up; }

# --- 1: an interface without CAN FD is refused by name --------------------------------------
set_mtu 16 || fail "could not set vcan0 mtu 16"
"$dualv" run --can vcan0 --config "$config" -p "$program" --variant retimed --no-plots \
  -o "$tmp/nofdif" >"$tmp/nofdif.run.log" 2>&1
[[ $? -ne 0 ]] || fail "interface: dualv run opened vcan0 (MTU 16) for the fd layout"
grep -q "CAN interface 'vcan0' does not carry CAN FD frames (MTU 16" "$tmp/nofdif.run.log" ||
  fail "interface: dualv run's error does not name vcan0 and its MTU"
grep -q "ip link set vcan0 mtu 72" "$tmp/nofdif.run.log" ||
  fail "interface: dualv run's error does not say how to set MTU 72"
timeout 20 "$dualv" sim --can vcan0 --config "$config" --exit-after 5 --status-every 0 \
  >"$tmp/nofdif.sim.log" 2>&1
grep -q "does not carry CAN FD frames" "$tmp/nofdif.sim.log" ||
  fail "interface: dualv sim did not refuse vcan0 (MTU 16) for the fd layout"
set_mtu 72 || { echo "FAIL: could not set vcan0 mtu 72 (root in the guest?)"; exit 1; }
[[ $(diff "$config_in" "$config" | grep -c '^>') -eq 1 ]] ||
  { echo "FAIL: the overlay changed more than can.bus_layout"; exit 1; }

# --- 2, 3, 5: the paper program with the fd layout ---------------------------------
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

echo "=== fd layout: dualv run --can vcan0 exit $run_rc"
grep -E "CAN bus load|drives booted|^(loop:|bus:)|STOPPED|stop" "$tmp/run.log" | head -n 20

booted=1
grep -q "drives booted" "$tmp/run.log" || { booted=0; fail "boot: the drives did not boot"; }
grep -q "CAN bus load: 4 drives, fd layout" "$tmp/run.log" ||
  fail "boot: the bus-load line does not name the fd layout"

if [[ -z "$capture" || ! -s "$capture" ]]; then
  fail "wire: no candump log"
else
  expect=()
  [[ $run_rc -eq 0 ]] && expect=(--expect-enabled)
  "$py" "$here/check_fd_wire.py" --config "$config" "${expect[@]}" "$capture" ||
    fail "wire: not the fd layout (see above)"
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

# --- 4: classic drives (PDOs end at 8 bytes) -----------------------------------------------
"$dualv" sim --can vcan0 --config "$config" --no-fd --exit-after 600 --status-every 0 \
  >"$tmp/nofd.sim.log" 2>&1 &
sim_pid=$!
wait_for "$tmp/nofd.sim.log" "drives booted" 10 || fail "refusal: dualv sim did not start"
"$dualv" run --can vcan0 --config "$config" -p "$program" --variant retimed --no-plots \
  -o "$tmp/nofd" >"$tmp/nofd.run.log" 2>&1
nf_rc=$?
kill -TERM "$sim_pid" 2>/dev/null
wait "$sim_pid"
sim_pid=
echo "=== classic drives: dualv run --can vcan0 exit $nf_rc"
grep -E "CAN FD" "$tmp/nofd.run.log" | head -n 3
[[ $nf_rc -ne 0 ]] || fail "refusal: dualv run booted classic drives with the fd layout"
grep -q "node 1 (can.drives\[0\]) refuses the 16-byte CAN FD RPDO mapping" "$tmp/nofd.run.log" ||
  fail "refusal: the error does not name the drive and the FD mapping"
grep -q "06040042h" "$tmp/nofd.run.log" || fail "refusal: the error does not give the abort code"

if [[ $failed -ne 0 ]]; then
  show "$tmp/run.log" "$tmp/sim.log" "$tmp/nofd.run.log" "$tmp/nofdif.run.log"
  exit 1
fi
echo "CAN FD HIL: an interface without FD refused by name; boots with the fd layout, the wire is" \
  "that layout, torque within the limit, every drive's state seen; classic drives refused by" \
  "name (run exit $run_rc)"
exit 0
