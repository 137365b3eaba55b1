"""Kirsch's plate with a hole by the damage particle method (docs/dpm.md).

First: DPM_KIRSCH_CSV=target/dpm-kirsch.csv cargo test --release --test engine dpm::a_plate_with_a_hole_carries_kirsch_s_stress
(writes the stresses along the two symmetry lines), then:
python3 docs/scripts/dpm_kirsch.py [CSV] [PNG]
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

src = sys.argv[1] if len(sys.argv) > 1 else "target/dpm-kirsch.csv"
dst = sys.argv[2] if len(sys.argv) > 2 else "docs/dpm-kirsch.png"
with open(src) as f:
    rows = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]

# Kirsch's infinite plate, drawn finely
top = max(r["r_over_a"] for r in rows)
fine = [1.0 + (top - 1.0) * k / 400 for k in range(401)]
fig, axes = plt.subplots(1, 2, figsize=(10, 4))
for ax, col, name, exact in [
    (axes[0], "sxx_over_sigma", "sigma_xx along x = 0", lambda r: 1 + 0.5 / r**2 + 1.5 / r**4),
    (axes[1], "syy_over_sigma", "sigma_yy along y = 0", lambda r: 0.5 / r**2 - 1.5 / r**4),
]:
    ax.plot(fine, [exact(r) for r in fine], "k-", lw=1, label="Kirsch (infinite plate)")
    ax.plot([r["r_over_a"] for r in rows], [r[col] for r in rows], "o", ms=3, label="damage particle method, a/h = 8.32")
    ax.axvline(1.0, color="0.6", lw=0.8)
    ax.set_xlabel("r / a")
    ax.set_ylabel(name.split()[0] + " / sigma")
    ax.set_title(name, fontsize=10)
    ax.set_xlim(0.9, top + 0.1)
    ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(dst, dpi=120)
print(f"wrote {dst}")
