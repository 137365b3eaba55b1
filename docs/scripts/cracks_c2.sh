#!/usr/bin/env bash
# Benchmark C2 of Nairn & Aimene, "J-integral methods for interacting
# cracks", section 3.2 (Fig. 4B, Fig. 8A, Table 1): the "patch test".
# The C1 SENT (w = 50 x L = 100 mm, plane stress, E = 2500 MPa,
# nu = 0.33, ends pulled to 1 % strain through grips) with a horizontal
# edge crack H of a = 32.5 mm at mid-height and a vertical crack V at
# x = 35 mm through the whole length (and through the grips), so the
# plate is a 35 mm SENT (a/w' = 0.929) beside a 15 mm strip in uniform
# tension. J of H's tip on square contours of 2, 4, 8, 16 mm, FIJC and
# PIJC, normalised by the paper's J_VCCT = 13 287 J/m2 and by this
# model's own 35 mm wide SENT with the single crack ("single35").
# docs/cracks-c2.md has the results and the reasoning behind every choice;
# the scene is the C1 scene of docs/scripts/cracks_c1.sh, adapted.
#
# Usage, from the repository root (one run at a time, one thread each):
#   CLEAVE=target/release/cleave OUT=/tmp/cracks_c2 bash docs/scripts/cracks_c2.sh
# Environment (all optional):
#   CLEAVE   the binary (default target/release/cleave)
#   OUT      output folder (default /tmp/cracks_c2): OUT/scenes/*.toml,
#            OUT/runs/<name>/ (each run's out dir), OUT/summary.md, OUT/summary.csv
#   CELL_MM  cell size in mm: 0.5 (contours 4, 8, 16, 32 cells, the
#            paper's Table 1), 1 (2, 4, 8, 16 cells) or 0.25 (8, 16, 32,
#            64 cells); the same 2, 4, 8, 16 mm squares (default 0.5)
#   CASES    runs, each CASE:METHOD, CASE = split (H + V) or single35
#            (a 35 mm wide SENT, H only), METHOD = fijc | pijc
#            (default "single35:fijc split:fijc split:pijc")
#   RAMP_MS, HOLD_MS  the end-displacement ramp and the hold after it
#            (default 1.0 and 0.5 ms); J is the mean over the hold
#   TIP_MM   where H's tip is drawn, mm (default 32.5; the contours are
#            centred on the node nearest the tip, so this moves them)
#   STRESS   usl (default, as C1) or musl: [transfer] stress_update
#   SHAPE    quadratic_bspline (default, as C1) or gimp: grid.shape_function
#   SUMMARY_ONLY=1  only rewrite the summary from the runs already in OUT
#   PLOT=1   also draw OUT/cracks-c2.png (needs matplotlib on PYTHONPATH)
#   GRIPS    bonded (default: dense, stiff grips pushed by a traction,
#            which hold the plate's ends in x) or roller (grips that drive
#            only v_y, the same u(t), and let the ends slide in x: `drive`)
#   CRAMP_EXTRA  lines added to every scene's [cramp] table, e.g.
#            'contact_passes = 2' (the paper's two crack-contact passes;
#            the default is one)
#   RAYON_NUM_THREADS (default 1)
# Run names: h<CELL_MM>_<case>_<method>, with _r<RAMP_MS> / _t<TIP_MM> /
# _musl / _gimp added when those differ from the defaults.
set -euo pipefail
CLEAVE=${CLEAVE:-target/release/cleave}
OUT=${OUT:-/tmp/cracks_c2}
CELL_MM=${CELL_MM:-0.5}
CASES=${CASES-"single35:fijc split:fijc split:pijc"}
RAMP_MS=${RAMP_MS:-1.0}
HOLD_MS=${HOLD_MS:-0.5}
TIP_MM=${TIP_MM:-32.5}
STRESS=${STRESS:-usl}
SHAPE=${SHAPE:-quadratic_bspline}
export RAYON_NUM_THREADS=${RAYON_NUM_THREADS:-1}
mkdir -p "$OUT/scenes" "$OUT/runs"

tag=""
[ "$RAMP_MS" != 1.0 ] && tag="${tag}_r${RAMP_MS}"
[ "$TIP_MM" != 32.5 ] && tag="${tag}_t${TIP_MM}"
[ "$STRESS" != usl ] && tag="${tag}_${STRESS}"
[ "$SHAPE" != quadratic_bspline ] && tag="${tag}_${SHAPE}"
export GRIPS=${GRIPS:-bonded}
[ "$GRIPS" != bonded ] && tag="${tag}_${GRIPS}"

# ---------------------------------------------------------------- scenes
cat > "$OUT/gen_c2.py" <<'EOF'
"""gen_c2.py OUT.toml CASE METHOD CELL_MM RAMP_MS HOLD_MS TIP_MM STRESS SHAPE
CASE: 'split' (H + full-length V at x = 35 mm) or 'single35' (35 mm wide
SENT, H only); METHOD: fijc | fijc_fixed | pijc."""
import math, os, sys

out, case, method = sys.argv[1], sys.argv[2], sys.argv[3]
h = float(sys.argv[4]) * 1e-3
ramp, hold = float(sys.argv[5]) * 1e-3, float(sys.argv[6]) * 1e-3
a = float(sys.argv[7]) * 1e-3           # H's tip, as drawn
stress = sys.argv[8]                    # usl | musl
shape = sys.argv[9]                     # quadratic_bspline | gimp

w = 0.05 if case == "split" else 0.035  # plate width
L, xv = 0.10, 0.035                     # height; V's x (split only)
yc = L / 2 + 0.1 * h                    # H's line: off node rows and particle rows
rho, E, nu = 1005.0, 2.5e9, 0.33        # as C1 (scenes/cramp_offset_cracks.toml)
tg, u0 = 0.002, 0.5e-3                  # grip thickness; each end's displacement (1 %)
grip = 1e8                              # grips: 1e8 x as dense and as stiff (same wave speed)
rho_g, E_g = rho * grip, E * grip
contours = [int(round(c / (h * 1e3))) for c in (2, 4, 8, 16)]   # 2, 4, 8, 16 mm
gx = 0.054 if case == "split" else 0.039   # grid: x in [-4, gx] mm, y in [-5, 105] mm

# H: from 3.9 cells outside the left edge (beyond the kernel's reach) to
# the tip at x = a, a point every half cell, listed edge -> tip, so the
# series' crack0_end_* is the tip
xs = [-3.9 * h] + [k * 0.5 * h for k in range(-7, int(math.floor(a / (0.5 * h) + 1e-9)) + 1)]
if a - xs[-1] > 1e-9:
    xs.append(a)
cracks = [[(x, yc) for x in xs]]
if case == "split":
    # V: x = 35 mm + 0.1 cell (off the node columns and particle columns),
    # from y = -4.4 mm to 104.4 mm, a point every half cell: through the
    # plate and both grips (2 mm), ending 2.4 mm (2.4 cells at 1 mm,
    # 4.8 at 0.5 mm) beyond the grips' outer faces, inside the grid
    xv1 = xv + 0.1 * h
    y0, y1 = -0.0044, 0.1044
    n = int(round((y1 - y0) / (0.5 * h)))
    cracks.append([(xv1, y0 + k * (y1 - y0) / n) for k in range(n + 1)])

# The grips follow u(t) = u0 (t/T - sin(2 pi t/T)/(2 pi)) as in C1: the
# traction on a grip's outer face is its mass per area times
# a(t) = u0 (2 pi/T^2) sin(2 pi t/T); 200 intervals. Roller grips
# (GRIPS=roller) drive v_y = u0/T (1 - cos(2 pi t/T)) instead and leave
# v_x free; they are 10 x as dense as the plate (the nodes they share
# with it are theirs) and 1e-3 x as stiff (they do not hold it in x).
roller = os.environ.get("GRIPS", "bonded") == "roller"
if roller:
    grip = None
    rho_g, E_g = rho * 10.0, E * 1e-3
N = 200
tab = [(ramp * k / N, rho_g * tg * u0 * 2 * math.pi / ramp ** 2 * math.sin(2 * math.pi * k / N))
       for k in range(N + 1)]
tab[-1] = (ramp, 0.0)
tab.append((ramp + hold, 0.0))
table = ", ".join("[%.6e, %.6e]" % p for p in tab)
vtab = [(ramp * k / N, u0 / ramp * (1.0 - math.cos(2 * math.pi * k / N))) for k in range(N + 1)]
vtab[-1] = (ramp, 0.0)
vtab.append((ramp + hold, 0.0))
vtable = ", ".join("[%.6e, %.6e]" % p for p in vtab)
neg_vtable = ", ".join("[%.6e, %.6e]" % (t, -v) for t, v in vtab)
loading = ('''[grid.boundary.top]
type = "traction"
normal = {{ table = [{table}] }}

[grid.boundary.bottom]
type = "traction"
normal = {{ table = [{table}] }}
'''.format(table=table), "", "")
if roller:
    loading = ("", "drive = { y = { table = [%s] } }\n" % neg_vtable,
               "drive = { y = { table = [%s] } }\n" % vtable)
end = ramp + hold
pts = lambda c: ", ".join("[%.7g, %.7g]" % p for p in c)
what = ("H a = %g mm + full-length V at x = %.4g mm" % (a * 1e3, cracks[1][0][0] * 1e3) if case == "split"
        else "35 mm wide SENT, H a = %g mm only (the single-crack reference)" % (a * 1e3))

open(out, "w").write(f"""# Nairn & Aimene section 3.2 (C2, patch test): SENT {w * 1e3:g} x 100 mm,
# {what}; J method {method}; {h * 1e3:g} mm cells.
# Written by docs/scripts/cracks_c2.sh (see docs/cracks-c2.md). Ends
# displaced 0.5 mm each (1 % strain) through {('roller grips (10 x as dense, 1e-3 x as stiff as the plate) that drive v_y only, moving them by' + chr(10) + '# ') if roller else ('bonded grips %g x as' % grip + chr(10) + '# dense and stiff as the plate, pushed by a traction that gives them' + chr(10) + '# ')}u0 (t/T - sin(2 pi t/T)/2 pi), T = {ramp * 1e3:g} ms; held to {end * 1e3:g} ms.
[meta]
name = "cracks_c2_{case}_{method}"
description = "Nairn & Aimene C2 patch test ({case}, {method})"

[grid]
cell_size = {h}
min = [-0.004, -0.005]
max = [{gx}, 0.105]
shape_function = "{shape}"

{loading[0]}
[analysis]
plane = "plane_stress"

[time]
end = {end:.6e}
cfl = 0.3

{'[transfer]' + chr(10) + 'stress_update = "musl"' + chr(10) + chr(10) if stress == 'musl' else ''}[materials.plate]
model = "linear_elastic"
density = {rho}
youngs_modulus = {E}
poissons_ratio = {nu}

[materials.grip]
model = "linear_elastic"
density = {rho_g:.6e}
youngs_modulus = {E_g:.6e}
poissons_ratio = {nu}

[[bodies]]
name = "plate"
shape = {{ type = "box", min = [0.0, 0.0], max = [{w}, {L}] }}
material = "plate"
explicit_cracks = [
""" + "".join("    { points = [" + pts(c) + "] },\n" for c in cracks) + f"""]

[[bodies]]
name = "bottom_grip"
shape = {{ type = "box", min = [0.0, {-tg}], max = [{w}, 0.0] }}
material = "grip"
{loading[1]}
[[bodies]]
name = "top_grip"
shape = {{ type = "box", min = [0.0, {L}], max = [{w}, {L + tg}] }}
material = "grip"
{loading[2]}
[cramp]
j_contours = {contours}
{os.environ.get('CRAMP_EXTRA', '')}
j_method = "{method}"

[output]
series_rows = {int(round(end / 1e-5)) + 1}
snapshots = 2
""")
EOF

# ---------------------------------------------------------------- runs
if [ "${SUMMARY_ONLY:-0}" != 1 ]; then
  for c in $CASES; do
    case_=${c%%:*}; m=${c##*:}
    name="h${CELL_MM}_${case_}_${m}${tag}"
    python3 "$OUT/gen_c2.py" "$OUT/scenes/$name.toml" "$case_" "$m" "$CELL_MM" "$RAMP_MS" "$HOLD_MS" "$TIP_MM" "$STRESS" "$SHAPE"
    echo "== $name" >&2
    "$CLEAVE" run "$OUT/scenes/$name.toml" --out "$OUT/runs/$name" --json --quiet \
      > "$OUT/runs/$name.json" 2> "$OUT/runs/$name.err" || { echo "   failed: $OUT/runs/$name.err" >&2; continue; }
    python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); print("   %s, %d steps, %.1f s" % (d["status"], d["steps"], d["wall_seconds"]))' "$OUT/runs/$name.json" >&2
  done
fi

# ---------------------------------------------------------------- summary
# Every run in OUT/runs (any cell size, ramp, tip) goes into the summary.
python3 - "$OUT" <<'EOF'
import csv, glob, json, math, os, re, struct, sys
out = sys.argv[1]
JV = 13287.0                                   # the paper's J_VCCT, J/m2
PAPER = {"pijc": [None, 1.002, 1.004, 0.943, 0.773], "fijc": [None, 1.002, 1.004, 1.064, 1.061]}
# (index by contour mm: 2 mm is not in the paper's table at 0.5 mm cells)
MM = [2, 4, 8, 16]
E, XV = 2.5e9, 0.035

def vtp(fn):
    d = open(fn, "rb").read()
    k = d.index(b"<AppendedData")
    head, start = d[:k].decode(), d.index(b"_", k) + 1
    arrs = {}
    for m in re.finditer(r'<DataArray type="(\w+)" Name="(\w+)" NumberOfComponents="(\d+)" format="appended" offset="(\d+)"', head):
        f = {"Float64": "d", "Float32": "f", "UInt32": "I", "Int64": "q", "UInt8": "B", "Int32": "i"}[m.group(1)]
        p = start + int(m.group(4))
        n = struct.unpack("<Q", d[p:p + 8])[0]
        arrs[m.group(2)] = (int(m.group(3)), struct.unpack("<%d%s" % (n // struct.calcsize(f), f), d[p + 8:p + 8 + n]))
    return arrs

def particles(run):
    """(id -> (body, x0, y0)) at t = 0 and the final snapshot's arrays."""
    a0, a1 = vtp(f"{run}/particles_0000.vtp"), vtp(f"{run}/particles_0001.vtp")
    pos0 = a0["position"][1]
    init = {i: (b, pos0[3 * k], pos0[3 * k + 1]) for k, (i, b) in enumerate(zip(a0["particle_id"][1], a0["body_id"][1]))}
    return init, a1

def grip_stretch(init, a1):
    """Mean y travel of the top grip minus the bottom grip's, m."""
    pos = a1["position"][1]
    s = {1: [], 2: []}
    for k, (i, b) in enumerate(zip(a1["particle_id"][1], a1["body_id"][1])):
        if b in s:
            s[b].append(pos[3 * k + 1] - init[i][2])
    return sum(s[2]) / len(s[2]) - sum(s[1]) / len(s[1])

def stress_name(a1):
    for n in ("stress", "cauchy_stress", "sigma"):
        if n in a1:
            return n
    return None

def strip(init, a1, eps):
    """The plate's particles right of V (x0 > 35 mm): sigma_yy mean, sd,
    min, max over |y0 - 50| < 30 mm (away from the grips) and all of it,
    the mean sigma_xx, sigma_xy there, the strain energy per volume
    against the uniform-tension value, and the left part's mean
    sigma_yy on the line y0 = 50 +- 30 mm for contrast."""
    sn = stress_name(a1)
    if sn is None:
        return None
    nc, S = a1[sn]
    pos = a1["position"][1]
    ne, Eps = a1["strain"] if "strain" in a1 else (0, None)
    vol = a1["volume"][1] if "volume" in a1 else None
    mid, full = [], []
    U = 0.0     # the strip's strain energy, J per m of thickness: sum of 1/2 sigma:eps V
    for k, (i, b) in enumerate(zip(a1["particle_id"][1], a1["body_id"][1])):
        if b != 0:
            continue
        _, x0, y0 = init[i]
        if x0 <= XV:
            continue
        s = S[nc * k:nc * k + nc]
        # 3x3 row-major (9), or Voigt-like (xx, yy, zz, yz, xz, xy) / (xx, yy, xy)
        if nc == 9:
            sxx, syy, sxy = s[0], s[4], s[1]
        elif nc == 6:   # VTK order xx, yy, zz, xy, yz, xz
            sxx, syy, sxy = s[0], s[1], s[3]
        elif nc == 4:
            sxx, syy, sxy = s[0], s[3], s[1]
        else:
            sxx, syy, sxy = s[0], s[1], s[2]
        full.append((sxx, syy, sxy))
        if ne == 6 and vol is not None:
            e = Eps[6 * k:6 * k + 6]
            U += 0.5 * (s[0] * e[0] + s[1] * e[1] + s[2] * e[2]) * vol[k]   # sigma_xy ~ 0 here
        if abs(y0 - 0.05) < 0.03:
            mid.append((sxx, syy, sxy))
    def st(v, j):
        x = [t[j] for t in v]
        mu = sum(x) / len(x)
        return mu, math.sqrt(sum((y - mu) ** 2 for y in x) / len(x)), min(x), max(x)
    return dict(n=len(full), mid_yy=st(mid, 1), full_yy=st(full, 1), mid_xx=st(mid, 0), mid_xy=st(mid, 2),
                full_xx=st(full, 0), target=E * eps, U=U, U0=0.5 * E * eps ** 2 * 0.015 * 0.1)

def v_gap(run, y):
    """V's opening (surface 1 x minus surface 2 x, or |difference|) near height y at the end, m."""
    try:
        a = vtp(f"{run}/cracks_0001.vtp")
    except (OSError, ValueError):
        return float("nan")
    P, C, O = a["position"][1], a["connectivity"][1], a["offsets"][1]
    xs = {}
    s = 0
    for crack, surf, e in zip(a["crack"][1], a["surface"][1], O):
        if crack == 1:
            pts = [(P[3 * C[j]], P[3 * C[j] + 1]) for j in range(s, e)]
            xs[surf] = min(pts, key=lambda p: abs(p[1] - y))[0]
        s = e
    if 1 in xs and 2 in xs:
        return abs(xs[1] - xs[2])
    return float("nan")

res = []
for run in sorted(glob.glob(f"{out}/runs/h*")):
    if not os.path.isdir(run) or not os.path.exists(f"{run}/series.csv"):
        continue
    name = os.path.basename(run)
    m = re.match(r"h([\d.]+)_(split|single35)_(\w+?)(?:_r([\d.]+))?(?:_t([\d.]+))?(_musl)?(_gimp)?$", name)
    if not m:
        continue
    cell, case, method = m.group(1), m.group(2), m.group(3)
    ramp = float(m.group(4) or 1.0) * 1e-3
    tip_drawn = float(m.group(5) or 32.5)
    stress = ("musl" if m.group(6) else "usl") + ("_gimp" if m.group(7) else "")
    h = float(cell) * 1e-3
    cont = [int(round(c / float(cell))) for c in MM]
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
    try:
        info = json.load(open(f"{run}.json"))
        wall, steps = info["wall_seconds"], info["steps"]
    except (OSError, ValueError, KeyError):
        wall, steps = float("nan"), 0
    tipx = [float(r["crack0_end_x"]) for r in allrows]
    nodes = [round((x + 0.004) / h) * h - 0.004 for x in tipx]   # grid min x = -4 mm
    switch = [float(allrows[k]["time"]) for k in range(1, len(nodes)) if abs(nodes[k] - nodes[k - 1]) > 1e-12]
    try:
        init, a1 = particles(run)
        stretch = grip_stretch(init, a1)
        sp = strip(init, a1, stretch / 0.1) if case == "split" else None
    except (OSError, ValueError, KeyError):
        stretch, sp = float("nan"), None
    yt = float(allrows[-1]["crack0_end_y"])
    res.append(dict(name=name, cell=cell, case=case, method=method, ramp=ramp, tip_drawn=tip_drawn, cont=cont, stress=stress,
                    J=J, sd=sd, wall=wall, steps=steps, rows=len(rows), tip=tipx[-1], node=nodes[-1], switch=switch,
                    stretch=stretch, strip=sp, vgap=v_gap(run, yt) if case == "split" else float("nan")))

def ref(r):
    """This model's single35 run with the same cell size, ramp, tip and stress update."""
    return next((s for s in res if s["case"] == "single35" and s["cell"] == r["cell"] and s["stress"] == r["stress"]
                 and s["ramp"] == r["ramp"] and s["tip_drawn"] == r["tip_drawn"]), None)

def js4(r):
    """Js4: the reference's J on its 4 mm contour, the largest one inside
    the 35 mm plate (its 8 and 16 mm contours leave the plate through its
    back face, x = 35 mm, and miss that face's W term)."""
    s = ref(r)
    return s["J"][1] if s else float("nan")

with open(f"{out}/summary.csv", "w") as f:
    f.write("run,cell_mm,case,method,ramp_ms,tip_drawn_mm,"
            + ",".join(f"J_{c}mm,J_{c}mm_over_JVCCT,J_{c}mm_over_Jsingle35,J_{c}mm_over_Js4,J_{c}mm_rel_sd" for c in MM)
            + ",tip_x_end_mm,ring_node_x_mm,ring_switch_ms,grip_stretch_mm,strip_syy_mid_MPa,strip_syy_mid_sd_MPa,"
              "strip_sxx_mid_MPa,strip_syy_target_MPa,v_opening_at_H_mm,steps,wall_s\n")
    for r in res:
        s = ref(r)
        sp = r["strip"]
        f.write(f"{r['name']},{r['cell']},{r['case']},{r['method']},{r['ramp'] * 1e3:g},{r['tip_drawn']:g},"
                + ",".join(f"{J:.1f},{J / JV:.4f},{(J / s['J'][k]) if s else float('nan'):.4f},{J / js4(r):.4f},{d:.4f}"
                           for k, (J, d) in enumerate(zip(r["J"], r["sd"])))
                + f",{r['tip'] * 1e3:.4f},{r['node'] * 1e3:.4g},{' '.join('%.3f' % (t * 1e3) for t in r['switch'])},"
                + f"{r['stretch'] * 1e3:.5f},"
                + (f"{sp['mid_yy'][0] / 1e6:.4f},{sp['mid_yy'][1] / 1e6:.4f},{sp['mid_xx'][0] / 1e6:.4f},{sp['target'] / 1e6:.4f},"
                   if sp else ",,,,")
                + f"{r['vgap'] * 1e3:.4f},{r['steps']},{r['wall']:.1f}\n")

with open(f"{out}/summary.md", "w") as f:
    f.write("J = mean over the hold; J_VCCT = 13 287 J/m2 (the paper); Js4 = this model's 35 mm SENT "
            "(single35, same cells, ramp, drawn tip, stress update) on its 4 mm contour, the largest inside "
            "its plate (its 8 and 16 mm contours leave it through the back face); contours of 2, 4, 8, 16 mm "
            "(0.5 mm cells: 4, 8, 16, 32 cells; 1 mm: 2, 4, 8, 16); * = V crosses the contour "
            "(16 and 32 cells at 0.5 mm)\n\n")
    f.write("| run | J2mm/JV | J4mm/JV | J8mm/JV | J16mm/JV | J2/Js4 | J4/Js4 | J8/Js4 | J16/Js4 | sd of J over hold, % | "
            "tip x end, mm | ring node, mm (switch, ms) | wall, s |\n|" + "---|" * 13 + "\n")
    for r in res:
        s = ref(r)
        h = float(r["cell"]) * 1e-3
        cross = lambda c: r["case"] == "split" and abs(XV - r["node"]) < c * 1e-3 / 2
        jv = " | ".join(f"{J / JV:.3f}{'*' if cross(c) else ''}" for J, c in zip(r["J"], MM))
        js = " | ".join(f"{J / js4(r):.3f}" for J in r["J"]) if s else " | | | "
        sw = f" ({', '.join(f'{t * 1e3:.2f}' for t in r['switch'])})" if r["switch"] else ""
        f.write(f"| {r['name']} | {jv} | {js} | {'/'.join(f'{d * 100:.1f}' for d in r['sd'])} | "
                f"{r['tip'] * 1e3:.3f} | {r['node'] * 1e3:.4g}{sw} | {r['wall']:.0f} |\n")
    f.write("\nPaper (Table 1, 0.5 mm cells), J/J_VCCT for 4, 8, 16*, 32* cells: "
            "PIJC 1.002, 1.004, 0.943, 0.773; FIJC 1.002, 1.004, 1.064, 1.061\n")
    f.write("\nJ in J/m2:\n\n| run | " + " | ".join(f"J {c} mm" for c in MM) + " |\n|---|---|---|---|---|\n")
    for r in res:
        f.write(f"| {r['name']} | " + " | ".join(f"{J:.0f}" for J in r["J"]) + " |\n")
    f.write("\nThe right strip (plate particles with x0 > 35 mm) at the end; target = E x (grips' stretch / 100 mm):\n\n"
            "| run | grips' stretch, mm | sigma_yy mean (sd; min..max), |y0-50| < 30 mm, MPa | sigma_yy whole strip, MPa | "
            "sigma_xx mean (min..max), mid, MPa | sigma_xy mean, mid | target sigma_yy, MPa | strain energy / (E eps^2/2 x 15 x 100 mm2) | V opening at H's line, mm |\n"
            "|---|---|---|---|---|---|---|---|---|\n")
    for r in res:
        sp = r["strip"]
        if not sp:
            f.write(f"| {r['name']} | {r['stretch'] * 1e3:.5f} | | | | | | | |\n")
            continue
        my, fy, mx, mxy = sp["mid_yy"], sp["full_yy"], sp["mid_xx"], sp["mid_xy"]
        f.write(f"| {r['name']} | {r['stretch'] * 1e3:.5f} | {my[0] / 1e6:.3f} ({my[1] / 1e6:.3f}; {my[2] / 1e6:.2f}..{my[3] / 1e6:.2f}) | "
                f"{fy[0] / 1e6:.3f} ({fy[2] / 1e6:.2f}..{fy[3] / 1e6:.2f}) | {mx[0] / 1e6:.3f} ({mx[2] / 1e6:.2f}..{mx[3] / 1e6:.2f}) | "
                f"{mxy[0] / 1e6:.3f} | {sp['target'] / 1e6:.3f} | {sp['U'] / sp['U0']:.4f} | {r['vgap'] * 1e3:.4f} |\n")
    # Eq. 13's terms (paper section 3.2), J/m2, per contour that V crosses:
    # W0 l_y (l_y = the contour's height in the strip = its side), the
    # reference's back-face term J4s - Jc_s (its contour leaves through
    # the back face, so it misses int W dy there: about -Gamma_6's W part),
    # PIJC - Js_c (same contour; eq. 13 says + W0 l_y), FIJC - PIJC
    # (= Gamma_6 + Gamma_7, eq. 13: <W_edge> l_y - W0 l_y)
    f.write("\nEq. 13 bookkeeping (J/m2; Js_c = single35 on the same contour, leaving its plate through the back face):\n\n"
            "| cells, mm | contour | W0 l_y | Js4 - Js_c | PIJC - Js_c | FIJC - PIJC | FIJC - Js4 |\n|---|---|---|---|---|---|---|\n")
    for cell in sorted({r["cell"] for r in res}):
        pick = lambda case, m: next((r for r in res if r["cell"] == cell and r["case"] == case and r["method"] == m
                                     and r["ramp"] == 1e-3 and r["tip_drawn"] == 32.5 and r["stress"] == "usl"), None)
        s35, fi, pi = pick("single35", "fijc"), pick("split", "fijc"), pick("split", "pijc")
        if not (s35 and fi and pi and fi["strip"]):
            continue
        W0 = 0.5 * fi["strip"]["mid_yy"][0] * fi["stretch"] / 0.1
        for k, c in enumerate(MM):
            if abs(XV - fi["node"]) >= c * 1e-3 / 2:
                continue
            f.write(f"| {cell} | {c} mm | {W0 * c * 1e-3:.0f} | {s35['J'][1] - s35['J'][k]:.0f} | {pi['J'][k] - s35['J'][k]:.0f} | "
                    f"{fi['J'][k] - pi['J'][k]:.0f} | {fi['J'][k] - s35['J'][1]:.0f} |\n")
print(open(f"{out}/summary.md").read())
EOF

# ---------------------------------------------------------------- plot
if [ "${PLOT:-0}" = 1 ]; then
python3 - "$OUT" <<'EOF'
import csv, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
out = sys.argv[1]
rows = {r["run"]: r for r in csv.DictReader(open(f"{out}/summary.csv"))}
MM = [2, 4, 8, 16]
fig, ax = plt.subplots(figsize=(6.5, 4.8))
paper = {"pijc": [1.002, 1.004, 0.943, 0.773], "fijc": [1.002, 1.004, 1.064, 1.061]}
ax.plot([2, 4, 8, 16], paper["fijc"], "s--", color="tab:red", mfc="none", label="paper FIJC (0.5 mm)")
ax.plot([2, 4, 8, 16], paper["pijc"], "o--", color="tab:blue", mfc="none", label="paper PIJC (0.5 mm)")
# paper's contours are 4, 8, 16, 32 cells at 0.5 mm = 2, 4, 8, 16 mm
sty = {("0.5", "split", "fijc"): ("s-", "tab:red", "FIJC, 0.5 mm cells"),
       ("0.5", "split", "pijc"): ("o-", "tab:blue", "PIJC, 0.5 mm cells"),
       ("0.5", "single35", "fijc"): ("^-", "k", "35 mm SENT alone, 0.5 mm"),
       ("1", "split", "fijc"): ("s:", "salmon", "FIJC, 1 mm cells"),
       ("1", "split", "pijc"): ("o:", "lightblue", "PIJC, 1 mm cells"),
       ("1", "single35", "fijc"): ("^:", "0.5", "35 mm SENT alone, 1 mm")}
for key, (st, col, lab) in sty.items():
    name = f"h{key[0]}_{key[1]}_{key[2]}"
    if name in rows:
        r = rows[name]
        y = [float(r[f"J_{c}mm_over_JVCCT"]) for c in MM]
        if key[1] == "single35":
            # its 8 and 16 mm contours leave the 35 mm plate through its
            # back face (no W term there): drawn apart, faded
            ax.plot(MM[:2], y[:2], st, color=col, label=lab)
            ax.plot(MM[1:], y[1:], st[0] + ":", color=col, alpha=0.35, mfc="none",
                    label=None if key[0] == "1" else "35 mm SENT, contour leaving it (invalid)")
        else:
            ax.plot(MM, y, st, color=col, label=lab)
ax.axvspan(6, 17, color="0.92", zorder=0)
ax.text(11.2, 1.185, "V crosses the contour", ha="center", fontsize=8)
ax.axhline(1.0, color="0.6", lw=0.8)
ax.set_xscale("log", base=2)
ax.set_xticks(MM)
ax.set_xticklabels([f"{c} mm\n({2 * c} cells at 0.5 mm)" for c in MM], fontsize=8)
ax.set_xlabel("square contour size")
ax.set_ylabel("J / J_VCCT (13 287 J/m²)")
ax.set_title("C2 patch test: H tip with a full-length V crack 2.5 mm ahead")
ax.legend(fontsize=7.5, loc="lower left")
fig.tight_layout()
fig.savefig(f"{out}/cracks-c2.png", dpi=110)
print(f"wrote {out}/cracks-c2.png")
EOF
fi
