#!/usr/bin/env bash
# HIL (inside the user-mode-linux guest, where LCM multicast stays on the guest's loopback):
# the service mode. `dualv run --serve` runs a program on a signed `dualv start`, ignores a
# start signed with an unknown key, needs a signed reset after an e-stop before it accepts a
# start again, and a reset never starts anything by itself.
# Usage: lcm_serve_hil.sh DUALV_BINARY CONFIG_YAML
set -u
. "$(dirname "$0")/hil_lib.sh"
dualv=${1:?usage: lcm_serve_hil.sh DUALV_BINARY CONFIG_YAML}
config=${2:?usage: lcm_serve_hil.sh DUALV_BINARY CONFIG_YAML}
skip_outside_lcm_guest
tmp=$(mktemp -d "${TMPDIR:-/tmp}/dualv-serve-hil.XXXXXX") || exit 1
pid=
trap '[[ -n "$pid" ]] && kill "$pid" 2>/dev/null; rm -rf "$tmp"' EXIT
url='udpm://239.255.76.67:7667?ttl=0'
mkdir -p "$tmp/keys" "$tmp/other"
head -c 32 /dev/urandom >"$tmp/keys/lab1.key"
head -c 32 /dev/urandom >"$tmp/other/intruder.key"
chmod 600 "$tmp/keys/lab1.key" "$tmp/other/intruder.key"
# Coarse guest timing: tolerate deadline misses, this test is about the command path.
sed -E 's/^( *max_consecutive_deadline_misses:) *[0-9]+/\1 1000/' "$config" >"$tmp/dualv.yaml"
program=$(dirname "$config")/paper.yaml
"$dualv" run -c "$tmp/dualv.yaml" --serve --lcm "$url" --keys "$tmp/keys" --out "$tmp/out" \
  >"$tmp/run.log" 2>&1 &
pid=$!
fail() {
  echo "FAIL: $*"
  cat "$tmp/run.log"
  exit 1
}
wait_for "$tmp/run.log" "serving: waiting" 20 || fail "no service"
"$dualv" start "$program" --key "$tmp/other/intruder.key" --lcm "$url" >/dev/null
wait_for "$tmp/run.log" "refused (unknown key)" 10 || fail "a start with an unknown key was not refused"
grep -q "starting " "$tmp/run.log" && fail "a start with an unknown key ran"
"$dualv" start "$program" --key "$tmp/keys/lab1.key" --lcm "$url" >/dev/null
wait_for "$tmp/run.log" "paper.yaml done" 60 || fail "the signed start did not run the program"
"$dualv" estop --lcm "$url" >/dev/null
wait_for "$tmp/run.log" "a reset is needed" 10 || fail "e-stop while idle not latched"
"$dualv" start "$program" --key "$tmp/keys/lab1.key" --lcm "$url" >/dev/null
wait_for "$tmp/run.log" "refused: the last stop has not been reset" 10 || fail "start accepted without a reset"
"$dualv" reset --key "$tmp/keys/lab1.key" --lcm "$url" >/dev/null
wait_for "$tmp/run.log" "reset (key lab1)" 10 || fail "signed reset not accepted"
sleep 1
[[ $(grep -c "^dualv run: starting " "$tmp/run.log") -eq 1 ]] || fail "a reset started motion"
echo "PASS: signed start runs; unknown key refused; e-stop needs a reset; reset starts nothing"
