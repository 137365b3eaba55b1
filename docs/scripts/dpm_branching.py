#!/usr/bin/env python3
"""The cracks of a branching run (scenes/dpm_branching.toml by the damage
particle method, scenes/p1_plate*.toml by the phase field) from its
snapshots: a particle is broken where its damage (or 1 - phase field) is
at least THRESHOLD; positions are the reference ones (position -
displacement) where the snapshot has displacements. Prints

- the crack front (the farthest broken particle to the right of the
  notch tip at x = 0.05 m) at each snapshot, and the mean speed of the
  front between x = 0.055 m and its last position;
- the branches at the end: the broken particles of the columns x = 0.07,
  0.08, 0.09 m (within one spacing), grouped where consecutive ones are
  more than 3 spacings apart in y: how many groups and their mean y;
- the dissipation at the end (`fracture_energy`, J per m of thickness).

    python3 docs/scripts/dpm_branching.py OUT_DIR... [--threshold 0.9] [--plot out.png]
"""
import argparse, math, re, sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from crack_band import read_vtp  # noqa: E402


def snapshots(out):
    pvd = open(f"{out}/particles.pvd").read()
    return [(float(t), f"{out}/{f}") for t, f in re.findall(r'timestep="([^"]+)"[^>]*file="([^"]+)"', pvd)]


def broken(path, threshold):
    d = read_vtp(path, ["position", "displacement", "damage", "phase_field", "volume"])
    x = d["position"][:, :2]
    if "displacement" in d:
        x = x - d["displacement"][:, :2]
    # the phase field is 1 intact, 0 broken: 1 - c is its damage
    c = d["damage"] if "damage" in d else 1.0 - d["phase_field"]
    h = math.sqrt(np.median(d["volume"]))
    return x, c, x[c >= threshold], h


def analyse(out, threshold):
    snaps = snapshots(out)
    front = []
    for t, f in snaps:
        _, _, b, h = broken(f, threshold)
        right = b[b[:, 0] >= 0.05]
        front.append((t, float(right[:, 0].max()) if len(right) else float("nan")))
    _, _, b, h = broken(snaps[-1][1], threshold)
    branches = {}
    for col in (0.07, 0.08, 0.09):
        y = np.sort(b[np.abs(b[:, 0] - col) <= h, 1])
        groups = np.split(y, np.where(np.diff(y) > 3 * h)[0] + 1) if len(y) else []
        branches[col] = [round(float(g.mean()) * 1e3, 1) for g in groups]
    ts = [(t, x) for t, x in front if x == x and x >= 0.055]
    speed = (ts[-1][1] - ts[0][1]) / (ts[-1][0] - ts[0][0]) if len(ts) > 1 and ts[-1][0] > ts[0][0] else float("nan")
    rows = open(f"{out}/series.csv").read().split("\n")
    head = rows[0].split(",")
    last = [v for v in rows if v][-1].split(",")
    g = float(last[head.index("fracture_energy")]) if "fracture_energy" in head else float("nan")
    return dict(spacing=h, front=front, speed=speed, branches=branches, dissipated=g)


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out", nargs="+")
    p.add_argument("--threshold", type=float, default=0.9)
    p.add_argument("--plot", help="write the runs' last snapshots side by side to this PNG (needs matplotlib)")
    a = p.parse_args()
    for out in a.out:
        r = analyse(out, a.threshold)
        print(f"{out}: spacing {r['spacing']:.3g} m, dissipated {r['dissipated']:.4g} J/m, "
              f"front speed {r['speed']:.0f} m/s")
        print("  front (us: mm): " + ", ".join(f"{t * 1e6:.0f}: {x * 1e3:.1f}" for t, x in r["front"] if x == x))
        print("  branches (column mm: group y mm): " + "; ".join(f"{c * 1e3:.0f}: {v}" for c, v in r["branches"].items()))
    if a.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, axes = plt.subplots(len(a.out), 1, figsize=(8, 3.4 * len(a.out)), squeeze=False)
        for ax, out in zip(axes[:, 0], a.out):
            x, c, _, h = broken(snapshots(out)[-1][1], a.threshold)
            # squares about a spacing wide (the axes span about 4.5 points per mm; a little more closes the seams)
            ax.scatter(x[:, 0] * 1e3, x[:, 1] * 1e3, c=c, s=(h * 1e3 * 6.0) ** 2, vmin=0, vmax=1,
                       cmap="viridis", marker="s", linewidths=0)
            ax.set_xlim(0, 100); ax.set_ylim(0, 40); ax.set_aspect("equal")
            what = "damage" if "damage" in read_vtp(snapshots(out)[-1][1], ["damage"]) else "1 - phase field"
            ax.set_title(f"{Path(out).name}: {what} at the end (particle spacing {h * 1e3:.2g} mm)", fontsize=9)
            ax.set_xlabel("x, mm"); ax.set_ylabel("y, mm")
        fig.tight_layout()
        fig.savefig(a.plot, dpi=130)
        print("wrote", a.plot)
