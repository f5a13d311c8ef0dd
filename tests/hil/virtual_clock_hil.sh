#!/usr/bin/env bash
# The virtual clock itself (run_in_vcan.sh --clock virtual; tests/hil/README.md "Guest clocks:
# real and virtual"), which every *_virtual_clock test relies on: in that guest computing takes
# no guest time, and a sleep until a deadline ends at the deadline, on CLOCK_MONOTONIC and
# CLOCK_REALTIME alike. On the real clock's guest the computing below takes ~0.3 s: it fails there.
set -u
. "$(dirname "$0")/hil_lib.sh"
on_virtual_clock || { echo "FAIL: not on the virtual clock (DUALV_HIL_CLOCK=${DUALV_HIL_CLOCK:-})"; exit 1; }
grep -qw 'time-travel=inf-cpu' /proc/cmdline || { echo "FAIL: the guest was not booted in time travel: $(cat /proc/cmdline)"; exit 1; }
exec python3 - <<'PY'
import hashlib, sys, time

def clocks():
    return time.monotonic(), time.time()

# ~0.3 s of host CPU: 256 MiB through SHA-256.
block = bytes(1 << 20)
m0, r0 = clocks()
h = hashlib.sha256()
for _ in range(256):
    h.update(block)
m1, r1 = clocks()
busy = m1 - m0
# Sleeps: each must end at its deadline, not before, and not later than the kernel's timer
# slack (50 us for SCHED_OTHER) allows.
late = []
for want in (0.001, 0.010, 0.5):
    a = time.monotonic()
    time.sleep(want)
    late.append(time.monotonic() - a - want)
m2, r2 = clocks()
print(f"virtual clock: 256 MiB hashed in {busy * 1e3:.3f} ms of guest time; sleeps of 1 ms, "
      f"10 ms, 0.5 s late by {', '.join(f'{x * 1e6:.0f}' for x in late)} us; "
      f"CLOCK_REALTIME moved {(r2 - r0) * 1e3:.3f} ms while CLOCK_MONOTONIC moved {(m2 - m0) * 1e3:.3f} ms")
errors = []
if busy > 0.005:
    errors.append(f"computing took {busy * 1e3:.1f} ms of guest time (expected none)")
for want, x in zip((0.001, 0.010, 0.5), late):
    if x < 0 or x > 0.001:
        errors.append(f"a sleep of {want} s ended {x * 1e6:.0f} us after its deadline")
if abs((r2 - r0) - (m2 - m0)) > 0.001:
    errors.append("CLOCK_REALTIME and CLOCK_MONOTONIC disagree")
for e in errors:
    print("FAIL:", e)
sys.exit(1 if errors else 0)
PY
