#!/bin/bash
# PID 1 inside the user-mode-linux guest started by run_in_vcan.sh (never run it by hand).
#
# The guest's root is the host's / (hostfs), so every path is the host's. The host passes
# dualv_hil_dir (the run folder) and dualv_hil_vcans on the kernel command line, which the
# kernel hands to init as environment. We set up SocketCAN and loopback multicast, run the
# command from $dualv_hil_dir/env.sh with its output in $dualv_hil_dir/output, write its
# exit status to $dualv_hil_dir/status and halt. The host reads that file: the exit status
# of linux.uml itself says nothing about the command.
export PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
dir=${dualv_hil_dir:-}
vcans=${dualv_hil_vcans:-1}

halt_guest() {
  sync
  # The caller's environment (sourced below) may have replaced PATH.
  PATH=/usr/sbin:/usr/bin:/sbin:/bin halt -f >/dev/null 2>&1
  # If halt is missing or refuses, leaving PID 1 ends the guest too (with a panic).
  exit 0
}

if [[ -z "$dir" || ! -d "$dir" ]]; then
  echo "guest-init: dualv_hil_dir not set or missing ('$dir')" >&2
  halt_guest
fi
out=$dir/output
: >"$out"

finish() {
  echo "$1" >"$dir/status.tmp"
  mv -f "$dir/status.tmp" "$dir/status"
  halt_guest
}
setup_fail() {
  echo "run_in_vcan (guest set-up): $*" >>"$out"
  finish 125
}

mount -t proc proc /proc || setup_fail "mount proc"
mount -t sysfs sysfs /sys || setup_fail "mount sysfs"
# bash's process substitution (<(...)) opens /dev/fd/N, which devtmpfs lacks (udev makes the
# links on a full system).
[[ -e /dev/fd ]] || ln -s /proc/self/fd /dev/fd
[[ -e /dev/stdin ]] || ln -s /proc/self/fd/0 /dev/stdin
[[ -e /dev/stdout ]] || ln -s /proc/self/fd/1 /dev/stdout
[[ -e /dev/stderr ]] || ln -s /proc/self/fd/2 /dev/stderr
# /dev is the guest's devtmpfs; give it a private /dev/shm for POSIX shared memory.
mkdir -p /dev/shm && mount -t tmpfs -o mode=1777 tmpfs /dev/shm || setup_fail "mount /dev/shm"

# Debian's linux.uml has SocketCAN as modules; the time-travel kernel
# (tests/hil/uml_kernel/build.sh) has it built in.
if [[ ! -d /proc/net/can ]]; then
  kdir=/usr/lib/uml/modules/$(uname -r)/kernel
  [[ -d "$kdir" ]] || setup_fail "no UML modules in $kdir (install user-mode-linux)"
  for m in net/can/can.ko net/can/can-raw.ko drivers/net/can/dev/can-dev.ko \
    drivers/net/can/vcan.ko; do
    insmod "$kdir/$m" >>"$out" 2>&1 || setup_fail "insmod $kdir/$m failed"
  done
  # Optional: can-bcm for tools that use it, sch_plug so tests can fill a transmit queue.
  for m in net/can/can-bcm.ko net/sched/sch_plug.ko; do
    [[ -f "$kdir/$m" ]] && insmod "$kdir/$m" >/dev/null 2>&1
  done
fi

for ((i = 0; i < vcans; ++i)); do
  ip link add dev "vcan$i" type vcan >>"$out" 2>&1 || setup_fail "ip link add vcan$i"
  ip link set "vcan$i" up >>"$out" 2>&1 || setup_fail "ip link set vcan$i up"
done
# LCM's UDP multicast stays inside the guest: loopback only (docs/architecture.md).
ip link set lo up && ip link set lo multicast on && ip route add 224.0.0.0/4 dev lo ||
  setup_fail "loopback multicast set-up"
hostname dualv-hil 2>/dev/null

# On the virtual clock (time-travel=inf-cpu) the guest's first sleep after boot ends ~7 ms late
# (seen in every run; every later one at its deadline plus the 50 us timer slack): taken here,
# not in the command's first cycles.
grep -qw 'time-travel=inf-cpu' /proc/cmdline && sleep 0.1

# env.sh sets DUALV_HIL_CMD (array), DUALV_HIL_CWD and the caller's exported environment.
# shellcheck disable=SC1091
source "$dir/env.sh" || setup_fail "cannot read $dir/env.sh"
cd "$DUALV_HIL_CWD" || setup_fail "cannot cd to $DUALV_HIL_CWD"
"${DUALV_HIL_CMD[@]}" >>"$out" 2>&1 </dev/null
finish $?
