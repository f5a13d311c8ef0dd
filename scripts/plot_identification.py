#!/usr/bin/python3
"""Measured vs predicted joint torques of `dualv identify`'s validation run.

Usage: plot_identification.py DIR  (reads DIR/validation_torques.csv, writes DIR/validation.png)

Measured: R tau, the part of the torques sent that moves the plate (range of Jm). Predicted:
Jm^{T*} W phi_b with the identified base parameters (docs/identification.md). Run with Debian's
/usr/bin/python3, which sees python3-matplotlib.
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main() -> int:
    if len(sys.argv) != 2:
        print(__doc__)
        return 2
    folder = sys.argv[1]
    with open(f"{folder}/validation_torques.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        print(f"{folder}/validation_torques.csv: no rows")
        return 1
    n = sum(1 for k in rows[0] if k.startswith("measured"))
    t = [float(r["t"]) for r in rows]
    fig, axes = plt.subplots(n, 1, sharex=True, figsize=(10, 2.2 * n))
    for i in range(n):
        ax = axes[i] if n > 1 else axes
        ax.plot(t, [float(r[f"measured{i + 1}"]) for r in rows], lw=0.8, label="measured (R tau)")
        ax.plot(t, [float(r[f"predicted{i + 1}"]) for r in rows], lw=0.8, ls="--",
                label="predicted (identified model)")
        ax.set_ylabel(f"tau{i + 1} [N m]")
        ax.grid(alpha=0.3)
    (axes[0] if n > 1 else axes).legend(loc="upper right", fontsize=8)
    (axes[-1] if n > 1 else axes).set_xlabel("t [s]")
    fig.suptitle("dualv identify: validation run, measured vs predicted joint torques")
    fig.tight_layout()
    fig.savefig(f"{folder}/validation.png", dpi=120)
    return 0


if __name__ == "__main__":
    sys.exit(main())
