#!/usr/bin/env python3
"""The two cracks of P3 (Kakouris & Triantafyllou, section 5.3.2, case
(ii)): a flexural crack from the beam's far (right) face at mid-span and a
crack from the impact (left) face, which may merge. Per particle snapshot
of a run of scenes/p3_sphere_beam.toml (or a variant), in the beam's
reference configuration: the broken particles (c < 0.1) within HALF of the
impact line y = Y0, sorted by x; the left crack is the run of them from
the impact face x = X0 inward (no gap wider than three particle
spacings), the right crack the run from the far face x = X0 + DEPTH. Printed:
each crack's depth from its face, whether they meet, and the beam's
fracture energy (the series' `fracture_energy_b0`) at the snapshot.

With --inclined (case (iii), whose cracks leave the impact line), each
face's crack is instead the connected set of broken particles (linked
within 1.5 particle spacings, in the reference configuration) that starts
within three spacings of that face and within WINDOW of the impact line;
printed are its depth (the largest distance from the face in x, m → mm)
and the y offset of its deepest particle from the impact line. Usage:

    python3 docs/scripts/p3_two_cracks.py OUT [--half 1e-3]
    python3 docs/scripts/p3_two_cracks.py OUT --inclined [--window 5e-3]
"""
import argparse
import csv
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from crack_band import grown, read_vtp, snapshots  # noqa: E402

X0, Y0, DEPTH = 0.035, 0.0375, 0.010
BEAM = 0


def beam(path, names):
    d = read_vtp(path, names + ["body_id", "particle_id"])
    m = d["body_id"] == BEAM
    o = np.argsort(d["particle_id"][m])
    return {k: d[k][m][o] for k in names}


def face_crack(pts, face, window, gap, link):
    """The broken points linked to face x = `face` near the impact line
    (see --inclined): (mask, depth from the face, y offset of the deepest)."""
    seen = grown(pts, (np.abs(pts[:, 0] - face) < gap) & (np.abs(pts[:, 1] - Y0) < window), link)
    if not seen.any():
        return seen, 0.0, 0.0
    dist = np.abs(pts[seen, 0] - face)
    k = int(np.argmax(dist))
    return seen, float(dist[k]), float(pts[seen][k, 1] - Y0)


def runs_from_faces(x, gap):
    """Depth of the run of sorted x from each face (0 if none starts there)."""
    x = np.sort(x)
    if len(x) == 0:
        return 0.0, 0.0
    breaks = np.where(np.diff(x) > gap)[0]
    first_end = x[breaks[0]] if len(breaks) else x[-1]
    last_start = x[breaks[-1] + 1] if len(breaks) else x[0]
    left = first_end - X0 if x[0] - X0 < gap else 0.0
    right = X0 + DEPTH - last_start if X0 + DEPTH - x[-1] < gap else 0.0
    return left, right


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out")
    p.add_argument("--half", type=float, default=1e-3)
    p.add_argument("--inclined", action="store_true")
    p.add_argument("--window", type=float, default=5e-3)
    a = p.parse_args()
    snaps = snapshots(a.out)
    ref = beam(snaps[0][1], ["position", "volume"])["position"]
    xs = np.unique(np.round(ref[:, 0], 9))
    spacing = float(np.median(np.diff(xs)))
    rows = list(csv.DictReader(open(Path(a.out) / "series.csv")))
    times = np.array([float(r["time"]) for r in rows])
    if a.inclined:
        print(" t (us)  left depth (mm)  its dy (mm)  right depth (mm)  its dy (mm)  joined  beam Psi_f (J)")
        for t, f in snaps[1:]:
            c = beam(f, ["phase_field"])["phase_field"]
            pts = ref[c < 0.1]
            lm, left, ly = face_crack(pts, X0, a.window, 3 * spacing, 1.5 * spacing)
            rm, right, ry = face_crack(pts, X0 + DEPTH, a.window, 3 * spacing, 1.5 * spacing)
            joined = bool((lm & rm).any())
            psi = float(rows[int(np.argmin(np.abs(times - t)))]["fracture_energy_b0"])
            print(f"{1e6 * t:7.1f}  {1e3 * left:10.2f}  {1e3 * ly:12.2f}  {1e3 * right:14.2f}  {1e3 * ry:12.2f}     "
                  f"{'yes' if joined else 'no ':3s}   {psi:.4f}")
        sys.exit(0)
    print(" t (us)  left crack (mm)  right crack (mm)  joined  beam Psi_f (J)")
    for t, f in snaps[1:]:
        c = beam(f, ["phase_field"])["phase_field"]
        near = (np.abs(ref[:, 1] - Y0) < a.half) & (c < 0.1)
        left, right = runs_from_faces(ref[near, 0], 3 * spacing)
        joined = left >= DEPTH - 3 * spacing or right >= DEPTH - 3 * spacing
        psi = float(rows[int(np.argmin(np.abs(times - t)))]["fracture_energy_b0"])
        print(f"{1e6 * t:7.1f}  {1e3 * left:10.2f}  {1e3 * right:14.2f}     {'yes' if joined else 'no ':3s}   {psi:.4f}")
