#!/usr/bin/env python3
"""Checks a `candump -l` capture of a `dualv run --can` session with the broadcast layout
(broadcast_hil.sh; issue 15). Standard library only (runs inside the user-mode-linux guest).

The layout (firmware_if/pdo.hpp, docs/architecture.md "Beating the naive bus limit"):
  200h        one RPDO, 2 B per drive (target torque 6071h, i16 per mille of 6076h, little
              endian, drive i at bytes 2i..2i+1), sent by the master before every SYNC
  200h + id   RPDO1, the controlword alone (2 B), on change (never per-drive 4-byte RPDOs)
  180h + id   TPDO1, the position alone (4 B), every SYNC
  380h + id   TPDO3, the statusword alone (2 B), on change, at most once per
              can.statusword_inhibit (plus the event timer, can.statusword_refresh)
Checks, on the frames only:
  - no frame of the per-drive layout (4-byte RPDO1, 6-byte TPDO1) and every 200h frame is
    2 x drives bytes
  - once the cyclic traffic runs (the first 200h frame on), every SYNC is preceded by
    exactly one 200h frame since the previous SYNC
  - no target torque above min(safety.torque.max, the drive's max_torque) (half an LSB)
  - every drive's statusword seen (TPDO3); with --expect-enabled, each one reported
    Operation enabled (statusword & 6Fh == 27h) at least once
  - each drive's TPDO3 count <= its time span / can.statusword_inhibit + 1 (the inhibit
    time bounds them; counted, not timed, so guest stalls cannot fake a failure)
Exit status 0 when everything holds, 1 otherwise (every problem is printed).
"""
import argparse
import re
import sys

from wire_check_common import (config_drives, config_bus_layout, config_torque_max, frames,
                               read_config)

TOOL = "check_broadcast_wire"


def parse_config(path):
    text = read_config(path)
    drives = config_drives(text, path, TOOL)
    if config_bus_layout(text) != "broadcast":
        raise SystemExit(f"{TOOL}: {path} does not say bus_layout: broadcast")
    inhibit = re.search(r"\n\s+statusword_inhibit:\s*([0-9.]+)", text)
    if not inhibit:
        raise SystemExit(f"{TOOL}: no can.statusword_inhibit in {path}")
    return drives, float(inhibit.group(1)), config_torque_max(text, path, TOOL)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", required=True)
    ap.add_argument("--expect-enabled", action="store_true")
    ap.add_argument("capture")
    a = ap.parse_args()
    drives, inhibit, safety_max = parse_config(a.config)
    nodes = [d["node"] for d in drives]
    problems = []
    bad_layout = 0
    torque_frames = 0
    syncs_checked = 0
    since_sync = None  # 200h frames since the last SYNC, None before the first 200h
    max_nm = 0.0
    statuswords = {n: [] for n in nodes}
    enabled = {n: False for n in nodes}
    for t, cob, data in frames(a.capture):
        if cob == 0x200:
            torque_frames += 1
            if len(data) != 2 * len(drives):
                problems.append(f"200h frame with {len(data)} bytes at {t}")
                continue
            since_sync = (since_sync or 0) + 1
            for i, d in enumerate(drives):
                pm = int.from_bytes(data[2 * i:2 * i + 2], "little", signed=True)
                nm = abs(pm) * d["rated"] / 1000.0
                max_nm = max(max_nm, nm)
                limit = min(safety_max, d["max"]) + 0.5 * d["rated"] / 1000.0
                if nm > limit:
                    problems.append(f"torque {nm:.3f} N m for node {d['node']} above {limit:.3f} at {t}")
        elif cob == 0x080:
            if since_sync is not None:
                syncs_checked += 1
                if since_sync != 1:
                    problems.append(f"SYNC at {t} preceded by {since_sync} 200h frames (expected 1)")
                since_sync = 0
        elif 0x201 <= cob <= 0x27F and cob - 0x200 in nodes:
            if len(data) != 2:
                bad_layout += 1
        elif 0x181 <= cob <= 0x1FF and cob - 0x180 in nodes:
            if len(data) != 4:
                bad_layout += 1
        elif 0x381 <= cob <= 0x3FF and cob - 0x380 in nodes:
            if len(data) != 2:
                bad_layout += 1
                continue
            statuswords[cob - 0x380].append(t)
            if int.from_bytes(data, "little") & 0x6F == 0x27:
                enabled[cob - 0x380] = True
    if bad_layout:
        problems.append(f"{bad_layout} PDO frames not of the broadcast layout (4-byte RPDO1 / 6-byte TPDO1 ...)")
    if torque_frames == 0 or syncs_checked == 0:
        problems.append("no broadcast torque frame / SYNC in the capture")
    for n in nodes:
        ts = statuswords[n]
        if not ts:
            problems.append(f"node {n}: no statusword TPDO3 (380h + {n}) seen")
            continue
        bound = int((ts[-1] - ts[0]) / inhibit) + 1
        if len(ts) > bound:
            problems.append(f"node {n}: {len(ts)} TPDO3s in {ts[-1] - ts[0]:.3f} s, more than the "
                            f"inhibit time ({inhibit} s) allows ({bound})")
        if a.expect_enabled and not enabled[n]:
            problems.append(f"node {n}: never reported Operation enabled in a TPDO3")
    print(f"check_broadcast_wire: {torque_frames} torque frames, {syncs_checked} SYNCs checked, "
          f"max torque {max_nm:.3f} N m, statuswords per node "
          + ", ".join(f"{n}: {len(statuswords[n])}" for n in nodes))
    for p in problems:
        print(f"check_broadcast_wire: {p}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
