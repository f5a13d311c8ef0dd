#!/usr/bin/env bash
# HIL (issue 13): a foreign CiA 402 drive, as a vendor's stack would answer, boots and runs
# the paper program over real SocketCAN (vcan0, through run_in_vcan.sh), between two
# processes, with the SHIPPED configuration (no overlay, no widened deadline, 1 kHz):
#   `dualv sim --can vcan0 --foreign`  four drives that answer SDO uploads without size
#                                      indication (e=1, s=0: 42h + 4 bytes) and have no 60C2h
#   `dualv run --can vcan0`            the controller, the paper program (retimed variant)
# Checks:
#   1. boot: the master prints, for every node, that 60C2h (interpolation_period, optional in
#      the shipped can.objects) was skipped, and the drives boot ("drives booted")
#   2. wire (candump -l): the drives' upload responses are 42h (no size), the master's 60C2h
#      write is answered by abort 06020000h, and 1006h is written (23 06 10 00 E8 03 00 00)
#   3. run: the program completes (dualv run exits 0) and the drives were enabled (0Fh on
#      the wire). If the guest cannot keep the 1 kHz timing (its ms-scale stalls: deadline
#      or staleness watchdogs), or the drives stop in cycle 0 because the host was silent
#      between boot and the first cycle (EMCY 8130h / 8250h: issue 12 points 1 and 6, the
#      loop's start-up, not this CANopen layer), the test asserts what does not depend on
#      that timing (boot + wire above) and says so in a NOTE.
# Needs can-utils (candump). Usage: foreign_drive_hil.sh DUALV_BINARY CONFIG_YAML [PROGRAM_YAML]
# KEEP=1 keeps the work folder.
set -u
. "$(dirname "$0")/hil_lib.sh"
usage="usage: foreign_drive_hil.sh DUALV_BINARY CONFIG_YAML [PROGRAM_YAML]"
dualv=${1:?$usage}
config=${2:?$usage}
program=${3:-$(dirname "$config")/paper.yaml}
command -v candump >/dev/null || { echo "FAIL: candump not found (install can-utils)"; exit 1; }
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dualv-foreign-hil.XXXXXX") || exit 1

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

mkdir -p "$tmp/dump"
(cd "$tmp/dump" && exec candump -l -r 8388608 vcan0) >"$tmp/candump.log" 2>&1 &
dump_pid=$!
for ((i = 0; i < 100; ++i)); do
  compgen -G "$tmp/dump/candump-*.log" >/dev/null && break
  sleep 0.05
done
"$dualv" sim --can vcan0 --config "$config" --foreign --exit-after 600 --status-every 0 --plant-step-nominal \
  >"$tmp/sim.log" 2>&1 &
sim_pid=$!
wait_for "$tmp/sim.log" "drives booted" 10 || fail "dualv sim did not start"
grep -q "foreign drive: SDO uploads without size (e=1, s=0), objects absent: 60C2h" "$tmp/sim.log" ||
  fail "dualv sim did not report the foreign drive"

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

echo "=== foreign drive: dualv run --can vcan0 exit $run_rc"
grep -E "skipped|drives booted|^(loop:|bus:)|STOPPED|stop" "$tmp/run.log" | head -n 20

# 1. boot
booted=1
grep -q "drives booted" "$tmp/run.log" || { booted=0; fail "boot: the drives did not boot"; }
for n in 1 2 3 4; do
  grep -q "node $n: interpolation_period skipped (optional): 60C2h sub1 .* aborted 06020000h" \
    "$tmp/run.log" || fail "boot: no skip of 60C2h logged for node $n"
done

# 2. wire (candump -l lines: "(time) vcan0 ID#DATA")
if [[ -z "$capture" || ! -s "$capture" ]]; then
  fail "wire: no candump log"
else
  grep -Eq " 58[1-4]#42" "$capture" || fail "wire: no upload response without size (42h)"
  grep -Eq " 58[1-4]#4[3-9A-F]" "$capture" && fail "wire: an upload response with size (the drive is foreign)"
  grep -Eq " 58[1-4]#80C2600.00000206" "$capture" || fail "wire: no abort 06020000h for 60C2h"
  grep -Eq " 60[1-4]#23061000E8030000" "$capture" || fail "wire: 1006h = 1000 us not written"
  if [[ $run_rc -eq 0 ]]; then
    grep -Eq " 20[1-4]#0F00" "$capture" || fail "wire: no drive was sent enable operation (0Fh)"
  fi
fi

# 3. the run
if [[ $booted -eq 1 && $run_rc -ne 0 ]]; then
  # Timing stops only: the loop's deadline and staleness watchdogs, a drive lost to a
  # heartbeat gap, or (issue 12 points 1 and 6) the drives stopping in cycle 0 because the
  # host was silent between boot and the first cycle: EMCY 8130h (their 1016h consumer of
  # the host's heartbeat) or 8250h (their RPDO deadline).
  timing=0
  # One or more timing causes, e.g. "safety stop (stale feedback, consecutive deadline misses)".
  grep -Eq "safety stop \(((consecutive deadline misses|deadline miss|stale feedback|drive lost)(, )?)+\)" \
    "$tmp/run.log" && timing=1
  grep -Eq "cycle 0 .*safety stop \(drive fault\)" "$tmp/run.log" &&
    grep -Eq "EMCY (8130|8250)h active" "$tmp/run.log" && timing=1
  if [[ $timing -eq 1 ]]; then
    guest_timing "run: dualv run --can exited $run_rc on the loop's timing watchdogs"
    echo "NOTE: the run stopped on host timing in the guest (exit $run_rc, see above); boot and wire" \
      "were checked; the loop's start-up and timing are issue 12's"
  else
    fail "run: dualv run --can exited $run_rc"
  fi
fi

if [[ $failed -ne 0 ]]; then
  show "$tmp/run.log" "$tmp/sim.log"
  exit 1
fi
echo "foreign drive HIL: boots without 60C2h and with uploads without size; paper program run (exit $run_rc)"
exit 0
