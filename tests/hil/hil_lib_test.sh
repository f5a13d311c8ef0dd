#!/usr/bin/env bash
# hil_lib.sh's judgement of a stop (first_stop_causes, timing_stops_only) on hand-made
# faults.jsonl lines, on the host: what every HIL script's retry-or-fail decision builds on;
# guest_timing (no excuse on the virtual clock) and run_in_vcan.sh's clock options.
# Each verdict must be able to come out both ways.
set -uo pipefail
. "$(dirname "$0")/hil_lib.sh"
failures=0
fault() {  # fault CYCLE REACTION TEXT: one faults.jsonl line (safety/fault_log.cpp's fields)
  printf '{"cycle":%d,"time_ns":%d000000,"event":"fault","cause":"x","reaction":"%s","drive":0,"text":"%s -> %s"}\n' \
    "$1" "$1" "$2" "$3" "$2"
}
expect_causes() {  # expect_causes NAME EXPECTED (newline separated) < faults
  local got
  got=$(first_stop_causes)
  [[ $got == "$2" ]] || { echo "FAIL $1: causes [$got], expected [$2]"; failures=$((failures + 1)); }
}
expect_timing() {  # expect_timing NAME 0|1 < faults: timing_stops_only's verdict on the first stop
  local rc=0
  first_stop_causes | timing_stops_only || rc=1
  [[ $rc == "$2" ]] || { echo "FAIL $1: timing_stops_only $rc, expected $2"; failures=$((failures + 1)); }
}
quick=$(fault 190 STO "drive fault drive 1: left Operation enabled (quick stop)")
emcy1=$(fault 192 STO "drive fault drive 1: EMCY 8250h")
hb1=$(fault 195 STO "drive fault drive 1: EMCY 8130h")
emcy2=$(fault 192 STO "drive fault drive 2: EMCY 8250h")
late1=$(fault 250 STO "drive fault drive 1: EMCY 8250h")
stale=$(fault 5 STO "stale feedback drive 1: 3 (limit 3)")
lost=$(fault 5 STO "drive lost drive 2")
warn=$(fault 4 warning "deadline miss")
ss1=$(fault 6 SS1 "plate velocity 3.1 m/s (limit 1)")
limit=$(fault 5 STO "torque limit drive 3: 70 (limit 60)")

# The first stop is every stopping fault of its cycle; warnings and later stops are not in it.
expect_causes "first cycle only" $'stale feedback drive 1: 3 (limit 3)\ndrive lost drive 2' \
  < <(printf '%s\n' "$warn" "$stale" "$lost" "$ss1")
expect_timing "stale feedback and drive lost" 0 < <(printf '%s\n' "$warn" "$stale" "$lost" "$ss1")
expect_timing "a torque limit beside a timing stop" 1 < <(printf '%s\n' "$stale" "$limit")
expect_timing "a later SS1 does not count" 0 < <(printf '%s\n' "$stale" "$ss1")
expect_timing "no stop at all" 1 < <(printf '%s\n' "$warn")
# A drive leaving Operation enabled is its reaction to its own EMCY 8250h / 8130h nearby.
expect_causes "quick stop tied to its EMCY after it" "drive fault drive 1: EMCY 8250h" \
  < <(printf '%s\n' "$quick" "$emcy1")
expect_timing "quick stop tied to its EMCY after it" 0 < <(printf '%s\n' "$quick" "$emcy1")
expect_timing "quick stop tied to its heartbeat EMCY" 0 < <(printf '%s\n' "$quick" "$hb1")
expect_timing "another drive's EMCY" 1 < <(printf '%s\n' "$quick" "$emcy2")
expect_timing "its EMCY 60 cycles later" 1 < <(printf '%s\n' "$quick" "$late1")
expect_timing "no EMCY" 1 < <(printf '%s\n' "$quick")
expect_causes "EMCY in the same cycle: once" "drive fault drive 1: EMCY 8250h" \
  < <(printf '%s\n' "$emcy1" "${quick/190/192}")

# guest_timing: excuses on the real clock (returns 0, prints nothing), fails on the virtual one.
expect_guest_timing() {  # expect_guest_timing NAME CLOCK RC
  local rc out
  out=$(DUALV_HIL_CLOCK=$2 bash -c '. "$1"; guest_timing "a stop"; echo excused' _ "$(dirname "$0")/hil_lib.sh")
  rc=$?
  [[ $rc == "$3" ]] || { echo "FAIL $1: guest_timing exited $rc, expected $3 ($out)"; failures=$((failures + 1)); }
  if [[ $3 == 0 ]]; then
    [[ $out == excused ]] || { echo "FAIL $1: [$out]"; failures=$((failures + 1)); }
  else
    [[ $out == "FAIL (virtual clock"*"a stop" ]] || { echo "FAIL $1: [$out]"; failures=$((failures + 1)); }
  fi
}
expect_guest_timing "real clock: excused" real 0
expect_guest_timing "no clock named: the real one" "" 0
expect_guest_timing "virtual clock: a failure" virtual 1

# run_in_vcan.sh's clock options, before any guest boots.
expect_wrapper() {  # expect_wrapper NAME RC ARGS...
  local rc
  DUALV_HIL_REQUIRE_VIRTUAL=${require:-0} "$(dirname "$0")/run_in_vcan.sh" "${@:3}" true >/dev/null 2>&1
  rc=$?
  [[ $rc == "$2" ]] || { echo "FAIL $1: run_in_vcan.sh exited $rc, expected $2"; failures=$((failures + 1)); }
}
expect_wrapper "an unknown clock" 2 --clock sundial
expect_wrapper "no time-travel kernel: skipped" 77 --clock virtual --kernel /nonexistent/linux
require=1 expect_wrapper "no time-travel kernel where required: an error" 125 --clock virtual --kernel /nonexistent/linux

[[ $failures -eq 0 ]] && echo "hil_lib_test: PASS" || { echo "hil_lib_test: $failures failed"; exit 1; }
