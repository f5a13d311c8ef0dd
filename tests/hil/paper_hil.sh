#!/usr/bin/env bash
# HIL (issue 5, issue 12 "test what ships"): the paper program in closed loop over real
# SocketCAN (vcan0, run through run_in_vcan.sh) between two processes, as on the machine:
# `dualv sim --can vcan0` (four CiA 402 drives + the mechanism) and `dualv run --can vcan0`
# (the controller), with the configuration given on the command line UNCHANGED (the shipped
# config/dualv.yaml: 1 kHz, shipped gains, deadlines, watchdogs and limits). Checks:
#   1. paper:   the run completes, and its tracking errors (summary.csv, `all` row of the
#               retimed run: max |ex|, max |ey|, max |e|, rms |e|) are within 2x (+ 0.01 mm)
#               of the in-process run of the same configuration (`dualv run`, simulated time)
#   2. wire:    the `candump -l` log of every run (check_paper_wire.py): SYNC count on the
#               wire = what the master says it sent = priming + control cycles + disable
#               cycles; every drive's RPDO before every SYNC; no target torque above the
#               configured limit; a completed run moved the robot; a stopped run (STO in its
#               fault log) sends zero torque and no "enable operation" from the STO's cycle on
#               and leaves every drive disabled
#   3. foreign: frames injected with canplayer during a second run (unknown COB-IDs, wrong
#               DLC, an SDO abort), then an EMCY 4210h from node 3: neither process crashes
#               (the run exits 1, the emulator 0 on SIGTERM), the emulator counts them all;
#               the EMCY is decoded, in the fault log as a drive fault of drive 3 with
#               reaction STO (safety/fault.hpp), the master counted the foreign frames that
#               came before it on the bus, and the wire shows the STO
#               (check_paper_wire.py --sto-after: zero torque from the third SYNC after the
#               EMCY, every drive disabled at the end)
#
# Timing in the guest: the user-mode-linux guest is one slow virtual CPU (every syscall ~0.1 ms
# of host time) that a loaded host freezes as a whole for ms to seconds (tests/hil/README.md).
# It cannot always keep the shipped 1 kHz, and the test does not widen a deadline or lower the
# rate to hide that. A run may end on the loop's own timing watchdogs (safety/fault.hpp:
# consecutive deadline misses, stale feedback, a drive lost to the heartbeat timeout, or a
# drive's EMCY 8250h / 8130h: its RPDO deadline or its consumer of the master's heartbeat).
#   - gates whatever the timing: the wire checks of every run's capture (2: a stopped run's
#     STO from the cycle of the first STO in its fault log), neither process crashing, the
#     emulator's count of the foreign frames, and that every stop is a timing watchdog's or
#     (3) the EMCY's
#   - gates when the run read what it is about: the tracking comparison (1) when the run over
#     vcan completed; the EMCY's decoding, STO and the master's counts (3) when the EMCY
#     reached the running loop. A run that ended on a timing watchdog first is tried again (up
#     to 4 attempts per part); when every attempt ended so, a NOTE gives each attempt's
#     figures and that part is not shown here (no failure). Any other outcome (a stop of
#     another cause, a crash, a wire violation) fails.
# What is not the configuration, and why:
#   - the emulator runs SCHED_FIFO 90 above the control loop (SCHED_FIFO 80, the shipped
#     loop.priority) and candump at 95 with an 8 MB receive buffer: like drive hardware, the
#     emulator answers every SYNC before the controller's next cycle, and no frame is lost
#     from the capture. This relaxes no limit of the controller
#   - `dualv sim` options: --free-run-after 0 (its plant does not advance without SYNC after
#     50 ms of silence, the emulator's model of a dead master: a guest frozen as a whole by the
#     host is not a dead master, and the emulator, running first when it thaws, would take it
#     for one), --plant-step-nominal (the plant advances 1006h per SYNC: a freeze of the whole
#     guest stops the controller's clock and the mechanism's alike, as it does not on the
#     machine), --exit-after 600 (a leftover emulator ends by itself), --status-every 0 (no
#     periodic status lines: fewer syscalls)
# Behaviour and ordering are asserted, never latency. Needs can-utils (candump, canplayer).
# Usage: paper_hil.sh DUALV_BINARY CONFIG_YAML [PROGRAM_YAML (default: paper.yaml beside it)]
# KEEP=1 keeps the work folder (logs, captures, outputs) and prints its path.
set -u
. "$(dirname "$0")/hil_lib.sh"
usage="usage: paper_hil.sh DUALV_BINARY CONFIG_YAML [PROGRAM_YAML]"
dualv=${1:?$usage}
config=${2:?$usage}
program=${3:-$(dirname "$config")/paper.yaml}
here=$(cd "$(dirname "$0")" && pwd)
py=/usr/bin/python3
[[ -x $py ]] || py=python3
for tool in candump canplayer; do
  command -v "$tool" >/dev/null || { echo "FAIL: $tool not found (install can-utils)"; exit 1; }
done
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dualv-paper-hil.XXXXXX") || exit 1
attempts=4

sim_pid='' dump_pid='' run_pid=''
# shellcheck disable=SC2317  # invoked by the EXIT trap
cleanup() {
  for p in $run_pid $sim_pid $dump_pid; do kill "$p" 2>/dev/null; done
  if [[ -n "${KEEP:-}" ]]; then echo "kept $tmp"; else rm -rf "$tmp"; fi
}
trap cleanup EXIT
failed=0
fail() {
  echo "FAIL: $*"
  failed=1
}
show() {  # show FILE...: the tail of logs after a failure
  for f in "$@"; do echo "--- $f (tail)"; tail -n 40 "$f" 2>/dev/null; done
}

# SCHED_FIFO where permitted (root in the guest, netns): the emulator above the controller.
sim_prefix=()
dump_prefix=()
if [[ $(id -u) -eq 0 ]] && command -v chrt >/dev/null && chrt -f 90 true 2>/dev/null; then
  sim_prefix=(chrt -f 90)
  dump_prefix=(chrt -f 95)
fi

# --- the reference: the same program and configuration in-process (simulated time) ------
"$dualv" run --config "$config" -p "$program" --variant retimed --no-plots -o "$tmp/ref" \
  >"$tmp/ref.log" 2>&1 || { show "$tmp/ref.log"; echo "FAIL: the in-process reference run failed"; exit 1; }

start_bus() {  # start_bus NAME [SIM_ARGS...]: candump -l and the emulator on vcan0
  local name=$1
  shift
  mkdir -p "$tmp/$name.dump"
  (cd "$tmp/$name.dump" && exec "${dump_prefix[@]}" candump -l -r 8388608 vcan0) \
    >"$tmp/$name.candump.log" 2>&1 &
  dump_pid=$!
  for ((i = 0; i < 100; ++i)); do
    compgen -G "$tmp/$name.dump/candump-*.log" >/dev/null && break
    sleep 0.05
  done
  "${sim_prefix[@]}" "$dualv" sim --can vcan0 --config "$config" --exit-after 600 \
    --status-every 0 --free-run-after 0 --plant-step-nominal "$@" >"$tmp/$name.sim.log" 2>&1 &
  sim_pid=$!
  wait_for "$tmp/$name.sim.log" "drives booted" 10 || fail "$name: dualv sim did not start"
}
stop_bus() {  # stop_bus NAME: ends the emulator (checks its clean exit) and the capture
  local name=$1 rc
  kill -TERM "$sim_pid" 2>/dev/null
  wait "$sim_pid"
  rc=$?
  sim_pid=
  [[ $rc -eq 0 ]] || fail "$name: dualv sim exited $rc after SIGTERM"
  grep -q "stopped (signal)" "$tmp/$name.sim.log" || fail "$name: dualv sim did not stop cleanly"
  sleep 0.2
  kill -INT "$dump_pid" 2>/dev/null
  wait "$dump_pid" 2>/dev/null
  dump_pid=
  capture=$(compgen -G "$tmp/$name.dump/candump-*.log" | head -n 1)
  [[ -s "$capture" ]] || { fail "$name: no candump log"; capture=''; }
}
summary_all() {  # summary_all SUMMARY_CSV: max_ex max_ey max_e rms_e of the retimed `all` row
  awk -F, '$1 == "retimed" && $2 == "all" {print $4, $5, $6, $7}' "$1"
}
# stops FAULTS_JSONL: every stopping fault (reaction SS1 or STO) in the fault log, as its text
# without the reaction ("drive fault drive 3: EMCY 4210h").
stops() { stop_causes 2>/dev/null <"$1"; }  # hil_lib.sh
# sto_cycle FAULTS_JSONL: the cycle from which the loop sends STO (the first fault with reaction
# STO, or SS1's "stop reached"); nothing when the fault log has none.
sto_cycle() {
  grep -E '"event":"(fault|stop reached)"' "$1" 2>/dev/null | grep '"reaction":"STO"' | head -n 1 |
    sed -nE 's/^\{"cycle":([0-9]+),.*/\1/p'
}
# wire NAME LABEL [ARGS...]: check_paper_wire.py on NAME's capture and run log; with the STO
# cycle of its fault log when it has one.
wire() {
  local name=$1 label=$2 k
  shift 2
  [[ -n "${capture:-}" ]] || return 0
  k=$(sto_cycle "$tmp/$name/faults.jsonl")
  "$py" "$here/check_paper_wire.py" --config "$config" --run-log "$tmp/$name.run.log" \
    ${k:+--sto-cycle "$k"} "$@" "$capture" || fail "$label: wire check"
}
# report NAME: the run's and the emulator's reports
report() {
  grep -E "^(loop:|bus:|  node )|FAILED in|cycle time|lateness" "$tmp/$1.run.log"
  grep -E "^dualv sim: (t=|stopped|node)" "$tmp/$1.sim.log"
}

# --- 1 + 2: the paper program over vcan, and its capture ---------------------------------
completed=0
notes=()
for ((attempt = 1; attempt <= attempts && completed == 0; ++attempt)); do
  name=paper$attempt
  start_bus "$name"
  "$dualv" run --can vcan0 --config "$config" -p "$program" --variant retimed \
    --no-plots -o "$tmp/$name" >"$tmp/$name.run.log" 2>&1
  run_rc=$?
  stop_bus "$name"
  echo "=== paper program over vcan, attempt $attempt (dualv run exit $run_rc)"
  report "$name"
  wire "$name" "paper (attempt $attempt)"
  causes=$(stops "$tmp/$name/faults.jsonl")
  if [[ $run_rc -eq 0 && -z $causes ]]; then
    completed=1
  elif [[ $run_rc -eq 1 && -n $causes ]] && timing_stops_only <<<"$causes"; then
    guest_timing "paper: attempt $attempt ended on the loop's timing watchdogs: $(tr '\n' ';' <<<"$causes")"
    notes+=("attempt $attempt: $(grep -m1 -oE "FAILED in .*" "$tmp/$name.run.log"); $(grep -m1 '^loop:' "$tmp/$name.run.log")")
    echo "note: attempt $attempt ended on the loop's timing watchdogs (guest timing): $(tr '\n' ';' <<<"$causes")"
  else
    fail "paper: dualv run --can exited $run_rc, stops: ${causes:-none} (neither completed nor a timing watchdog's stop)"
    break
  fi
  [[ $failed -eq 0 ]] || break
done
if [[ $completed -eq 1 ]]; then
  # (no process substitution: the guest has no /dev/fd)
  read -r -a ref <<<"$(summary_all "$tmp/ref/summary.csv")"
  read -r -a can <<<"$(summary_all "$tmp/$name/summary.csv")"
  if [[ ${#ref[@]} -ne 4 || ${#can[@]} -ne 4 ]]; then
    fail "paper: no 'retimed,all' row in a summary.csv"
  else
    names=(max_ex_mm max_ey_mm max_e_mm rms_e_mm)
    for k in 0 1 2 3; do
      verdict=$(awk -v c="${can[$k]}" -v r="${ref[$k]}" 'BEGIN {print (c <= 2 * r + 0.01) ? "ok" : "ABOVE 2x"}')
      printf '  %-10s in-process %8.3f  over vcan %8.3f  %s\n' "${names[$k]}" "${ref[$k]}" "${can[$k]}" "$verdict"
      [[ $verdict == ok ]] || fail "paper: ${names[$k]} ${can[$k]} over vcan, more than 2x the in-process ${ref[$k]}"
    done
  fi
elif [[ $failed -eq 0 ]]; then
  echo "NOTE (guest timing): the paper program over vcan did not complete in $attempts attempts, each"
  echo "  ended by the loop's timing watchdogs (the guest did not keep 1 kHz); the tracking comparison"
  echo "  is not shown here, the wire checks of every attempt passed:"
  printf '  %s\n' "${notes[@]}"
fi

# --- 3: foreign frames during a run, then an EMCY ------------------------------------------
# The foreign frames as soon as the control loop runs: counted, no crash. Then an EMCY from
# node 3: the defined reaction, STO (safety/fault.hpp). All from one canplayer process (1 ms
# apart, the EMCY last): the guest's one CPU spawns a process in tens of ms, and a run the
# guest's timing stops ends within a few cycles.
frames=(
  185#0102030405060708   # TPDO1 of node 5: no such drive on this bus (unknown)
  7E5#0400000000000000   # LSS (function code 15, no node): unknown COB-ID
  12345678#DEADBEEF      # extended identifier: unknown
  181#3712               # TPDO1 of node 1 with 2 bytes instead of 6: wrong DLC
  701#                   # heartbeat of node 1 without its state byte: wrong DLC
  581#8041600043000406   # SDO abort 06040043h from node 1 (no SDO transfer is open)
)
# EMCY 4210h (excess temperature), error register 08h, from node 3.
for f in "${frames[@]}" 083#1042080000000000; do echo "(0.000000) vcan0 $f"; done >"$tmp/foreign.frames"
count() { sed -nE "s/.*$1 ([0-9]+).*/\1/p" <<<"$2"; }
emcy_shown=0
enotes=()
for ((attempt = 1; attempt <= attempts && emcy_shown == 0 && failed == 0; ++attempt)); do
  name=foreign$attempt
  start_bus "$name"
  "$dualv" run --can vcan0 --config "$config" -p "$program" --variant retimed \
    --no-plots -o "$tmp/$name" >"$tmp/$name.run.log" 2>&1 &
  run_pid=$!
  if ! wait_for "$tmp/$name.run.log" "control loop running\|FAILED in" 60; then
    fail "foreign: the control loop did not start"
    show "$tmp/$name.run.log"
  fi
  canplayer -t -g 1 -I "$tmp/foreign.frames" || fail "foreign: canplayer"
  kill -0 "$sim_pid" 2>/dev/null || fail "foreign: dualv sim ended after the foreign frames"
  stopped=0
  for ((i = 0; i < 600; ++i)); do
    kill -0 "$run_pid" 2>/dev/null || { stopped=1; break; }
    sleep 0.05
  done
  if [[ $stopped -eq 0 ]]; then
    fail "foreign: dualv run still running 30 s after the EMCY"
    kill -INT "$run_pid" 2>/dev/null
  fi
  wait "$run_pid"
  run_rc=$?
  run_pid=
  stop_bus "$name"
  echo "=== foreign frames, then an EMCY from node 3, attempt $attempt (dualv run exit $run_rc)"
  report "$name"
  [[ $run_rc -eq 1 ]] || fail "foreign: dualv run exited $run_rc, expected 1 (stopped)"
  # Counted by the emulator too (frames not for its drives), and it did not crash (stop_bus).
  nf=$(sed -nE 's/.* ([0-9]+) frames not for these drives.*/\1/p' "$tmp/$name.sim.log")
  [[ "${nf:-0}" -ge ${#frames[@]} ]] ||
    fail "foreign: the emulator counted ${nf:-no} foreign frames (expected >= ${#frames[@]})"
  causes=$(stops "$tmp/$name/faults.jsonl")
  emcy='drive fault drive 3: EMCY 4210h'
  if grep -qxF "$emcy" <<<"$causes"; then
    # Decoded, a drive fault of drive 3 with reaction STO, and the only stop apart from the
    # timing watchdogs (which may fire in the same cycles).
    grep '"event":"fault"' "$tmp/$name/faults.jsonl" | grep -F "\"text\":\"$emcy -> STO\"" |
      grep -q '"cause":"drive fault","reaction":"STO"' ||
      fail "foreign: EMCY 4210h of node 3 not a drive fault with reaction STO in the fault log"
    others=$(grep -vxF "$emcy" <<<"$causes")
    [[ -z $others ]] || timing_stops_only <<<"$others" || fail "foreign: other stops: $causes"
    # The run read the EMCY, so every foreign frame before it on the bus: counted by the
    # master (3 unknown, 1 malformed heartbeat, the SDO abort ignored (no transfer open),
    # node 1's short TPDO). A run a timing watchdog ended before them never read them.
    bus=$(grep -E "^bus: " "$tmp/$name.run.log")
    [[ "$(count "unknown frames" "$bus")" == 3 ]] || fail "foreign: unknown frames not counted 3: $bus"
    [[ "$(count "malformed frames" "$bus")" == 1 ]] || fail "foreign: malformed frames not counted 1: $bus"
    [[ "$(count "ignored frames" "$bus")" == 1 ]] || fail "foreign: SDO abort not counted 1: $bus"
    node1=$(grep -E "^  node 1:" "$tmp/$name.run.log")
    [[ "$(count "malformed" "$node1")" == 1 ]] || fail "foreign: node 1's short TPDO not counted: $node1"
    node3=$(grep -E "^  node 3:" "$tmp/$name.run.log")
    [[ "$(count "EMCYs" "$node3")" -ge 1 ]] || fail "foreign: node 3's EMCY not counted: $node3"
    wire "$name" "foreign (STO after the EMCY)" --sto-after 3:4210
    emcy_shown=1
  elif [[ -n $causes ]] && timing_stops_only <<<"$causes"; then
    guest_timing "foreign: attempt $attempt ended on the loop's timing watchdogs before the EMCY: $(tr '\n' ';' <<<"$causes")"
    wire "$name" "foreign (attempt $attempt)"
    enotes+=("attempt $attempt: $(grep -m1 -oE "FAILED in .*" "$tmp/$name.run.log"); $(grep -m1 '^loop:' "$tmp/$name.run.log")")
    echo "note: attempt $attempt ended on the loop's timing watchdogs before the EMCY: $(tr '\n' ';' <<<"$causes")"
  else
    fail "foreign: stops: ${causes:-none} (neither the EMCY's STO nor a timing watchdog's)"
  fi
done
if [[ $emcy_shown -eq 0 && $failed -eq 0 ]]; then
  echo "NOTE (guest timing): the EMCY's STO and the master's counts not shown: every one of $attempts"
  echo "  runs ended on the loop's timing watchdogs before the frames came (the emulator counted them,"
  echo "  every capture checked):"
  printf '  %s\n' "${enotes[@]}"
fi

if [[ $failed -ne 0 ]]; then
  show "$tmp/$name.run.log" "$tmp/$name.sim.log"
  exit 1
fi
echo "paper HIL (shipped configuration): tracking within 2x of in-process:" \
  "$([[ $completed -eq 1 ]] && echo shown || echo "NOTE above");" \
  "wire: SYNCs, RPDOs, torque limit, STO: ok; foreign frames counted by the emulator;" \
  "by the master and EMCY -> STO: $([[ $emcy_shown -eq 1 ]] && echo shown || echo "NOTE above")"
exit 0
