#!/usr/bin/env bash
# HIL: the safety layer on real SocketCAN (vcan0, through run_in_vcan.sh). Two processes, as
# on a real machine: `dualv sim --can vcan0` (four CiA 402 drives + the mechanism, with an
# e-stop button and fault injection) and the controller `dualv selftest --can vcan0`
# (the control cycle with the safety filter). `candump -L` captures the wire; every case is
# checked on the captured frames afterwards (check_wire.py), not on internal variables:
#   1. drive fault (EMCY 2310h from the emulator)  -> STO: torque 0 on the wire at once
#   2. hardwired e-stop button (60FDh)              -> STO
#   3. SIGINT to the controller (signal e-stop)     -> SS1, then torque off
#   4. the drives vanish (emulator SIGSTOPped)      -> STO (stale feedback / drive lost)
#   5. host-injected faults (encoder jump, 10x torque, NaN): the selftest table
# and in every case no target torque above safety.torque.max in any captured RPDO.
# Timing in the UML guest is coarse: behaviour and ordering are asserted, never latency.
# Usage: safety_hil.sh DUALV_BINARY CONFIG_YAML
set -u
dualv=${1:?usage: safety_hil.sh DUALV_BINARY CONFIG_YAML}
config_in=${2:?usage: safety_hil.sh DUALV_BINARY CONFIG_YAML}
here=$(cd "$(dirname "$0")" && pwd)
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dualv-safety-hil.XXXXXX") || exit 1
py=/usr/bin/python3
[[ -x $py ]] || py=python3
sim_pid= dump_pid= ctl_pid=
cleanup() {
  for p in $sim_pid $dump_pid $ctl_pid; do kill -CONT "$p" 2>/dev/null; kill "$p" 2>/dev/null; done
  [[ -n "${KEEP:-}" ]] || rm -rf "$tmp"
}
trap cleanup EXIT
failed=0
fail() {
  echo "FAIL: $*"
  for f in "$tmp"/*.log; do echo "--- $f (tail)"; tail -n 30 "$f"; done
  failed=1
}
wait_for() {  # wait_for FILE PATTERN SECONDS
  local n=$(( $3 * 20 ))
  for ((i = 0; i < n; ++i)); do
    grep -q -- "$2" "$1" 2>/dev/null && return 0
    sleep 0.05
  done
  return 1
}

# The guest's timing is coarse (ms-scale late wake-ups, bursts of late frames): widen the
# timing-related limits (deadline misses, stale cycles, torque rate, the drives' RPDO
# deadline and heartbeat timeouts) so the cases below test what they name, not the guest.
# The control rate (250 Hz: the guest's ms-scale jitter is then a fraction of a period) and
# the controller gains too: kp = 7000 is tuned at the edge of stability for exactly one
# cycle of delay; the guest's late frames add more, and the loop then oscillates until the
# safety layer stops it (torque limit, plate velocity), which is right but not these tests.
config=$tmp/dualv.yaml
sed -e 's/max_consecutive_deadline_misses: [0-9]*/max_consecutive_deadline_misses: 200/' \
    -e 's/stale_feedback_cycles: [0-9]*/stale_feedback_cycles: 20/' \
    -e 's/max_rate: [0-9.]*/max_rate: 1000000.0/' \
    -e 's/rpdo_deadline: [0-9.]*/rpdo_deadline: 0.2/' \
    -e 's/drive_timeout: [0-9.]*/drive_timeout: 1.0/' \
    -e 's/master_timeout: [0-9.]*/master_timeout: 1.0/' \
    -e 's/^  rate_hz: [0-9.]*/  rate_hz: 250.0/' -e 's/^    period: 0.001 /    period: 0.004 /' \
    -e 's/^  kp: [0-9.]*/  kp: 300.0/' -e 's/^  kd: [0-9.]*/  kd: 5.0/' \
    -e 's/^  max_tracking_error: [0-9.]*/  max_tracking_error: 0.05/' \
    -e 's/^  max_tracking_error_angle: [0-9.]*/  max_tracking_error_angle: 0.5/' "$config_in" >"$config"

# A slow program (1 mm/s at most): in the guest, late TPDOs and scheduling stalls of tens of
# ms make the paper program's fast shapes trip the safety layer for real (inconsistent
# encoders, jumps after the emulator's free run): right, but not what these cases test.
program=$tmp/slow.yaml
cat >"$program" <<'YAML'
program:
  segments:
    - dwell: {duration: 1.0}
    - ptp: {to: [0.01, 0.25, 0.0], duration: 10.0}
    - dwell: {duration: 30.0}
YAML

# run_case NAME SIM_ARGS... -- SELFTEST_ARGS...
run_case() {
  local name=$1; shift
  local sim_args=() st_args=()
  while [[ $# -gt 0 && $1 != -- ]]; do sim_args+=("$1"); shift; done
  shift
  st_args=("$@")
  local dump=$tmp/$name.dump.log simlog=$tmp/$name.sim.log ctl=$tmp/$name.ctl.log
  candump -L vcan0 >"$dump" 2>&1 &
  dump_pid=$!
  sleep 0.3
  "$dualv" sim --can vcan0 --config "$config" --exit-after 60 --status-every 0 \
    --rpdo-watchdog 0 "${sim_args[@]}" >"$simlog" 2>&1 &
  sim_pid=$!
  wait_for "$simlog" "drives booted" 10 || { fail "$name: dualv sim did not start"; return; }
  "$dualv" selftest --can vcan0 --i-understand-this-moves-hardware --config "$config" \
    --program "$program" --fault-log "$tmp/$name.faults.log" "${st_args[@]}" >"$ctl" 2>&1 &
  ctl_pid=$!
  echo "$name" >"$tmp/current"
}
finish_case() {
  local name=$1 expect_rc=$2
  wait "$ctl_pid"
  local rc=$?
  ctl_pid=
  kill -CONT "$sim_pid" 2>/dev/null
  kill -TERM "$sim_pid" 2>/dev/null
  wait "$sim_pid" 2>/dev/null
  sim_pid=
  sleep 0.2
  kill "$dump_pid" 2>/dev/null
  wait "$dump_pid" 2>/dev/null
  dump_pid=
  echo "=== $name (selftest exit $rc)"
  cat "$tmp/$name.ctl.log"
  cat "$tmp/$name.faults.log" 2>/dev/null
  [[ $rc -eq $expect_rc ]] || fail "$name: selftest exited $rc, expected $expect_rc"
}
check_wire() {  # check_wire NAME MODE
  "$py" "$here/check_wire.py" --config "$config" --mode "$2" "$tmp/$1.dump.log" ||
    fail "$1: wire check ($2)"
}

case_drive_fault() {  # 1. Drive fault from the emulator: EMCY, then STO.
  run_case drive_fault --fault-after 6 --fault-drive 2 --fault-code 0x2310 -- --await-stop 25 --expect sto
  finish_case drive_fault 0
  grep -q "cause: drive fault" "$tmp/drive_fault.ctl.log" || fail "drive_fault: not stopped by the drive fault"
  check_wire drive_fault after-emcy
}
case_estop_button() {  # 2. The e-stop button (hardwired circuit, 60FDh).
  run_case estop_button --estop-after 6 -- --await-stop 25 --expect sto
  finish_case estop_button 0
  grep -Eq "cause: (e-stop circuit|drive fault)" "$tmp/estop_button.ctl.log" ||
    fail "estop_button: not stopped by the circuit"
  check_wire estop_button torque-off-at-end
}
case_sigint() {  # 3. SIGINT to the controller: a signal e-stop request, SS1 then torque off.
  run_case sigint -- --await-stop 25 --expect ss1
  sleep 7
  kill -INT "$ctl_pid"
  finish_case sigint 0
  grep -q "cause: e-stop (signal)" "$tmp/sigint.ctl.log" || fail "sigint: not stopped by the signal"
  check_wire sigint torque-off-at-end
}
case_drives_gone() {  # 4. The drives vanish (the emulator process stops answering): STO.
  run_case drives_gone -- --await-stop 25 --expect sto
  sleep 7
  kill -STOP "$sim_pid"
  finish_case drives_gone 0
  grep -Eq "cause: (stale feedback|drive lost)" "$tmp/drives_gone.ctl.log" || fail "drives_gone: wrong cause"
  check_wire drives_gone torque-off-at-end
}
case_host_faults() {  # 5. Host-injected faults, as the commissioning test runs them on a bus.
  run_case host_faults -- --only "encoder jump" "10x" "NaN" --inject-at 3.0
  finish_case host_faults 0
  check_wire host_faults limit-only
}

# Each case gets a second attempt: the guest sometimes stalls a process for a second or more
# (both sides then lose each other's heartbeat), which no setting here can absorb. A case
# fails the test only when both attempts fail; the first attempt's output stays above.
any_failed=0
for c in drive_fault estop_button sigint drives_gone host_faults; do
  failed=0
  "case_$c"
  if [[ $failed -ne 0 ]]; then
    echo "--- $c: second attempt"
    failed=0
    "case_$c"
    [[ $failed -ne 0 ]] && any_failed=1
  fi
done
failed=$any_failed

if [[ $failed -ne 0 ]]; then
  exit 1
fi
echo "safety HIL: drive fault, e-stop button, signal, drives gone, host faults: ok"
exit 0
