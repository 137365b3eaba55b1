#!/usr/bin/env python3
"""Summarise and plot E1 (docs/eigen.md) from the runs docs/scripts/eigen_e1.sh
leaves in OUT: lme/, linear/ (eigenerosion, MUSL), lme_newmark/ and
linear_newmark/ (the same under the Newmark predictor-corrector), and j/
(the explicit crack's J).
The reaction per flank is the walls' work rate over their speed,
R = (dW_ext/dt) / (2 v), from consecutive series rows; "noise" is the RMS
of R minus its running mean over 11 rows, over the loading before the
first erosion, divided by the peak.
Usage: python3 docs/scripts/eigen_e1.py OUT PNG"""
import csv, sys

out, png = sys.argv[1], sys.argv[2]
V, GC, AREA = 2.5e-4, 1.0e-4, 0.75  # flank speed, G_c, crack area (0.75 H x 1)


def disp(t):
    # the walls' ramp to V over the first second
    return V * t * t / 2 if t < 1 else V * (t - 0.5)


def read(k):
    return list(csv.DictReader(open(f"{out}/{k}/series.csv")))


j = read("j")
jc = [(disp(float(r["time"])), float(r["crack0_end_J"])) for r in j if float(r["time"]) > 5]
# J = c d^2 at a fixed crack: c from the last rows, the onset where J = G_c
c = sum(v / d / d for d, v in jc[-5:]) / 5
d_griffith = (GC / c) ** 0.5
print(f"J of the initial crack: J = {c:.4f} d^2, J = G_c at flank displacement {d_griffith:.4e}")
curves = {}
RUNS = ("linear", "lme", "linear_newmark", "lme_newmark")
for k in RUNS:
    r = read(k)
    t = [float(x["time"]) for x in r]
    w = [float(x["external_work"]) for x in r]
    d = [disp((t[i] + t[i - 1]) / 2) for i in range(1, len(t))]
    R = [(w[i] - w[i - 1]) / (t[i] - t[i - 1]) / (2 * V) for i in range(1, len(t))]
    e0 = float(r[0]["eroded_particles"])
    onset = next((i for i, x in enumerate(r) if float(x["eroded_particles"]) > e0), None)
    peak = max(R)
    ip = R.index(peak)
    lo = next(i for i, x in enumerate(t) if x > 2.0)
    hi = (onset or len(r)) - 1
    dev = []
    for i in range(lo + 5, hi - 5):
        mean = sum(R[i - 5:i + 6]) / 11
        dev.append((R[i] - mean) ** 2)
    noise = (sum(dev) / len(dev)) ** 0.5 / peak
    last = r[-1]
    W, U, K = (float(last[c]) for c in ("external_work", "strain_energy", "kinetic_energy"))
    D = float(last["fracture_energy"])
    j_onset = c * disp(t[onset]) ** 2 if onset is not None else float("nan")
    if t[-1] < 39.99:
        print(f"{k}: the run ended at t = {t[-1]:.2f} s (failed), its last row below")
    print(f"{k}: first erosion at t = {t[onset] if onset else float('nan'):.2f} s, flank displacement "
          f"{disp(t[onset]) if onset else float('nan'):.4e} (J there {j_onset / GC:.3f} G_c); peak reaction "
          f"{peak:.4e} at {d[ip]:.4e}; loading noise {noise:.2e} of the peak; at the end: crack length "
          f"{float(last['crack_length']):.3f}, fragments {last['fragments']}, eroded {last['eroded_particles']}, "
          f"W {W:.3e}, U {U:.3e}, K {K:.3e}, eroded points' energy {D:.3e} ({D / (GC * AREA):.3f} G_c A), "
          f"W - U - K {W - U - K:.3e} ({(W - U - K) / (GC * AREA):.3f} G_c A)")
    curves[k] = (d, R)
try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    sys.exit("no matplotlib: the table above, no plot")
fig, ax = plt.subplots(figsize=(7, 4.5))
LABELS = {"linear": ("tab:red", "-", "linear hat, MUSL"), "lme": ("tab:blue", "-", "LME, γ = 3.5, MUSL"),
          "linear_newmark": ("tab:orange", "--", "linear hat, Newmark"),
          "lme_newmark": ("tab:cyan", "--", "LME, γ = 3.5, Newmark")}
for k in RUNS:
    d, R = curves[k]
    col, ls, label = LABELS[k]
    ax.plot(d, R, color=col, ls=ls, lw=0.9, label=label)
ax.axvline(d_griffith, color="grey", ls="--", lw=0.8, label="J = G_c (explicit crack)")
ax.set_xlabel("flank displacement (each side)")
ax.set_ylabel("reaction per flank (per unit thickness)")
ax.set_title("E1: edge-cracked panel, eigenerosion (H = 1, a = 0.25 H, h = 0.025)")
ax.legend(loc="upper left", fontsize=8)
fig.tight_layout()
fig.savefig(png, dpi=110)
print(f"wrote {png}")
