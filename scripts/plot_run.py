#!/usr/bin/env python3
"""Figures of a dualv closed-loop run, in the spirit of the paper's figures 2-4, 7 and 8.

Usage: plot_run.py RUN_DIR
Reads RUN_DIR/<variant>.csv (written by `dualv run`) and writes into RUN_DIR:
  paths.png     reference and actual path of every shape (retimed vs original clock)
  errors.png    x and y tracking error against time, both clocks
  torques.png   motor torques against time, both clocks
  lambda.png    the phase lambda and its derivatives (retimed vs original)
  internal.png  internal (antagonistic) torque with and without projection
Needs Debian's python3-matplotlib (run it with /usr/bin/python3).
"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def load(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    cols = {k: [float(r[k]) for r in rows] for k in rows[0]} if rows else {}
    return cols


def shape_segments(run):
    """Segment ids whose lambda moves: the closed shapes."""
    segs = {}
    for seg, lam, lam_dot in zip(run["segment"], run["lambda"], run["lambda_dot"]):
        if abs(lam_dot) > 0 or abs(lam) > 0:
            segs.setdefault(int(seg), True)
    return sorted(segs)


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    d = sys.argv[1]
    runs = {}
    for name in ("retimed", "original", "retimed-no-projection", "retimed-no-feedforward"):
        p = os.path.join(d, name + ".csv")
        if os.path.exists(p):
            runs[name] = load(p)
    if not runs:  # runs converted from an LCM log (dualv plot LOG): every CSV but the summary
        for f in sorted(os.listdir(d)):
            if f.endswith(".csv") and f != "summary.csv":
                runs[f[:-4]] = load(os.path.join(d, f))
    if not runs:
        print(f"plot_run.py: no run CSV in {d}", file=sys.stderr)
        return 1
    colours = {"retimed": "tab:blue", "original": "tab:red",
               "retimed-no-projection": "tab:green", "retimed-no-feedforward": "tab:orange"}
    main_runs = [n for n in ("retimed", "original") if n in runs] or list(runs)[:2]
    palette = ["tab:blue", "tab:red", "tab:green", "tab:orange"]
    for i, n in enumerate(runs):
        colours.setdefault(n, palette[i % len(palette)])

    # Shape names per segment, from summary.csv when `dualv run` wrote one.
    names = {}
    summary = os.path.join(d, "summary.csv")
    if os.path.exists(summary):
        with open(summary, newline="") as f:
            for r in csv.DictReader(f):
                if r["segment"].isdigit():
                    names[int(r["segment"])] = r["shape"]

    # Paths per shape.
    ref = runs[main_runs[0]]
    shapes = shape_segments(ref)
    fig, axes = plt.subplots(1, max(1, len(shapes)), figsize=(4 * max(1, len(shapes)), 4))
    axes = axes if hasattr(axes, "__len__") else [axes]
    for ax, seg in zip(axes, shapes):
        for name in main_runs:
            r = runs[name]
            idx = [i for i, s in enumerate(r["segment"]) if int(s) == seg]
            ax.plot([r["x"][i] * 1e3 for i in idx], [r["y"][i] * 1e3 for i in idx],
                    color=colours[name], lw=1, label=f"actual ({name})")
        idx = [i for i, s in enumerate(ref["segment"]) if int(s) == seg]
        ax.plot([ref["x_d"][i] * 1e3 for i in idx], [ref["y_d"][i] * 1e3 for i in idx],
                "k--", lw=1, label="reference")
        ax.set_aspect("equal")
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
        ax.set_title(names.get(seg, f"segment {seg}"))
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(d, "paths.png"), dpi=110)
    plt.close(fig)

    # Errors against time.
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    for name in main_runs:
        r = runs[name]
        ax1.plot(r["t"], r["ex_mm"], color=colours[name], lw=0.8, label=name)
        ax2.plot(r["t"], r["ey_mm"], color=colours[name], lw=0.8, label=name)
    ax1.set_ylabel("error x [mm]")
    ax2.set_ylabel("error y [mm]")
    ax2.set_xlabel("t [s]")
    ax1.legend()
    ax1.set_title("Cartesian tracking error: retimed vs original clock")
    fig.tight_layout()
    fig.savefig(os.path.join(d, "errors.png"), dpi=110)
    plt.close(fig)

    # Torques.
    ntau = len([k for k in ref if k.startswith("tau") and k[3:].isdigit()])
    fig, axes = plt.subplots(len(main_runs), 1, figsize=(10, 3 * len(main_runs)), sharex=True,
                             squeeze=False)
    for ax, name in zip(axes[:, 0], main_runs):
        r = runs[name]
        for i in range(1, ntau + 1):
            ax.plot(r["t"], r[f"tau{i}"], lw=0.8, label=f"motor {i}")
        ax.set_ylabel("torque [N m]")
        ax.set_title(f"motor torques ({name})")
    axes[0, 0].legend(ncol=ntau, fontsize=8)
    axes[-1, 0].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(os.path.join(d, "torques.png"), dpi=110)
    plt.close(fig)

    # Lambda and derivatives.
    fig, axes = plt.subplots(3, 1, figsize=(10, 7), sharex=True)
    for name in main_runs:
        r = runs[name]
        for ax, key in zip(axes, ("lambda", "lambda_dot", "lambda_dd")):
            ax.plot(r["t"], r[key], color=colours[name], lw=0.8, label=name)
    for ax, label in zip(axes, ("lambda [rad]", "lambda_dot [rad/s]", "lambda_dd [rad/s^2]")):
        ax.set_ylabel(label)
    axes[0].legend()
    axes[-1].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(os.path.join(d, "lambda.png"), dpi=110)
    plt.close(fig)

    # Internal torque.
    fig, ax = plt.subplots(figsize=(10, 3.5))
    for name in [n for n in ("retimed", "retimed-no-projection") if n in runs] or main_runs:
        if name in runs:
            r = runs[name]
            ax.semilogy(r["t"], [max(v, 1e-18) for v in r["tau_internal"]],
                        color=colours[name], lw=0.8, label=name)
    ax.set_ylabel("|N tau| [N m]")
    ax.set_xlabel("t [s]")
    ax.set_title("internal (antagonistic) torque of the command")
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(d, "internal.png"), dpi=110)
    plt.close(fig)
    print(f"plots written to {d}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
