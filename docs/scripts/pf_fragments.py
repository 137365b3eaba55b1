#!/usr/bin/env python3
"""Fragments of each body of a phase-field run, per snapshot: the
connected components of its intact particles (phase field c >= C, default
0.5), two particles linked when closer than 1.5 particle spacings (the
spacing from the median particle area, volume / thickness). Pieces of
fewer than MIN particles (default 1 % of the body's) are counted apart as
debris. Used for seed 001's P2 (two rings: each breaks in two at
+-0.01 mm/us and in five at +-0.02 mm/us).

    python3 docs/scripts/pf_fragments.py OUT_DIR [--thickness 0.002] [--c 0.5] [--min 0.01] [--last]
"""
import argparse
import math
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from crack_band import read_vtp, snapshots  # noqa: E402


def components(x, link):
    """Labels of the connected components of points x (n x 2) linked when
    closer than `link`, by union-find over bins of that size."""
    n = len(x)
    parent = np.arange(n)

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    bins = defaultdict(list)
    keys = np.floor(x / link).astype(np.int64)
    for i, (a, b) in enumerate(keys):
        bins[(a, b)].append(i)
    for (a, b), members in bins.items():
        near = []
        for da in (-1, 0, 1):
            for db in (-1, 0, 1):
                near.extend(bins.get((a + da, b + db), ()))
        near = np.array(near)
        for i in members:
            d = np.hypot(*(x[near] - x[i]).T)
            for j in near[(d < link) & (near > i)]:
                ri, rj = find(i), find(j)
                if ri != rj:
                    parent[max(ri, rj)] = min(ri, rj)
    return np.array([find(i) for i in range(n)])


def fragments(path, thickness, c_min, min_share):
    d = read_vtp(path, ["position", "phase_field", "volume", "body_id"])
    out = []
    for body in np.unique(d["body_id"]):
        m = d["body_id"] == body
        spacing = math.sqrt(np.median(d["volume"][m]) / thickness)
        intact = m & (d["phase_field"] >= c_min)
        labels = components(d["position"][intact][:, :2], 1.5 * spacing)
        sizes = sorted(np.bincount(np.unique(labels, return_inverse=True)[1]), reverse=True)
        big = [s for s in sizes if s >= min_share * m.sum()]
        out.append((int(body), len(big), len(sizes) - len(big), big))
    return out


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out")
    p.add_argument("--thickness", type=float, default=0.002)
    p.add_argument("--c", type=float, default=0.5)
    p.add_argument("--min", type=float, default=0.01)
    p.add_argument("--last", action="store_true", help="the last snapshot only")
    a = p.parse_args()
    snaps = snapshots(a.out, partial=True)  # a run still going: its snapshots so far
    if a.last:
        snaps = snaps[-1:]
    for t, f in snaps:
        parts = "; ".join(f"body {b}: {n} fragments {[int(v) for v in big]}" + (f" + {k} debris" if k else "")
                          for b, n, k, big in fragments(f, a.thickness, a.c, a.min))
        print(f"{1e6 * t:6.1f} us  {parts}")
