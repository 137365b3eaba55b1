#!/usr/bin/env bash
# Benchmark C3 of Nairn & Aimene, "J-integral methods for interacting
# cracks", section 3.3 (Fig. 4C, Fig. 9A): a centre-notched plate
# (CN, modelled as its right half, w = 50 x L = 100 mm, plane stress,
# E = 2500 MPa, nu = 0.33) with a horizontal crack H of a = 25 mm from the
# left edge (a symmetry plane) at mid-height whose faces carry a pressure
# ramped as (P/2)(1 - cos(pi t/t_r)), P = 5 MPa, and a vertical crack V of
# 50 mm centred on H's line at x = b; optionally a horizontal pressure P_h
# on the right edge and Coulomb friction on the cracks. J of H's tip,
# normalised by the paper's single-crack G0 = 1392 J/m2, by the
# explicit-crack (CRAMP) model with its crack-face pressure.
# docs/cracks-c3.md has the results and the reasoning behind every choice.
#
# Usage, from the repository root (one run at a time, one thread each):
#   CLEAVE=target/release/cleave OUT=/tmp/cracks_c3 bash docs/scripts/cracks_c3.sh
# Environment (all optional):
#   CLEAVE   the binary (default target/release/cleave)
#   OUT      output folder (default /tmp/cracks_c3): OUT/scenes/*.toml,
#            OUT/runs/<name>/ (each run's out dir), OUT/summary_h<CELL_MM>.md/.csv
#   CELL_MM  cell size in mm, 1 (contours 2, 4, 8 cells) or 0.5 (4, 8, 16
#            cells): the paper's 2, 4 and 8 mm contours either way (default 1)
#   CASES    "single" and/or b/w values (default below)
#   ENDS     free (default: the top and bottom ends traction-free) or held
#            (the ends bonded to 2 mm grips 1e8 x as dense and stiff as
#            the plate, not driven: C1's grips standing still)
#   MODEL    half (default: x from 0, the grid's left side a roller at the
#            plate's left edge, H from x = 0) or full (the whole 100 mm wide
#            plate, H from -a to a, V at +b and its mirror at -b, no roller)
#   PH_MPA   the right edge's pressure P_h, MPa, ramped like P (default 0;
#            in the full model on both edges)
#   MU       Coulomb friction on every crack (default 0: frictionless)
#   RAMP_MS, HOLD_MS  t_r and the hold after it (default 1.0 and 0.5 ms);
#            J is the mean over the hold
#   STRESS_UPDATE  musl (default) or usl (the code's default, as C1): the
#            [transfer] stress update; USL leaves stress noise at the
#            pressure-loaded faces where V crosses H (docs/cracks-c3.md).
#            Run names end in "_musl" for MUSL
#   SCHEME   the [transfer] scheme: flip (default: FLIP 0.99), pic, apic,
#            xpic1 or fmpm1 (the paper's FMPM(1)); run names then end in
#            "_<scheme>" and the summary's update column reads musl+<scheme>
#   SUMMARY_ONLY=1  only rewrite the summary from runs already there
#   CRAMP_EXTRA  lines added to every scene's [cramp] table, e.g.
#            'contact_passes = 2' (the paper's two crack-contact passes;
#            the default is one)
#   RAYON_NUM_THREADS (default 1)
set -euo pipefail
CLEAVE=${CLEAVE:-target/release/cleave}
OUT=${OUT:-/tmp/cracks_c3}
CELL_MM=${CELL_MM:-1}
CASES=${CASES-"single 0.8 0.6 0.55 0.52 0.48 0.45 0.4 0.3"}
ENDS=${ENDS:-free}
MODEL=${MODEL:-half}
PH_MPA=${PH_MPA:-0}
MU=${MU:-0}
RAMP_MS=${RAMP_MS:-1.0}
HOLD_MS=${HOLD_MS:-0.5}
STRESS_UPDATE=${STRESS_UPDATE:-musl}
SCHEME=${SCHEME:-flip}
export RAYON_NUM_THREADS=${RAYON_NUM_THREADS:-1}
mkdir -p "$OUT/scenes" "$OUT/runs"

# ---------------------------------------------------------------- scenes
cat > "$OUT/gen_c3.py" <<'EOF'
"""gen_c3.py OUT.toml CASE CELL_MM ENDS MODEL RAMP_MS HOLD_MS PH_MPA MU STRESS_UPDATE SCHEME
CASE: 'single' (no V crack) or b/w."""
import math, os, sys

out, case = sys.argv[1], sys.argv[2]
h = float(sys.argv[3]) * 1e-3
ends, model = sys.argv[4], sys.argv[5]
ramp, hold = float(sys.argv[6]) * 1e-3, float(sys.argv[7]) * 1e-3
ph, mu = float(sys.argv[8]) * 1e6, float(sys.argv[9])
su = sys.argv[10]
scheme = sys.argv[11] if len(sys.argv) > 11 else "flip"
transfer = ([f'stress_update = "{su}"'] if su != "usl" else []) + ([f'scheme = "{scheme}"'] if scheme != "flip" else [])

w, L, a, lb = 0.05, 0.10, 0.025, 0.05   # half width, height, H (half) length, V length
P = 5e6                                 # crack-face pressure
yc = L / 2 + 0.1 * h                    # H's line: off node rows and particle rows
rho, E, nu = 1005.0, 2.5e9, 0.33        # as docs/cracks-c1.md
tg, grip = 0.002, 1e8                   # held ends: grip thickness, density and stiffness factor
contours = [int(round(c / (h * 1e3))) for c in (2, 4, 8)]   # 2, 4, 8 mm

# (pmax/2)(1 - cos(pi t/t_r)), 100 intervals, then held
N = 100
def ramp_tab(pmax):
    t = [(ramp * k / N, 0.5 * pmax * (1 - math.cos(math.pi * k / N))) for k in range(N + 1)]
    t.append((ramp + hold, pmax))
    return "{ table = [" + ", ".join("[%.6e, %.6e]" % q for q in t) + "] }"

def vcrack(xv):
    n = int(round(lb / (0.5 * h)))
    return [(xv, yc - lb / 2 + k * 0.5 * h) for k in range(n + 1)]

if model == "half":
    # H from the symmetry plane x = 0 (the grid's left side, a roller) to
    # the tip, a point every half cell, listed mouth -> tip (crack0_end = tip)
    cracks = [[(k * 0.5 * h, yc) for k in range(int(round(a / (0.5 * h))) + 1)]]
    if case != "single":
        cracks.append(vcrack(float(case) * w + 0.1 * h))   # off node and particle columns
    gx, left = (0.0, 0.054), '"roller"'
    box = (0.0, w)
else:
    # the whole plate; H from the left tip to the right tip (crack0_end)
    n = int(round(2 * a / (0.5 * h)))
    cracks = [[(-a + k * 0.5 * h, yc) for k in range(n + 1)]]
    if case != "single":
        xv = float(case) * w + 0.1 * h
        cracks += [vcrack(xv), vcrack(-xv)]   # crack 1 beside crack0_end, crack 2 its mirror
    gx = (-0.054, 0.054)
    left = ('{ type = "traction", normal = %s }' % ramp_tab(-ph)) if ph else '"free"'
    box = (-w, w)
right = ('{ type = "traction", normal = %s }' % ramp_tab(-ph)) if ph else '"free"'

end = ramp + hold
pts = lambda c: ", ".join("[%.7g, %.7g]" % p for p in c)
fr = f", friction = {mu}" if mu > 0 else ""
lines = "    { points = [" + pts(cracks[0]) + "], pressure = " + ramp_tab(P) + fr + " },\n"
lines += "".join("    { points = [" + pts(c) + "]" + fr + " },\n" for c in cracks[1:])
held = ends == "held"
gripmat = f"""
[materials.grip]
model = "linear_elastic"
density = {rho * grip:.6e}
youngs_modulus = {E * grip:.6e}
poissons_ratio = {nu}
""" if held else ""
grips = f"""
[[bodies]]
name = "bottom_grip"
shape = {{ type = "box", min = [{box[0]}, {-tg}], max = [{box[1]}, 0.0] }}
material = "grip"

[[bodies]]
name = "top_grip"
shape = {{ type = "box", min = [{box[0]}, {L}], max = [{box[1]}, {L + tg}] }}
material = "grip"
""" if held else ""
what = "no V crack (single-crack reference)" if case == "single" else f"V crack at b/w = {case} (x = {float(case) * w * 1e3 + 0.1 * h * 1e3:.4g} mm)"
open(out, "w").write(f"""# Nairn & Aimene section 3.3 (C3): CN plate ({model} model), pressure-loaded
# H crack a = 25 mm, {what}; {h * 1e3:g} mm cells.
# Written by docs/scripts/cracks_c3.sh (see docs/cracks-c3.md). H's faces
# carry (P/2)(1 - cos(pi t/t_r)), P = 5 MPa, t_r = {ramp * 1e3:g} ms, held to
# {end * 1e3:g} ms; ends {ends}; right-edge pressure P_h = {ph / 1e6:g} MPa (same
# ramp); crack friction {mu:g}.
[meta]
name = "cracks_c3_{case}"
description = "Nairn & Aimene C3: pressure-loaded crack ({case}, {model}, ends {ends}, P_h {ph / 1e6:g} MPa, friction {mu:g})"

[grid]
cell_size = {h}
min = [{gx[0]}, -0.005]
max = [{gx[1]}, 0.105]
shape_function = "quadratic_bspline"

[grid.boundary]
left = {left}
right = {right}

[analysis]
plane = "plane_stress"

[time]
end = {end:.6e}
cfl = 0.3

[materials.plate]
model = "linear_elastic"
density = {rho}
youngs_modulus = {E}
poissons_ratio = {nu}
{gripmat}
[[bodies]]
name = "plate"
shape = {{ type = "box", min = [{box[0]}, 0.0], max = [{box[1]}, {L}] }}
material = "plate"
explicit_cracks = [
{lines}]
{grips}
{'' if not transfer else chr(10) + '[transfer]' + chr(10) + chr(10).join(transfer) + chr(10)}
[cramp]
j_contours = {contours}
{os.environ.get('CRAMP_EXTRA', '')}

[output]
series_rows = {int(round(end / 1e-5)) + 1}
snapshots = 2
""")
EOF

# ---------------------------------------------------------------- runs
tag="${ENDS}_${MODEL}_ph${PH_MPA}_mu${MU}_tr${RAMP_MS}"
[ "$STRESS_UPDATE" != usl ] && tag="${tag}_${STRESS_UPDATE}"
[ "$SCHEME" != flip ] && tag="${tag}_${SCHEME}"
names=()
for c in $CASES; do names+=("h${CELL_MM}_${c}_${tag}"); done

if [ "${SUMMARY_ONLY:-0}" != 1 ]; then
  for c in $CASES; do
    name="h${CELL_MM}_${c}_${tag}"
    python3 "$OUT/gen_c3.py" "$OUT/scenes/$name.toml" "$c" "$CELL_MM" "$ENDS" "$MODEL" "$RAMP_MS" "$HOLD_MS" "$PH_MPA" "$MU" "$STRESS_UPDATE" "$SCHEME"
    echo "== $name" >&2
    "$CLEAVE" run "$OUT/scenes/$name.toml" --out "$OUT/runs/$name" --json --quiet \
      > "$OUT/runs/$name.json" 2> "$OUT/runs/$name.err" || { echo "   failed: $OUT/runs/$name.err" >&2; continue; }
    python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); print("   %s, %d steps, %.1f s" % (d["status"], d["steps"], d["wall_seconds"]))' "$OUT/runs/$name.json" >&2
  done
fi

# ---------------------------------------------------------------- summary
# every run in OUT/runs at this CELL_MM (any ENDS/MODEL/PH/MU/ramp), one row each
python3 - "$OUT" "$CELL_MM" <<'EOF'
import csv, glob, json, math, os, re, struct, sys
out, cell = sys.argv[1], sys.argv[2]
h = float(cell) * 1e-3
G0 = 1392.0
cont = [int(round(c / float(cell))) for c in (2, 4, 8)]
pat = re.compile(rf"h{re.escape(cell)}_(?P<case>[^_]+)_(?P<ends>free|held)_(?P<model>half|full)_ph(?P<ph>[^_]+)_mu(?P<mu>[^_]+)_tr(?P<tr>[^_/]+)(_(?P<su>musl))?(_(?P<sc>pic|apic|xpic1|fmpm1))?$")

def vtp(fn):
    d = open(fn, "rb").read()
    k = d.index(b"<AppendedData")
    head, start = d[:k].decode(), d.index(b"_", k) + 1
    arrs = {}
    for m in re.finditer(r'<DataArray type="(\w+)" Name="(\w+)" NumberOfComponents="(\d+)" format="appended" offset="(\d+)"', head):
        f = {"Float64": "d", "UInt32": "I", "Int64": "q"}[m.group(1)]
        p = start + int(m.group(4))
        n = struct.unpack("<Q", d[p:p + 8])[0]
        arrs[m.group(2)] = struct.unpack("<%d%s" % (n // struct.calcsize(f), f), d[p + 8:p + 8 + n])
    return arrs

def v_line_x(run, y):
    """x of the V crack's plane (crack 1) at height y at the end."""
    try:
        a = vtp(f"{run}/cracks_0001.vtp")
    except (OSError, ValueError):
        return float("nan")
    s = 0
    for crack, surf, e in zip(a["crack"], a["surface"], a["offsets"]):
        if crack == 1 and surf == 0:
            pts = [(a["position"][3 * a["connectivity"][j]], a["position"][3 * a["connectivity"][j] + 1]) for j in range(s, e)]
            return min(pts, key=lambda p: abs(p[1] - y))[0]
        s = e
    return float("nan")

res = []
for run in sorted(glob.glob(f"{out}/runs/h{cell}_*")):
    m = pat.search(run)
    if not m or not os.path.isdir(run) or not os.path.exists(f"{run}/series.csv"):
        continue
    g = m.groupdict()
    ramp = float(g["tr"]) * 1e-3
    allrows = list(csv.DictReader(open(f"{run}/series.csv")))
    rows = [r for r in allrows if float(r["time"]) >= ramp - 1e-9]
    if not rows:
        continue
    cols = ["crack0_end_J"] + [f"crack0_end_J{n}" for n in cont[1:]]
    J, sd = [], []
    for col in cols:
        v = [float(r[col]) for r in rows]
        mu = sum(v) / len(v)
        J.append(mu)
        sd.append(math.sqrt(sum((x - mu) ** 2 for x in v) / len(v)) / abs(mu) if mu else float("nan"))
    # J at t_r/2 (P/2 there): it should be a quarter of the final J
    half = min(allrows, key=lambda r: abs(float(r["time"]) - ramp / 2))
    follow = [float(half[c]) / (Jf / 4) for c, Jf in zip(cols, J)]
    try:
        js = json.load(open(f"{run}.json"))
        wall, eerr = js["wall_seconds"], js["energy_error_relative"]
    except (OSError, ValueError, KeyError):
        wall = eerr = float("nan")
    tip = float(allrows[-1]["crack0_end_x"])
    node = round(tip / h) * h          # the node nearest the tip (grid lines at multiples of h)
    xv = v_line_x(run, float(allrows[-1]["crack0_end_y"])) if g["case"] != "single" else float("nan")
    crossed = [g["case"] != "single" and abs(xv - node) < n / 2 * h for n in cont]
    g["su"] = (g["su"] or "usl") + ("+" + g["sc"] if g["sc"] else "")
    res.append(dict(g, J=J, sd=sd, follow=follow, wall=wall, eerr=eerr, tip=tip, node=node, xv=xv, crossed=crossed, rows=len(rows)))

def key(r):
    return (r["ends"], r["model"], float(r["ph"]), float(r["mu"]), float(r["tr"]), r["su"],
            -1.0 if r["case"] == "single" else -float(r["case"]))
res.sort(key=key)
# Js: the single crack of the same set-up (ends, model, P_h, mu, t_r, stress update), per contour
same = lambda r: (r["ends"], r["model"], r["ph"], r["mu"], r["tr"], r["su"])
singles = {same(r): r for r in res if r["case"] == "single"}
for r in res:
    s0 = singles.get(same(r))
    r["rel"] = [J / Js for J, Js in zip(r["J"], s0["J"])] if s0 else [float("nan")] * 3
with open(f"{out}/summary_h{cell}.csv", "w") as f:
    f.write("case,ends,model,ph_MPa,mu,t_r_ms,stress_update," + ",".join(f"J_{c}mm,J_{c}mm_over_G0,J_{c}mm_over_single,J_{c}mm_rel_sd,J_{c}mm_at_half_ramp_over_quarter,J_{c}mm_crossed" for c in (2, 4, 8))
            + ",tip_x_end_mm,ring_node_x_mm,v_x_end_mm,gap_mm,energy_error_rel,wall_s\n")
    for r in res:
        f.write(f"{r['case']},{r['ends']},{r['model']},{r['ph']},{r['mu']},{r['tr']},{r['su']}," + ",".join(
            f"{J:.1f},{J / G0:.4f},{x:.4f},{s:.4f},{fo:.4f},{int(c)}" for J, x, s, fo, c in zip(r["J"], r["rel"], r["sd"], r["follow"], r["crossed"]))
            + f",{r['tip'] * 1e3:.4f},{r['node'] * 1e3:g},{r['xv'] * 1e3:.4f},{(r['xv'] - r['tip']) * 1e3:.3f},{r['eerr']:.4f},{r['wall']:.1f}\n")
with open(f"{out}/summary_h{cell}.md", "w") as f:
    f.write(f"{cell} mm cells (contours {cont} cells = 2, 4, 8 mm); J = mean over the hold; "
            f"J/G0 with G0 = 1392 J/m2; * = the V crack crosses that contour; "
            f"Js = the single crack's J (same contour and set-up); 'J(t_r/2)' = J4 at half the ramp over a quarter of its final value; sd = J4's over the hold\n\n")
    f.write("| case | ends | model | P_h, MPa | mu | t_r, ms | stress | J2/G0 | J4/G0 | J8/G0 | J2/Js | J4/Js | J8/Js | sd J4 | J(t_r/2) | tip x, mm | node, mm | gap, mm | energy error | wall, s |\n"
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n")
    for r in res:
        gj = " | ".join(f"{J / G0:.3f}{'*' if c else ''}" for J, c in zip(r["J"], r["crossed"]))
        gap = "—" if r["case"] == "single" else f"{(r['xv'] - r['tip']) * 1e3:.2f}"
        rel = " | ".join(f"{x:.3f}" for x in r["rel"])
        f.write(f"| {r['case']} | {r['ends']} | {r['model']} | {r['ph']} | {r['mu']} | {r['tr']} | {r['su']} | {gj} | {rel}"
                f" | {100 * r['sd'][1]:.2f} % | {r['follow'][1]:.3f} | {r['tip'] * 1e3:.3f} | {r['node'] * 1e3:g} | {gap} | {100 * r['eerr']:.1f} % | {r['wall']:.0f} |\n")
print(open(f"{out}/summary_h{cell}.md").read())
EOF
