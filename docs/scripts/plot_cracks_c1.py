#!/usr/bin/env python3
"""Plot J/G0 against b/w for benchmark C1 (docs/cracks-c1.md) from the
summaries docs/scripts/cracks_c1.sh writes: OUT/summary_h1.csv (and
OUT/summary_h0.5.csv when present). Usage:
  python3 docs/scripts/plot_cracks_c1.py OUT docs/cracks-c1.png
Open symbols: the V crack does not cross the contour; filled: it does
(a "JCIC" in the paper's words), as in the paper's Fig. 6 and 7."""
import csv, os, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

out, png = sys.argv[1], sys.argv[2]
cells = [c for c in ("1", "0.5") if os.path.exists(f"{out}/summary_h{c}.csv")]
fig, axes = plt.subplots(1, len(cells), figsize=(6.5 * len(cells), 5), squeeze=False)
marks = {"2": ("o", 5), "4": ("D", 6), "8": ("s", 8)}
cols = {"fijc": {"2": "tab:green", "4": "tab:blue", "8": "tab:red"},
        "pijc": {"2": "0.55", "4": "0.35", "8": "0.1"}}
for ax, cell in zip(axes[0], cells):
    rows = list(csv.DictReader(open(f"{out}/summary_h{cell}.csv")))
    single = next((r for r in rows if r["b_over_w"] == "single"), None)
    for method in ("fijc", "pijc"):
        rs = sorted((r for r in rows if r["method"] == method and r["b_over_w"] != "single"),
                    key=lambda r: float(r["b_over_w"]))
        if not rs:
            continue
        for c in ("2", "4", "8"):
            m, s = marks[c]
            col = cols[method][c]
            xs = [float(r["b_over_w"]) for r in rs]
            ys = [float(r[f"J_{c}mm_over_G0"]) for r in rs]
            cr = [r[f"J_{c}mm_crossed"] == "1" for r in rs]
            ls = "-" if method == "fijc" else ":"
            for side in (lambda x: x > 0.5, lambda x: x < 0.5):
                pts = [(x, y) for x, y in zip(xs, ys) if side(x)]
                if pts:
                    ax.plot(*zip(*pts), ls, color=col, lw=0.8)
            lab = f"{method.upper()} {c} mm"
            ax.scatter([x for x, k in zip(xs, cr) if not k], [y for y, k in zip(ys, cr) if not k],
                       marker=m, s=s ** 2, facecolors="none", edgecolors=col, label=lab)
            ax.scatter([x for x, k in zip(xs, cr) if k], [y for y, k in zip(ys, cr) if k],
                       marker=m, s=s ** 2, color=col)
    if single:
        for c in ("2", "4", "8"):
            ax.axhline(float(single[f"J_{c}mm_over_G0"]), color=cols["fijc"][c], lw=0.6, ls="--")
    ax.axhline(1.0, color="k", lw=0.6)
    ax.axvline(0.5, color="k", lw=0.4, ls=":")
    ax.set_xlabel("b / w")
    ax.set_ylabel("J / G0  (G0 = 13 402 J/m²)")
    ax.set_title(f"C1, {cell} mm cells: filled = V crack crosses the contour;\n"
                 "dashed = this model's single-crack J per contour")
    ax.legend(fontsize=8, loc="upper left")
    ax.set_ylim(bottom=0)
    ax.set_xlim(0.15, 0.95)
fig.tight_layout()
fig.savefig(png, dpi=110)
print("wrote", png)
