#!/usr/bin/env bash
# HIL: `dualv sim --can vcan0` as its own process answers like four CiA 402 drives on real
# SocketCAN (run through run_in_vcan.sh, see README.md). Checked with can-utils only:
#   - power-on boot-ups 701#00..704#00, and again after `cansend vcan0 000#8100` (NMT reset
#     all nodes, CiA 301 7.2.8.3.1)
#   - `cansend vcan0 601#4041600000000000` (SDO upload 6041h) answered with
#     581#4B41600040020000 (2 bytes: 0240h = Switch on disabled + remote)
#   - the e-stop input (--estop-after) makes 60FDh bit 16 readable by SDO
#   - SIGTERM ends the process cleanly with status 0
# Usage: dualv_sim_hil.sh DUALV_BINARY CONFIG_YAML
set -u
. "$(dirname "$0")/hil_lib.sh"
dualv=${1:?usage: dualv_sim_hil.sh DUALV_BINARY CONFIG_YAML}
config=${2:?usage: dualv_sim_hil.sh DUALV_BINARY CONFIG_YAML}
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dualv-sim-hil.XXXXXX") || exit 1
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

candump -L vcan0 >"$tmp/dump.log" 2>&1 &
dump_pid=$!
sleep 0.3
"$dualv" sim --can vcan0 --config "$config" --exit-after 60 --status-every 0 \
  --estop-after 2.0 >"$tmp/sim.log" 2>&1 &
sim_pid=$!
wait_for "$tmp/sim.log" "drives booted" 10 || fail "dualv sim did not start"
wait_for "$tmp/dump.log" " 704#00" 5 || fail "no power-on boot-up of node 4"

cansend vcan0 000#8100
sleep 0.5
cansend vcan0 601#4041600000000000
wait_for "$tmp/dump.log" " 581#" 5 || fail "no SDO response from node 1"
wait_for "$tmp/sim.log" "e-stop input pressed" 10 || fail "e-stop not pressed"
cansend vcan0 602#40FD600000000000
wait_for "$tmp/dump.log" " 582#" 5 || fail "no SDO response from node 2"

kill -TERM "$sim_pid"
wait "$sim_pid"
sim_rc=$?
sim_pid=
sleep 0.2
kill "$dump_pid" 2>/dev/null
wait "$dump_pid" 2>/dev/null
dump_pid=

frames=$(awk '{print $3}' "$tmp/dump.log")
[[ $sim_rc -eq 0 ]] || fail "dualv sim exited with $sim_rc after SIGTERM"
grep -q "stopped (signal)" "$tmp/sim.log" || fail "dualv sim did not report a clean stop"
for n in 1 2 3 4; do
  c=$(grep -c "^70$n#00\$" <<<"$frames")
  [[ $c -eq 2 ]] || fail "node $n: $c boot-ups, expected 2 (power-on, NMT reset)"
done
# Order: the second boot-ups come after the NMT reset.
awk '$3 == "000#8100" {r = NR} $3 == "701#00" && r && NR > r {ok = 1} END {exit !ok}' \
  "$tmp/dump.log" || fail "no boot-up after the NMT reset"
# 6041h: Switch on disabled (0240h), with the warning bit 7 (02C0h) when the e-stop input
# (--estop-after 2.0) was already pressed: on a loaded host the request can come after it.
grep -qE "^581#4B416000(40|C0)020000\$" <<<"$frames" || fail "6041h upload: wrong answer"
grep -q "^582#43FD600000000100\$" <<<"$frames" || fail "60FDh upload: e-stop bit 16 not set"
echo "dualv sim HIL: boot-ups, NMT reset, SDO 6041h and 60FDh, clean SIGTERM: ok"
exit 0
