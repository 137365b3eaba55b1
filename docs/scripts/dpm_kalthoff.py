#!/usr/bin/env python3
"""The crack of a Kalthoff-Winkler run of the damage particle method
(scenes/dpm_kalthoff.toml) from its last snapshot: the broken particles
(damage >= 0.99) in their reference places (position - displacement),
the crack's length from the notch tip (the farthest broken particle
connected to the tip through broken neighbours within 2.5 spacings), and
its angle to the x axis: of the line from the tip to that particle, and
the least-squares one through the connected broken particles. With
--series it adds the dissipation at the end (fracture_energy, J per m of
thickness at thickness = 1).

    python3 docs/scripts/dpm_kalthoff.py OUT_DIR [--tip 0.05,0.025]
"""
import argparse, glob, math, sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from crack_band import linked_to, read_vtp  # noqa: E402


def crack(out, tip):
    f = sorted(glob.glob(f"{out}/particles_*.vtp"))[-1]
    d = read_vtp(f, ["position", "displacement", "damage", "volume"])
    x0 = d["position"][:, :2] - d["displacement"][:, :2]
    h = math.sqrt(np.median(d["volume"]))
    broken = np.where(d["damage"] >= 0.99)[0]
    pts = x0[broken]
    # connected to the tip through broken particles within 2.5 spacings
    seen = linked_to(pts, tip, 2.5 * h, 2.5 * h)
    c = pts[seen]
    if len(c) == 0:
        return dict(snapshot=f, spacing=h, broken=len(broken), connected=0)
    r = np.hypot(*(c - tip).T)
    far = c[np.argmax(r)]
    ang_far = math.degrees(math.atan2(far[1] - tip[1], far[0] - tip[0]))
    # principal axis of the connected points about the tip
    q = c - tip
    _, _, vt = np.linalg.svd(np.vstack([q, [0.0, 0.0]]), full_matrices=False)
    v = vt[0] if vt[0] @ (far - tip) > 0 else -vt[0]
    ang_fit = math.degrees(math.atan2(v[1], v[0]))
    return dict(snapshot=f, spacing=h, broken=len(broken), connected=int(seen.sum()),
                length=float(r.max()), angle_far=ang_far, angle_fit=ang_fit)


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out", nargs="+")
    p.add_argument("--tip", default="0.05,0.025")
    a = p.parse_args()
    tip = np.array([float(v) for v in a.tip.split(",")])
    for out in a.out:
        r = crack(out, tip)
        rows = open(f"{out}/series.csv").read().split("\n")
        head = rows[0].split(",")
        last = [v for v in rows if v][-1].split(",")
        r["dissipated"] = float(last[head.index("fracture_energy")])
        r["time"] = float(last[head.index("time")])
        print(out, " ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in r.items() if k != "snapshot"))
