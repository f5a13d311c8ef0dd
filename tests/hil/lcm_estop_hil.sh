#!/usr/bin/env bash
# HIL (inside the user-mode-linux guest, where LCM multicast stays on the guest's loopback):
# `dualv estop` from another process stops a running `dualv run` over LCM. Checks that the
# run ends in a safety stop caused by the LCM e-stop, carried out as SS1 then STO, both in
# the fault log. The guest's timing is coarse (ms-scale stalls), so its copy of the
# configuration tolerates deadline misses: this test is about the command path.
# Usage: lcm_estop_hil.sh DUALV_BINARY CONFIG_YAML
set -u
. "$(dirname "$0")/hil_lib.sh"
dualv=${1:?usage: lcm_estop_hil.sh DUALV_BINARY CONFIG_YAML}
config=${2:?usage: lcm_estop_hil.sh DUALV_BINARY CONFIG_YAML}
skip_outside_lcm_guest
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dualv-estop-hil.XXXXXX") || exit 1
trap 'rm -rf "$tmp"' EXIT
url='udpm://239.255.76.67:7667?ttl=0'
sed -E 's/^( *max_consecutive_deadline_misses:) *[0-9]+/\1 1000/' "$config" >"$tmp/dualv.yaml"
grep -q "max_consecutive_deadline_misses: 1000" "$tmp/dualv.yaml" || { echo "config edit failed"; exit 1; }
"$dualv" run -c "$tmp/dualv.yaml" -p "$(dirname "$config")/paper.yaml" --realtime --variant retimed --no-plots --out "$tmp/out" --lcm "$url" >"$tmp/run.log" 2>&1 &
run_pid=$!
sleep 2
"$dualv" estop --lcm "$url" >"$tmp/estop.log" 2>&1 || { cat "$tmp/estop.log"; exit 1; }
wait "$run_pid"
rc=$?
fail() {
  echo "FAIL: $*"
  cat "$tmp/run.log"
  exit 1
}
[[ $rc -eq 1 ]] || fail "dualv run exited $rc, expected 1 (stopped)"
grep -q "safety stop (e-stop (LCM))" "$tmp/run.log" || fail "no LCM e-stop in the run's report"
grep -q '"cause":"e-stop (LCM)","reaction":"SS1"' "$tmp/out/faults.jsonl" || fail "no SS1 event"
grep -q '"event":"stop reached","cause":"","reaction":"STO"' "$tmp/out/faults.jsonl" ||
  fail "SS1 did not end in STO"
echo "PASS: LCM e-stop -> SS1 -> STO"
