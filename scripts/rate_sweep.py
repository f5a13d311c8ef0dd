#!/usr/bin/python3
"""The rate experiment (issue 15): what a faster control loop buys the Dual-V.

Runs the paper program (config/paper.yaml), retimed, in the in-process simulation with every
realism knob as shipped (one cycle of transport delay, current-loop lag, encoder and torque
quantisation, friction, model mismatch) at each control rate, with two sets of gains:

  shipped  config/dualv.yaml's controller (kp, kd, velocity_cutoff_hz), tuned at 1 kHz (the
           paper gives no numbers: its gains were tuned by trial and error at 10 kHz).
  scaled   the feedback bandwidth follows 1 / (effective delay), the delay being 1.5 cycles
           (transport delay + zero-order hold) plus the drive's current-loop lag (fixed in
           time): with s = d(1 kHz) / d(f), kp ~ s^2, kd ~ s and the velocity filter cutoff ~ s
           (natural frequency ~ s, damping ratio kept, about the same phase margin against
           the delay as the shipped gains at 1 kHz), until one encoder count makes
           `max_count_torque` N m of torque (0.25 N m = 5 torque quanta; kp <= 41700 N m/rad);
           above, the gains stay there. Scaling with the rate alone (kp ~ f^2) ignores the
           current-loop lag: at 2 and 2.5 kHz the loop oscillates until the safety filter
           stops it on the torque rate limit (--rules shipped,scaled,rate shows it). The rigid-body simulation has no
           structural modes: on the machine its first mode caps the bandwidth too.

Each run is `dualv run --rate HZ --variant retimed -c CFG -o DIR --no-plots` with CFG written to a
temporary folder. Torque noise: RMS over the shapes and the four motors of the command minus
its centred 10 ms moving average (what is left above ~100 Hz, whatever the rate).
Prints a Markdown table and writes rate_sweep.csv and rate_sweep.png into OUT.

  /usr/bin/python3 scripts/rate_sweep.py --dualv build/release/apps/dualv --out out/rate-sweep
"""
import argparse
import csv
import math
import os
import subprocess
import sys
import tempfile

import yaml

RATES = [500, 1000, 1500, 2000, 2500, 5000, 10000]
SHAPES = ["circle", "ellipse", "tear", "deltoid"]
NOISE_WINDOW_S = 0.010


def bus_limits(dualv, config):
    """{layout: max rate [Hz]} from `dualv bus-load`'s side-by-side table."""
    p = subprocess.run([dualv, "bus-load", "-c", config], capture_output=True, text=True)
    limits = {}
    for line in p.stdout.splitlines():
        f = line.split()
        if len(f) >= 12 and f[0] in ("per_drive", "broadcast", "fd") and f[-1] in ("yes", "NO"):
            limits[f[0]] = float(f[-3])
    return limits


def effective_delay(rate, current_lag):
    """Delay the feedback sees [s]: one cycle of transport delay, half a cycle of zero-order
    hold, and the drive's current loop (fixed in time, not in cycles)."""
    return 1.5 / rate + current_lag


def gains(cfg, rate, rule, max_count_torque):
    base = cfg["controller"]
    kp, kd, fc = base["kp"], base["kd"], base.get("velocity_cutoff_hz", 250.0)
    if rule == "shipped":
        return kp, kd, fc
    cl = cfg["plant"].get("current_loop", {})
    lag = cl.get("time_constant", 0.0) if cl.get("enabled", True) else 0.0
    count = 2.0 * math.pi / cfg["plant"]["encoder"]["counts_per_revolution"]
    kp_cap = max_count_torque / count
    # The shipped gains are the 1 kHz point of the rule: bandwidth ~ 1 / effective delay
    # ("scaled"), or ~ the rate alone ("rate", for comparison: ignores the current loop).
    if rule == "rate":
        s = rate / 1000.0
    else:
        s = effective_delay(1000.0, lag) / effective_delay(rate, lag)
    s = min(s, math.sqrt(kp_cap / kp))
    return kp * s * s, kd * s, fc * s


def noise(csv_file, shape_segments):
    import numpy as np

    with open(csv_file, newline="") as f:
        rows = list(csv.DictReader(f))
    t = np.array([float(r["t"]) for r in rows])
    seg = np.array([int(r["segment"]) for r in rows])
    taus = [k for k in rows[0] if k.startswith("tau") and k[3:].isdigit()]
    dt = float(np.median(np.diff(t)))
    w = max(1, int(round(NOISE_WINDOW_S / dt)))
    w += 1 - w % 2  # odd: centred
    kernel = np.ones(w) / w
    mask = np.isin(seg, list(shape_segments))
    sq, n = 0.0, 0
    for k in taus:
        tau = np.array([float(r[k]) for r in rows])
        smooth = np.convolve(tau, kernel, mode="same")
        resid = (tau - smooth)[w:-w][mask[w:-w]]
        sq += float(np.sum(resid**2))
        n += resid.size
    return math.sqrt(sq / n) if n else float("nan")


def run_one(dualv, base_cfg, rate, rule, tmp, args):
    cfg = yaml.safe_load(open(base_cfg))
    kp, kd, fc = gains(cfg, rate, rule, args.max_count_torque)
    cfg["controller"].update({"kp": kp, "kd": kd, "velocity_cutoff_hz": fc})
    cfg["loop"]["rate_hz"] = float(rate)
    cfg.setdefault("can", {}).setdefault("sync", {})["period"] = round(1.0 / rate, 7)
    name = f"{rule}-{rate}"
    cfg_file = os.path.join(tmp, name + ".yaml")
    with open(cfg_file, "w") as f:
        yaml.safe_dump(cfg, f)
    out = os.path.join(tmp, name)
    cmd = [dualv, "run", "--rate", str(rate), "--variant", "retimed", "-c", cfg_file, "-o", out,
           "--no-plots"]
    if args.program:
        cmd += ["-p", args.program]
    p = subprocess.run(cmd, capture_output=True, text=True)
    res = {"rule": rule, "rate": rate, "kp": kp, "kd": kd, "cutoff": fc, "ok": p.returncode == 0}
    summary = os.path.join(out, "summary.csv")
    failed = [l for l in p.stdout.splitlines() if "FAILED" in l]
    if failed or not os.path.exists(summary):
        # A stopped run's figures cover part of the program only: not comparable.
        res["ok"] = False
        why = failed[0].split("): ", 1)[-1] if failed else (p.stderr or p.stdout or "no output")
        res["failure"] = why.strip().splitlines()[-1]
        return res
    shape_segments = set()
    with open(summary, newline="") as f:
        for r in csv.DictReader(f):
            if r["run"] != "retimed":
                continue
            key = {"all": "all shapes", "program": "program"}.get(r["segment"], r["shape"])
            res[key] = (float(r["max_e_mm"]), float(r["rms_e_mm"]))
            if r["segment"].isdigit():
                shape_segments.add(int(r["segment"]))
    res["noise"] = noise(os.path.join(out, "retimed.csv"), shape_segments)
    return res


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dualv", default="build/release/apps/dualv")
    ap.add_argument("--config", default="config/dualv.yaml")
    ap.add_argument("--program", default="")
    ap.add_argument("--out", default="out/rate-sweep")
    ap.add_argument("--rates", default=",".join(map(str, RATES)))
    ap.add_argument("--rules", default="shipped,scaled",
                    help="gain rules to run: shipped, scaled, rate (kp ~ f^2, for comparison)")
    ap.add_argument("--max-count-torque", type=float, default=0.25,
                    help="scaled gains: torque of one encoder count at most [N m]")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    rates = [int(r) for r in args.rates.split(",")]
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for rule in args.rules.split(","):
            for rate in rates:
                r = run_one(args.dualv, args.config, rate, rule, tmp, args)
                results.append(r)
                print(f"  {rule:8} {rate:6d} Hz: {'ok' if r['ok'] else 'stopped: ' + r.get('failure', '')}",
                      file=sys.stderr)

    cols = SHAPES + ["all shapes", "program"]
    with open(os.path.join(args.out, "rate_sweep.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["gains", "rate_hz", "kp", "kd", "velocity_cutoff_hz", "ok"] +
                   [f"{c}_{m}" for c in cols for m in ("max_e_mm", "rms_e_mm")] + ["torque_noise_nm"])
        for r in results:
            w.writerow([r["rule"], r["rate"], f"{r['kp']:.1f}", f"{r['kd']:.3f}", f"{r['cutoff']:.1f}",
                        int(r["ok"])] + [f"{r[c][i]:.4f}" if c in r else "" for c in cols for i in (0, 1)] +
                       [f"{r.get('noise', float('nan')):.4f}"])

    print("| gains | rate | kp, kd, filter | " + " | ".join(SHAPES) +
          " | all shapes | whole program | torque noise |")
    print("|---|---|---|" + "---|" * len(SHAPES) + "---|---|---|")
    for r in results:
        def cell(c):
            return f"{r[c][0]:.3f} / {r[c][1]:.3f}" if c in r else "-"
        status = "" if r["ok"] else f" (stopped: {r.get('failure', '')})"
        noise_cell = f"{r['noise']:.3f} N m" if "noise" in r else "-"
        print(f"| {r['rule']} | {r['rate'] / 1000:g} kHz{status} | {r['kp']:.0f}, {r['kd']:.1f}, "
              f"{r['cutoff']:.0f} Hz | " + " | ".join(cell(c) for c in SHAPES) +
              f" | {cell('all shapes')} | {cell('program')} | {noise_cell} |")
    print("(errors: max / RMS |(ex, ey)| in mm; torque noise: RMS of tau minus its 10 ms moving "
          "average over the shapes)")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5))
    styles = {"shipped": "-", "scaled": "--", "rate": ":"}
    for rule in args.rules.split(","):
        rs = [r for r in results if r["rule"] == rule and r["ok"] and "all shapes" in r]
        x = [r["rate"] / 1000 for r in rs]
        for c in SHAPES + ["program"]:
            axes[0].plot(x, [r[c][0] for r in rs], styles[rule], marker="o",
                         label=f"{c} ({rule})")
            axes[1].plot(x, [r[c][1] for r in rs], styles[rule], marker="o", label=f"{c} ({rule})")
        axes[2].plot(x, [r["noise"] for r in rs], styles[rule], marker="o", label=rule)
    for layout, hz in bus_limits(args.dualv, args.config).items():
        for ax in axes:
            ax.axvline(hz / 1000, color="grey", lw=0.8, ls=":")
        axes[0].annotate(f"{layout}\nmax {hz / 1000:.2f} kHz", (hz / 1000, 0.02), xycoords=("data", "axes fraction"),
                         fontsize=7, rotation=90, va="bottom", ha="right", color="grey")
    for ax, title, unit in zip(axes, ["max tracking error", "RMS tracking error", "torque noise"],
                               ["mm", "mm", "N m"]):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("control rate [kHz]")
        ax.set_ylabel(unit)
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
    axes[1].legend(fontsize=6, ncol=2)
    axes[2].legend(fontsize=8)
    fig.suptitle("Paper program, retimed, realism knobs on: shipped gains (solid) and gains scaled "
                 "with the rate (dashed)")
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "rate_sweep.png"), dpi=110)
    print(f"wrote {args.out}/rate_sweep.csv and rate_sweep.png", file=sys.stderr)


if __name__ == "__main__":
    main()
