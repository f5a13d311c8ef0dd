# Helpers shared by the HIL scripts (sourced: `. "$(dirname "$0")/hil_lib.sh"`).

# wait_for FILE PATTERN SECONDS: 0 as soon as FILE has a line matching PATTERN (grep's basic
# regex), 1 after SECONDS. The guest's timing is coarse: wait for what a process says it did,
# never for a fixed time.
wait_for() {
  local n=$(($3 * 20))
  for ((i = 0; i < n; ++i)); do
    grep -q -- "$2" "$1" 2>/dev/null && return 0
    sleep 0.05
  done
  return 1
}

# on_virtual_clock: 0 when the guest runs on the virtual clock (run_in_vcan.sh --clock virtual,
# DUALV_HIL_CLOCK=virtual): its time stands still while it computes, so it keeps every deadline
# of the shipped configuration whatever the host does (tests/hil/README.md "Guest clocks").
on_virtual_clock() { [[ ${DUALV_HIL_CLOCK:-real} == virtual ]]; }
# guest_timing WHAT: called where a script is about to excuse guest timing (a timing-watchdog
# stop retried, a NOTE, a skip). On the real clock it returns 0 and the script excuses it; on
# the virtual clock nothing is excused: it prints FAIL with WHAT and ends the script with 1.
guest_timing() {
  on_virtual_clock || return 0
  echo "FAIL (virtual clock: the guest keeps every deadline, nothing is excused as guest timing): $*"
  exit 1
}

# skip_outside_lcm_guest: exit 77 (ctest: skipped) unless this runs in the HIL guest or a
# private network namespace, the only places LCM's UDP multicast may be sent.
skip_outside_lcm_guest() {
  if [[ "${DUALV_HIL:-}" != uml && "${DUALV_HIL:-}" != netns ]]; then
    echo "skipped: LCM multicast only inside the guest or a private network namespace"
    exit 77
  fi
}

# lines_matching FILE PATTERN: the lines of FILE matching PATTERN (grep's basic regex); 0 without a file.
lines_matching() { grep -c -- "$2" "$1" 2>/dev/null || true; }

# wait_for_lines FILE PATTERN N SECONDS: 0 as soon as FILE has N lines matching PATTERN, 1 after
# SECONDS.
wait_for_lines() {
  local i
  for ((i = 0; i < $4 * 20; ++i)); do
    [[ $(lines_matching "$1" "$2") -ge $3 ]] && return 0
    sleep 0.05
  done
  return 1
}

# serve_reset DUALV KEY URL LOG: a signed `dualv reset` to a `dualv run --serve` logging to LOG.
# Waits until the service logged the reset's receipt and, when a stop is latched (more "torque
# off" lines than answers to resets), for the loop's answer ("reset accepted" / "reset
# refused"); with nothing latched the loop gives none. 1 if the receipt or the answer never came.
serve_reset() {
  local got answers latched
  got=$(lines_matching "$4" "reset (key ")
  answers=$(lines_matching "$4" "reset accepted\|reset refused")
  latched=$(($(lines_matching "$4" "torque off (STO)") > answers))
  "$1" reset --key "$2" --lcm "$3" >/dev/null || return 1
  wait_for_lines "$4" "reset (key " $((got + 1)) 20 || return 1
  [[ $latched -eq 0 ]] || wait_for_lines "$4" "reset accepted\|reset refused" $((answers + 1)) 20
}

# timing_stops: 0 when the fault-log lines on stdin (faults.jsonl) hold a stop by one of the
# loop's own timing watchdogs (safety/fault.hpp: consecutive deadline misses, stale feedback;
# both STO), the stops a slow guest causes whatever the test does.
timing_stops() {
  grep '"event":"fault"' | grep -qE '"cause":"(consecutive deadline misses|stale feedback)","reaction":"STO"'
}

# without_reaction: each fault text on stdin ("stale feedback drive 1: 3 (limit 3) -> STO")
# without its " -> REACTION".
without_reaction() { sed -E 's/ -> [A-Z0-9]+$//'; }

# stop_causes: the stopping faults (reaction SS1 or STO) of the faults.jsonl lines on stdin, one a
# line: its "text" without the " -> REACTION" (e.g. "stale feedback drive 1: 3 (limit 3)").
stop_causes() {
  grep '"event":"fault"' | grep -E '"reaction":"(SS1|STO)"' |
    sed -nE 's/.*"text":"([^"]*)".*/\1/p' | without_reaction
}

# first_stop_causes: the causes (as stop_causes prints them) of the first stop among the
# faults.jsonl lines on stdin: every stopping fault logged in the cycle of the first, as the
# safety filter found them together (bus-off is a bus error and every drive lost at once).
# Faults logged later while stopped (a monitor reading a coasting robot after feedback came
# back) did not cause the stop. A drive seen leaving Operation enabled is its own fault
# reaction (6007h abort connection option, sim/drive_emulator.cpp abort_connection) when its
# EMCY 8250h (RPDO deadline) or 8130h (the master's heartbeat) is logged within
# $tie_cycles cycles of it: the EMCY is sent at the trip, the new statusword with the next
# SYNC's TPDO, and either may be read first. That cause is then printed as the EMCY.
tie_cycles=20
first_stop_causes() {
  grep -E '"event":"fault".*"reaction":"(SS1|STO)"' |
    awk -v tie="$tie_cycles" '
      { n++; line[n] = $0; match($0, /"cycle":[0-9]+/); cyc[n] = substr($0, RSTART + 8, RLENGTH - 8) + 0 }
      match($0, /"text":"drive fault drive [0-9]+: EMCY 8(250|130)h/) {
        d = substr($0, RSTART + 8, RLENGTH - 8); sub(/: EMCY.*/, "", d)
        ne++; emcy_drive[ne] = d; emcy_cycle[ne] = cyc[n]; emcy_line[ne] = $0
      }
      END {
        for (i = 1; i <= n; i++) {
          if (cyc[i] != cyc[1]) continue
          out = line[i]
          if (match(line[i], /"text":"drive fault drive [0-9]+: left Operation enabled/)) {
            d = substr(line[i], RSTART + 8, RLENGTH - 8); sub(/: left.*/, "", d)
            for (k = 1; k <= ne; k++) {
              dc = emcy_cycle[k] - cyc[i]
              if (emcy_drive[k] == d && dc <= tie && dc >= -tie) { out = emcy_line[k]; break }
            }
          }
          if (!(out in seen)) { seen[out] = 1; print out }
        }
      }' |
    stop_causes
}

# timing_stops_only: 0 when the stopping faults on stdin (one a line: a faults.jsonl "text"
# without its " -> STO", e.g. "stale feedback drive 1: 3 (limit 3)") are all stops by the
# loop's own timing watchdogs (safety/fault.hpp: consecutive deadline misses, stale feedback,
# a drive lost to the heartbeat timeout) or by a drive's watchdog on the master's timing (EMCY
# 8250h: its RPDO deadline; 8130h: its consumer of the master's heartbeat): what a slow or
# frozen guest causes. 1 for an empty input.
timing_stops_only() {
  local causes
  causes=$(cat)
  [[ -n $causes ]] || return 1
  ! grep -vE '^((consecutive deadline misses|stale feedback|drive lost)( drive [0-9]+)?(: .*)?|drive fault drive [0-9]+: EMCY 8(250|130)h)$' \
    <<<"$causes" | grep -q .
}
