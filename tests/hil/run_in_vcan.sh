#!/usr/bin/env bash
# Runs a command where SocketCAN interfaces vcan0 (.. vcanN-1) are up, and exits with the
# command's exit status. Used by ctest (dualv_add_hil_test, label hil) and by hand:
#
#   tests/hil/run_in_vcan.sh [--timeout S] [--vcans N] [--mode auto|uml|netns|host]
#                            [--clock real|virtual] [--kernel PATH] [--shim PATH]
#                            [--] COMMAND [ARGS...]
#
# Modes (auto picks the first that works):
#   netns  the host kernel has vcan and we are root: the command runs in a private network
#          namespace with its own vcan0.. and loopback (parallel runs never see each other)
#   host   vcan0 already exists on the host (a target PC set up by its admin): the command
#          runs directly against it (parallel runs share that bus)
#   uml    otherwise (build machines and CI, whose kernel has no CONFIG_CAN): the command runs
#          inside Debian's user-mode-linux guest (package user-mode-linux), root = host's /,
#          with vcan0.. up and loopback multicast routed for LCM. About 3 s of overhead.
#
# In the guest the command keeps the caller's environment and working directory and runs as
# root; /tmp is the host's /tmp; guest timing is coarse (assert ordering, not latency).
#
# Clocks (--clock, default real):
#   real     the guest's clocks are the host's: its one virtual CPU, which the host freezes
#            as a whole under load, often cannot keep a 1 kHz loop's timing
#   virtual  always uml, on the time-travel kernel tests/hil/uml_kernel/build.sh builds
#            (--kernel, default build/uml-kernel/linux beside this checkout), booted with
#            time-travel=inf-cpu: guest time advances only while every guest task sleeps, so
#            computing and system calls take no guest time and every deadline of the shipped
#            configuration holds whatever the host does; the kernel, its CAN stack and the
#            sockets are real (tests/hil/README.md "Guest clocks"). The command sees
#            DUALV_HIL_CLOCK=virtual. Without the kernel: skipped (77), or 125 when
#            DUALV_HIL_REQUIRE_VIRTUAL=1 (scripts/test.sh)
# The command's output (stdout and stderr together) is printed when it has finished.
#
# Exit status: the command's; 124 on timeout; 125 when the guest died or could not be set
# up (the console log's tail is printed); 127 when the command does not exist; 77 (skip)
# when an AddressSanitizer build would have to run in the guest, where ASan cannot work
# (the guest's 39-bit address space overlaps ASan's fixed shadow memory); 2 on bad usage.
#
# Environment: DUALV_HIL_TIMEOUT (default 300 s), DUALV_HIL_VCANS (default 1),
# DUALV_HIL_MODE (default auto), DUALV_UML_SHIM (see uml_xstate_shim.c), DUALV_UML_MEM
# (default 256M), DUALV_HIL_KEEP=1 keeps the run folder, DUALV_HIL_CLOCK (default real),
# DUALV_UML_KERNEL (the virtual clock's kernel). The command sees DUALV_HIL set to the mode
# it runs in.
set -u

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
timeout_s=${DUALV_HIL_TIMEOUT:-300}
vcans=${DUALV_HIL_VCANS:-1}
mode=${DUALV_HIL_MODE:-auto}
shim=${DUALV_UML_SHIM:-}
mem=${DUALV_UML_MEM:-256M}
keep=${DUALV_HIL_KEEP:-0}
clock=${DUALV_HIL_CLOCK:-real}
kernel=${DUALV_UML_KERNEL:-$(cd "$here/../.." && pwd)/build/uml-kernel/linux}

usage() {
  awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "${BASH_SOURCE[0]}" >&2
  exit 2
}
while [[ $# -gt 0 ]]; do
  case $1 in
    --timeout) timeout_s=${2:?}; shift 2 ;;
    --vcans) vcans=${2:?}; shift 2 ;;
    --mode) mode=${2:?}; shift 2 ;;
    --shim) shim=${2:?}; shift 2 ;;
    --clock) clock=${2:?}; shift 2 ;;
    --kernel) kernel=${2:?}; shift 2 ;;
    --help | -h) usage ;;
    --) shift; break ;;
    -*) echo "run_in_vcan: unknown option $1" >&2; usage ;;
    *) break ;;
  esac
done
[[ $# -gt 0 ]] || usage
[[ "$timeout_s" =~ ^[0-9]+$ && "$vcans" =~ ^[0-9]+$ && "$vcans" -ge 1 ]] || usage

log() { echo "run_in_vcan: $*" >&2; }

case $clock in
  real) ;;
  virtual)
    # Time travel exists only in a guest of our own kernel: never the host's clock.
    mode=uml
    if [[ ! -x "$kernel" ]]; then
      log "no time-travel UML kernel at $kernel: build it with tests/hil/uml_kernel/build.sh" \
        "(Debian's linux-source-6.1; scripts/test.sh does)"
      [[ "${DUALV_HIL_REQUIRE_VIRTUAL:-0}" == 1 ]] && exit 125
      exit 77
    fi
    ;;
  *) log "unknown clock '$clock' (real, virtual)"; exit 2 ;;
esac
export DUALV_HIL_CLOCK=$clock

if ! command -v -- "$1" >/dev/null 2>&1; then
  log "command '$1' not found (not built yet?)"
  exit 127
fi

netns_works() {
  [[ $(id -u) -eq 0 ]] && command -v unshare >/dev/null && command -v ip >/dev/null &&
    unshare --net -- ip link add dev vcan0 type vcan >/dev/null 2>&1
}

if [[ "$mode" == auto ]]; then
  if netns_works; then
    mode=netns
  elif ip link show vcan0 >/dev/null 2>&1; then
    mode=host
  else
    mode=uml
  fi
fi

case $mode in
  host)
    export DUALV_HIL=host
    exec timeout -k 5 "$timeout_s" "$@"
    ;;
  netns)
    export DUALV_HIL=netns
    # shellcheck disable=SC2016
    exec timeout -k 5 "$timeout_s" unshare --net -- bash -c '
      fail() { echo "run_in_vcan (network namespace set-up): $*" >&2; exit 125; }
      n=$1; shift
      ip link set lo up && ip link set lo multicast on && ip route add 224.0.0.0/4 dev lo ||
        fail "loopback multicast"
      for ((i = 0; i < n; ++i)); do
        ip link add dev "vcan$i" type vcan && ip link set "vcan$i" up || fail "vcan$i"
      done
      exec "$@"' run_in_vcan "$vcans" "$@"
    ;;
  uml) ;;
  *) log "unknown mode '$mode' (auto, uml, netns, host)"; exit 2 ;;
esac

# --- user-mode-linux --------------------------------------------------------------------
asan_skip() {
  log "skipped: $1 is built with AddressSanitizer, which cannot run inside user-mode-linux" \
    "(its 39-bit address space overlaps ASan's shadow memory); run HIL tests from a build" \
    "without DUALV_SANITIZE, or on a host whose kernel has vcan"
  exit 77
}
cmd_path=$(command -v -- "$1")
if [[ -f "$cmd_path" ]] && grep -qa -e __asan_init "$cmd_path"; then
  asan_skip "$1"
fi
# A script that runs a program given as an argument (tests/hil/*.sh DUALV_BINARY ...).
for arg in "${@:2}"; do
  if [[ -f "$arg" && -x "$arg" ]] && grep -qa -e __asan_init "$arg"; then
    asan_skip "$arg"
  fi
done

uml_args=()
if [[ "$clock" == virtual ]]; then
  uml=$kernel
  uml_args=(time-travel=inf-cpu)
else
  uml=$(command -v linux.uml || true)
  if [[ -z "$uml" ]]; then
    log "linux.uml not found: install Debian's user-mode-linux (scripts/install-deps.sh)"
    exit 125
  fi
fi

# A fresh folder per run: several guests may run at once (ctest -j). The guest sees it at
# the same path because its root is the host's /.
run_dir=$(mktemp -d "${TMPDIR:-/tmp}/dualv-hil.XXXXXX") || exit 125
if [[ "$run_dir" == *[[:space:]]* ]]; then
  log "run folder '$run_dir' contains spaces (kernel command line): set TMPDIR"
  rm -rf "$run_dir"
  exit 125
fi
uml_pid=
# shellcheck disable=SC2317  # invoked by the EXIT trap
cleanup() {
  [[ -n "$uml_pid" ]] && kill "$uml_pid" 2>/dev/null
  if [[ "$keep" == 1 ]]; then
    log "kept $run_dir"
  else
    rm -rf "$run_dir"
  fi
}
trap cleanup EXIT
trap 'exit 143' TERM
trap 'exit 130' INT

if [[ -z "$shim" || ! -f "$shim" ]]; then
  # Not built by CMake (run by hand): build it here, it takes a fraction of a second.
  shim=$run_dir/uml_xstate_shim.so
  if ! cc -O2 -shared -fPIC -o "$shim" "$here/uml_xstate_shim.c" -ldl 2>"$run_dir/shim.log"; then
    log "cannot build $here/uml_xstate_shim.c:"
    cat "$run_dir/shim.log" >&2
    exit 125
  fi
fi

# The command, its working directory and environment, for guest-init.sh to source.
{
  DUALV_HIL_CMD=("$@")
  declare -p DUALV_HIL_CMD
  printf 'DUALV_HIL_CWD=%q\n' "$PWD"
  while IFS= read -r name; do
    case $name in
      LD_PRELOAD | SHLVL | PWD | OLDPWD | _ | BASH_* | SHELLOPTS | BASHOPTS | DUALV_HIL_*) ;;
      *) printf 'export %s=%q\n' "$name" "${!name}" ;;
    esac
  done < <(compgen -e)
  echo 'export DUALV_HIL=uml'
  printf 'export DUALV_HIL_CLOCK=%q\n' "$clock"
  # Keep glibc's string functions off AVX-512 registers, which the UML 6.1 guest does not
  # save per thread (see uml_xstate_shim.c).
  hw='glibc.cpu.hwcaps=-AVX512F,-AVX512VL,-AVX512BW,-AVX512DQ,-AVX512CD'
  printf 'export GLIBC_TUNABLES=%q\n' "${GLIBC_TUNABLES:+$GLIBC_TUNABLES:}$hw"
} >"$run_dir/env.sh"
cp "$here/guest-init.sh" "$run_dir/guest-init.sh" && chmod +x "$run_dir/guest-init.sh" || exit 125
mkdir -p "$run_dir/uml"

# stdin from /dev/null and console on fds 0/1: no tty needed (ctest, CI).
LD_PRELOAD=$shim timeout -k 5 "$timeout_s" "$uml" \
  mem="$mem" rootfstype=hostfs rw uml_dir="$run_dir/uml" umid=hil \
  init="$run_dir/guest-init.sh" con=null con0=fd:0,fd:1 "${uml_args[@]}" \
  dualv_hil_dir="$run_dir" dualv_hil_vcans="$vcans" \
  </dev/null >"$run_dir/console.log" 2>&1 &
uml_pid=$!
wait "$uml_pid"
uml_rc=$?
uml_pid=

[[ -f "$run_dir/output" ]] && cat "$run_dir/output"
if [[ -f "$run_dir/status" ]]; then
  rc=$(<"$run_dir/status")
  if [[ "$rc" != 0 ]] && grep -q 'ASan shadow was supposed to be' "$run_dir/output" 2>/dev/null; then
    asan_skip "a program the command ran"
  fi
  if [[ "$rc" == 125 ]] && grep -q 'guest set-up' "$run_dir/output" 2>/dev/null; then
    log "guest set-up failed; console tail:"
    tail -n 30 "$run_dir/console.log" >&2
  fi
  exit "$rc"
fi
if [[ $uml_rc -eq 124 || $uml_rc -eq 137 ]]; then
  log "timed out after ${timeout_s}s (no exit status from the guest); console tail:"
  tail -n 30 "$run_dir/console.log" >&2
  exit 124
fi
log "the guest died without writing an exit status (linux.uml exited $uml_rc); console tail:"
tail -n 40 "$run_dir/console.log" >&2
exit 125
