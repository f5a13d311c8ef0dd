#!/usr/bin/env python3
"""Where the CPU of a (user-mode-linux) guest went: per thread of the given processes, its
scheduling, lifetime, time running and time runnable but waiting for the CPU, from
/proc/PID/task/TID/schedstat (CONFIG_SCHED_INFO: ns on the CPU, ns waiting on a run queue,
time slices) and /proc/PID/task/TID/stat; and the whole CPU's busy/idle share since boot
(/proc/stat), or since an earlier copy of its first line (--since FILE). A diagnosis for
serve_can_hil.sh (issue 12): a loop thread that is late while runnable lost the CPU to other
tasks (or to the SCHED_FIFO throttling); one that is late while sleeping was woken late.
Prints a table; exit status 0 (a process that is gone is skipped).

Usage: guest_cpu.py [--since FILE] LABEL=PID [LABEL=PID ...]
  (FILE: `head -n 1 /proc/stat` taken earlier, e.g. when the service was up)
Standard library only (runs with Debian's /usr/bin/python3 in the guest).
"""
import os
import sys

POLICY = {0: "OTHER", 1: "FIFO", 2: "RR", 3: "BATCH", 5: "IDLE", 6: "DEADLINE"}


def read(path):
    with open(path) as f:
        return f.read()


def stat_fields(text):
    """Fields of /proc/.../stat after the command name (which may contain spaces)."""
    return text[text.rindex(")") + 2:].split()


def main(argv):
    hz = os.sysconf("SC_CLK_TCK")
    uptime = float(read("/proc/uptime").split()[0])
    since = "boot"
    cpu = [int(x) for x in read("/proc/stat").splitlines()[0].split()[1:8]]
    if len(argv) >= 2 and argv[0] == "--since":
        before = [int(x) for x in read(argv[1]).split()[1:8]]
        cpu = [a - b for a, b in zip(cpu, before)]
        since, argv = f"the reading in {os.path.basename(argv[1])}", argv[2:]
    idle = cpu[3] + cpu[4]  # idle + iowait, in clock ticks
    total = max(sum(cpu), 1)
    busy = 100.0 * (total - idle) / total
    print(f"guest CPU since {since} ({total / hz:.1f} s): busy {busy:.1f} % (user {100.0 * cpu[0] / total:.1f}, system {100.0 * cpu[2] / total:.1f}, softirq "
          f"{100.0 * cpu[6] / total:.1f}), idle {100.0 * idle / total:.1f} %")
    print(f"  {'process':<10} {'thread':<16} {'sched':<9} {'life s':>7} {'on CPU s':>9} "
          f"{'%':>5} {'waiting s':>9} {'%':>5} {'slices':>8}")
    for arg in argv:
        label, _, pid = arg.partition("=")
        try:
            tids = sorted(os.listdir(f"/proc/{pid}/task"), key=int)
        except OSError:
            print(f"  {label:<10} (pid {pid} gone)")
            continue
        for tid in tids:
            base = f"/proc/{pid}/task/{tid}"
            try:
                comm = read(f"{base}/comm").strip()
                f = stat_fields(read(f"{base}/stat"))
                run_ns, wait_ns, slices = (int(x) for x in read(f"{base}/schedstat").split())
            except (OSError, ValueError):
                continue
            # stat fields (proc(5)), counted from field 3 (state) as index 0
            start_s = int(f[19]) / hz
            rt_prio, policy = int(f[37]), int(f[38])
            life = max(uptime - start_s, 1e-9)
            sched = POLICY.get(policy, str(policy)) + (f" {rt_prio}" if rt_prio else "")
            print(f"  {label:<10} {comm:<16} {sched:<9} {life:7.1f} {run_ns * 1e-9:9.2f} "
                  f"{100.0 * run_ns * 1e-9 / life:5.1f} {wait_ns * 1e-9:9.2f} "
                  f"{100.0 * wait_ns * 1e-9 / life:5.1f} {slices:8d}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
