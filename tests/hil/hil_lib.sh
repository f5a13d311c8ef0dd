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

# skip_outside_lcm_guest: exit 77 (ctest: skipped) unless this runs in the HIL guest or a
# private network namespace, the only places LCM's UDP multicast may be sent.
skip_outside_lcm_guest() {
  if [[ "${DUALV_HIL:-}" != uml && "${DUALV_HIL:-}" != netns ]]; then
    echo "skipped: LCM multicast only inside the guest or a private network namespace"
    exit 77
  fi
}
