#!/usr/bin/env python3
"""P3's Hertzian cone index (Kakouris & Triantafyllou, section 5.3.4,
Figs. 30-31) from the runs of docs/scripts/p3_cone.sh: per projectile
speed, the beam's phase field at the run's last snapshot (t = 16 us, the
paper's instant) read in the beam's reference configuration (each
particle where it was at t = 0), depth d from the impact face x = X0 and
offset s from the impact line y = Y0.

- cone (beta = 1): on *both* sides of the impact line, broken particles
  (c < 0.1) in the wedge 2 mm <= d <= 10 mm, 2 mm <= |s| <= 2 mm + 1.5 d
  (within about 56 degrees of the beam's normal, off the crushed zone
  under the disk) that span at least 2 mm of depth: two inclined cracks
  running from the contact zone into the beam. Cracks from the impact
  face farther along the beam (the paper's "secondary cracks from the
  left edge") fall outside the wedge.
- on the line: the deepest broken particle within 1 mm of the impact
  line and deeper than 2 mm (a crack there, from either face;
  docs/scripts/p3_two_cracks.py tells which).

Prints a row per run (speed, beta, each side's span, the depth on the line, the
beam's fracture energy at the end, wall seconds) and, with --plot, draws
beta against the speed (the paper's Fig. 30) and the phase field of six
speeds (its Fig. 31). Usage:

    python3 docs/scripts/p3_cone.py OUT [--plot PNG] [--panels PNG]
"""
import argparse
import csv
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from crack_band import read_vtp, snapshots  # noqa: E402

X0, Y0 = 0.035, 0.0375
BEAM = 0


def reference(path):
    d = read_vtp(path, ["position", "body_id", "particle_id"])
    m = d["body_id"] == BEAM
    o = np.argsort(d["particle_id"][m])
    return d["position"][m][o]


def measure(run):
    snaps = snapshots(run)
    x0 = reference(snaps[0][1])
    d = read_vtp(snaps[-1][1], ["phase_field", "body_id", "particle_id"])
    m = d["body_id"] == BEAM
    c = d["phase_field"][m][np.argsort(d["particle_id"][m])]
    depth, s = x0[:, 0] - X0, x0[:, 1] - Y0
    broken = c < 0.1
    wedge = broken & (depth >= 2e-3) & (depth <= 10e-3) & (np.abs(s) >= 2e-3) & (np.abs(s) <= 2e-3 + 1.5 * depth)
    spans = []
    for side in (s > 0, s < 0):
        k = wedge & side
        spans.append(float(np.ptp(depth[k])) if k.any() else 0.0)
    med = broken & (np.abs(s) < 1e-3) & (depth > 2e-3)
    median = float(depth[med].max()) if med.any() else 0.0
    beta = int(min(spans) >= 2e-3)
    rows = list(csv.DictReader(open(Path(run) / "series.csv")))
    psi = float(rows[-1]["fracture_energy"])
    return beta, spans, median, psi, snaps[-1][0]


def speed(run):
    text = (Path(run) / "scene.toml").read_text()
    for line in text.splitlines():
        if line.startswith("velocity = ["):
            return float(line.split("[")[1].split(",")[0])
    raise ValueError(f"{run}: no velocity")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out")
    p.add_argument("--plot")
    p.add_argument("--panels")
    a = p.parse_args()
    runs = sorted((speed(r), r) for r in Path(a.out).glob("v*") if (r / "particles.pvd").exists())
    print(" v0 (mm/us)  beta  cone span above / below (mm)  on the line to (mm)  beam+disk Psi_f (J)  wall (s)")
    table = []
    for v, r in runs:
        beta, spans, median, psi, t = measure(r)
        wall = json.loads((r / "summary.json").read_text())["wall_seconds"] if (r / "summary.json").exists() else float("nan")
        table.append((v, beta))
        print(f"  {v / 1000:8.3f}   {beta}     {1e3 * spans[0]:5.2f} / {1e3 * spans[1]:5.2f}          {1e3 * median:5.2f}            {psi:.4f}          {wall:.0f}")
    onset = next((v for v, b in table if b), None)
    print(f"first speed with a cone: {onset / 1000 if onset else None} mm/us (the paper: above 0.10 mm/us)")
    if a.plot or a.panels:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    if a.plot:
        fig, ax = plt.subplots(figsize=(6, 3))
        ax.step([v / 1000 for v, _ in table], [b for _, b in table], where="mid", label="this run (h = l0 = 0.25 mm)")
        ax.plot([v / 1000 for v, _ in table], [b for _, b in table], "o")
        ax.axvline(0.10, color="k", ls="--", lw=0.8, label="the paper's onset (0.10 mm/µs)")
        ax.set_xlabel("projectile speed (mm/µs)")
        ax.set_ylabel("Hertzian cone index β")
        ax.set_yticks([0, 1])
        ax.legend(loc="center left", fontsize=8)
        fig.tight_layout()
        fig.savefig(a.plot, dpi=110)
    if a.panels:
        pick = [0.02, 0.06, 0.09, 0.10, 0.13, 0.18]
        chosen = runs if len(runs) <= len(pick) else [min(runs, key=lambda vr: abs(vr[0] / 1000 - q)) for q in pick]
        fig, axes = plt.subplots(1, len(chosen), figsize=(1.6 * len(chosen), 5.0), sharey=True)
        for ax, (v, r) in zip(axes, chosen):
            d = read_vtp(snapshots(r)[-1][1], ["position", "phase_field", "body_id"])
            m = d["body_id"] == BEAM
            xy = d["position"][m]
            ax.scatter(1e3 * xy[:, 0], 1e3 * xy[:, 1], c=d["phase_field"][m], s=0.05, cmap="viridis", vmin=0, vmax=1, rasterized=True)
            ax.set_title(f"{v / 1000:.3f} mm/µs", fontsize=9)
            ax.set_xlim(33, 48)
            ax.set_ylim(10, 65)
            ax.set_aspect("equal")
            ax.set_xlabel("x (mm)")
        axes[0].set_ylabel("y (mm)")
        fig.suptitle("beam's phase field at 16 µs (0 = broken)", fontsize=10)
        fig.tight_layout()
        fig.savefig(a.panels, dpi=110)
