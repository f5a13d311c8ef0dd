#!/usr/bin/env python3
"""Checks a `candump -L` capture of the Dual-V bus for the safety HIL test (safety_hil.sh).

Decodes RPDO1 (200h + node: controlword u16, target torque i16 per mille of the rated
torque 6076h, little endian; firmware_if/pdo.hpp) and EMCY (80h + node) frames, and checks:
  always:            no target torque above the safety limit in any RPDO; the robot moved
  after-emcy:        from the third SYNC after the first EMCY with a non-zero code on, every
                     target torque on the wire is 0 (STO within 2 control cycles)
  torque-off-at-end: every node's last RPDO carries 0 torque and a controlword that is not
                     "enable operation" (CiA 402: low nibble 0Fh)
Standard library only (runs with Debian's /usr/bin/python3 inside the UML guest).
"""
import argparse
import re
import sys


def config_numbers(path):
    text = open(path).read()
    safety = text[text.index("\nsafety:"):]
    torque_max = float(re.search(r"\n\s+max:\s*([0-9.]+)", safety).group(1))
    rated = float(re.search(r"node_id:\s*1,.*?rated_torque:\s*([0-9.]+)", text).group(1))
    return torque_max, rated


def frames(path):
    pat = re.compile(r"^\((\d+\.\d+)\)\s+(\S+)\s+([0-9A-Fa-f]+)#([0-9A-Fa-f]*)")
    for line in open(path):
        m = pat.match(line.strip())
        if m:
            yield float(m.group(1)), int(m.group(3), 16), bytes.fromhex(m.group(4))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--config", required=True)
    ap.add_argument("--mode", default="limit-only",
                    choices=["limit-only", "after-emcy", "torque-off-at-end"])
    ap.add_argument("capture")
    a = ap.parse_args()
    torque_max, rated = config_numbers(a.config)
    limit = torque_max + 0.5 * rated / 1000.0
    errors = []
    rpdos = moving = 0
    worst = 0.0
    last = {}
    emcy_at = None
    syncs_after_emcy = 0
    nonzero_after = []
    for ts, cob, data in frames(a.capture):
        if cob == 0x080 and emcy_at is not None:
            syncs_after_emcy += 1
        if 0x081 <= cob <= 0x0FF and len(data) >= 2 and (data[0] | data[1] << 8) != 0:
            if emcy_at is None:
                emcy_at = ts
        if 0x201 <= cob <= 0x27F and len(data) >= 4:
            cw = data[0] | data[1] << 8
            tq = int.from_bytes(data[2:4], "little", signed=True)
            nm = tq * rated / 1000.0
            rpdos += 1
            moving += tq != 0
            worst = max(worst, abs(nm))
            if abs(nm) > limit:
                errors.append(f"{ts:.6f} {cob:03X}: {nm:.2f} N m above the limit {torque_max}")
            last[cob] = (cw, tq, ts)
            if emcy_at is not None and syncs_after_emcy >= 3 and tq != 0:
                nonzero_after.append(f"{ts:.6f} {cob:03X}: {nm:.2f} N m after the EMCY")
    if rpdos == 0 or moving == 0:
        errors.append(f"no torque on the wire ({rpdos} RPDOs): the robot never moved")
    if a.mode == "after-emcy":
        if emcy_at is None:
            errors.append("no EMCY on the wire")
        errors += nonzero_after[:5]
    if a.mode in ("after-emcy", "torque-off-at-end"):
        for cob, (cw, tq, ts) in sorted(last.items()):
            if tq != 0 or (cw & 0x0F) == 0x0F:
                errors.append(f"{cob:03X}: last RPDO at {ts:.6f}: controlword {cw:04X}, "
                              f"torque {tq} per mille (expected torque off)")
    print(f"check_wire: {rpdos} RPDOs, max |torque| {worst:.2f} N m (limit {torque_max}), "
          f"mode {a.mode}: {'ok' if not errors else 'FAILED'}")
    for e in errors[:20]:
        print("  " + e)
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
