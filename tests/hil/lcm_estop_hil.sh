#!/usr/bin/env bash
# HIL (inside the user-mode-linux guest, where LCM multicast stays on the guest's loopback):
# `dualv estop` from another process stops `dualv run` over LCM, with the shipped
# configuration unchanged (1 kHz, 3 consecutive deadline misses -> STO).
#   1. E-stop while the program is prepared (issue 12: latched in every phase): e-stops are
#      sent from before the run starts until it ends. The run must refuse to start the
#      program (no motion: no sample in its CSV), and its fault log must show the LCM e-stop
#      (SS1). If one e-stop lands after the first cycle instead, the run must end in a safety
#      stop caused by it (SS1 -> STO), which is case 2's check.
#   2. E-stop while the program runs: sent as soon as the run reports its first cycle; the
#      run must end in a safety stop caused by it, SS1 then STO in the fault log.
# The guest's timing is coarse (every syscall is ~0.1 ms of host time, ms-scale stalls on a
# loaded host): a run at 1 kHz may end on its own timing watchdog (consecutive deadline
# misses, stale feedback) a few cycles after its start, before an e-stop sent then can
# arrive. Case 1 does not depend on that timing and always gates (up to five attempts, as its
# first e-stop may come after a run's first cycles). Case 2 is tried up to five times; if
# every attempt ends on guest timing first, the test says so in a NOTE (the property was not
# shown here) and is skipped (exit 77); any other outcome fails.
# Each case is its own ctest: hil_lcm_estop (case 1) and hil_lcm_estop_running (case 2).
# Usage: lcm_estop_hil.sh DUALV_BINARY CONFIG_YAML prepared|running
set -u
. "$(dirname "$0")/hil_lib.sh"
dualv=${1:?usage: lcm_estop_hil.sh DUALV_BINARY CONFIG_YAML}
config=${2:?usage: lcm_estop_hil.sh DUALV_BINARY CONFIG_YAML prepared|running}
case_name=${3:?usage: lcm_estop_hil.sh DUALV_BINARY CONFIG_YAML prepared|running}
[[ $case_name == prepared || $case_name == running ]] || { echo "unknown case $case_name"; exit 2; }
skip_outside_lcm_guest
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dualv-estop-hil.XXXXXX") || exit 1
spammer=""
trap 'touch "$tmp/run.ended"; [[ -n $spammer ]] && wait "$spammer"; rm -rf "$tmp"' EXIT
url='udpm://239.255.76.67:7667?ttl=0'
fail() {
  echo "FAIL: $*"
  cat "$tmp/run.log"
  exit 1
}
# The stops of the run's own timing watchdogs (safety/fault.hpp causes), not of the e-stop.
timing_stop='safety stop (.*\(consecutive deadline misses\|stale feedback\)'
start_run() {
  # The last attempt's log goes first: else a wait for a line of this run could find it in
  # that log before this run's redirection has emptied the file (and e-stop a run not started).
  rm -rf "$tmp/out" "$tmp/run.log"
  "$dualv" run -c "$config" -p "$(dirname "$config")/paper.yaml" --realtime --variant retimed \
    --no-plots --out "$tmp/out" --lcm "$url" --replay-state "$tmp/state/replay.state" >"$tmp/run.log" 2>&1 &
  run_pid=$!
}
# A run stopped by the LCM e-stop while it ran: SS1, then STO, in its fault log.
check_stopped_by_estop() {
  [[ $1 -eq 1 ]] || fail "dualv run exited $1, expected 1 (stopped)"
  grep -q '"cause":"e-stop (LCM)","reaction":"SS1"' "$tmp/out/faults.jsonl" || fail "no SS1 event"
  grep -q '"event":"stop reached","cause":"","reaction":"STO"' "$tmp/out/faults.jsonl" ||
    fail "SS1 did not end in STO"
}

# --- 1. e-stop while the program is prepared ------------------------------------------------
if [[ $case_name == prepared ]]; then
prepared_ok=0
for ((attempt = 1; attempt <= 5; ++attempt)); do
  # E-stops every 10 ms (1 s per `dualv estop`) until the run has ended; the last one is
  # waited for, so none is left to reach the next run.
  rm -f "$tmp/run.ended"
  (while [[ ! -e $tmp/run.ended ]]; do "$dualv" estop --lcm "$url" --repeat 100 >/dev/null 2>&1; done) &
  spammer=$!
  start_run
  wait "$run_pid"
  rc=$?
  touch "$tmp/run.ended"
  wait "$spammer" 2>/dev/null
  spammer=""
  if grep -q "refused the start: a stop is latched" "$tmp/run.log"; then
    [[ $rc -eq 1 ]] || fail "dualv run exited $rc after refusing the start, expected 1"
    grep -q '"cause":"e-stop (LCM)","reaction":"SS1"' "$tmp/out/faults.jsonl" ||
      fail "the e-stop that refused the start is not in the fault log"
    samples=$(($(wc -l <"$tmp/out/retimed.csv") - 1))
    [[ $samples -eq 0 ]] || fail "the refused program ran $samples cycles"
    echo "PASS: e-stop while the program is prepared: the program never started (attempt $attempt)"
    prepared_ok=1
    break
  elif grep -q "safety stop (e-stop (LCM))" "$tmp/run.log"; then
    check_stopped_by_estop "$rc"
    echo "PASS: the e-stop landed after the first cycle: SS1 -> STO (attempt $attempt)"
    prepared_ok=1
    break
  elif grep -q "$timing_stop" "$tmp/run.log"; then
    guest_timing "attempt $attempt: the run stopped on guest timing before an e-stop arrived: $(grep "safety stop" "$tmp/run.log" | head -1)"
    echo "NOTE: attempt $attempt: the run stopped on guest timing before an e-stop arrived:"
    grep "safety stop" "$tmp/run.log" | head -1
  else
    fail "the run was neither refused nor stopped by the e-stop"
  fi
done
[[ $prepared_ok -eq 1 ]] || fail "no e-stop reached the run in 5 attempts (each stopped on timing)"
exit 0
fi

# --- 2. e-stop while the program runs -------------------------------------------------------
for ((attempt = 1; attempt <= 5; ++attempt)); do
  start_run
  wait_for "$tmp/run.log" 't = *0\.00 /' 60 || { kill "$run_pid"; fail "the run did not start"; }
  "$dualv" estop --lcm "$url" >"$tmp/estop.log" 2>&1 || { cat "$tmp/estop.log"; exit 1; }
  wait "$run_pid"
  rc=$?
  if grep -q "safety stop (e-stop (LCM))" "$tmp/run.log"; then
    check_stopped_by_estop "$rc"
    echo "PASS: LCM e-stop while running -> SS1 -> STO (attempt $attempt)"
    exit 0
  fi
  grep -q "command accepted: e-stop" "$tmp/run.log" ||
    grep -q "$timing_stop" "$tmp/run.log" || fail "the e-stop sent while the run ran was never received"
  grep -q "$timing_stop" "$tmp/run.log" || fail "the run was not stopped by the e-stop"
  guest_timing "attempt $attempt: the run stopped on guest timing before the e-stop arrived: $(grep "safety stop" "$tmp/run.log" | head -1)"
  echo "NOTE: attempt $attempt: the run stopped on guest timing before the e-stop arrived:"
  grep "safety stop" "$tmp/run.log" | head -1
done
guest_timing "e-stop while running not shown in this guest: every attempt stopped on its own timing"
echo "NOTE: e-stop while running not shown in this guest: every attempt stopped on its own timing"
echo "      watchdog first (the guest cannot hold 1 kHz here)"
exit 77
