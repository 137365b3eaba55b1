#!/usr/bin/env python3
"""Plot J/G0 against b/w for benchmark C3 (docs/cracks-c3.md) from the
summaries docs/scripts/cracks_c3.sh writes: OUT/summary_h1.csv (and
OUT/summary_h0.5.csv when present). Usage:
  python3 docs/scripts/plot_cracks_c3.py OUT docs/cracks-c3.png
Free ends, half model, t_r = 1 ms, MUSL. Circles, diamonds, squares: the
2, 4, 8 mm contours with P_h = 0 and frictionless cracks; open symbols:
the V crack does not cross the contour, filled: it does (as the paper's
Fig. 9A). Triangles: P_h = 10 MPa and friction 0.6, 2 mm contour."""
import csv, os, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

out, png = sys.argv[1], sys.argv[2]
cells = [c for c in ("1", "0.5") if os.path.exists(f"{out}/summary_h{c}.csv")]
fig, axes = plt.subplots(1, len(cells), figsize=(6.5 * len(cells), 5), squeeze=False, sharey=True)
marks = {"2": ("o", 6), "4": ("D", 6), "8": ("s", 8)}
cols = {"2": "tab:green", "4": "tab:blue", "8": "tab:red"}
base = lambda r: r["ends"] == "free" and r["model"] == "half" and r["t_r_ms"] == "1.0" and r["stress_update"] == "musl"
for ax, cell in zip(axes[0], cells):
    rows = [r for r in csv.DictReader(open(f"{out}/summary_h{cell}.csv")) if base(r)]
    for (ph, mu, contours, style) in (("0", "0", ("2", "4", "8"), "plain"), ("10", "0.6", ("2",), "tri")):
        sel = [r for r in rows if r["ph_MPa"] == ph and r["mu"] == mu]
        single = next((r for r in sel if r["case"] == "single"), None)
        rs = sorted((r for r in sel if r["case"] != "single"), key=lambda r: float(r["case"]))
        if not rs:
            continue
        for c in contours:
            m, s = marks[c] if style == "plain" else ("^", 8)
            col = cols[c] if style == "plain" else "tab:purple"
            lab = f"{c} mm" if style == "plain" else f"{c} mm, P_h = 10 MPa, μ = 0.6"
            xs = [float(r["case"]) for r in rs]
            ys = [float(r[f"J_{c}mm_over_G0"]) for r in rs]
            cr = [r[f"J_{c}mm_crossed"] == "1" for r in rs]
            for side in (lambda x: x > 0.5, lambda x: x < 0.5):
                pts = [(x, y) for x, y in zip(xs, ys) if side(x)]
                if pts:
                    ax.plot(*zip(*pts), "-" if style == "plain" else "--", color=col, lw=0.8)
            ax.scatter([x for x, k in zip(xs, cr) if not k], [y for y, k in zip(ys, cr) if not k],
                       marker=m, s=s ** 2, facecolors="none", edgecolors=col, label=lab)
            ax.scatter([x for x, k in zip(xs, cr) if k], [y for y, k in zip(ys, cr) if k],
                       marker=m, s=s ** 2, color=col)
            if single and style == "plain":
                ax.axhline(float(single[f"J_{c}mm_over_G0"]), color=col, lw=0.6, ls="--")
    ax.axhline(1.0, color="k", lw=0.6)
    ax.axvline(0.5, color="k", lw=0.4, ls=":")
    ax.set_xlabel("b / w")
    ax.set_ylabel("J / G0  (G0 = 1392 J/m²)")
    ax.set_title(f"C3, {cell} mm cells: filled = V crack crosses the contour;\n"
                 "dashed = this model's single-crack J per contour")
    ax.legend(fontsize=8, loc="upper left")
    ax.set_ylim(bottom=0)
    ax.set_xlim(0.25, 0.85)
fig.tight_layout()
fig.savefig(png, dpi=110)
print("wrote", png)
