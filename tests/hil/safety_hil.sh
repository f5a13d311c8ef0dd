#!/usr/bin/env bash
# HIL: the safety layer on real SocketCAN (vcan0, through run_in_vcan.sh). Two processes, as
# on a real machine: `dualv sim --can vcan0` (four CiA 402 drives + the mechanism, with an
# e-stop button and fault injection) and the controller `dualv selftest --can vcan0`
# (the control cycle with the safety filter). can_capture (tests/hil/can_capture.cpp: candump's
# log format, error frames included, at a fraction of candump's cost in the guest) captures the
# wire; every case is
# checked on the captured frames afterwards (check_wire.py), not on internal variables:
#   1. drive fault (EMCY 2310h from the emulator)  -> STO: torque 0 on the wire at once
#   2. hardwired e-stop button (60FDh)              -> STO
#   3. SIGINT to the controller (signal e-stop)     -> SS1, then torque off
#   4. the drives vanish (emulator SIGSTOPped)      -> STO (stale feedback / drive lost)
#   5. host-injected faults (encoder jump, 10x torque, NaN, deadline misses) and the limit
#      tests (torque rate, joint and plate velocity, workspace, singularity distance,
#      tracking error): the selftest table
# With --gateway (ctest hil_safety_frames, vcan0 + vcan1) the frame faults, through
# can_fault_gateway.cpp between the controller (vcan0) and the emulator (vcan1), which
# forwards every frame and breaks the frames of one COB-ID as told:
#   6. tpdo_lost:    drive 2's TPDO1 (182h) dropped for good    -> stale feedback -> STO
#   7. tpdo_glitch:  drive 2's TPDO1 dropped 3 times and drive 3's delayed 12 ms 25 times
#                    (below the stale-feedback watchdog)          -> NO stop, frames counted
#   8. rpdo_lost:    drive 2's RPDO1 (202h) dropped for good    -> the drive's RPDO watchdog
#                    -> EMCY 8250h -> drive fault -> STO
#   9. tpdo_bad_dlc: drive 3's TPDO1 (183h) with DLC 5 for good -> rejected and counted by
#                    the master (malformed) -> stale feedback -> STO
#  10. tpdo_xor:     one TPDO1 of drive 4 (184h) with every byte flipped -> STO within 2 cycles
#                    (encoder jump / drive fault: never used as a position)
#  11. bus_off:      a CAN_ERR_BUSOFF error frame on the controller's vcan0 (cansend)
#                    -> bus error -> STO; after it the master sends nothing at all, and the
#                    drives stop on their own (EMCY from each, on vcan1)
# and in every case no target torque above safety.torque.max in any captured RPDO.
# Timing in the UML guest is coarse: behaviour and ordering are asserted, never latency.
# Usage: safety_hil.sh DUALV_BINARY CONFIG_YAML --capture CAN_CAPTURE [--gateway CAN_FAULT_GATEWAY]
#        [CASE...]
# (default cases: 1-5; with --gateway: 6-11). KEEP=1 keeps the work folder.
set -u
. "$(dirname "$0")/hil_lib.sh"
usage="usage: safety_hil.sh DUALV_BINARY CONFIG_YAML --capture CAN_CAPTURE [--gateway CAN_FAULT_GATEWAY] [CASE...]"
dualv=${1:?$usage}
config_in=${2:?$usage}
[[ ${3:-} == --capture ]] || { echo "$usage"; exit 2; }
capture=${4:?$usage}
shift 4
gateway=
if [[ ${1:-} == --gateway ]]; then
  gateway=${2:?$usage}
  shift 2
fi
cases=("$@")
if [[ ${#cases[@]} -eq 0 ]]; then
  if [[ -n $gateway ]]; then
    cases=(tpdo_lost tpdo_glitch rpdo_lost tpdo_bad_dlc tpdo_xor bus_off)
  else
    cases=(drive_fault estop_button sigint drives_gone host_faults)
  fi
fi
here=$(cd "$(dirname "$0")" && pwd)
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dualv-safety-hil.XXXXXX") || exit 1
py=/usr/bin/python3
[[ -x $py ]] || py=python3
sim_pid= dump_pid= ctl_pid= gw_pid= dump1_pid=
cleanup() {
  for p in $sim_pid $dump_pid $ctl_pid $gw_pid $dump1_pid; do
    kill -CONT "$p" 2>/dev/null
    kill "$p" 2>/dev/null
  done
  if [[ -n "${KEEP:-}" ]]; then echo "kept $tmp"; else rm -rf "$tmp"; fi
}
trap cleanup EXIT
failed=0
fail() {  # the logs of the case running now (its name is in $tmp/current)
  echo "FAIL: $*"
  local name
  name=$(cat "$tmp/current" 2>/dev/null)
  for f in "$tmp/$name".*.log; do echo "--- $f (tail)"; tail -n 30 "$f"; done
  failed=1
}

# The guest's timing is coarse (ms-scale late wake-ups, bursts of late frames): widen the
# timing-related limits (deadline misses, stale cycles, torque rate, the drives' RPDO
# deadline and heartbeat timeouts) so the cases below test what they name, not the guest.
# The control rate (250 Hz: the guest's ms-scale jitter is then a fraction of a period) and
# the controller gains too: kp = 7000 is tuned at the edge of stability for exactly one
# cycle of delay; the guest's late frames add more, and the loop then oscillates until the
# safety layer stops it (torque limit, plate velocity), which is right but not these tests.
# The velocity filter's cutoff must stay below the 250 Hz loop's Nyquist rate (125 Hz).
config=$tmp/dualv.yaml
sed -e 's/max_consecutive_deadline_misses: [0-9]*/max_consecutive_deadline_misses: 200/' \
    -e 's/stale_feedback_cycles: [0-9]*/stale_feedback_cycles: 20/' \
    -e 's/max_rate: [0-9.]*/max_rate: 1000000.0/' \
    -e 's/rpdo_deadline: [0-9.]*/rpdo_deadline: 0.2/' \
    -e 's/drive_timeout: [0-9.]*/drive_timeout: 1.0/' \
    -e 's/master_timeout: [0-9.]*/master_timeout: 1.0/' \
    -e 's/^    sdo: [0-9.]*/    sdo: 1.0/' \
    -e 's/^  rate_hz: [0-9.]*/  rate_hz: 250.0/' -e 's/^    period: 0.001 /    period: 0.004 /' \
    -e 's/^  kp: [0-9.]*/  kp: 300.0/' -e 's/^  kd: [0-9.]*/  kd: 5.0/' \
    -e 's/^  velocity_cutoff_hz: [0-9.]*/  velocity_cutoff_hz: 100.0/' \
    -e 's/^  max_tracking_error: [0-9.]*/  max_tracking_error: 0.05/' \
    -e 's/^  max_tracking_error_angle: [0-9.]*/  max_tracking_error_angle: 0.5/' "$config_in" >"$config"
# The gateway cases run at SCHED_FIFO like paper_hil.sh, and take its wider limits for what
# a guest frozen by host load looks like (hundreds of late cycles in a row, RPDOs 0.2 s
# apart): the drive-side RPDO watchdog they test counts SYNCs, which a stall cannot trip.
if [[ -n $gateway ]]; then
  sed -i -e 's/max_consecutive_deadline_misses: [0-9]*/max_consecutive_deadline_misses: 1000/' \
    -e 's/rpdo_deadline: [0-9.]*/rpdo_deadline: 1.0/' "$config"
fi

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

# Gateway cases, as paper_hil.sh runs its processes: SCHED_FIFO where permitted (root in the
# guest): the gateway (90) forwards every frame it is not told to break at once, the
# emulator (85) answers each SYNC before the controller's (80) next cycle, as drive hardware
# does, and the capture (95, 8 MB buffer) loses nothing. bg_rt PRIO CMD... & (exec: $! is CMD).
fifo_ok=0
if [[ -n $gateway && $(id -u) -eq 0 ]] && command -v chrt >/dev/null && chrt -f 90 true 2>/dev/null; then
  fifo_ok=1
fi
bg_rt() {
  local prio=$1
  shift
  if [[ $fifo_ok -eq 1 ]]; then exec chrt -f "$prio" "$@"; else exec "$@"; fi
}

# Set by a case before run_case: the gateway's rules (gateway mode: the emulator on vcan1,
# the gateway between vcan1 and the controller's vcan0) and the emulator's RPDO watchdog.
gw_rules=()
sim_watchdog=0
# run_case NAME SIM_ARGS... -- SELFTEST_ARGS...
run_case() {
  local name=$1; shift
  local sim_args=(--plant-step-nominal) st_args=()  # the guest is frozen as a whole by host load: its clock jumps are not time the drives saw
  while [[ $# -gt 0 && $1 != -- ]]; do sim_args+=("$1"); shift; done
  shift
  st_args=("$@")
  local dump=$tmp/$name.dump.log simlog=$tmp/$name.sim.log ctl=$tmp/$name.ctl.log
  local sim_if=vcan0
  echo "$name" >"$tmp/current"
  # Every frame plus error frames (the bus-off case).
  bg_rt 95 "$capture" vcan0 "$dump" --errors 2>"$dump.err" &
  dump_pid=$!
  wait_for "$dump.err" "capturing" 5 || { fail "$name: can_capture did not start"; return; }
  if [[ -n $gateway ]]; then
    sim_if=vcan1
    # The emulator's free run off: a guest frozen as a whole by host load is no dead master.
    sim_args+=(--free-run-after 0)
    bg_rt 95 "$capture" vcan1 "$tmp/$name.drives.dump.log" 2>"$tmp/$name.drives.dump.err" &
    dump1_pid=$!
    wait_for "$tmp/$name.drives.dump.err" "capturing" 5 ||
      { fail "$name: can_capture (vcan1) did not start"; return; }
    local rule_args=()
    for r in "${gw_rules[@]}"; do rule_args+=(--rule "$r"); done
    bg_rt 90 "$gateway" vcan0 vcan1 "${rule_args[@]}" >"$tmp/$name.gw.log" 2>&1 &
    gw_pid=$!
    wait_for "$tmp/$name.gw.log" "ready" 5 || { fail "$name: can_fault_gateway did not start"; return; }
  fi
  sleep 0.3
  bg_rt 85 "$dualv" sim --can "$sim_if" --config "$config" --exit-after 60 --status-every 0 \
    --rpdo-watchdog "$sim_watchdog" "${sim_args[@]}" >"$simlog" 2>&1 &
  sim_pid=$!
  wait_for "$simlog" "drives booted" 10 || { fail "$name: dualv sim did not start"; return; }
  bg_rt 80 "$dualv" selftest --can vcan0 --i-understand-this-moves-hardware --config "$config" \
    --program "$program" --fault-log "$tmp/$name.faults.log" "${st_args[@]}" >"$ctl" 2>&1 &
  ctl_pid=$!
}
finish_case() {  # finish_case NAME EXPECTED_SELFTEST_EXIT [SECONDS_TO_LET_THE_DRIVES_RUN_ON]
  local name=$1 expect_rc=$2
  wait "$ctl_pid"
  local rc=$?
  ctl_pid=
  sleep "${3:-0}"
  kill -CONT "$sim_pid" 2>/dev/null
  kill -TERM "$sim_pid" 2>/dev/null
  wait "$sim_pid" 2>/dev/null
  sim_pid=
  if [[ -n $gw_pid ]]; then
    kill -TERM "$gw_pid" 2>/dev/null
    wait "$gw_pid" 2>/dev/null
    gw_pid=
  fi
  sleep 0.2
  for p in $dump_pid $dump1_pid; do
    kill "$p" 2>/dev/null
    wait "$p" 2>/dev/null
  done
  dump_pid= dump1_pid=
  for e in "$tmp/$name".dump.err "$tmp/$name".drives.dump.err; do
    [[ ! -f $e ]] || grep -q " 0 lost" "$e" || fail "$name: the capture lost frames: $(tail -n 1 "$e")"
  done
  echo "=== $name (selftest exit $rc)"
  cat "$tmp/$name.ctl.log"
  cat "$tmp/$name.faults.log" 2>/dev/null
  [[ -f "$tmp/$name.gw.log" ]] && grep -E "rule .*(acts|acted)|stopped" "$tmp/$name.gw.log"
  [[ $rc -eq $expect_rc ]] || fail "$name: selftest exited $rc, expected $expect_rc"
}
check_wire() {  # check_wire NAME MODE [CHECK_WIRE_ARGS...]
  local name=$1 mode=$2
  shift 2
  "$py" "$here/check_wire.py" --config "$config" --mode "$mode" "$@" "$tmp/$name.dump.log" ||
    fail "$name: wire check ($mode)"
}
in_log() {  # in_log NAME SUFFIX EXTENDED_REGEX: the case's log has a line matching
  grep -Eq -- "$3" "$tmp/$1.$2" 2>/dev/null
}
acted() {  # acted NAME N: the gateway's first rule acted on at least N frames
  local n
  n=$(sed -n "s/^can_fault_gateway: rule .* acted on \([0-9]*\) frames$/\1/p" "$tmp/$1.gw.log" | head -n 1)
  [[ -n $n && $n -ge $2 ]] || fail "$1: the gateway's rule acted on ${n:-no} frames, expected >= $2"
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
case_host_faults() {  # 5. Host-injected faults and limit tests, as commissioning runs them.
  run_case host_faults -- --only "encoder jump" "10x" "NaN" "deadline misses" "limit test" \
    --inject-at 3.0
  finish_case host_faults 0
  [[ $(grep -c "limit test: .* PASS" "$tmp/host_faults.ctl.log") -eq 6 ]] ||
    fail "host_faults: not every limit test ran and passed"
  check_wire host_faults limit-only
}


# --- frame faults, through can_fault_gateway (--gateway) -----------------------------------
# Rules act from 5.5 s after the master first enabled the drives (the gateway's time base):
# into the slow move, where the target torques are large enough to show on the wire (one
# per mille of the rated torque is 0.05 N m). Drive i (0-based in the fault log) is node i + 1.
case_tpdo_lost() {  # 6. Drive 2's position never arrives again: stale feedback, STO.
  gw_rules=("drop 0x182 from=5.5")
  run_case tpdo_lost -- --await-stop 13 --expect sto
  finish_case tpdo_lost 0
  acted tpdo_lost 1
  in_log tpdo_lost ctl.log "cause: stale feedback" || fail "tpdo_lost: not stopped by stale feedback"
  in_log tpdo_lost faults.log '"cause":"stale feedback","reaction":"STO","drive":1,' ||
    fail "tpdo_lost: no stale-feedback STO of drive 2 in the fault log"
  check_wire tpdo_lost torque-off-at-end
}
case_tpdo_glitch() {  # 7. Short losses and delays below the watchdog: the machine keeps going.
  gw_rules=("drop 0x182 from=5.5 count=3" "delay 0x183 ms=12 from=6.5 count=25")
  run_case tpdo_glitch -- --await-stop 9 --expect sto
  finish_case tpdo_glitch 1
  in_log tpdo_glitch gw.log "rule 'drop 0x182 from=5.5 count=3' acted on 3 frames" ||
    fail "tpdo_glitch: the gateway did not drop 3 TPDOs"
  in_log tpdo_glitch gw.log "rule 'delay 0x183 ms=12 from=6.5 count=25' acted on 25 frames" ||
    fail "tpdo_glitch: the gateway did not delay 25 TPDOs"
  in_log tpdo_glitch ctl.log "no stop within" || fail "tpdo_glitch: stopped by a tolerated glitch"
  # The only stop is the host's own at the end (a stop request, SS1): no stop from a monitor.
  if grep '"event":"fault"' "$tmp/tpdo_glitch.faults.log" | grep -E '"reaction":"(SS1|STO)"' |
    grep -v '"cause":"e-stop (CLI)"' | grep -q .; then
    fail "tpdo_glitch: a monitor stopped the machine: $(grep -E '"reaction":"(SS1|STO)"' "$tmp/tpdo_glitch.faults.log" | head -n 1)"
  fi
  in_log tpdo_glitch ctl.log "node 2: .*missed [1-9]" || fail "tpdo_glitch: drive 2's losses not counted"
  check_wire tpdo_glitch no-stop
}
case_rpdo_lost() {  # 8. Drive 2 gets no target torque: its RPDO watchdog faults it, STO.
  gw_rules=("drop 0x202 from=5.5")
  sim_watchdog=5
  run_case rpdo_lost -- --await-stop 13 --expect sto
  sim_watchdog=0
  finish_case rpdo_lost 0
  acted rpdo_lost 5
  in_log rpdo_lost sim.log "node 2: .*RPDO watchdog trips [1-9]" ||
    fail "rpdo_lost: drive 2's RPDO watchdog did not trip"
  in_log rpdo_lost ctl.log "cause: drive fault" || fail "rpdo_lost: not stopped by the drive fault"
  in_log rpdo_lost faults.log '"cause":"drive fault","reaction":"STO","drive":1,' ||
    fail "rpdo_lost: no drive-fault STO of drive 2 in the fault log"
  check_wire rpdo_lost after-emcy
}
case_tpdo_bad_dlc() {  # 9. Drive 3's TPDOs one byte short: rejected, counted, then stale: STO.
  gw_rules=("dlc 0x183 dlc=5 from=5.5")
  run_case tpdo_bad_dlc -- --await-stop 13 --expect sto
  finish_case tpdo_bad_dlc 0
  acted tpdo_bad_dlc 1
  in_log tpdo_bad_dlc ctl.log "node 3: .*malformed [1-9]" ||
    fail "tpdo_bad_dlc: the master did not count the malformed TPDOs"
  in_log tpdo_bad_dlc ctl.log "cause: stale feedback" ||
    fail "tpdo_bad_dlc: not stopped by stale feedback"
  in_log tpdo_bad_dlc faults.log '"cause":"stale feedback","reaction":"STO","drive":2,' ||
    fail "tpdo_bad_dlc: no stale-feedback STO of drive 3 in the fault log"
  # Detected at the stale-feedback watchdog (20 cycles in this overlay), torque off with it.
  check_wire tpdo_bad_dlc after-bad-tpdo --within 25
}
case_tpdo_xor() {  # 10. One TPDO of drive 4 with every byte flipped: STO within 2 cycles.
  gw_rules=("xor 0x184 mask=0xFF from=5.5 count=1")
  run_case tpdo_xor -- --await-stop 13 --expect sto
  finish_case tpdo_xor 0
  acted tpdo_xor 1
  # The flipped statusword reads as Fault and the position as a jump: either is the cause,
  # never the missing feedback.
  in_log tpdo_xor ctl.log "cause: (encoder jump|drive fault|invalid state)" ||
    fail "tpdo_xor: not stopped by the corrupted feedback"
  in_log tpdo_xor faults.log '"reaction":"STO","drive":3,' ||
    fail "tpdo_xor: no STO event for drive 4 in the fault log"
  check_wire tpdo_xor after-bad-tpdo
}
case_bus_off() {  # 11. The controller's CAN goes bus-off: STO, silence, the drives stop alone.
  gw_rules=()
  run_case bus_off -- --await-stop 13 --expect sto
  wait_for "$tmp/bus_off.gw.log" "first enable operation" 15 || fail "bus_off: never enabled"
  sleep 5.5
  # An error frame as a controller driver reports bus-off (linux/can/error.h).
  cansend vcan0 20000040#0000000000000000 || fail "bus_off: cansend could not send the error frame"
  # The drives' own stop (RPDO deadline, master heartbeat consumer) comes within 1 s.
  finish_case bus_off 0 2
  in_log bus_off ctl.log "cause: (bus error|drive lost)" || fail "bus_off: not stopped by the bus-off"
  in_log bus_off faults.log '"cause":"bus error","reaction":"STO"' || fail "bus_off: no bus error in the fault log"
  in_log bus_off ctl.log "bus: .*bus-off 1;" || fail "bus_off: the master did not report the bus-off"
  check_wire bus_off after-busoff --drives-capture "$tmp/bus_off.drives.dump.log"
}

# Each case gets a second attempt: the guest sometimes stalls a process for a second or more
# (both sides then lose each other's heartbeat), which no setting here can absorb. A case
# fails the test only when both attempts fail; the first attempt's output stays above.
any_failed=0
for c in "${cases[@]}"; do
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
echo "safety HIL: ${cases[*]}: ok"
exit 0
