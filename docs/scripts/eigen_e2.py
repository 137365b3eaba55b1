#!/usr/bin/env python3
"""E2 (docs/eigen.md): the drop-weight beam. Reads OUT/<run>/series.csv of
the runs docs/scripts/eigen_e2.sh makes, prints each one's peak hammer
force and peak support reaction (with their times) against the
experiment's (Zhang et al. 2010, read off the authors' figure: about
109 kN near 0.13 ms and 55 kN near 0.3 ms), and plots both against time.
The hammer's force is the rate of its (downward, negative) momentum (central
differences of the series rows), the reaction the bottom wall's force on
the supports (its `reaction_bottom_y`, the row's step).
Usage: python3 docs/scripts/eigen_e2.py OUT PNG RUN [RUN ...]"""
import csv, sys

out, png, runs = sys.argv[1], sys.argv[2], sys.argv[3:]
EXP_IMPACT, EXP_IMPACT_T, EXP_REACTION, EXP_REACTION_T = 109e3, 0.13e-3, 55e3, 0.3e-3
curves = {}
for k in runs:
    r = list(csv.DictReader(open(f"{out}/{k}/series.csv")))
    t = [float(x["time"]) for x in r]
    # the hammer, and its weight where the variant makes it a body of its own
    p = [float(x["momentum_y_hammer"]) + float(x.get("momentum_y_weight", 0.0)) for x in r]
    # the beam pushes the falling hammer up: its momentum (negative) rises
    f = [(p[i + 1] - p[i - 1]) / (t[i + 1] - t[i - 1]) for i in range(1, len(t) - 1)]
    tf = t[1:-1]
    reac = [float(x["reaction_bottom_y"]) for x in r]
    i = max(range(len(f)), key=lambda j: f[j])
    j = max(range(len(reac)), key=lambda j: reac[j])
    last = r[-1]
    print(f"{k}: hammer force peak {f[i] / 1e3:.1f} kN at {tf[i] * 1e3:.3f} ms "
          f"({100 * (f[i] / EXP_IMPACT - 1):+.0f} % of the experiment's {EXP_IMPACT / 1e3:.0f} kN); "
          f"reaction peak {reac[j] / 1e3:.1f} kN at {t[j] * 1e3:.3f} ms "
          f"({100 * (reac[j] / EXP_REACTION - 1):+.0f} % of {EXP_REACTION / 1e3:.0f} kN); at the end: "
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
