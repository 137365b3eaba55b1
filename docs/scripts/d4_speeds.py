#!/usr/bin/env python3
"""Where the Brazilian disk's mean speed (seed 000 D4) comes from, at the
last snapshot of each run given: the mass-weighted mean |v| of the disk's
particles (body 0) in all (the series' `mean_speed`), of those with
damage below 0.5 (the fragments' material, `output.fragment_damage`), of
the failed ones (damage 1), with the mass share of each; and the
mass-weighted mean speed of the fragments of 10 particles or more (from
fragments_NNNN.csv). Usage: python3 docs/scripts/d4_speeds.py OUT_DIR..."""
import csv
import glob
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from crack_band import read_vtp  # noqa: E402

for out in sys.argv[1:]:
    f = sorted(glob.glob(f"{out}/particles_*.vtp"))[-1]
    d = read_vtp(f, ["velocity", "mass", "damage", "body_id"])
    disk = d["body_id"] == 0
    m, v, dmg = d["mass"][disk], np.linalg.norm(d["velocity"][disk], axis=1), d["damage"][disk]

    def mean(sel):
        return (m[sel] * v[sel]).sum() / m[sel].sum() if sel.any() else float("nan")

    intact, failed = dmg < 0.5, dmg >= 1.0
    frags = [r for r in csv.DictReader(open(sorted(glob.glob(f"{out}/fragments_*.csv"))[-1]))
             if int(r["particles"]) >= 10]
    fm = sum(float(r["mass"]) for r in frags)
    fv = sum(float(r["mass"]) * float(r["speed"]) for r in frags) / fm if fm else float("nan")
    print(f"{out}: {disk.sum()} particles; mean |v| all {mean(np.ones_like(intact)):.1f} m/s; "
          f"damage < 0.5: {mean(intact):.1f} m/s ({m[intact].sum() / m.sum():.1%} of the mass); "
          f"failed: {mean(failed):.1f} m/s ({m[failed].sum() / m.sum():.1%}); "
          f"fragments >= 10 particles: {fv:.1f} m/s ({len(frags)} of them, {fm / m.sum():.1%})")
