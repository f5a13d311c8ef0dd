#!/usr/bin/env bash
# HIL (issue 12, "How it is shown"): the service mode over real SocketCAN, with the SHIPPED
# configuration unchanged (no widened deadline, no changed rate). Inside the user-mode-linux
# guest (run_in_vcan.sh; LCM multicast stays on the guest's loopback): `dualv sim --can vcan0`
# (the four emulated drives) + `dualv run --serve --can vcan0 --lcm URL`, can_capture (candump -l
# format, tests/hil/can_capture.cpp) capturing vcan0 the whole time. In order:
#   1. idle 5 s ("serving: waiting"): `dualv status` finds a robot state while idle
#   2. a signed `dualv start paper`: "starting ...paper.yaml", then "paper.yaml done"
#   3. idle ~1 s; `dualv stream --circle 0.01 --duration 2` (its signed start, the setpoints,
#      its signed stop at the end): "stream done"
#   4. a signed start of paper and, while `dualv start` still runs, `dualv estop`: the program
#      never starts ("refused" for that start, no "done"/"STOPPED" for it, no enable on the
#      wire); then a signed reset
#   5. a signed start of paper, ~1.5 s into it `dualv estop`: "paper.yaml STOPPED", and in
#      faults.jsonl the e-stop with reaction SS1 and then "stop reached" STO
#   6. a signed reset, a signed start of paper: it completes ("done" count 2)
#   7. SIGINT: the service ends, exit 0
# Then on the capture (check_serve_wire.py), from the service's first SYNC to its last: no SYNC
# gap and no gap between one drive's RPDOs longer than can.rpdo_deadline, every drive's RPDO in
# every cycle, no target torque above safety.torque.max, exactly 4 enable episodes (paper,
# stream, the e-stopped paper, paper: none for the start of step 4).
#
# Timing in the guest: it is one slow virtual CPU that the host freezes as a whole under load
# (tests/hil/README.md), so it cannot keep a 1 kHz loop's timing everywhere. What this test
# does instead of widening the configuration:
#   - a stall probe (SCHED_FIFO 99, above every process of the test) records the intervals in
#     which not even it ran (the guest "frozen"); a wire gap above the deadline is excused only
#     when it is within the deadline without those intervals (check_serve_wire.py --stalls).
#     When the loop ran below 95 % of its rate over the service's life, the machine did not
#     carry the rate and the gaps are a NOTE with that rate (--min-rate; the guest runs it at
#     152-930 SYNC/s: tests/hil/README.md "What a cycle costs in the guest"); on a machine that
#     carries the rate every gap is checked. What does not depend on timing is asserted as it
#     is: every drive's RPDO in every cycle (but frames the master counted as refused by the
#     kernel, ENOBUFS, in its bus report: --run-log), the torque limit, the enable episodes,
#     the log and fault log of each step
#   - a program stopped by a timing watchdog alone (deadline misses, stale feedback, drive lost,
#     or a drive's RPDO deadline or heartbeat EMCY 8250h / 8130h: what a guest
#     freeze causes) is not a failure of
#     what this test checks: the step is retried after a signed reset, at most twice, and the
#     retries are reported. NOTE (guest timing): when all three attempts of a step are stopped
#     so, the step is reported as not shown in this guest and the test goes on after a signed
#     reset (which must be accepted, and the next steps must still run): that such a stop was
#     a correct stop is checked on the wire for every stop (check_serve_wire.py: no torque
#     without "enable operation", every drive reports leaving "operation enabled" after each
#     enable episode) and in faults.jsonl (STO reached, timing_only)
#   - a signed command the service refused as stale (it reached the service more than the
#     verifier's 2 s after signing: the guest's command tools wait behind its real-time tasks)
#     is signed and sent again, and counted; the freshness window stays as shipped
#   - the emulator's free run (its plant advancing without SYNC after 50 ms: a dead master) is
#     off (`--free-run-after 0`, an emulator option, not the configuration): a guest frozen as
#     a whole is not a dead master (as paper_hil.sh)
#   - the emulator runs SCHED_FIFO 70 below the control loop (80): it answers a cycle's SYNC
#     while the loop sleeps, and reads the cycle's frames in one wake-up (the master sends them
#     in one sendmmsg); the capture (SCHED_FIFO 95) wakes every 20 ms, not per frame, and fails
#     the test if its 8 MB receive buffer ever overflowed. This is what lets the one virtual
#     CPU carry the loop at all (tests/hil/README.md "Timing in the guest")
# On the virtual clock (run_in_vcan.sh --clock virtual, DUALV_HIL_CLOCK=virtual: the guest's
# time stands still while it computes, so it keeps every deadline of the shipped configuration
# whatever the host does) none of the above is excused: a retry, a resend, a NOTE (guest
# timing) or a skip fails the test, and every gap on the wire is checked (no --stalls, no
# --min-rate). That run shows every step over real SocketCAN (ctest hil_serve_can_virtual_clock).
# Usage: serve_can_hil.sh DUALV_BINARY CONFIG_YAML PROGRAM_YAML CAN_CAPTURE_BINARY
# KEEP=1 keeps the work folder (logs, capture) and prints its path.
set -u
. "$(dirname "$0")/hil_lib.sh"
usage="usage: serve_can_hil.sh DUALV_BINARY CONFIG_YAML PROGRAM_YAML CAN_CAPTURE"
dualv=${1:?$usage}
config=${2:?$usage}
program=${3:?$usage}
can_capture=${4:?$usage}
here=$(cd "$(dirname "$0")" && pwd)
skip_outside_lcm_guest
strict=0  # the virtual clock: nothing excused as guest timing (above)
on_virtual_clock && strict=1  # hil_lib.sh
py=/usr/bin/python3
[[ -x $py ]] || py=python3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dualv-serve-can-hil.XXXXXX") || exit 1
url='udpm://239.255.76.67:7667?ttl=0'
key=$tmp/keys/lab1.key
mkdir -p "$tmp/keys" "$tmp/dump"
head -c 32 /dev/urandom >"$key"
chmod 600 "$key"
pname=$(basename "$program")

run_pid='' sim_pid='' dump_pid='' probe_pid=''
# shellcheck disable=SC2317  # invoked by the EXIT trap
cleanup() {
  for p in $run_pid $sim_pid $probe_pid $dump_pid; do kill "$p" 2>/dev/null; done
  if [[ -n "${KEEP:-}" ]]; then echo "kept $tmp"; else rm -rf "$tmp"; fi
}
trap cleanup EXIT
fail() {
  echo "FAIL: $*"
  for f in run.log sim.log status.log stream.log out/faults.jsonl; do
    echo "--- $f"
    tail -n 60 "$tmp/$f" 2>/dev/null
  done
  exit 1
}
# count PATTERN: lines of the service's log matching PATTERN (grep -E)
count() { grep -cE -- "$1" "$tmp/run.log"; }
# wait_new SECONDS PATTERN BASELINE [PATTERN BASELINE]...: waits until the service's log has
# more than BASELINE lines matching one of the PATTERNs (grep -E); echoes the number (1, 2, ..)
# of the first that has, or returns 1 after SECONDS. Polled every 0.2 s for a time (bash's
# SECONDS), not a count of polls: each poll is a grep process, the guest's SCHED_OTHER share is
# small, and it answers commands seconds late when the host is loaded.
wait_new() {
  local until=$((SECONDS + $1)) i
  shift
  local pairs=("$@")
  while :; do
    for ((i = 0; 2 * i < ${#pairs[@]}; ++i)); do
      [[ $(count "${pairs[2 * i]}") -gt ${pairs[2 * i + 1]} ]] && { echo $((i + 1)); return 0; }
    done
    ((SECONDS < until)) || return 1
    sleep 0.2
  done
}
# wait_count PATTERN N SECONDS: 0 once the service's log has N lines matching PATTERN.
wait_count() { wait_new "$3" "$1" $(($2 - 1)) >/dev/null; }
# The operator's commands (and step 3's streamer) run at SCHED_FIFO 60 where permitted, below
# the loop (80) and the emulator (70): in the guest a SCHED_OTHER process gets a tenth of the
# CPU (the RT throttling below) and reaches the service seconds late, by when the idle loop
# may have latched a timing stop again after the reset before it. A test tool's priority,
# not the configuration.
cmd() {  # cmd ARGS...: dualv ARGS..., its output appended to commands.log
  # shellcheck disable=SC2046
  $(fifo 60) "$dualv" "$@" >>"$tmp/commands.log" 2>&1
}
signed() { cmd "$@" --key "$key" --lcm "$url"; }

fifo() {  # fifo PRIO: a chrt prefix where permitted (root in the guest), else nothing
  if [[ $(id -u) -eq 0 ]] && command -v chrt >/dev/null && chrt -f "$1" true 2>/dev/null; then
    echo "chrt -f $1"
  fi
}

# --- the guest's real-time throttling, for this test only (a property of the guest, not of the
# product: tests/hil/README.md "What a cycle costs in the guest"). The guest's one virtual CPU
# spends ~1 ms of host time per cycle on the loop's and the emulator's system calls, so the
# SCHED_FIFO tasks take nearly all of it and the kernel's default throttling (950 ms of every
# 1 s) leaves the test's own SCHED_OTHER commands 50 ms a second, in one block: `dualv status`
# then fails LCM's UDP self-test. A 10 ms throttling period with 9 ms for SCHED_FIFO leaves them
# 1 ms of every 10 ms instead: the loop then loses at most ~1 ms at a time (within the drives'
# 10 ms RPDO deadline) and only when the real-time tasks would take the whole CPU. Only in the
# user-mode-linux guest (never a host's or a namespace's kernel). The guest kernel has
# CONFIG_RT_GROUP_SCHED, so the throttling that applies is the root task group's (cgroup v1
# cpu.rt_*_us; the sysctls only bound it): runtime first, it must never exceed the period.
# Not on the virtual clock: there computing takes no guest time, so the real-time tasks never
# fill a throttling period (and that kernel has no RT group scheduling).
if [[ "${DUALV_HIL:-}" == uml && $strict -eq 0 ]]; then
  rt_cg=/dev/shm/dualv-rt-cgroup
  if ! { mkdir -p "$rt_cg" && mount -t cgroup -o cpu cgroup "$rt_cg" &&
    echo 9000 >"$rt_cg/cpu.rt_runtime_us" && echo 10000 >"$rt_cg/cpu.rt_period_us"; }; then
    echo "FAIL: cannot set the guest's RT throttling"
    exit 1
  fi
  echo "guest RT throttling: SCHED_FIFO may take $(cat "$rt_cg/cpu.rt_runtime_us") us of every" \
    "$(cat "$rt_cg/cpu.rt_period_us") us"
fi

# --- the guest stall probe: intervals (CLOCK_REALTIME, as candump's timestamps) in which a
# SCHED_FIFO 99 thread sleeping 2 ms did not run for more than 4 ms: the guest was frozen.
# shellcheck disable=SC2046
$(fifo 99) "$py" -u -c '
import sys, time
out = open(sys.argv[1], "w", buffering=1)
last = time.time()
while True:
    time.sleep(0.002)
    now = time.time()
    if now - last > 0.004:
        out.write("%.6f %.6f\n" % (last, now))
    last = now
' "$tmp/stalls.txt" &
probe_pid=$!

# The frames the guest kernel dropped before any socket saw them (its per-CPU input backlog
# full: /proc/net/softnet_stat, 2nd column, hex): no drive and no capture saw them, so the wire
# check counts them among the frames an interval without one RPDO of every drive per SYNC may
# have lost (check_serve_wire.py --kernel-drops; seen in CI: 196 drops, "SYNC n after 2 RPDOs
# 201", a SYNC lost with the RPDOs before it).
backlog_drops() {
  local _ dropped rest n=0
  while read -r _ dropped rest; do n=$((n + 16#$dropped)); done </proc/net/softnet_stat
  echo "$n"
}
backlog_drops_before=$(backlog_drops)

# shellcheck disable=SC2046
$(fifo 95) "$can_capture" vcan0 "$tmp/dump/capture.log" 2>"$tmp/capture.err" &
dump_pid=$!
for ((i = 0; i < 100; ++i)); do
  [[ -s "$tmp/capture.err" ]] && break
  sleep 0.05
done
# shellcheck disable=SC2046
$(fifo 70) "$dualv" sim --can vcan0 --config "$config" --status-every 0 --free-run-after 0 --plant-step-nominal \
  >"$tmp/sim.log" 2>&1 &
sim_pid=$!
wait_for "$tmp/sim.log" "drives booted" 20 || fail "dualv sim did not start"
# The service. Its boot's SDO exchanges have the configured timeout (can.timeouts.sdo, 0.1 s),
# which a guest frozen by a loaded host can exceed: a boot that ends on an SDO timeout while
# the stall probe saw the guest frozen is a NOTE (guest timing) and the service is started again
# (at most 3 times; three such boots skip the test, as a guest too slow for the loop's rate
# does below); any other boot failure fails the test.
boot_retries=0
for boot in 1 2 3; do
  : >"$tmp/run.log"
  "$dualv" run --serve --can vcan0 --config "$config" --lcm "$url" --keys "$tmp/keys" \
    -o "$tmp/out" >"$tmp/run.log" 2>&1 &
  run_pid=$!
  for ((i = 0; i < 300; ++i)); do
    grep -q "serving: waiting" "$tmp/run.log" && break
    kill -0 "$run_pid" 2>/dev/null || break
    sleep 0.2
  done
  grep -q "serving: waiting" "$tmp/run.log" && { head -n 1 /proc/stat >"$tmp/cpu.serving"; break; }
  kill "$run_pid" 2>/dev/null
  wait "$run_pid" 2>/dev/null
  run_pid=
  if ! grep -q "SDO timeout" "$tmp/run.log" || [[ ! -s "$tmp/stalls.txt" ]]; then
    fail "no service (boot $boot): $(grep -m1 "error" "$tmp/run.log")"
  fi
  [[ $strict -eq 0 ]] || fail "the service's boot $boot ended on an SDO timeout on the virtual clock"
  if [[ $boot -eq 3 ]]; then  # as the rate check below: a guest that cannot run this at all
    echo "skipped: three boots of the drives ended on SDO timeouts (can.timeouts.sdo) with the" \
      "guest frozen $(awk 'NR == 1 {a = $1} {s += $2 - $1; b = $2} END {printf "%.1f s of %.1f s", s, b - a}' "$tmp/stalls.txt")" \
      "by its host (tests/hil/README.md); run it on a less loaded host or a PC with vcan"
    exit 77
  fi
  ((++boot_retries))
  echo "NOTE (guest timing): the service's boot $boot ended on an SDO timeout with the guest" \
    "frozen $(awk '{s += $2 - $1} END {printf "%.1f", s}' "$tmp/stalls.txt") s so far: started again"
  cp "$tmp/run.log" "$tmp/run.boot$boot.log"
done

# Timing-watchdog stops (what a guest freeze causes), not what this test checks: see above.
timing_only() {  # timing_only FIRST_LINE: 0 when the first stop from that line of faults.jsonl
  # on was a timing watchdog's (what the loop detected later while stopped did not stop it)
  tail -n "+$1" "$tmp/out/faults.jsonl" 2>/dev/null | first_stop_causes | timing_stops_only  # hil_lib.sh
}
faults_lines() { [[ -f "$tmp/out/faults.jsonl" ]] && wc -l <"$tmp/out/faults.jsonl" || echo 0; }
last_reset_f=1  # the first line of faults.jsonl after the test's last signed reset
resets_before=0  # "reset accepted" lines in the log before the test's last signed reset
reset_refusals_before=0  # "reset refused" lines, likewise
signed_reset() {
  last_reset_f=$(($(faults_lines) + 1))
  resets_before=$(count "reset accepted")
  reset_refusals_before=$(count "reset refused")
  reset_stale_before=$(count "command refused \(stale\)")
  signed reset
}
# reset_accepted: 0 once the service accepted the last signed reset. Counted from before it was
# sent: the service may accept it before `dualv reset` has returned. A reset is refused while a
# stop's cause is still active; in the guest that is a timing watchdog's condition (stale
# feedback, deadline misses, a drive lost to its heartbeat, a drive's fault from its RPDO
# deadline or heartbeat consumer, EMCY 8250h / 8130h) that held at that moment: the reset is
# sent again after a second, as an operator would, at most 3 more times. A refusal naming any
# other condition, or no answer, is a failure.
reset_retries=0
reset_accepted() {
  local k f0=$last_reset_f active causes
  for k in 1 2 3 4; do
    wait_count "reset accepted" $((resets_before + 1)) 20 && return 0
    if [[ $k -lt 4 && $(count "command refused \(stale\)") -gt $reset_stale_before ]]; then
      stale_refusal "a reset" "$k" reset
      signed_reset
      continue
    fi
    [[ $k -lt 4 && $(count "reset refused") -gt $reset_refusals_before ]] || return 1
    active=$(grep "reset refused: still active: " "$tmp/run.log" | tail -n 1 | sed 's/.*still active: //')
    [[ -n $active ]] || return 1
    # The active conditions, a drive fault as the EMCYs the fault log gave it since the reset,
    # judged by hil_lib.sh's one list of timing causes.
    causes=$(
      sed 's/, /\n/g' <<<"$active" | grep -vx "drive fault"
      if grep -q "drive fault" <<<"$active"; then
        tail -n "+$f0" "$tmp/out/faults.jsonl" | stop_causes | grep "^drive fault"
      fi
    )
    [[ -z $causes ]] || timing_stops_only <<<"$causes" || return 1
    echo "note: a signed reset was refused while the guest's timing watchdogs still held" \
      "($active): sent again"
    ((++reset_retries))
    sleep 1
    signed_reset
  done
  return 1
}
retries=0
refusals=0  # starts refused after a timing-watchdog stop while idle (retried)
not_shown=''  # steps whose every attempt a timing watchdog stopped (NOTE, see above)
idle_resets=0
# refused_by_timing STEP ATTEMPT: for a start the service refused. Refused because a timing
# watchdog latched a stop again while idle, after the last reset (a frozen guest): a
# guest-timing attempt like a timing stop (a signed reset, then the caller retries); refused
# for any other reason: a failure.
refused_by_timing() {
  if ! { grep "start of .* refused" "$tmp/run.log" | tail -n 1 |
    grep -q "the last stop has not been reset" && timing_only "$last_reset_f"; }; then
    fail "$1: the signed start was refused: $(grep "start of .* refused" "$tmp/run.log" | tail -n 1)"
  fi
  ((++refusals))
  echo "note: $1: the start was refused after a timing-watchdog stop while idle (attempt $2)"
  signed_reset
  reset_accepted || fail "$1: reset after a timing stop"
}
# started_or_refused STEP ATTEMPT PATTERN WHAT: a signed start of WHAT; 0 once the service's log
# has a new line matching PATTERN (it started), 1 when the service refused it after a timing stop
# while idle (refused_by_timing has reset: the caller retries) or never received it (below); a
# failure when it received the start and neither started nor refused it.
started_or_refused() {
  local starts refused received stale
  starts=$(count "$3") refused=$(count "start of .* refused")
  received=$(count "command accepted: start signed") stale=$(count "command refused \(stale\)")
  signed start "$4"
  case $(wait_new 60 "$3" "$starts" "start of .* refused" "$refused" "command refused \(stale\)" "$stale") in
    1) return 0 ;;
    2) refused_by_timing "$1" "$2"; return 1 ;;
    3) stale_refusal "$1" "$2" start; return 1 ;;
  esac
  # `dualv start` sends its one datagram (LCM over UDP on the guest's loopback); in a guest
  # whose SCHED_FIFO tasks take most of its CPU the service's receiving thread (not real-time)
  # can lose it: seen once. Tried again like a timing stop; a command channel that is broken
  # fails the next steps' commands all the same.
  if [[ $(count "command accepted: start signed") -eq $received ]]; then
    echo "note: $1: the start never reached the service in 60 s (attempt $2): $(tail -n 1 "$tmp/commands.log")"
    ((++retries))
    return 1
  fi
  fail "$1: the signed start of $4 was received but neither started nor was refused in 60 s"
}
# stale_refusal STEP ATTEMPT WHAT: the service refused a signed WHAT as stale: it arrived more
# than the verifier's 2 s after `dualv` signed it (runtime/command_auth.hpp; a security limit,
# not widened here). In the guest a command tool at SCHED_FIFO 60 still waits behind the loop
# and the emulator (seen once: 2.2 s). Guest timing: the caller sends it again, freshly signed.
stale_resends=0
stale_refusal() {
  echo "note: $1: the signed $3 reached the service too late and was refused as stale (attempt $2):" \
    "$(grep "command refused (stale)" "$tmp/run.log" | tail -n 1 | sed 's/.*refused (stale): //')"
  ((++stale_resends))
}
# run_paper STEP: a signed start of the program until it completes (timing-only stops and
# starts refused after a timing-only stop retried, 3 attempts; then a NOTE)
run_paper() {
  local done0 stopped0 f0 refused0 starts0 stale0 ended
  for attempt in 1 2 3; do
    done0=$(count "$pname done") stopped0=$(count "$pname STOPPED") f0=$(($(faults_lines) + 1))
    refused0=$(count "start of .* refused")
    starts0=$(count "^dualv run: starting .*$pname \(key lab1\)")
    stale0=$(count "command refused \(stale\)")
    signed start "$program"
    ended=$(wait_new 180 "$pname (done|STOPPED)" $((done0 + stopped0)) "start of .* refused" "$refused0" \
      "command refused \(stale\)" "$stale0")
    if [[ $ended == 2 ]]; then
      refused_by_timing "$1" "$attempt"
      continue
    fi
    if [[ $ended == 3 ]]; then
      stale_refusal "$1" "$attempt" start
      continue
    fi
    [[ $ended == 1 ]] || fail "$1: the signed start of $pname did not end in 180 s"
    [[ $(count "^dualv run: starting .*$pname \(key lab1\)") -gt $starts0 ]] ||
      fail "$1: $pname ended without a 'starting ... $pname (key lab1)' line"
    [[ $(count "$pname done") -gt $done0 ]] && return 0
    timing_only "$f0" || fail "$1: $pname STOPPED, not by a timing watchdog"
    ((++retries))
    echo "note: $1: $pname stopped by a timing watchdog in the guest (attempt $attempt): $(grep "$pname STOPPED" "$tmp/run.log" | tail -n 1)"
    signed_reset
    reset_accepted || fail "$1: reset after a timing stop"
  done
  echo "NOTE (guest timing): $1: all 3 attempts of $pname stopped (or refused after a stop) by" \
    "timing watchdogs in the guest; its completion is not shown here, its stops are checked on the wire"
  not_shown+=" $1"
}

# 1. Boot, then idle 5 s: the robot state is published while idle.
grep -q "serving: waiting" "$tmp/run.log" || fail "no service (boot)"
boot_done=$(date +%s)
sleep 5
kill -0 "$run_pid" 2>/dev/null || fail "the service ended while idle"
"$dualv" status --lcm "$url" --timeout 10 >"$tmp/status.log" 2>&1 ||
  fail "dualv status found no robot state while the service is idle"
grep -q "plate X" "$tmp/status.log" || fail "dualv status printed no state"
# A guest that cannot run the loop near its rate at all (a host loaded by other work: the guest
# is one virtual CPU that the host freezes as a whole) can show nothing of what the steps
# below check: skip there (ctest: skipped, with the figure), never widen the configuration.
rate=$(awk '/rate_hz:/ {print $2; exit}' "$config")
syncs=$(grep -c " vcan0 080#" "$tmp/dump/capture.log" 2>/dev/null || true)
elapsed=$(( $(date +%s) - boot_done ))
if [[ -n $rate && $elapsed -gt 0 ]] &&
   awk -v s="$syncs" -v e="$elapsed" -v r="$rate" 'BEGIN { exit !(s / e < 0.5 * r) }'; then
  [[ $strict -eq 0 ]] || fail "the loop ran at $((syncs / elapsed)) SYNC/s of $rate while idle on the virtual clock"
  echo "skipped: the guest ran the ${rate} Hz loop at $((syncs / elapsed)) SYNC/s while idle" \
    "(its one virtual CPU cannot carry the loop and the four emulated drives at this" \
    "rate: tests/hil/README.md); run it on a PC with vcan"
  exit 77
fi
# The first cycle must come within the drives' RPDO deadline after their priming; a frozen
# guest can miss it (the service then warns, the drives report EMCY 8250h, the stop latches
# with the drives disabled). Timing only: a signed reset clears it (retried like the steps).
if grep -q "torque off (STO)" "$tmp/run.log"; then
  timing_only 1 || fail "step 1: a stop while idle, not by a timing watchdog"
  ((++idle_resets))
  echo "note: step 1: stop latched while idle by a timing watchdog: $(grep -E "WARNING|torque off" "$tmp/run.log" | head -n 2 | tr '\n' ' ')"
  signed_reset
  wait_count "reset accepted" 1 20 || fail "step 1: the signed reset after the idle stop was refused"
fi

# 2. A signed start of the paper program: it starts and completes.
run_paper "step 2"

# 3. Idle ~1 s, then a stream ended by its signed stop. `dualv stream` sends its signed start
# and then its setpoints at once, as an operator runs it (started first and the streamer
# after, the stream's watchdog, 0.1 s from the start, would fire before a process started in
# the guest sends anything). It runs at SCHED_FIFO 60 as the commands do (cmd). A stream
# stopped as "command stream stale" while the streamer still ran is guest timing too
# (lcm_stream_hil.sh; the exact watchdog: tests/apps/stream_closed_loop_test.cpp).
sleep 1
streamed=0
for attempt in 1 2 3; do
  f3=$(($(faults_lines) + 1))
  ends3=$(count "stream (done|STOPPED)") refused3=$(count "start of .* refused")
  received3=$(count "command accepted: start signed")
  # shellcheck disable=SC2046
  $(fifo 60) "$dualv" stream --key "$key" --lcm "$url" --circle 0.01 --duration 2 >"$tmp/stream.log" 2>&1
  stream_rc=$?
  case $(wait_new 60 "stream (done|STOPPED)" "$ends3" "start of .* refused" "$refused3") in
    1) streamed=1; break ;;
    2) refused_by_timing "step 3" "$attempt" ;;
    *)
      # The streamer's start datagram lost on the guest's loopback (as started_or_refused
      # handles for a program's start): tried again; a start received and neither started nor
      # refused is a failure.
      [[ $(count "command accepted: start signed") -eq $received3 ]] ||
        fail "step 3: the stream neither ended nor was refused in 60 s"
      echo "note: step 3: the stream's start never reached the service (attempt $attempt)"
      ((++retries))
      ;;
  esac
done
if [[ $streamed -eq 0 ]]; then
  echo "NOTE (guest timing): step 3: no stream started in 3 attempts (each refused after a" \
    "timing watchdog's stop while idle, or its start lost; their stops are checked on the wire)"
  not_shown+=" step 3"
elif [[ $(count "stream done") -gt $ends3 ]]; then
  [[ $stream_rc -eq 0 ]] || fail "step 3: dualv stream failed ($stream_rc)"
else
  grep "stream STOPPED" "$tmp/run.log" | tail -n 1 | grep -q "command stream stale" ||
    timing_only "$f3" || fail "step 3: the stream did not end normally"
  ((++retries))
  echo "NOTE (guest timing): step 3: the stream was stopped by a timing watchdog or went stale" \
    "in the guest: $(grep "stream STOPPED" "$tmp/run.log" | tail -n 1)"
  not_shown+=" step 3"
  signed_reset
  reset_accepted || fail "step 3: reset"
fi

# 4. An e-stop while a start is being prepared: that program never starts. The e-stop is sent
# while `dualv start` is still running (both at once), so it reaches the service before the
# start or while the program is prepared, and the start is refused. In the guest, where a
# process takes ~0.4 s to start, the program's preparation can still end first (seen in CI):
# then the program must not complete and must stop (by the e-stop, or a timing watchdog
# before it), and the step is a NOTE (guest timing), its stop checked on the wire.
done4=$(count "$pname done") stopped4=$(count "$pname STOPPED") refused4=$(count "start of .* refused")
starts4=$(count "^dualv run: starting .*$pname") resets4=$(count "reset \(key lab1\)")
signed start "$program" &
start_pid=$!
cmd estop --lcm "$url"
wait "$start_pid"
wait_new 60 "start of .* refused" "$refused4" "$pname (done|STOPPED)" $((done4 + stopped4)) >/dev/null
if [[ $(count "start of .* refused") -gt $refused4 ]]; then
  grep "start of .* refused" "$tmp/run.log" | tail -n 1 | sed 's/^/  step 4: /'
  sleep 2
  [[ $(count "^dualv run: starting .*$pname") -eq $starts4 && $(count "$pname done") -eq $done4 &&
    $(count "$pname STOPPED") -eq $stopped4 ]] || fail "step 4: the program started despite the e-stop"
elif [[ $(count "$pname STOPPED") -gt $stopped4 && $(count "$pname done") -eq $done4 ]]; then
  ((++retries))  # an enable episode the wire check may see
  echo "NOTE (guest timing): step 4: the program's preparation ended before the e-stop came;" \
    "it was stopped: $(grep "$pname STOPPED" "$tmp/run.log" | tail -n 1)"
  not_shown+=" step 4"
else
  fail "step 4: the start during an e-stop was neither refused nor stopped"
fi
signed_reset
wait_count "reset \(key lab1\)" $((resets4 + 1)) 20 || fail "step 4: the signed reset was not accepted"

# 5. An e-stop while the program runs: SS1, then STO. `new`: the fault log of the attempt that
# reached the e-stop ('' while none has).
new=''
for attempt in 1 2 3; do
  stopped5=$(count "$pname STOPPED") done5=$(count "$pname done") f5=$(($(faults_lines) + 1))
  started_or_refused "step 5" "$attempt" "^dualv run: starting .*$pname" "$program" || continue
  sleep 1.5
  cmd estop --lcm "$url"
  wait_count "$pname (done|STOPPED)" $((stopped5 + done5 + 1)) 60 || fail "step 5: no end after the e-stop"
  [[ $(count "$pname done") -eq $done5 ]] || fail "step 5: the program completed despite the e-stop"
  grep "$pname STOPPED" "$tmp/run.log" | tail -n 1 | sed 's/^/  step 5: /'
  attempt_faults=$(tail -n "+$f5" "$tmp/out/faults.jsonl" 2>/dev/null)
  # The e-stop must be what stopped the program (an e-stop received after a timing stop, while
  # stopped, is logged too).
  if first_stop_causes <<<"$attempt_faults" | grep -q '^e-stop (LCM)$' &&
    grep '"event":"fault"' <<<"$attempt_faults" | grep '"cause":"e-stop (LCM)"' | grep -q '"reaction":"SS1"'; then
    new=$attempt_faults
    break
  fi
  # stopped before the e-stop came: a timing watchdog (retried), or a failure
  timing_only "$f5" || fail "step 5: no e-stop (LCM) with reaction SS1 in faults.jsonl"
  ((++retries))
  echo "note: step 5: stopped by a timing watchdog before the e-stop (attempt $attempt)"
  signed_reset
  reset_accepted || fail "step 5: reset"
done
if [[ -n $new ]]; then
  grep -A1000 '"cause":"e-stop (LCM)","reaction":"SS1"' <<<"$new" | grep '"event":"stop reached"' |
    grep -q '"reaction":"STO"' || fail "step 5: no 'stop reached' STO after the e-stop's SS1 in faults.jsonl"
else
  echo "NOTE (guest timing): step 5: no run reached the e-stop in 3 attempts (each refused after," \
    "or stopped by, a timing watchdog's stop first; their stops are checked on the wire)"
  not_shown+=" step 5"
fi

# 6. A signed reset, then a start: it completes.
resets=$(count "reset \(key lab1\)")
signed_reset
wait_count "reset \(key lab1\)" $((resets + 1)) 20 || fail "step 6: the signed reset was not accepted"
run_paper "step 6"

# Where the guest's one CPU went over the service's life (a diagnosis, nothing asserted): per
# thread, time on the CPU and time runnable but waiting for it (tests/hil/README.md "What a
# cycle costs in the guest").
"$py" "$here/guest_cpu.py" --since "$tmp/cpu.serving" run="$run_pid" sim="$sim_pid" \
  capture="$dump_pid" probe="$probe_pid" ksoftirqd="$(pgrep -x ksoftirqd/0 || echo none)" || true

# 7. SIGINT: the service ends cleanly.
kill -INT "$run_pid"
wait "$run_pid"
rc=$?
run_pid=
[[ $rc -eq 0 ]] || fail "step 7: dualv run --serve exited $rc after SIGINT"
grep -q "stop signal: ending the service" "$tmp/run.log" || fail "step 7: no 'ending the service'"
kill -TERM "$sim_pid" 2>/dev/null
wait "$sim_pid" 2>/dev/null
sim_pid=
sleep 0.2
kill "$probe_pid" 2>/dev/null
wait "$probe_pid" 2>/dev/null
probe_pid=
kill -INT "$dump_pid" 2>/dev/null
wait "$dump_pid" 2>/dev/null
dump_pid=
grep -E "^dualv sim: (stopped|node)" "$tmp/sim.log"

# The wire: gaps, every drive every cycle, torque limit, every stop a stop on the wire, 4 enable
# episodes (paper, stream, the e-stopped paper, paper; none for step 4's start). A start stopped
# by a timing watchdog may or may not have reached "enable operation" before its stop: with
# retries, 4 - (steps not shown) to 4 + retries.
enables=4
if [[ $retries -ne 0 || -n $not_shown ]]; then
  lo=$((4 - $(grep -o "step" <<<"$not_shown" | wc -l)))  # not_shown: " step 2 step 5"
  enables="$((lo > 0 ? lo : 0))-$((4 + retries))"
fi
capture=$tmp/dump/capture.log
[[ -s "$capture" ]] || fail "no capture"
grep -q " 0 lost" "$tmp/capture.err" || fail "the capture lost frames: $(tail -n 1 "$tmp/capture.err")"
# The capture runs above the loop (SCHED_FIFO 95): its own longest wake-up, to set beside a
# wire gap the stall probe does not excuse.
grep "wake-ups" "$tmp/capture.err" || true
kernel_drops=$(($(backlog_drops) - backlog_drops_before))
echo "guest kernel input backlog: $kernel_drops frames dropped during the run"
# A machine that ran the loop below 95 % of its rate shows nothing of its gaps: a NOTE there
# (check_serve_wire.py --min-rate), every other wire check holds.
wire_excuses=(--stalls "$tmp/stalls.txt" --min-rate 0.95)
[[ $strict -eq 0 ]] || wire_excuses=()
"$py" "$here/check_serve_wire.py" --config "$config" "${wire_excuses[@]}" --run-log "$tmp/run.log" \
  --kernel-drops "$kernel_drops" --expect-enables="$enables" "$capture" || fail "wire check"
# The virtual clock excuses nothing: every step shown at its first attempt.
excused=$((retries + refusals + idle_resets + reset_retries + stale_resends + boot_retries))
if [[ $strict -eq 1 && ($excused -ne 0 || -n $not_shown) ]]; then
  fail "on the virtual clock, where the guest keeps every deadline: timing-watchdog retries" \
    "$retries, starts refused after one $refusals, idle resets $idle_resets, resets sent again" \
    "$reset_retries, stale commands $stale_resends, boot retries $boot_retries; not shown:${not_shown:- none}"
fi
# What passed, in the steps' order; a step not shown in this guest is named as such.
shown_steps="idle state published; step 2 paper done; step 3 stream done; step 4 e-stop during"
shown_steps+=" preparation: never started; step 5 e-stop while running: SS1 -> STO; step 6 reset,"
shown_steps+=" paper done"
for s in $(grep -o "[0-9]" <<<"$not_shown"); do
  shown_steps=$(sed -E "s/step $s [^;]*/step $s NOT SHOWN (guest timing)/" <<<"$shown_steps")
done
echo "PASS: serve over vcan with the shipped configuration: $shown_steps; SIGINT exit 0; wire" \
  "checked (timing-watchdog retries: $retries, starts refused after one: $refusals, idle resets:" \
  "$idle_resets, resets sent again: $reset_retries, stale commands sent again: $stale_resends," \
  "boot retries: $boot_retries)"
[[ -z $not_shown ]] || echo "NOTE (guest timing): not shown in this guest (every attempt stopped by" \
  "a timing watchdog; the stops checked):$not_shown"
