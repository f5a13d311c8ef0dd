#!/usr/bin/env python3
"""Checks a `candump -l` capture of a `dualv run --serve --can` session (serve_can_hil.sh).

Standard library only (runs with Debian's /usr/bin/python3 inside the user-mode-linux guest).
Reads can.rpdo_deadline, can.drives (node_id, rated_torque, max_torque) and safety.torque.max
from the configuration the service used, and checks, between the first and the last SYNC on
the wire (the service's loop runs from boot to shutdown: idle, programs, stream, stops):
  - no gap between consecutive SYNCs (080h), nor between consecutive RPDO1s of one drive
    (200h + node), longer than can.rpdo_deadline. The guest cannot keep that timing when the
    host freezes it as a whole (host load): with --stalls FILE (the guest's stall probe,
    serve_can_hil.sh), a gap is excused when, without the time the whole guest was frozen
    within it, it is within the deadline; excused gaps are counted and printed, never hidden.
    With --min-rate S, when the SYNCs on the wire came at less than S times the configured
    rate (1 / can.sync.period) over the span, the machine running the test did not carry the
    loop's rate (a user-mode-linux guest: tests/hil/README.md "What a cycle costs in the
    guest"): the gaps not excused are printed as a NOTE with the rate instead of failing.
    A host that carries the rate (a PC with vcan) has every gap checked: a loop that pauses
    (in a mode change, while a program is prepared) costs it a few cycles, not a share of its
    rate (every other check below holds either way)
  - every SYNC after each drive's first RPDO has exactly one RPDO of every drive since the
    previous SYNC (this does not depend on timing: the loop never skips a drive in a cycle).
    The exceptions are frames that never reached the wire, each counted where it was lost, so
    a SYNC interval that breaks the rule is allowed only while the frames it needs lost (at
    least: a SYNC for each RPDO of a drive beyond the first, an RPDO for each drive below the
    most, `lost_frames`) fit within those counts, and is printed:
      - a frame the kernel refused to queue (ENOBUFS, a full socket send buffer while the
        receivers could not run: the master drops that frame and counts it,
        drivers/canopen_actuator_set.cpp): with --run-log, the service's output, whose "bus:"
        report gives the master's ENOBUFS count;
      - a frame the guest kernel dropped from its per-CPU input backlog before any socket, the
        drives' and the capture's, saw it (a loaded user-mode-linux guest: seen as a SYNC lost
        with the RPDOs just before it, "SYNC n after 2 RPDOs 201"): with --kernel-drops N,
        /proc/net/softnet_stat's drop count over the run (serve_can_hil.sh). A host that
        carries the rate drops none, and there the rule holds frame for frame
  - no target torque above min(safety.torque.max, the drive's max_torque), from per mille of
    the drive's rated_torque (RPDO1: controlword u16 + target torque i16, little endian;
    firmware_if/pdo.hpp), half an LSB allowed
  - with --expect-enables N (or MIN-MAX): exactly N (MIN to MAX) enable episodes (spans in which some drive's
    controlword is "enable operation", 0Fh); each program or stream that ran is one
  - every stop is a stop on the wire, whatever ended it (a program's end, an e-stop, a timing
    watchdog in a frozen guest): a target torque other than 0 only with the controlword
    "enable operation" (so torque is 0 from the first RPDO of an episode's end on), and after
    every episode each drive's statusword (TPDO1 180h + node: statusword u16 + position i32)
    leaves "operation enabled" (CiA 402: statusword & 6Fh == 27h) before the next episode
Exit status 0 when everything holds, 1 otherwise (every problem is printed).
"""
import argparse
import bisect
import re
import sys

from wire_check_common import (config_drives, config_bus_layout, config_torque_max, frames,
                               read_config)

TOOL = "check_serve_wire"


def parse_config(path):
    text = read_config(path)
    drives = config_drives(text, path, TOOL)
    layout = config_bus_layout(text)
    if layout and layout != "per_drive":
        raise SystemExit(f"{TOOL}: bus_layout {layout}: only per_drive is checked")
    can = text[text.index("\ncan:"):]
    deadline = re.search(r"\n  rpdo_deadline:\s*([0-9.eE+-]+)", can)
    if not deadline or float(deadline.group(1)) <= 0:
        raise SystemExit(f"{TOOL}: no positive can.rpdo_deadline in {path}")
    period = re.search(r"\n  sync:\s*\n    period:\s*([0-9.eE+-]+)", can)
    if not period or float(period.group(1)) <= 0:
        raise SystemExit(f"{TOOL}: no positive can.sync.period in {path}")
    return (drives, float(deadline.group(1)), float(period.group(1)),
            config_torque_max(text, path, TOOL))


def parse_stalls(path):
    """Intervals (a, b) in CLOCK_REALTIME seconds in which the guest's probe did not run,
    sorted, overlapping ones merged."""
    out = []
    if path:
        with open(path) as f:
            for line in f:
                p = line.split()
                if len(p) == 2:
                    out.append((float(p[0]), float(p[1])))
    merged = []
    for a, b in sorted(out):
        if merged and a <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(merged[-1][1], b))
        else:
            merged.append((a, b))
    return merged


class FrozenTime:
    """The time within [t1, t2] covered by the stalls (parse_stalls: sorted, disjoint), found by
    bisection: a 5-minute service in the guest has ~30 000 gaps and ~20 000 stalls, too many to
    compare every pair (minutes of Python in the guest, near the test's time limit)."""

    def __init__(self, stalls):
        self.starts = [a for a, _ in stalls]
        self.ends = [b for _, b in stalls]
        self.before = [0.0]  # before[i]: the stalls' total length before the i-th
        for a, b in stalls:
            self.before.append(self.before[-1] + b - a)

    def within(self, t1, t2):
        i = bisect.bisect_right(self.ends, t1)  # the first stall ending after t1
        j = bisect.bisect_left(self.starts, t2)  # the first stall starting at t2 or later
        if i >= j:
            return 0.0
        return (self.before[j] - self.before[i] - max(0.0, t1 - self.starts[i])
                - max(0.0, self.ends[j - 1] - t2))


def lost_frames(counts):
    """The fewest frames lost for one SYNC interval whose drives' RPDO counts are COUNTS, when
    the master sent exactly one RPDO of every drive per SYNC: with m the largest count (at
    least 1), m - 1 SYNCs between them and m - k RPDOs of a drive that shows k."""
    counts = list(counts)
    m = max([1, *counts])
    return m - 1 + sum(m - k for k in counts)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", required=True, help="the YAML the service used")
    ap.add_argument("--stalls", help="the guest stall probe's intervals (start end per line)")
    ap.add_argument("--min-rate", type=float,
                    help="when the SYNCs came at less than this share of the configured rate, "
                         "the gaps are a NOTE, not a failure (a machine that did not carry it)")
    ap.add_argument("--run-log", help="the service's output, with its 'bus:' report (ENOBUFS)")
    ap.add_argument("--kernel-drops", type=int, default=0,
                    help="frames the kernel dropped from its input backlog during the run "
                         "(/proc/net/softnet_stat): no socket saw them")
    ap.add_argument("--expect-enables", help="number of enable episodes expected: N or MIN-MAX")
    ap.add_argument("capture", help="candump -l log")
    a = ap.parse_args()
    drives, deadline, sync_period, safety_max = parse_config(a.config)
    refused = 0  # frames the master counted as refused by the kernel (ENOBUFS)
    if a.run_log:
        bus = re.search(r"^bus: \d+ SYNCs sent.*, ENOBUFS (\d+),", open(a.run_log).read(), re.M)
        if not bus:
            raise SystemExit(f"{TOOL}: no 'bus: ... ENOBUFS N' report in {a.run_log}")
        refused = int(bus.group(1))
    stalls = parse_stalls(a.stalls)
    frozen_time = FrozenTime(stalls)
    by_cob = {0x200 + d["node"]: d for d in drives}
    tpdo_of = {0x180 + d["node"]: 0x200 + d["node"] for d in drives}
    errors = []
    # Two passes over the file, never the whole capture in memory: a 1 kHz service's capture
    # is over a million frames, more than the guest's 256 MB hold as Python objects.
    sync_ts = [ts for ts, cob, _ in frames(a.capture) if cob == 0x080]
    if len(sync_ts) < 2:
        print(f"check_serve_wire: {len(sync_ts)} SYNCs on the wire: FAILED")
        return 1
    first, last = sync_ts[0], sync_ts[-1]

    gaps = {"SYNC": 0, "RPDO": 0}
    gap_errors = []
    excused = {"SYNC": 0, "RPDO": 0}
    worst = {"SYNC": 0.0, "RPDO": 0.0}
    worst_unexcused = {"SYNC": 0.0, "RPDO": 0.0}

    def gap(kind, what, t1, t2):
        g = t2 - t1
        worst[kind] = max(worst[kind], g)
        if g <= deadline:
            return
        frozen = frozen_time.within(t1, t2)
        if g - frozen <= deadline:
            excused[kind] += 1
            return
        gaps[kind] += 1
        worst_unexcused[kind] = max(worst_unexcused[kind], g - frozen)
        if gaps[kind] <= 10:
            gap_errors.append(f"{t1:.6f}: {what}: {g * 1e3:.1f} ms to the next (guest frozen "
                          f"{frozen * 1e3:.1f} ms of it), longer than can.rpdo_deadline "
                          f"{deadline * 1e3:.0f} ms")

    for t1, t2 in zip(sync_ts, sync_ts[1:]):
        gap("SYNC", "SYNC", t1, t2)

    last_rpdo = {}
    since_sync = {cob: None for cob in by_cob}  # None: before the drive's first RPDO
    broken = lost_total = 0  # SYNC intervals that break the rule, the frames they need lost
    broken_at = []
    rpdos = 0
    worst_nm = 0.0
    enabled = {cob: False for cob in by_cob}
    episodes = []  # [start, end]
    syncs = 0
    torque_off = 0  # RPDOs with a torque but no "enable operation"
    # Per drive, since the last episode ended: None (in an episode or before the first), False
    # (the drive still reported "operation enabled"), True (it left it).
    left_enabled = {cob: None for cob in by_cob}
    not_left = 0
    for ts, cob, data in frames(a.capture):
        if ts < first or ts > last:
            continue
        if cob in tpdo_of and len(data) >= 2:
            rc = tpdo_of[cob]
            if left_enabled[rc] is False and (int.from_bytes(data[0:2], "little") & 0x6F) != 0x27:
                left_enabled[rc] = True
            continue
        if cob == 0x080:
            syncs += 1
            counts = {c: k for c, k in since_sync.items() if k is not None}
            lost = lost_frames(counts.values())
            if lost:
                broken += 1
                lost_total += lost
                if broken <= 5:
                    seen = ", ".join(f"{c:03X} x{k}" for c, k in counts.items() if k != 1)
                    broken_at.append(f"{ts:.6f}: SYNC {syncs} after RPDOs {seen} since the "
                                     f"previous SYNC ({lost} frames lost at least)")
            for c in counts:
                since_sync[c] = 0
            continue
        d = by_cob.get(cob)
        if d is None:
            continue
        if len(data) != 4:
            errors.append(f"{ts:.6f} {cob:03X}: RPDO with {len(data)} bytes (expected 4)")
            continue
        rpdos += 1
        if cob in last_rpdo:
            gap("RPDO", f"RPDO {cob:03X}", last_rpdo[cob], ts)
        last_rpdo[cob] = ts
        since_sync[cob] = (since_sync[cob] or 0) + 1
        cw = int.from_bytes(data[0:2], "little")
        tq = int.from_bytes(data[2:4], "little", signed=True)
        nm = tq * d["rated"] / 1000.0
        limit = min(safety_max, d["max"])
        worst_nm = max(worst_nm, abs(nm))
        if abs(nm) > limit + 0.5 * d["rated"] / 1000.0:
            errors.append(f"{ts:.6f} {cob:03X}: target torque {nm:.3f} N m above the limit {limit} N m")
        if tq != 0 and (cw & 0x0F) != 0x0F:
            torque_off += 1
            if torque_off <= 5:
                errors.append(f"{ts:.6f} {cob:03X}: target torque {nm:.3f} N m with controlword "
                              f"{cw:04X}h (not enable operation)")
        was = any(enabled.values())
        enabled[cob] = (cw & 0x0F) == 0x0F
        now = any(enabled.values())
        if now and not was:
            for c, v in left_enabled.items():
                if v is False:
                    not_left += 1
                    errors.append(f"{ts:.6f}: an episode starts but drive {c - 0x200} never "
                                  "reported leaving operation enabled after the previous one")
                left_enabled[c] = None
            episodes.append([ts, ts])
        if was and not now:
            for c in left_enabled:
                left_enabled[c] = False
        if now:
            episodes[-1][1] = ts
    for c in by_cob:
        if c not in last_rpdo:
            errors.append(f"no RPDO {c:03X} while the service ran")
    for c, v in left_enabled.items():
        if v is False:
            not_left += 1
            errors.append(f"drive {c - 0x200} never reported leaving operation enabled after the "
                          "last episode")
    if torque_off > 5:
        errors.append(f"{torque_off} RPDOs with a torque but no enable operation in all")
    if broken:
        summary = (f"{broken} SYNC intervals without exactly one RPDO of every drive, {lost_total} "
                   f"frames lost at least; the master counted {refused} refused by the kernel "
                   f"(ENOBUFS), the kernel dropped {a.kernel_drops} from its input backlog")
        if lost_total > refused + a.kernel_drops:
            errors += broken_at + [summary]
        else:
            print(f"note: {summary}: within them. The first: {broken_at[0]}")
    if a.expect_enables is not None:
        lo, _, hi = a.expect_enables.partition("-")
        if not lo.isdigit() or not (hi or lo).isdigit():
            raise SystemExit(f"{TOOL}: --expect-enables N or MIN-MAX, got {a.expect_enables}")
        if not int(lo) <= len(episodes) <= int(hi or lo):
            errors.append(f"{len(episodes)} enable episodes on the wire, expected {a.expect_enables}")
    if gaps["SYNC"] > 10 or gaps["RPDO"] > 10:
        gap_errors.append(f"{gaps['SYNC']} SYNC gaps and {gaps['RPDO']} RPDO gaps above the deadline in all")
    rate = (len(sync_ts) - 1) / (last - first)
    if gap_errors and a.min_rate is not None and rate < a.min_rate / sync_period:
        print(f"NOTE (guest timing): the loop ran at {rate:.0f} SYNC/s over the service's life, "
              f"less than {a.min_rate * 100:.0f} % of the configured {1 / sync_period:.0f}: this "
              f"machine did not carry the rate, its gaps above the deadline are reported, not "
              f"checked:")
        for e in gap_errors:
            print("  " + e)
    else:
        errors += gap_errors
    span = ", ".join(f"{s - first:.2f}-{e - first:.2f} s" for s, e in episodes)
    print(f"check_serve_wire: {syncs} SYNCs over {last - first:.2f} s ({rate:.0f}/s), {rpdos} RPDOs from "
          f"{len(drives)} drives; longest gap SYNC {worst['SYNC'] * 1e3:.1f} ms, RPDO "
          f"{worst['RPDO'] * 1e3:.1f} ms (deadline {deadline * 1e3:.0f} ms; above it: "
          f"{gaps['SYNC']} SYNC + {gaps['RPDO']} RPDO gaps, {excused['SYNC']} + {excused['RPDO']} "
          f"more excused by {len(stalls)} guest freezes of "
          f"{sum(b - a for a, b in stalls) * 1e3:.0f} ms); max |target torque| {worst_nm:.2f} N m "
          f"(limit {safety_max} N m, none without enable operation: {torque_off == 0}); "
          f"{len(episodes)} enable episodes ({span}), each left by every drive: {not_left == 0}: "
          f"{'ok' if not errors else 'FAILED'}")
    for e in errors[:40]:
        print("  " + e)
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
