"""Force-displacement curves of Wei & Chen's bar (docs/dpm.md).

First: cargo test --release --lib dpm::explicit::tests::the_bar_at_four_resolutions -- --ignored --nocapture
(writes target/dpm-bar.csv, or $DPM_BAR_CSV), then: python3 docs/scripts/dpm_bar.py [CSV] [PNG]
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

src = sys.argv[1] if len(sys.argv) > 1 else "target/dpm-bar.csv"
dst = sys.argv[2] if len(sys.argv) > 2 else "docs/dpm-bar.png"
curves = {}
with open(src) as f:
    for row in csv.DictReader(f):
        key = (int(row["nodes"]), row["regularised"] == "1")
        curves.setdefault(key, []).append((float(row["u"]), float(row["force"])))

fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
for ax, regularised, title in [(axes[0], False, "unregularised (kappa_c of the 16-node cell)"), (axes[1], True, "regularised (eq. 33)")]:
    for nodes in sorted({k[0] for k in curves}):
        pts = curves.get((nodes, regularised), [])
        ax.plot([p[0] for p in pts], [p[1] for p in pts], label=f"{nodes} nodes", lw=1)
    # the cohesive bar's answer, eq. 9: u = F L/(E A) + (2 G_F/f_t)(1 - F/(f_t A))
    fs = [2000.0 * k / 100 for k in range(101)]
    ax.plot([f * 100 / 2.0e7 + 0.01885 * (1 - f / 2000.0) for f in fs], fs, "k--", lw=1, label="cohesive, eq. 9")
    ax.plot([0, 0.01], [0, 2000], "k--", lw=1)
    ax.set_xlim(0, 0.022)
    ax.set_xticks([0, 0.005, 0.01, 0.015, 0.02])
    ax.set_ylim(-100, 2600)
    ax.set_xlabel("end displacement u")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8)
axes[0].set_ylabel("force F")
fig.tight_layout()
fig.savefig(dst, dpi=120)
print(f"wrote {dst}")
