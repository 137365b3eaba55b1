#!/usr/bin/env python3
"""E2 (docs/eigen.md): the drop-weight beam. Reads OUT/<run>/series.csv of
the runs docs/scripts/eigen_e2.sh makes, prints each one's peak hammer
force and peak support reaction (with their times) against the
experiment's (Zhang et al. 2010, read off the authors' figure: about
109 kN near 0.13 ms and 55 kN near 0.3 ms), and plots both against time.
The hammer's force is the rate of its (downward, negative) momentum (central
differences of the series rows; the hammer is every body but the beam and
the supports, so a variant may build it of several), its impulse the force's
integral over the first pulse (to where the force first falls to zero after
its peak; the experiment's, from the authors' figure read every 0.01-0.04
ms, is about 18 N s), the reaction the bottom wall's force on the supports
(its `reaction_bottom_y`, the row's step), with its impulse to where it
first falls to zero after its peak (the experiment's about 19 N s to
0.65 ms).
Usage: python3 docs/scripts/eigen_e2.py OUT PNG RUN [RUN ...]"""
import csv, sys

out, png, runs = sys.argv[1], sys.argv[2], sys.argv[3:]
EXP_IMPACT, EXP_IMPACT_T, EXP_REACTION, EXP_REACTION_T = 109e3, 0.13e-3, 55e3, 0.3e-3
curves = {}
for k in runs:
    r = list(csv.DictReader(open(f"{out}/{k}/series.csv")))
    t = [float(x["time"]) for x in r]
    # the hammer: every body but the beam and the supports (a variant may
    # give it a weight or a pad of its own)
    cols = [c for c in r[0] if c.startswith("momentum_y_")
            and c not in ("momentum_y_beam", "momentum_y_support_left", "momentum_y_support_right")]
    p = [sum(float(x[c]) for c in cols) for x in r]
    # the beam pushes the falling hammer up: its momentum (negative) rises
    f = [(p[i + 1] - p[i - 1]) / (t[i + 1] - t[i - 1]) for i in range(1, len(t) - 1)]
    tf = t[1:-1]
    reac = [float(x["reaction_bottom_y"]) for x in r]
    i = max(range(len(f)), key=lambda j: f[j])
    end = next((j for j in range(i, len(f)) if f[j] <= 0.0), len(f) - 1)
    impulse = sum(0.5 * (f[j] + f[j + 1]) * (tf[j + 1] - tf[j]) for j in range(end))
    j = max(range(len(reac)), key=lambda j: reac[j])
    rend = next((k for k in range(j, len(reac)) if reac[k] <= 0.0), len(reac) - 1)
    rimp = sum(0.5 * (reac[k] + reac[k + 1]) * (t[k + 1] - t[k]) for k in range(rend))
    last = r[-1]
    print(f"{k}: hammer force peak {f[i] / 1e3:.1f} kN at {tf[i] * 1e3:.3f} ms "
          f"({100 * (f[i] / EXP_IMPACT - 1):+.0f} % of the experiment's {EXP_IMPACT / 1e3:.0f} kN), "
          f"first pulse {impulse:.1f} N s to {tf[end] * 1e3:.3f} ms (experiment about 18 N s to 0.29 ms); "
          f"reaction peak {reac[j] / 1e3:.1f} kN at {t[j] * 1e3:.3f} ms "
          f"({100 * (reac[j] / EXP_REACTION - 1):+.0f} % of {EXP_REACTION / 1e3:.0f} kN), "
          f"impulse {rimp:.1f} N s to {t[rend] * 1e3:.3f} ms (experiment about 19 N s to 0.65 ms); at the end: "
          f"hammer speed {-p[-1] / 120.6:.3f} m/s, softening {last['softening_particles']}, "
          f"eroded {last['eroded_particles']}, dissipated {float(last['fracture_energy']):.3f} J "
          f"(G_F x ligament {141 * 0.05 * 0.1:.3f} J), fragments {last['fragments']}")
    curves[k] = (tf, f, t, reac)
try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    sys.exit("no matplotlib: the table above, no plot")
fig, ax = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
for k, (tf, f, t, reac) in curves.items():
    ax[0].plot([x * 1e3 for x in tf], [y / 1e3 for y in f], lw=0.9, label=k)
    ax[1].plot([x * 1e3 for x in t], [y / 1e3 for y in reac], lw=0.9, label=k)
ax[0].plot([EXP_IMPACT_T * 1e3], [EXP_IMPACT / 1e3], "ko", label="experiment's peak (Zhang et al. 2010)")
ax[1].plot([EXP_REACTION_T * 1e3], [EXP_REACTION / 1e3], "ko", label="experiment's peak")
ax[0].set_title("hammer force")
ax[1].set_title("support reaction (both supports)")
for a in ax:
    a.set_xlabel("time (ms)")
    a.grid(alpha=0.3)
ax[0].set_ylabel("force (kN)")
ax[0].legend(fontsize=7)
fig.suptitle("E2: drop-weight impact on a notched HSC beam, eigensoftening")
fig.tight_layout()
fig.savefig(png, dpi=110)
print(f"wrote {png}")
