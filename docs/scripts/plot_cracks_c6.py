#!/usr/bin/env python3
"""Measure and plot runs of the ten-crack plate (Nairn & Aimene 3.7, C6).

    python3 docs/scripts/plot_cracks_c6.py --rate R LABEL=RUN_DIR [--rate R LABEL=RUN_DIR ...]
        [--paths docs/cracks-c6.png] [--curves docs/cracks-c6-stress.png]

Each RUN_DIR is the --out of `cleave run` on a scene written by
docs/scripts/cramp_ten_cracks_scene.py (docs/scripts/cracks_c6.sh runs
all four). From its series.csv and its first and last cracks_NNNN.vtp it
prints, per run (its strain rate R, 1/s, the --rate before it: 4.1351 for
the paper's slow rate, 206.75 for its fast one):

- per crack (numbered
  1-10, crack0_* is crack 1), when it first grew (the first row where its
  length is 0.1 mm beyond the first row's stretched by twice the nominal
  strain: a segment is half a cell, 0.198 mm), at what nominal strain,
  and how much its length grew by the end;
- the nominal stress: the force on the plate from each grip's momentum
  (its rate is the force the plate exerts on it; roller grips, whose
  momentum is driven, report their force in the reaction columns), the
  mean of top and bottom over the plate's width and thickness, and its
  peak; under biaxial loading, the same along x from the side grips, and
  both stresses' means over the run's last fifth;
- the energy the cracks released (the series' fracture_energy).

With matplotlib: the initial and final crack planes of every run
(--paths) and the nominal stress against strain (--curves).
"""
import csv
import glob
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from plot_offset_cracks import read_cracks  # noqa: E402

W = 0.0508
THICKNESS = 1.0


def series(run):
    rows = list(csv.DictReader(open(os.path.join(run, "series.csv"))))
    return {k: [float(r[k]) for r in rows] for k in rows[0]}


def planes(run):
    files = sorted(glob.glob(os.path.join(run, "cracks_*.vtp")))
    first = [ln["points"] for ln in read_cracks(files[0]) if ln["surface"] == 0]
    last = [ln["points"] for ln in read_cracks(files[-1]) if ln["surface"] == 0]
    return first, last


def measure(label, run, rate):
    s = series(run)
    t = s["time"]
    n = sum(1 for k in s if k.startswith("crack") and k.endswith("_length"))
    # the grips move at a constant speed (bonded ones are slowed by under
    # 1e-4): the nominal strain is the strain rate times the time
    strain = [rate * x for x in t]

    def grip_force(low, high, axis):
        """The mean of the pulls of grips `low` and `high` along `axis`."""
        if f"reaction_{high}_grip_{axis}" in s:
            # the drive's force on the material it holds: on the plate
            # (the driven grip's own momentum is constant)
            return [0.5 * (h - l) for h, l in zip(s[f"reaction_{high}_grip_{axis}"],
                                                  s[f"reaction_{low}_grip_{axis}"])]
        p_high, p_low = s[f"momentum_{axis}_{high}_grip"], s[f"momentum_{axis}_{low}_grip"]
        force = []
        for k in range(len(t)):
            a, b = max(k - 1, 0), min(k + 1, len(t) - 1)
            dt = t[b] - t[a]
            force.append(0.5 * (-(p_high[b] - p_high[a]) + (p_low[b] - p_low[a])) / dt)
        return force

    stress = [f / (W * THICKNESS) for f in grip_force("bottom", "top", "y")]
    print(f"== {label} ({run}): strain rate {rate:.4g} /s, {len(t)} rows to {t[-1] * 1e3:.3f} ms")
    peak = max(range(len(t)), key=lambda k: stress[k])
    print(f"   peak nominal stress {stress[peak] / 1e6:.2f} MPa at {t[peak] * 1e6:.1f} us, "
          f"strain {strain[peak] * 100:.3f} %")
    tail = [k for k in range(len(t)) if t[k] >= 0.8 * t[-1]]
    held = f"   over the last fifth: nominal stress y {sum(stress[k] for k in tail) / len(tail) / 1e6:.2f} MPa"
    if any(k.startswith("momentum_x_left_grip") or k.startswith("reaction_left_grip") for k in s):
        across = [f / (W * THICKNESS) for f in grip_force("left", "right", "x")]
        held += f", x {sum(across[k] for k in tail) / len(tail) / 1e6:.2f} MPa"
    print(held)
    print(f"   released energy {s['fracture_energy'][-1]:.4g} J (per m of thickness)")
    order = []
    for c in range(n):
        length = s[f"crack{c}_length"]
        # a growth event adds half a cell (0.198 mm); the crack's length
        # also stretches with the plate, by up to the strain times its
        # length (twice that where the waves from the ends meet)
        first = next((k for k in range(len(t))
                      if length[k] > length[0] * (1.0 + 2.0 * strain[k]) + 1e-4), None)
        grown = (length[-1] - length[0]) * 1e3
        if first is None:
            print(f"   crack {c + 1:2d}: never grew")
        else:
            order.append((t[first], c + 1))
            print(f"   crack {c + 1:2d}: first grew at {t[first] * 1e6:7.1f} us "
                  f"(strain {strain[first] * 100:.3f} %), grown {grown:5.1f} mm")
    order.sort()
    print("   order: " + ", ".join(f"{c}" for _, c in order))
    print(f"   {n - len(order)} of {n} cracks never grew")
    return dict(t=t, strain=strain, stress=stress, planes=planes(run))


def main():
    args = sys.argv[1:]
    paths_png = curves_png = None
    rate = None
    runs = []
    while args:
        a = args.pop(0)
        if a == "--paths":
            paths_png = args.pop(0)
        elif a == "--curves":
            curves_png = args.pop(0)
        elif a == "--rate":
            rate = float(args.pop(0))
        else:
            label, run = a.split("=", 1)
            runs.append((label, measure(label, run, rate)))
    if not (paths_png or curves_png):
        return
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("(no matplotlib: numbers only)")
        return
    if paths_png:
        cols = min(len(runs), 2)
        rows = (len(runs) + cols - 1) // cols
        fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 4.2 * rows), squeeze=False)
        for ax, (label, r) in zip(axes.flat, runs):
            ax.plot([0, W * 1e3, W * 1e3, 0, 0], [0, 0, W * 1e3, W * 1e3, 0], color="0.6", lw=0.8)
            first, last = r["planes"]
            for k, pts in enumerate(last):
                ax.plot([p[0] * 1e3 for p in pts], [p[1] * 1e3 for p in pts], color="k", lw=1.2)
            for k, pts in enumerate(first):
                ax.plot([p[0] * 1e3 for p in pts], [p[1] * 1e3 for p in pts], color="tab:red", lw=2.0)
                mid = pts[len(pts) // 2]
                ax.annotate(str(k + 1), (mid[0] * 1e3, mid[1] * 1e3), xytext=(4, 4),
                            textcoords="offset points", color="tab:red", fontsize=8)
            ax.set_title(label, fontsize=10)
            ax.set_aspect("equal")
            ax.set_xlim(-1, W * 1e3 + 1)
            ax.set_ylim(-1, W * 1e3 + 1)
            ax.set_xlabel("x (mm)")
            ax.set_ylabel("y (mm)")
        for ax in list(axes.flat)[len(runs):]:
            ax.axis("off")
        fig.suptitle("Ten-crack plate: initial cracks (red) and final crack planes (black)", fontsize=10)
        fig.tight_layout()
        fig.savefig(paths_png, dpi=130)
        print(f"wrote {paths_png}")
    if curves_png:
        fig, ax = plt.subplots(figsize=(6, 4))
        for label, r in runs:
            ax.plot([e * 100 for e in r["strain"]], [s / 1e6 for s in r["stress"]], label=label, lw=1)
        ax.set_xlabel("nominal strain (%)")
        ax.set_ylabel("nominal stress (MPa)")
        ax.set_title("Ten-crack plate: nominal stress from the grips' force on the plate")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(curves_png, dpi=130)
        print(f"wrote {curves_png}")


if __name__ == "__main__":
    main()
