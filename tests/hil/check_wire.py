#!/usr/bin/env python3
"""Checks a `candump -L` capture of the Dual-V bus for the safety HIL test (safety_hil.sh).

Decodes RPDO1 (200h + node: controlword u16, target torque i16 per mille of the rated
torque 6076h, little endian; firmware_if/pdo.hpp) and EMCY (80h + node) frames, and checks:
  always:            no target torque above the safety limit in any RPDO; the robot moved
  after-emcy:        from the third SYNC after the first EMCY with a non-zero code on, every
                     target torque on the wire is 0 (STO within 2 control cycles)
  torque-off-at-end: every node's last RPDO carries 0 torque and a controlword that is not
                     "enable operation" (CiA 402: low nibble 0Fh)
  after-bad-tpdo:    the first corrupted TPDO1 on the wire (DLC not 6, or a position step
                     above 2^16 counts from the node's previous TPDO1) is the trigger; from
                     the --within'th SYNC after it every target torque is 0, and torque off
                     at the end
  no-stop:           every node was in "enable operation" (a fault below its watchdog must
                     be tolerated); whether anything stopped it before the host's own
                     shutdown at the end (SS1, disable voltage, NMT pre-operational:
                     docs/architecture.md "Start-up and shutdown") is read from the fault
                     log by safety_hil.sh, which tells the two apart
  after-busoff:      a bus-off error frame (CAN_ERR_FLAG | CAN_ERR_BUSOFF) is on the wire and
                     after it the master sends nothing (no SYNC, RPDO, NMT, SDO request nor
                     its heartbeat 700h + can.master.node_id); with --drives-capture (the
                     drives' side of the gateway) every drive then stops on its own: an EMCY
                     with a non-zero code from each node after the bus-off
--within N (default 3, "STO within 2 control cycles"): the SYNC count for after-emcy and
after-bad-tpdo.
Every run prints when the master stopped: its first RPDO1 whose controlword is not "enable
operation" after its first that is, in seconds after that first (can_fault_gateway.cpp's and
`dualv sim --times-from-enable`'s time base), or "no stop". A stop that cannot be the
injected fault's answer ends with status 3 instead of 0 (safety_hil.sh then reads the
fault log for the cause: a timing watchdog's in a slow guest, or a failure):
  --fault-from S:    the master stopped less than S s after its first enable (the fault is
                     injected at S)
  --drives-silent:   a drive sent a TPDO1 after the master stopped (the case stops the drives
                     answering: the stop came while they still did)
A stop before any torque, or no enable at all, is status 3 too (nothing to show). A run stopped
before its fault is checked only for what holds whatever stopped it (no torque
above the limit; torque off at the end in the modes that check it).
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


def config_nodes(path):
    text = open(path).read()
    master = int(re.search(r"\n\s+master:\s*\n\s+node_id:\s*([0-9]+)", text).group(1))
    drives = [int(n) for n in re.findall(r"\{node_id:\s*([0-9]+),", text)]
    return master, drives


CAN_ERR_FLAG = 0x20000000
CAN_ERR_BUSOFF = 0x40


def from_master(cob, master):
    """COB-IDs only the master sends (docs/architecture.md, CAN contract)."""
    return (cob == 0x000 or cob == 0x080 or 0x200 <= cob <= 0x27F or 0x600 <= cob <= 0x67F
            or cob == 0x700 + master)


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
                    choices=["limit-only", "after-emcy", "torque-off-at-end", "after-bad-tpdo",
                             "no-stop", "after-busoff"])
    ap.add_argument("--within", type=int, default=3)
    ap.add_argument("--drives-capture")
    ap.add_argument("--fault-from", type=float)
    ap.add_argument("--drives-silent", action="store_true")
    ap.add_argument("capture")
    a = ap.parse_args()
    torque_max, rated = config_numbers(a.config)
    master, drive_nodes = config_nodes(a.config)
    limit = torque_max + 0.5 * rated / 1000.0
    errors = []
    rpdos = moving = 0
    worst = 0.0
    last = {}
    enabled = set()
    emcy_at = None
    syncs_after_emcy = 0
    nonzero_after = []
    bad_tpdo = None  # (ts, text) of the first corrupted TPDO1
    prev_pos = {}
    busoff_at = None
    after_busoff = []
    enabled_at = stopped_at = None  # the master's first enable operation, its first stop after
    last_tpdo = None
    moved_before_stop = False
    for ts, cob, data in frames(a.capture):
        if cob & CAN_ERR_FLAG:
            if cob & CAN_ERR_BUSOFF and busoff_at is None:
                busoff_at = ts
            continue
        if busoff_at is not None and from_master(cob, master):
            after_busoff.append(f"{ts:.6f} {cob:03X}#{data.hex().upper()} sent after bus-off")
        if 0x181 <= cob <= 0x1FF:
            last_tpdo = ts
        if 0x181 <= cob <= 0x1FF and bad_tpdo is None:
            if len(data) != 6:
                bad_tpdo = (ts, f"{cob:03X} with DLC {len(data)}")
            else:
                pos = int.from_bytes(data[2:6], "little", signed=True)
                if cob in prev_pos and abs(pos - prev_pos[cob]) > 1 << 16:
                    bad_tpdo = (ts, f"{cob:03X} position {prev_pos[cob]} -> {pos}")
                prev_pos[cob] = pos
            if bad_tpdo is not None and a.mode == "after-bad-tpdo":
                emcy_at = ts  # the trigger: the same SYNC-counted check as after an EMCY
        if cob == 0x080 and emcy_at is not None:
            syncs_after_emcy += 1
        if (a.mode == "after-emcy" and 0x081 <= cob <= 0x0FF and len(data) >= 2
                and (data[0] | data[1] << 8) != 0):
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
            if (cw & 0x0F) == 0x0F:
                enabled.add(cob)
                if enabled_at is None:
                    enabled_at = ts
            elif enabled_at is not None and stopped_at is None:
                stopped_at = ts
            if tq != 0 and stopped_at is None:
                moved_before_stop = True
            if emcy_at is not None and syncs_after_emcy >= a.within and tq != 0:
                nonzero_after.append(f"{ts:.6f} {cob:03X}: {nm:.2f} N m {syncs_after_emcy} "
                                     f"SYNCs after the trigger")
    before_fault = None  # why the stop cannot be the fault's answer
    if enabled_at is None:
        print("check_wire: never enabled")
        before_fault = "the master never enabled the drives"
    elif stopped_at is None:
        print("check_wire: no stop")
    else:
        after = stopped_at - enabled_at
        print(f"check_wire: stop {after:.3f} s after the first enable operation")
        if a.fault_from is not None and after < a.fault_from:
            before_fault = f"the master stopped {after:.3f} s after enabling, before the fault at {a.fault_from} s"
        if a.drives_silent and last_tpdo is not None and last_tpdo > stopped_at:
            before_fault = (f"the master stopped {last_tpdo - stopped_at:.3f} s before the drives' "
                            f"last TPDO1 (while they still answered)")
        if not moved_before_stop:
            before_fault = "the master stopped before it commanded any torque: nothing to show"
    if before_fault is not None:
        errors = [e for e in errors if "above the limit" in e]
        a.mode = "torque-off-at-end" if a.mode in ("after-emcy", "after-bad-tpdo") else "limit-only"
    if (rpdos == 0 or moving == 0) and before_fault is None:
        errors.append(f"no torque on the wire ({rpdos} RPDOs): the robot never moved")
    if a.mode == "after-emcy":
        if emcy_at is None:
            errors.append("no EMCY on the wire")
        errors += nonzero_after[:5]
    if a.mode == "after-bad-tpdo":
        if bad_tpdo is None:
            errors.append("no corrupted TPDO1 on the wire")
        else:
            print(f"check_wire: first corrupted TPDO1 at {bad_tpdo[0]:.6f}: {bad_tpdo[1]}")
        errors += nonzero_after[:5]
    if a.mode == "no-stop":
        for cob in sorted(last):
            if cob not in enabled:
                errors.append(f"{cob:03X}: never in enable operation")
    if a.mode == "after-busoff":
        if busoff_at is None:
            errors.append("no bus-off error frame on the wire")
        else:
            errors += after_busoff[:5]
            if a.drives_capture:
                stopped = {}
                for ts, cob, data in frames(a.drives_capture):
                    node = cob - 0x080
                    if (node in drive_nodes and ts > busoff_at and len(data) >= 2
                            and (data[0] | data[1] << 8) != 0 and node not in stopped):
                        stopped[node] = (ts, data[0] | data[1] << 8)
                for n in drive_nodes:
                    if n in stopped:
                        print(f"check_wire: node {n} stopped on its own: EMCY "
                              f"{stopped[n][1]:04X}h {stopped[n][0] - busoff_at:.3f} s after "
                              f"the bus-off")
                    else:
                        errors.append(f"node {n}: no EMCY after the bus-off (did not stop on "
                                      f"its own)")
    if a.mode in ("after-emcy", "torque-off-at-end", "after-bad-tpdo"):
        for cob, (cw, tq, ts) in sorted(last.items()):
            if tq != 0 or (cw & 0x0F) == 0x0F:
                errors.append(f"{cob:03X}: last RPDO at {ts:.6f}: controlword {cw:04X}, "
                              f"torque {tq} per mille (expected torque off)")
    print(f"check_wire: {rpdos} RPDOs, max |torque| {worst:.2f} N m (limit {torque_max}), "
          f"mode {a.mode}: {'ok' if not errors else 'FAILED'}")
    for e in errors[:20]:
        print("  " + e)
    if before_fault is not None:
        print(f"check_wire: {before_fault}")
    return 1 if errors else 3 if before_fault is not None else 0


if __name__ == "__main__":
    sys.exit(main())
