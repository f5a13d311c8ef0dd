#!/usr/bin/env python3
"""Checks a `candump -l` capture of a `dualv run --can` session (paper_hil.sh).

Standard library only (runs with Debian's /usr/bin/python3 inside the user-mode-linux guest).
Reads the `can:` and `safety:` sections of the configuration the run used, the run's own
report (its stdout: "loop: K cycles ..." and "bus: N SYNCs sent (P before the program ...)")
and the capture, and checks, on the frames only:
  - SYNC (080h) count on the wire == SYNCs the master says it sent == P + K, i.e. one SYNC
    per control cycle of the program plus the priming cycles before it
  - every SYNC is preceded, since the previous SYNC, by exactly one RPDO1 (200h + node,
    controlword u16 + target torque i16 in per mille of the rated torque 6076h, little
    endian; firmware_if/pdo.hpp) from every configured drive: every drive's RPDO each cycle
  - no target torque above the configured limit: min(safety.torque.max, the drive's
    max_torque) in N m, from per mille with the drive's rated_torque (half an LSB allowed)
  - the robot moved: some RPDO carries a non-zero torque with "enable operation" (0Fh)
  - with --sto-cycle K (the first STO in the run's fault log, faults.jsonl): from control
    cycle K on (its RPDOs precede the (P + K + 1)th SYNC) every target torque is 0 and no
    controlword is "enable operation" (safety/fault.hpp: STO in the detection cycle), and
    every drive's last RPDO carries torque 0 and a controlword that is not "enable operation";
    such a run need not have moved (a timing watchdog may stop it in cycle 0)
  - with --sto-after NODE:CODE (hex), the defined reaction to that drive's fault EMCY
    (safety/fault.hpp: drive fault -> STO): from the third SYNC after the first EMCY
    (80h + NODE) with that error code on, every target torque is 0, and every drive's last
    RPDO carries torque 0 and a controlword that is not "enable operation" (disable voltage)
Exit status 0 when everything holds, 1 otherwise (every problem is printed).
"""
import argparse
import re
import sys

from wire_check_common import (config_drives, config_bus_layout, config_torque_max, frames,
                               read_config)

TOOL = "check_paper_wire"

# Zero-torque disable cycles after the loop ends: 3 from the machine (apps/experiment/machine.cpp
# shutdown), 5 from the drives' shut-down before NMT pre-operational (can.on_exit).
DISABLE_CYCLES = 3 + 5


def parse_config(path):
    text = read_config(path)
    drives = config_drives(text, path, TOOL)
    layout = config_bus_layout(text)
    if layout and layout != "per_drive":
        raise SystemExit(f"{TOOL}: bus_layout {layout}: only per_drive is checked")
    return drives, config_torque_max(text, path, TOOL)


def parse_run_log(path):
    text = open(path).read()
    loop = re.search(r"^loop: (\d+) cycles", text, re.M)
    bus = re.search(r"^bus: (\d+) SYNCs sent \((\d+) before the program", text, re.M)
    if not loop or not bus:
        raise SystemExit(f"check_paper_wire: no 'loop:' / 'bus:' report in {path}")
    return int(loop.group(1)), int(bus.group(1)), int(bus.group(2))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", required=True, help="the YAML the run used")
    ap.add_argument("--run-log", required=True, help="stdout of `dualv run --can`")
    ap.add_argument("--sto-after", metavar="NODE:CODE",
                    help="expect STO after this drive's EMCY (e.g. 2:2310)")
    ap.add_argument("--sto-cycle", metavar="K", type=int,
                    help="the run's fault log has STO from control cycle K on")
    ap.add_argument("capture", help="candump -l log")
    a = ap.parse_args()
    sto_cob = sto_code = None
    if a.sto_after:
        node, code = a.sto_after.split(":")
        sto_cob, sto_code = 0x080 + int(node), int(code, 16)
    drives, safety_max = parse_config(a.config)
    cycles, syncs_sent, priming = parse_run_log(a.run_log)
    # Control cycle K's RPDOs go out before the SYNC that ends it, the (priming + K + 1)th.
    sto_from = None if a.sto_cycle is None else priming + a.sto_cycle
    by_cob = {0x200 + d["node"]: d for d in drives}
    errors = []

    syncs = 0
    rpdos = 0
    moving = 0
    worst = 0.0
    since_sync = {cob: 0 for cob in by_cob}
    missing = duplicated = 0
    emcy_at = None
    syncs_after_emcy = 0
    after = []
    after_sto = []
    last = {}
    for ts, cob, data in frames(a.capture):
        if cob == sto_cob and len(data) == 8 and emcy_at is None and \
                int.from_bytes(data[0:2], "little") == sto_code:
            emcy_at = ts
        if cob == 0x080:
            syncs += 1
            if emcy_at is not None:
                syncs_after_emcy += 1
            for c, k in since_sync.items():
                if k == 0:
                    missing += 1
                    if missing <= 5:
                        errors.append(f"{ts:.6f}: SYNC {syncs} without an RPDO {c:03X} since the previous SYNC")
                elif k > 1:
                    duplicated += 1
                    if duplicated <= 5:
                        errors.append(f"{ts:.6f}: SYNC {syncs} after {k} RPDOs {c:03X}")
                since_sync[c] = 0
            continue
        d = by_cob.get(cob)
        if d is None:
            continue
        if len(data) != 4:
            errors.append(f"{ts:.6f} {cob:03X}: RPDO with {len(data)} bytes (expected 4)")
            continue
        rpdos += 1
        since_sync[cob] += 1
        cw = int.from_bytes(data[0:2], "little")
        tq = int.from_bytes(data[2:4], "little", signed=True)
        nm = tq * d["rated"] / 1000.0
        limit = min(safety_max, d["max"])
        worst = max(worst, abs(nm))
        if abs(nm) > limit + 0.5 * d["rated"] / 1000.0:
            errors.append(f"{ts:.6f} {cob:03X}: target torque {nm:.3f} N m above the limit {limit} N m")
        if tq != 0 and (cw & 0x0F) == 0x0F:
            moving += 1
        last[cob] = (ts, cw, tq)
        if emcy_at is not None and syncs_after_emcy >= 3 and tq != 0:
            after.append(f"{ts:.6f} {cob:03X}: {nm:.3f} N m after the EMCY")
        if sto_from is not None and syncs >= sto_from and (tq != 0 or (cw & 0x0F) == 0x0F):
            after_sto.append(f"{ts:.6f} {cob:03X}: controlword {cw:04X}, {nm:.3f} N m in control "
                             f"cycle {syncs - priming}, after STO from cycle {a.sto_cycle}")
    trailing = [f"{c:03X}" for c, k in since_sync.items() if k]
    if trailing:
        errors.append(f"RPDOs after the last SYNC from {', '.join(trailing)}")
    if missing > 5 or duplicated > 5:
        errors.append(f"{missing} missing and {duplicated} duplicated RPDOs in all")
    if syncs != syncs_sent:
        errors.append(f"{syncs} SYNCs on the wire but the master sent {syncs_sent}")
    # After its last control cycle `dualv run` leaves the drives disabled with zero torque in
    # DISABLE_CYCLES more cycles (apps/experiment/closed_loop.cpp, run_program).
    if syncs != priming + cycles + DISABLE_CYCLES:
        errors.append(f"{syncs} SYNCs on the wire, expected {priming} (priming) + {cycles} "
                      f"(control cycles) + {DISABLE_CYCLES} (disable) = "
                      f"{priming + cycles + DISABLE_CYCLES}")
    if sto_cob is not None:
        if emcy_at is None:
            errors.append(f"no EMCY {sto_code:04X}h from {sto_cob:03X} on the wire")
        else:
            errors += after[:5]
    if sto_from is not None:
        errors += after_sto[:5]
        if len(after_sto) > 5:
            errors.append(f"{len(after_sto)} RPDOs with torque or enabled after the STO in all")
    stopped = sto_cob is not None or sto_from is not None
    for cob, (ts, cw, tq) in sorted(last.items()):
        if stopped and (tq != 0 or (cw & 0x0F) == 0x0F):
            errors.append(f"{cob:03X}: last RPDO at {ts:.6f}: controlword {cw:04X}, torque "
                          f"{tq} per mille (expected STO: torque 0, not enabled)")
    # A run stopped by a timing watchdog may stop before the robot moves (cycle 0).
    if moving == 0 and sto_from is None:
        errors.append("no RPDO with torque in Operation enabled: the robot never moved")
    print(f"check_paper_wire: {syncs} SYNCs = {priming} priming + {cycles} control cycles "
          f"+ {DISABLE_CYCLES} disable "
          f"(master: {syncs_sent}); {rpdos} RPDOs from {len(drives)} drives; "
          f"max |target torque| {worst:.2f} N m (limit {safety_max} N m): "
          f"{'STO after the EMCY, ' if emcy_at is not None else ''}"
          f"{f'STO from cycle {a.sto_cycle}, ' if sto_from is not None else ''}"
          f"{'ok' if not errors else 'FAILED'}")
    for e in errors[:30]:
        print("  " + e)
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
