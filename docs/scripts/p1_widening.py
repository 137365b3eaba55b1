#!/usr/bin/env python3
"""Crack widening and branching in Borden's plate (seed 001 P1) from a
run's particle snapshots, as Borden et al. tell them apart: the zone with
c < 0.1 near the tip first widens, then splits. Per snapshot: the tip (the
largest x of a c < 0.1 particle within 10 mm of the pre-crack's line
y = Y0), the zone's width across y in 1-mm columns, and the number of
separate c < 0.1 intervals in a column (a gap of more than two particle
spacings splits them). Printed: the width in the 2 mm behind the tip
against the band's width 4-10 mm behind it (widening: the ratio above
1.5), and the largest number of intervals within 4 mm of the tip
(branching: two). Usage:

    python3 docs/scripts/p1_widening.py OUT_DIR [--y0 0.02] [--from 5e-6]
"""
import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from crack_band import read_vtp, snapshots  # noqa: E402


def column(y, gap):
    """Width (max - min) and number of intervals of the sorted values y."""
    if len(y) == 0:
        return 0.0, 0
    y = np.sort(y)
    return y[-1] - y[0], 1 + int(np.sum(np.diff(y) > gap))


def measure(path, y0, thickness):
    d = read_vtp(path, ["position", "phase_field", "volume"])
    x, y = d["position"][:, 0], d["position"][:, 1]
    s = math.sqrt(np.median(d["volume"]) / thickness)
    m = (d["phase_field"] < 0.1) & (np.abs(y - y0) < 0.01)
    if not m.any():
        return None
    xb, yb = x[m], y[m]
    tip = xb.max()
    def band(lo, hi):
        cols = [column(yb[(xb >= a) & (xb < a + 1e-3)], 2 * s) for a in np.arange(lo, hi, 1e-3)]
        return cols
    near = band(tip - 2e-3, tip)
    behind = band(tip - 10e-3, tip - 4e-3)
    w_near = max((w for w, _ in near), default=0.0)
    w_behind = np.median([w for w, _ in behind]) if behind else 0.0
    splits = max((k for _, k in band(tip - 4e-3, tip)), default=0)
    return tip, w_near, w_behind, splits


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out")
    p.add_argument("--y0", type=float, default=0.02)
    p.add_argument("--from", dest="t0", type=float, default=5e-6)
    p.add_argument("--thickness", type=float, default=1.0)
    a = p.parse_args()
    snaps = snapshots(a.out)
    print(" t (us)   tip x (mm)  speed (m/s)  width near tip / behind (mm)  ratio  intervals")
    last = None
    for t, f in snaps:
        if t < a.t0:
            continue
        r = measure(f, a.y0, a.thickness)
        if r is None:
            continue
        tip, wn, wb, k = r
        v = (tip - last[1]) / (t - last[0]) if last else math.nan
        last = (t, tip)
        ratio = wn / wb if wb > 0 else math.nan
        print(f"{1e6 * t:7.2f}  {1e3 * tip:9.2f}  {v:10.0f}   {1e3 * wn:6.2f} / {1e3 * wb:5.2f}   {ratio:6.2f}  {k}")
