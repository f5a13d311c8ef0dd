#!/usr/bin/env python3
"""check_paper_wire.py against hand-built `candump -l` captures (no guest, no CAN).

Each capture is written frame by frame here from the layout firmware_if/pdo.hpp gives
(RPDO1 200h + node: controlword u16 + target torque i16 in per mille of 6076h, little
endian; SYNC 080h; EMCY 80h + node: error code u16 first) and checked with the shipped
config/dualv.yaml (four drives, nodes 1-4, rated torque 50 N m, safety.torque.max 60 N m).
"""
import os
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
CONFIG = os.path.join(HERE, "..", "..", "config", "dualv.yaml")
ENABLED, DISABLED = 0x000F, 0x0000
DISABLE_CYCLES = 3 + 5  # check_paper_wire.py: the machine's 3 + can.on_exit's 5


class Capture:
    def __init__(self):
        self.lines, self.t = [], 1.0

    def frame(self, cob, data):
        self.lines.append(f"({self.t:.6f}) vcan0 {cob:03X}#{data.hex().upper()}")
        self.t += 0.0001

    def cycle(self, cw, per_mille):  # every drive's RPDO1, then SYNC
        for node in (1, 2, 3, 4):
            self.frame(0x200 + node, cw.to_bytes(2, "little") + per_mille.to_bytes(2, "little", signed=True))
        self.frame(0x080, b"")

    def emcy(self, node, code):
        self.frame(0x080 + node, code.to_bytes(2, "little") + bytes([0x08, 0, 0, 0, 0, 0]))


def run(cap, cycles, priming=1, syncs_sent=None, args=()):
    """check_paper_wire.py's exit status and output for CAP and a run log of CYCLES."""
    syncs = sum(1 for line in cap.lines if " 080#" in line)
    with tempfile.TemporaryDirectory() as d:
        log, capture = os.path.join(d, "run.log"), os.path.join(d, "candump-1.log")
        with open(log, "w") as f:
            f.write(f"loop: {cycles} cycles at 1000 Hz\nbus: {syncs if syncs_sent is None else syncs_sent} "
                    f"SYNCs sent ({priming} before the program: priming), ENOBUFS 0\n")
        with open(capture, "w") as f:
            f.write("\n".join(cap.lines) + "\n")
        p = subprocess.run([sys.executable, os.path.join(HERE, "check_paper_wire.py"), "--config", CONFIG,
                            "--run-log", log, *args, capture], capture_output=True, text=True)
        return p.returncode, p.stdout


def program(torques, enabled_until=None):
    """Priming, one cycle per torque (enabled while index < enabled_until), the disable cycles."""
    cap = Capture()
    cap.cycle(ENABLED, 0)
    for k, tq in enumerate(torques):
        cap.cycle(ENABLED if enabled_until is None or k < enabled_until else DISABLED, tq)
    for _ in range(DISABLE_CYCLES):
        cap.cycle(DISABLED, 0)
    return cap


class CheckPaperWire(unittest.TestCase):
    def test_completed_run_that_moved_passes(self):
        rc, out = run(program([10, 20, -20, 0]), 4)
        self.assertEqual(rc, 0, out)

    def test_a_run_that_never_moved_fails_unless_stopped(self):
        cap = program([0, 0, 0], enabled_until=0)
        self.assertEqual(run(cap, 3)[0], 1)
        rc, out = run(cap, 3, args=["--sto-cycle", "0"])
        self.assertEqual(rc, 0, out)

    def test_torque_above_the_limit_fails(self):
        # 1201 per mille of 50 N m = 60.05 N m > 60 N m (+ half an LSB, 0.025 N m)
        rc, out = run(program([1201]), 1)
        self.assertEqual(rc, 1)
        self.assertIn("above the limit", out)
        self.assertEqual(run(program([1200]), 1)[0], 0)

    def test_sync_count_not_what_the_master_sent_fails(self):
        cap = program([10, 10])
        syncs = sum(1 for line in cap.lines if " 080#" in line)
        rc, out = run(cap, 2, syncs_sent=syncs + 1)
        self.assertEqual(rc, 1)
        self.assertIn("but the master sent", out)

    def test_sto_cycle_is_the_first_cycle_without_torque(self):
        # Cycles 0-2 with torque and enabled, from cycle 3 on torque 0 and disabled.
        cap = program([10, 10, 10, 0, 0], enabled_until=3)
        self.assertEqual(run(cap, 5, args=["--sto-cycle", "3"])[0], 0)
        rc, out = run(cap, 5, args=["--sto-cycle", "2"])
        self.assertEqual(rc, 1)
        self.assertIn("in control cycle 2, after STO from cycle 2", out)

    def test_enabled_without_torque_after_sto_fails(self):
        cap = program([10, 0, 0], enabled_until=2)  # cycle 1: torque 0 but still enabled
        self.assertEqual(run(cap, 3, args=["--sto-cycle", "1"])[0], 1)

    def test_sto_after_emcy(self):
        def with_emcy(torque_after):
            cap = Capture()
            cap.cycle(ENABLED, 0)
            cap.cycle(ENABLED, 10)
            cap.emcy(3, 0x4210)
            for _ in range(3):  # the RPDOs before the first three SYNCs after it may carry torque
                cap.cycle(ENABLED, 10)
            cap.cycle(DISABLED, torque_after)  # after the third SYNC: 0
            for _ in range(DISABLE_CYCLES):
                cap.cycle(DISABLED, 0)
            return cap
        self.assertEqual(run(with_emcy(0), 5, args=["--sto-after", "3:4210"])[0], 0)
        rc, out = run(with_emcy(5), 5, args=["--sto-after", "3:4210"])
        self.assertEqual(rc, 1)
        self.assertIn("after the EMCY", out)
        rc, out = run(with_emcy(0), 5, args=["--sto-after", "2:4210"])
        self.assertEqual(rc, 1)
        self.assertIn("no EMCY 4210h from 082", out)


if __name__ == "__main__":
    unittest.main()
