#!/usr/bin/env python3
"""Checks a `candump -l` capture of a `dualv run --can` session with the CAN FD layout
(fd_hil.sh; issue 15). Standard library only (runs inside the user-mode-linux guest).

The layout (firmware_if/pdo.hpp fd_rpdo_layout, docs/architecture.md "Beating the naive bus
limit"); candump writes an FD frame as ID##F<data>, F the flags nibble (1 = BRS):
  200h        one CAN FD frame with BRS, 4 B per drive (controlword 6040h u16, then target
              torque 6071h i16 per mille of 6076h, little endian, drive i at bytes 4i..4i+3),
              16 B for four drives, sent by the master before every SYNC
  180h + id   TPDO1, statusword + position (6 B), a CAN FD frame with BRS, every SYNC
  280h + id   TPDO2, 60FDh digital inputs (4 B), event driven, a CAN FD frame too (every
              TPDO of a CAN FD drive is)
  080h        SYNC, a classic frame (as NMT, heartbeat, EMCY, SDO)
Checks, on the frames only:
  - 200h and TPDO1 frames are FD with BRS and of the layout's size; no classic 200h / TPDO1
    frame, no per-drive RPDO1 (200h + id) nor statusword TPDO3 (380h + id), no other FD frame
  - once the cyclic traffic runs (the first 200h frame on), every SYNC is preceded by exactly
    one 200h frame since the previous SYNC
  - no target torque above min(safety.torque.max, the drive's max_torque) (half an LSB)
  - every drive's statusword seen (TPDO1); with --expect-enabled, each one reported Operation
    enabled (statusword & 6Fh == 27h) at least once
Exit status 0 when everything holds, 1 otherwise (every problem is printed).
"""
import argparse
import re
import sys

from wire_check_common import config_bus_layout, config_drives, config_torque_max, read_config

TOOL = "check_fd_wire"


def parse_config(path):
    text = read_config(path)
    drives = config_drives(text, path, TOOL)
    if config_bus_layout(text) != "fd":
        raise SystemExit(f"{TOOL}: {path} does not say bus_layout: fd")
    return drives, config_torque_max(text, path, TOOL)


def frames(path):
    """(time, cob, data, fd, brs) per data frame; classic `ID#data`, FD `ID##Fdata` (the FD
    form wire_check_common.frames does not read)."""
    pat = re.compile(r"^\((\d+\.\d+)\)\s+(\S+)\s+([0-9A-Fa-f]+)(#|##([0-9A-Fa-f]))([0-9A-Fa-f]*)$")
    for line in open(path):
        m = pat.match(line.strip())
        if m:
            fd = m.group(4).startswith("##")
            flags = int(m.group(5), 16) if fd else 0
            yield float(m.group(1)), int(m.group(3), 16), bytes.fromhex(m.group(6)), fd, bool(flags & 1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", required=True)
    ap.add_argument("--expect-enabled", action="store_true")
    ap.add_argument("capture")
    a = ap.parse_args()
    drives, safety_max = parse_config(a.config)
    nodes = [d["node"] for d in drives]
    rpdo_bytes = {1: 4, 2: 8, 3: 12, 4: 16}[len(drives)]
    problems = []
    bad = []
    rpdos = 0
    syncs_checked = 0
    since_sync = None
    max_nm = 0.0
    tpdos = {n: 0 for n in nodes}
    enabled = {n: False for n in nodes}
    for t, cob, data, fd, brs in frames(a.capture):
        if cob == 0x200:
            rpdos += 1
            if not (fd and brs and len(data) == rpdo_bytes):
                bad.append(f"200h fd={fd} brs={brs} {len(data)} B at {t}")
                continue
            since_sync = (since_sync or 0) + 1
            for i, d in enumerate(drives):
                pm = int.from_bytes(data[4 * i + 2:4 * i + 4], "little", signed=True)
                nm = abs(pm) * d["rated"] / 1000.0
                max_nm = max(max_nm, nm)
                limit = min(safety_max, d["max"]) + 0.5 * d["rated"] / 1000.0
                if nm > limit:
                    problems.append(f"torque {nm:.3f} N m for node {d['node']} above {limit:.3f} at {t}")
        elif cob == 0x080:
            if fd:
                bad.append(f"SYNC as an FD frame at {t}")
            if since_sync is not None:
                syncs_checked += 1
                if since_sync != 1:
                    problems.append(f"SYNC at {t} preceded by {since_sync} 200h frames (expected 1)")
                since_sync = 0
        elif 0x181 <= cob <= 0x1FF and cob - 0x180 in nodes:
            if not (fd and brs and len(data) == 6):
                bad.append(f"TPDO1 {cob:03X}h fd={fd} brs={brs} {len(data)} B at {t}")
                continue
            tpdos[cob - 0x180] += 1
            if int.from_bytes(data[0:2], "little") & 0x6F == 0x27:
                enabled[cob - 0x180] = True
        elif 0x281 <= cob <= 0x2FF and cob - 0x280 in nodes:
            if not (fd and len(data) == 4):
                bad.append(f"TPDO2 {cob:03X}h fd={fd} {len(data)} B at {t}")
        elif (0x201 <= cob <= 0x27F and cob - 0x200 in nodes) or (0x381 <= cob <= 0x3FF and cob - 0x380 in nodes):
            bad.append(f"{cob:03X}h is not a frame of the fd layout at {t}")
        elif fd:
            bad.append(f"{cob:03X}h as an FD frame at {t} (only the PDOs are FD)")
    if bad:
        problems.append(f"{len(bad)} frames not of the fd layout, first: {bad[0]}")
    if rpdos == 0 or syncs_checked == 0:
        problems.append("no FD RPDO / SYNC in the capture")
    for n in nodes:
        if tpdos[n] == 0:
            problems.append(f"node {n}: no FD TPDO1 (180h + {n}) seen")
        elif a.expect_enabled and not enabled[n]:
            problems.append(f"node {n}: never reported Operation enabled in a TPDO1")
    print(f"check_fd_wire: {rpdos} FD RPDOs, {syncs_checked} SYNCs checked, max torque "
          f"{max_nm:.3f} N m, TPDO1s per node " + ", ".join(f"{n}: {tpdos[n]}" for n in nodes))
    for p in problems:
        print(f"check_fd_wire: {p}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
