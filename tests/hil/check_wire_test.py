#!/usr/bin/env python3
"""check_wire.py (safety_hil.sh's wire check) against hand-built `candump -L` captures.

No guest, no CAN: each capture is written frame by frame from the layout firmware_if/pdo.hpp
gives (RPDO1 200h + node: controlword u16 + target torque i16 in per mille of 6076h; TPDO1
180h + node: statusword u16 + position i32; SYNC 080h; EMCY 80h + node: error code u16 first,
all little endian) and checked with the shipped config/dualv.yaml (nodes 1-4, rated torque
50 N m, safety.torque.max 60 N m). The verdicts safety_hil.sh builds on: 0 (the fault was
answered), 1 (a violation), 3 (the stop came before the fault could act: nothing shown).
"""
import os
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
CONFIG = os.path.join(HERE, "..", "..", "config", "dualv.yaml")
ENABLED, DISABLED = 0x000F, 0x0000
PERIOD = 0.001


class Capture:
    def __init__(self):
        self.lines, self.t = [], 100.0

    def frame(self, cob, data):
        self.lines.append(f"({self.t:.6f}) vcan0 {cob:03X}#{data.hex().upper()}")

    def cycles(self, n, cw, per_mille, tpdos=True):
        """n control cycles: every drive's RPDO1, SYNC, then (tpdos) every drive's TPDO1."""
        for _ in range(n):
            for node in (1, 2, 3, 4):
                self.frame(0x200 + node, cw.to_bytes(2, "little") +
                           per_mille.to_bytes(2, "little", signed=True))
            self.frame(0x080, b"")
            if tpdos:
                for node in (1, 2, 3, 4):
                    self.frame(0x180 + node, (0x0627).to_bytes(2, "little") + (1000).to_bytes(4, "little"))
            self.t += PERIOD

    def emcy(self, node, code):
        self.frame(0x080 + node, code.to_bytes(2, "little") + bytes([0x08, 0, 0, 0, 0, 0]))


def check(cap, *args):
    with tempfile.NamedTemporaryFile("w", suffix=".log", delete=False) as f:
        f.write("\n".join(cap.lines) + "\n")
        path = f.name
    try:
        p = subprocess.run([sys.executable, "-B", os.path.join(HERE, "check_wire.py"),
                            "--config", CONFIG, *args, path], capture_output=True, text=True)
        return p.returncode, p.stdout
    finally:
        os.unlink(path)


def run_then_stop(moving_cycles, per_mille=4, tpdos_after=True):
    """Disabled 10 cycles, enabled and moving, then stopped (torque 0, disabled) 20 cycles."""
    cap = Capture()
    cap.cycles(10, DISABLED, 0)
    cap.cycles(moving_cycles, ENABLED, per_mille)
    cap.cycles(20, DISABLED, 0, tpdos=tpdos_after)
    return cap


class CheckWire(unittest.TestCase):
    def test_a_stop_after_the_fault_time_is_its_answer(self):
        rc, out = check(run_then_stop(150), "--mode", "torque-off-at-end", "--fault-from", "0.1")
        self.assertEqual(rc, 0, out)
        self.assertIn("stop 0.150 s after the first enable operation", out)

    def test_a_stop_before_the_fault_time_shows_nothing(self):
        rc, out = check(run_then_stop(50), "--mode", "torque-off-at-end", "--fault-from", "0.1")
        self.assertEqual(rc, 3, out)
        self.assertIn("before the fault at 0.1 s", out)

    def test_a_stop_before_any_torque_shows_nothing(self):
        rc, out = check(run_then_stop(150, per_mille=0), "--mode", "torque-off-at-end")
        self.assertEqual(rc, 3, out)
        self.assertIn("before it commanded any torque", out)

    def test_never_enabled_shows_nothing(self):
        cap = Capture()
        cap.cycles(30, DISABLED, 0)
        rc, out = check(cap, "--mode", "after-emcy", "--fault-from", "0.1")
        self.assertEqual(rc, 3, out)
        self.assertIn("never enabled", out)

    def test_torque_above_the_limit_fails_whatever_stopped_the_loop(self):
        # 65 N m at 50 N m rated: above safety.torque.max 60; stopped before the fault.
        rc, out = check(run_then_stop(20, per_mille=1300), "--mode", "torque-off-at-end",
                        "--fault-from", "0.1")
        self.assertEqual(rc, 1, out)
        self.assertIn("above the limit", out)

    def test_drives_silent_before_the_stop_is_its_answer(self):
        cap = Capture()
        cap.cycles(10, DISABLED, 0)
        cap.cycles(100, ENABLED, 4)
        cap.cycles(3, ENABLED, 4, tpdos=False)  # the drives stopped answering, then the stop
        cap.cycles(20, DISABLED, 0, tpdos=False)
        rc, out = check(cap, "--mode", "torque-off-at-end", "--drives-silent")
        self.assertEqual(rc, 0, out)

    def test_drives_answering_after_the_stop_were_not_its_cause(self):
        rc, out = check(run_then_stop(100, tpdos_after=True), "--mode", "torque-off-at-end",
                        "--drives-silent")
        self.assertEqual(rc, 3, out)
        self.assertIn("while they still answered", out)

    @staticmethod
    def emcy_then_stop(cycles_with_torque):
        """Moving 0.15 s, an EMCY 2310h from node 3, CYCLES_WITH_TORQUE more, then stopped."""
        cap = Capture()
        cap.cycles(10, DISABLED, 0)
        cap.cycles(150, ENABLED, 4)
        cap.emcy(3, 0x2310)
        cap.cycles(cycles_with_torque, ENABLED, 4)
        cap.cycles(20, DISABLED, 0)
        return check(cap, "--mode", "after-emcy", "--fault-from", "0.1")

    def test_torque_after_an_emcy_fails(self):
        rc, out = self.emcy_then_stop(5)  # torque 3 SYNCs and more after the EMCY
        self.assertEqual(rc, 1, out)
        self.assertIn("SYNCs after the trigger", out)

    def test_torque_off_within_two_cycles_of_an_emcy_passes(self):
        rc, out = self.emcy_then_stop(1)
        self.assertEqual(rc, 0, out)


if __name__ == "__main__":
    unittest.main()
