"""The crack of a Kalthoff-Winkler run (scenes/d2_kalthoff.toml and the
variants docs/scripts/d2_kalthoff.sh writes) from its series.csv: the
angle of the line from the notch tip (50, 25) mm to the crack tip, from
the notch's axis, at 20, 40, 60 and 90 us; the crack's length at the end;
the peak crack speed (1-us rows) and the mean over 40-50 us (the length
gained); the
fracture energy at the end. The series' tip is the farthest D > 0.9
particle connected to the origin through such particles, and loses the
crack where a kink leaves a particle below 0.9; so the last snapshot is
read too: the plate's particles with D >= 0.9 above the notch's plane,
linked to the notch tip through broken neighbours less than 2.5
spacings apart; the crack's end is the one farthest from the tip ("end",
its length and angle from the tip), and the speed of that end between
the snapshots nearest 40 and 50 us. Usage: python3 d2_kalthoff.py
OUT_DIR..."""
import csv
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from crack_band import linked_to, read_vtp, snapshots  # noqa: E402

TIP = (0.05, 0.025)  # --tip X,Y for another (a notch cut as a gap: its corner)


def snapshot_end(f):
    """The end of the crack in snapshot `f` as the docstring says: (end, its
    distance from the tip, its angle), None without a crack."""
    a = read_vtp(f, ["position", "damage", "volume", "body_id"])
    plate = a["body_id"] == 0
    h = math.sqrt(np.median(a["volume"][plate]) / 1e-3)  # thickness 1 mm
    x = a["position"][:, :2]
    tip = np.array(TIP)
    pts = x[plate & (a["damage"] >= 0.9) & (x[:, 1] > TIP[1] + 0.5 * h) & (x[:, 0] > TIP[0] - 3 * h)]
    c = pts[linked_to(pts, tip, 4 * h, 2.5 * h)]
    if len(c) == 0:
        return None
    r = np.hypot(*(c - tip).T)
    e = c[np.argmax(r)]
    return e, r.max(), math.degrees(math.atan2(e[1] - tip[1], e[0] - tip[0]))


def from_snapshots(d):
    """The snapshots' crack: its end at the last one, and the speed of its
    end over the snapshots nearest 40 and 50 us."""
    if not Path(f"{d}/particles.pvd").exists():
        return "none"
    snaps = snapshots(d)
    last = snapshot_end(snaps[-1][1])
    if last is None:
        return "no crack above the notch"
    (e, r, ang) = last
    (t0, f0), (t1, f1) = (min(snaps, key=lambda s: abs(s[0] - t)) for t in (40e-6, 50e-6))
    r0, r1 = ((x[1] if x else 0.0) for x in (snapshot_end(f0), snapshot_end(f1)))
    return (f"end ({1e3 * e[0]:.1f}, {1e3 * e[1]:.1f}) mm, {1e3 * r:.1f} mm from the tip at {ang:.1f} deg; "
            f"its speed {1e6 * t0:.0f}-{1e6 * t1:.0f} us {(r1 - r0) / (t1 - t0) / 1e3:.2f} km/s")


def summary(d):
    rows = list(csv.DictReader(open(f"{d}/series.csv")))
    def at(t):
        return min(rows, key=lambda r: abs(float(r["time"]) - t))
    def angle(r):
        dx = float(r["crack_tip_x"]) - TIP[0]
        dy = float(r["crack_tip_y"]) - TIP[1]
        if math.hypot(dx, dy) < 2e-4:
            return "-"
        return f"{math.degrees(math.atan2(dy, dx)):.1f}"
    angles = " / ".join(angle(at(t)) for t in (20e-6, 40e-6, 60e-6, 90e-6))
    speeds = [float(r["crack_speed"]) for r in rows if not math.isnan(float(r["crack_speed"]))]
    # the paper's window (Belytschko et al.'s 40-50 us): the length gained over it
    mean = (float(at(50e-6)["crack_length"]) - float(at(40e-6)["crack_length"])) / 10e-6
    last = rows[-1]
    return (f"{d}: angle at 20/40/60/90 us {angles} deg; length {1e3 * float(last['crack_length']):.1f} mm; "
            f"speed peak {max(speeds) / 1e3:.2f} km/s, mean 40-50 us {mean / 1e3:.2f} km/s; "
            f"tip ({1e3 * float(last['crack_tip_x']):.1f}, {1e3 * float(last['crack_tip_y']):.1f}) mm; "
            f"fracture energy {float(last['fracture_energy']):.3f} J; snapshots: {from_snapshots(d)}")


args = sys.argv[1:]
if args[:1] == ["--tip"]:
    TIP = tuple(float(v) for v in args[1].split(","))
    args = args[2:]
for d in args:
    print(summary(d))
