#!/usr/bin/env bash
# Benchmark C4 of Nairn & Aimene, "J-integral methods for interacting
# cracks" (DENT, two collinear edge cracks; Figs. 8B, 10A, 10B), by the
# explicit-crack (CRAMP) model. docs/cracks-c4.md has the results and
# the reasoning behind every choice.
#
# Part 1 (Fig. 10A): a double-edge-notched plate, w = 50 x L = 100 mm,
# plane stress, E = 2500 MPa, nu = 0.33, two collinear edge cracks of
# 23.5 mm at mid-height (tips 3 mm = 6 cells of 0.5 mm apart), ends
# pulled to 1 % strain through grips as in C1 (docs/cracks-c1.md). J of
# both tips on contours of 4 ... 20 cells, by adaptive FIJC ("fijc"),
# non-adaptive FIJC ("fijc_fixed") and PIJC ("pijc"), one run each
# (j_contours is a list, so one run gives every contour size).
#
# Part 2 (Fig. 10B): the same plate with two 12.5 mm cracks
# (a/w = b/w = 0.25), J_Ic = 1000 J/m2, pulled at a constant extension
# rate (grips and initial velocity gradient as scenes/cramp_offset_cracks.toml);
# the cracks grow by the maximum hoop stress (docs/cracks.md, "Growth").
#
# Usage, from the repository root (one run at a time, one thread each):
#   CLEAVE=/tmp/cleave-s40 OUT=/tmp/cracks_c4 bash docs/scripts/cracks_c4.sh
# Environment (all optional):
#   CLEAVE   the binary (default target/release/cleave)
#   OUT      output folder (default /tmp/cracks_c4): OUT/scenes/*.toml,
#            OUT/runs/<case>/ (each run's out dir), OUT/summary_j.{md,csv},
#            OUT/summary_growth.{md,csv}
#   CELL_MM  cell size of part 1, mm (default 0.5, the paper's)
#   METHODS  part 1's j_methods (default "fijc fijc_fixed pijc"; "" none)
#   CONTOURS part 1's contour sides, cells (default "4 6 8 10 12 14 16 20")
#   ENERGY_A part 1's extra runs with both cracks of another length, mm
#            (default "23.25 23.75"; "" none), run with j_method "fijc": the
#            strain energy's change gives a contour-free J (summary_energy.md)
#   RAMP_MS, HOLD_MS  part 1's end-displacement ramp and hold (default 1.0
#            and 0.5 ms, as C1); J is the mean over the hold
#   GROW     part 2's runs, "CELL_MM:METHOD:CONTOUR" each (default
#            "1:fijc:4 0.5:fijc:4 1:fijc_fixed:8"; "" none)
#   RATE     part 2's extension rate, 1/s (default 3.75, as C5)
#   GROW_END_MS  part 2's end time (default 2.7 ms, 1.01 % strain)
#   SUMMARY_ONLY=1  only rewrite the summaries from runs already there
#   PLOT=1   also draw docs/cracks-c4.png (needs matplotlib on PYTHONPATH)
#   CRAMP_EXTRA  lines added to every scene's [cramp] table, e.g.
#            'contact_passes = 2' (the paper's two crack-contact passes;
#            the default is one)
#   RAYON_NUM_THREADS (default 1)
set -euo pipefail
CLEAVE=${CLEAVE:-target/release/cleave}
OUT=${OUT:-/tmp/cracks_c4}
CELL_MM=${CELL_MM:-0.5}
METHODS=${METHODS-"fijc fijc_fixed pijc"}
CONTOURS=${CONTOURS:-"4 6 8 10 12 14 16 20"}
ENERGY_A=${ENERGY_A-"23.25 23.75"}
RAMP_MS=${RAMP_MS:-1.0}
HOLD_MS=${HOLD_MS:-0.5}
GROW=${GROW-"1:fijc:4 0.5:fijc:4 1:fijc_fixed:8"}
RATE=${RATE:-3.75}
GROW_END_MS=${GROW_END_MS:-2.7}
export RAYON_NUM_THREADS=${RAYON_NUM_THREADS:-1}
mkdir -p "$OUT/scenes" "$OUT/runs"

# ---------------------------------------------------------------- scenes
cat > "$OUT/gen_c4.py" <<'EOF'
"""gen_c4.py OUT.toml j    METHOD CELL_MM RAMP_MS HOLD_MS "CONTOURS" [A_MM]
   gen_c4.py OUT.toml grow METHOD CELL_MM RATE END_MS CONTOUR
'j': part 1 (23.5 mm cracks, ramp to 1 % and hold, J on every contour);
'grow': part 2 (12.5 mm cracks, constant extension rate, growth)."""
import math, os, sys

out, part, method = sys.argv[1], sys.argv[2], sys.argv[3]
h = float(sys.argv[4]) * 1e-3
w, L = 0.05, 0.10
rho, E, nu = 1005.0, 2.5e9, 0.33        # as scenes/cramp_offset_cracks.toml
tg = 0.002                              # grip thickness
yc = L / 2 + 0.1 * h                    # the cracks' line: off node rows and particle rows


def cracks(a):
    """Crack 0 into the left edge, crack 1 into the right, a long each,
    both on y = yc, from 3.9 cells outside the edge (beyond the kernel's
    reach), a point every half cell, listed edge -> tip (the series'
    crack{c}_end_* is the tip)."""
    n = int(round(a / (0.5 * h)))
    xs = [-3.9 * h] + [k * 0.5 * h for k in range(-7, n + 1)]
    return [[(x, yc) for x in xs], [(w - x, yc) for x in xs]]


pts = lambda c: ", ".join("[%.7g, %.7g]" % p for p in c)

if part == "j":
    ramp, hold = float(sys.argv[5]) * 1e-3, float(sys.argv[6]) * 1e-3
    contours = [int(c) for c in sys.argv[7].split()]
    a = float(sys.argv[8]) * 1e-3 if len(sys.argv) > 8 else 0.0235   # each crack's length
    u0, grip = 0.5e-3, 1e8              # each end's travel (1 %); grip factor
    rho_g, E_g = rho * grip, E * grip
    # the grips follow u(t) = u0 (t/T - sin(2 pi t/T)/(2 pi)) (as C1): a
    # traction on their outer faces of mass/area x a(t), 200 intervals
    N = 200
    tab = [(ramp * k / N, rho_g * tg * u0 * 2 * math.pi / ramp ** 2 * math.sin(2 * math.pi * k / N))
           for k in range(N + 1)]
    tab[-1] = (ramp, 0.0)
    tab.append((ramp + hold, 0.0))
    table = ", ".join("[%.6e, %.6e]" % p for p in tab)
    end = ramp + hold
    open(out, "w").write(f"""# Nairn & Aimene C4 (Fig. 10A): DENT 50 x 100 mm, two collinear 23.5 mm
# edge cracks of {a * 1e3:g} mm at y = {yc * 1e3:g} mm, tips {(w - 2 * a) * 1e3:g} mm apart; J method {method}; {h * 1e3:g} mm cells.
# Written by docs/scripts/cracks_c4.sh (see docs/cracks-c4.md). Ends
# displaced 0.5 mm each (1 % strain) through bonded grips {grip:g} x as
# dense and stiff as the plate, pushed by a traction that gives them
# u0 (t/T - sin(2 pi t/T)/2 pi), T = {ramp * 1e3:g} ms; held to {end * 1e3:g} ms.
[meta]
name = "cracks_c4_j_{method}_a{a * 1e3:g}"
description = "Nairn & Aimene C4: DENT, two collinear cracks 3 mm apart, J against contour size ({method})"

[grid]
cell_size = {h}
min = [-0.004, -0.005]
max = [0.054, 0.105]
shape_function = "quadratic_bspline"

[grid.boundary.top]
type = "traction"
normal = {{ table = [{table}] }}

[grid.boundary.bottom]
type = "traction"
normal = {{ table = [{table}] }}

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
""" + "".join("    { points = [" + pts(c) + "] },\n" for c in cracks(a)) + f"""]

[[bodies]]
name = "bottom_grip"
shape = {{ type = "box", min = [0.0, {-tg}], max = [{w}, 0.0] }}
material = "grip"

[[bodies]]
name = "top_grip"
shape = {{ type = "box", min = [0.0, {L}], max = [{w}, {L + tg}] }}
material = "grip"

[cramp]
j_contours = {contours}
{os.environ.get('CRAMP_EXTRA', '')}
j_method = "{method}"

[output]
series_rows = {int(round(end / 1e-5)) + 1}
snapshots = 2
""")
else:
    rate, end = float(sys.argv[5]), float(sys.argv[6]) * 1e-3
    contour = int(sys.argv[7])
    a, grip, j_ic = 0.0125, 1e6, 1000.0
    v = rate * L / 2                    # each grip's speed
    rho_g, E_g = rho * grip, E * grip
    dt_row = 0.5e-6
    open(out, "w").write(f"""# Nairn & Aimene C4 propagation (Fig. 10B): DENT 50 x 100 mm, two collinear
# 12.5 mm edge cracks (a/w = b/w = 0.25) at y = {yc * 1e3:g} mm, J_Ic = {j_ic:g} J/m2,
# growth by the maximum hoop stress, J on {contour}-cell contours ({method}); {h * 1e3:g} mm cells.
# Written by docs/scripts/cracks_c4.sh (see docs/cracks-c4.md). Constant
# extension rate {rate} /s as scenes/cramp_offset_cracks.toml: grips {grip:g} x as
# dense and stiff as the plate, started at +-{v:g} m/s, and the plate
# started with the matching velocity gradient; to {end * 1e3:g} ms ({rate * end * 100:.3g} % strain).
[meta]
name = "cracks_c4_grow_{method}_{contour}"
description = "Nairn & Aimene C4: DENT, two collinear cracks a/w = 0.25 grow and link ({method}, {contour}-cell J)"

[grid]
cell_size = {h}
min = [-0.004, -0.004]
max = [0.054, 0.104]
shape_function = "quadratic_bspline"

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

[materials.grip]
model = "linear_elastic"
density = {rho_g:.6e}
youngs_modulus = {E_g:.6e}
poissons_ratio = {nu}

[[bodies]]
name = "plate"
shape = {{ type = "box", min = [0.0, 0.0], max = [{w}, {L}] }}
material = "plate"
velocity_gradient = [[0.0, 0.0], [0.0, {rate}]]
velocity_origin = [{w / 2}, {L / 2}]
explicit_cracks = [
""" + "".join("    { points = [" + pts(c) + "] },\n" for c in cracks(a)) + f"""]

[[bodies]]
name = "bottom_grip"
shape = {{ type = "box", min = [0.0, {-tg}], max = [{w}, 0.0] }}
material = "grip"
velocity = [0.0, {-v}]

[[bodies]]
name = "top_grip"
shape = {{ type = "box", min = [0.0, {L}], max = [{w}, {L + tg}] }}
material = "grip"
velocity = [0.0, {v}]

[cramp]
j_contours = [{contour}]
{os.environ.get('CRAMP_EXTRA', '')}
j_method = "{method}"
growth = {{ j_ic = {j_ic} }}

[output]
series_rows = {int(round(end / dt_row)) + 1}
snapshots = 11
""")
EOF

run_one() {   # name
  local name=$1
  echo "== $name" >&2
  "$CLEAVE" run "$OUT/scenes/$name.toml" --out "$OUT/runs/$name" --json --quiet \
    > "$OUT/runs/$name.json" 2> "$OUT/runs/$name.err" || { echo "   failed: $OUT/runs/$name.err" >&2; return 0; }
  python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); print("   %s, %d steps, %.1f s" % (d["status"], d["steps"], d["wall_seconds"]))' "$OUT/runs/$name.json" >&2
}

# ---------------------------------------------------------------- runs
if [ "${SUMMARY_ONLY:-0}" != 1 ]; then
  for m in $METHODS; do
    name="j_h${CELL_MM}_${m}"
    python3 "$OUT/gen_c4.py" "$OUT/scenes/$name.toml" j "$m" "$CELL_MM" "$RAMP_MS" "$HOLD_MS" "$CONTOURS"
    run_one "$name"
  done
  for am in $ENERGY_A; do
    name="j_h${CELL_MM}_fijc_a${am}"
    python3 "$OUT/gen_c4.py" "$OUT/scenes/$name.toml" j fijc "$CELL_MM" "$RAMP_MS" "$HOLD_MS" "$CONTOURS" "$am"
    run_one "$name"
  done
  for g in $GROW; do
    IFS=: read -r gh gm gc <<< "$g"
    name="grow_h${gh}_${gm}_${gc}"
    python3 "$OUT/gen_c4.py" "$OUT/scenes/$name.toml" grow "$gm" "$gh" "$RATE" "$GROW_END_MS" "$gc"
    run_one "$name"
  done
fi

# ---------------------------------------------------------------- summary
python3 - "$OUT" "$CELL_MM" "$RAMP_MS" "$CONTOURS" "$RATE" "$METHODS" "$GROW" "$ENERGY_A" <<'EOF'
import csv, json, math, os, re, struct, sys
out, cell, ramp, contours, rate = sys.argv[1], sys.argv[2], float(sys.argv[3]) * 1e-3, \
    [int(c) for c in sys.argv[4].split()], float(sys.argv[5])
methods, grows, energy_a = sys.argv[6].split(), sys.argv[7].split(), sys.argv[8].split()
PAPER_JREF = 21954.0
# Fig. 10A as the paper's text gives it: all methods identical up to 10
# cells; non-adaptive FIJC 40 % low at 12, ~0 from 14; adaptive ~1
PAPER_FIXED = {4: "1", 6: "1", 8: "1", 10: "1", 12: "≈ 0.6", 14: "≈ 0", 16: "≈ 0", 20: "≈ 0"}
PAPER_ADAPT = {n: "≈ 1" for n in contours}


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


def wall(run):
    try:
        d = json.load(open(f"{run}.json"))
        return d["wall_seconds"], d["steps"]
    except (OSError, ValueError, KeyError):
        return float("nan"), 0


def fnum(r, k):
    try:
        return float(r[k])
    except (KeyError, ValueError, TypeError):
        return float("nan")


def adapted(lo, hi, t, o):
    """contour.rs Rect::adapted, x only (collinear tips): the right edge
    moved to leave o 2 (else 1) cells outside with t 2 (else 1) inside."""
    for margin in (2.0, 1.0):
        edge = math.floor(o - margin)
        if edge >= t + margin:
            return min(edge, hi)
    return None


# ---- part 1
res = {}
for m in methods:
    run = f"{out}/runs/j_h{cell}_{m}"
    if not os.path.exists(f"{run}/series.csv"):
        continue
    allrows = list(csv.DictReader(open(f"{run}/series.csv")))
    rows = [r for r in allrows if float(r["time"]) >= ramp - 1e-9]
    if not rows:
        continue
    d = {"wall": wall(run), "rows": len(rows), "J": {}, "sd": {}}
    for c in (0, 1):
        for i, n in enumerate(contours):
            col = f"crack{c}_end_J" if i == 0 else f"crack{c}_end_J{n}"
            v = [fnum(r, col) for r in rows]
            good = [x for x in v if x == x]
            mu = sum(good) / len(good) if good else float("nan")
            d["J"][(c, n)] = mu
            d["sd"][(c, n)] = (math.sqrt(sum((x - mu) ** 2 for x in good) / len(good)) / abs(mu)
                               if good and mu else float("nan"))
            d.setdefault("nan", {})[(c, n)] = len(v) - len(good)
    h = float(cell) * 1e-3
    d["tip"] = [(fnum(allrows[0], f"crack{c}_end_x"), fnum(allrows[-1], f"crack{c}_end_x")) for c in (0, 1)]
    res[m] = d

if res:
    ref = res.get("fijc", next(iter(res.values())))["J"][(0, contours[0])]
    h = float(cell) * 1e-3
    ox = -0.004
    any_run = next(iter(res.values()))
    ta, tb = any_run["tip"][0][1], any_run["tip"][1][1]
    xa, xb = (ta - ox) / h, (tb - ox) / h          # grid index units
    na = round(xa)
    with open(f"{out}/summary_j.csv", "w") as f:
        f.write("method,contour_cells,Ja,Jb,Ja_over_Jref,Jb_over_Jref,Ja_rel_sd,Jb_rel_sd,nan_rows_a,nan_rows_b,wall_s,steps\n")
        for m, d in res.items():
            for n in contours:
                f.write(f"{m},{n},{d['J'][(0, n)]:.1f},{d['J'][(1, n)]:.1f},{d['J'][(0, n)] / ref:.4f},"
                        f"{d['J'][(1, n)] / ref:.4f},{d['sd'][(0, n)]:.4f},{d['sd'][(1, n)]:.4f},"
                        f"{d['nan'][(0, n)]},{d['nan'][(1, n)]},{d['wall'][0]:.1f},{d['wall'][1]}\n")
    with open(f"{out}/summary_j.md", "w") as f:
        f.write(f"{cell} mm cells; J = mean over the hold ({any_run['rows']} rows); "
                f"J_ref = J of crack a (crack 0), {contours[0]}-cell contour, {res.get('fijc') and 'fijc' or next(iter(res))} "
                f"= {ref:.0f} J/m2 (paper 21 954, ratio {ref / PAPER_JREF:.3f})\n\n")
        f.write(f"Tips at the start: a {any_run['tip'][0][0] * 1e3:.3f} mm, b {any_run['tip'][1][0] * 1e3:.3f} mm; "
                f"at the end: a {ta * 1e3:.3f} mm, b {tb * 1e3:.3f} mm (gap {(tb - ta) * 1e3:.3f} mm = "
                f"{(tb - ta) / h:.2f} cells); contour centre (node nearest tip a) x = {(ox + na * h) * 1e3:g} mm, "
                f"b's tip {xb - na:.2f} cells right of it\n\n")
        hdr = "| contour, cells | b's tip vs the square (end) | adapted right edge, cells from centre | " + \
              " | ".join(f"{m} J_a/J_ref | {m} J_b/J_ref" for m in res) + \
              " | paper, adaptive | paper, non-adaptive |\n"
        f.write(hdr + "|" + "---|" * (3 + 2 * len(res) + 2) + "\n")
        for n in contours:
            r = n // 2
            lo, hi = na - r, na + r
            where = "inside" if xb < hi else ("next cell" if xb < hi + 1 else "outside")
            ad = adapted(lo, hi, xa, xb) if xb < hi + 1 else None
            ads = "—" if xb >= hi + 1 else (f"{ad - na}" if ad is not None else "kept")
            f.write(f"| {n} | {where} | {ads} | " + " | ".join(
                f"{d['J'][(0, n)] / ref:.3f} | {d['J'][(1, n)] / ref:.3f}" for d in res.values())
                + f" | {PAPER_ADAPT[n] if n in PAPER_ADAPT else ''} | {PAPER_FIXED.get(n, '')} |\n")
        f.write("\n| method | J_a, J/m2 (4 cells) | rel. sd over hold (4 cells) | wall, s | steps |\n|---|---|---|---|---|\n")
        for m, d in res.items():
            f.write(f"| {m} | {d['J'][(0, contours[0])]:.0f} | {d['sd'][(0, contours[0])]:.4f} | {d['wall'][0]:.0f} | {d['wall'][1]} |\n")
    print(open(f"{out}/summary_j.md").read())

# ---- the energy check: J = -dU/d(2a) at fixed end displacement (both
# cracks lengthen), U = strain + kinetic energy (per unit thickness)
# averaged over the hold, by differences between runs with both cracks a
# long (a = 23.5 mm: the fijc run above). And a handbook J: the load P
# from the last snapshot (mean sigma_yy of the plate's particles 65-85 mm
# high, times w) in Tada's DENT formula, K = (P/w) sqrt(pi a) F(a/b),
# F = (1 + 0.122 cos^4(pi a/2b)) sqrt((2b/pi a) tan(pi a/2b)), b = w/2, J = K^2/E.
def tada_j(a, sigma):
    b, E = 0.025, 2.5e9
    F = (1 + 0.122 * math.cos(math.pi * a / b / 2) ** 4) * math.sqrt(2 * b / (math.pi * a) * math.tan(math.pi * a / b / 2))
    return (sigma * math.sqrt(math.pi * a) * F) ** 2 / E


def gross_stress(run):
    try:
        p = vtp(f"{run}/particles_0001.vtp")
    except (OSError, ValueError):
        return float("nan")
    s = [p["stress"][6 * k + 1] for k, b in enumerate(p["body_id"])
         if b == 0 and 0.065 < p["position"][3 * k + 1] < 0.085]
    return sum(s) / len(s)


erows = []
for am in ["23.5"] + energy_a:
    run = f"{out}/runs/j_h{cell}_fijc" + ("" if am == "23.5" else f"_a{am}")
    if not os.path.exists(f"{run}/series.csv"):
        continue
    rows = [r for r in csv.DictReader(open(f"{run}/series.csv")) if float(r["time"]) >= ramp - 1e-9]
    if not rows:
        continue
    U = sum(float(r["strain_energy"]) + float(r["kinetic_energy"]) for r in rows) / len(rows)
    J4 = sum(float(r["crack0_end_J"]) for r in rows) / len(rows)
    Jl = sum(float(r[f"crack0_end_J{contours[-1]}"]) for r in rows) / len(rows)
    sg = gross_stress(run)
    erows.append((float(am), U, J4, Jl, wall(run), sg, tada_j(float(am) * 1e-3, sg)))
erows.sort()
if len(erows) >= 2:
    with open(f"{out}/summary_energy.md", "w") as f:
        f.write(f"U = strain + kinetic energy per unit thickness, mean over the hold; J_U = -(U2 - U1)/(2 (a2 - a1)) "
                f"between neighbouring lengths (both cracks grow), at their mean a\n\n"
                f"| a, mm | U, J/m | J (4-cell), J/m2 | J ({contours[-1]}-cell, fijc), J/m2 | P/w at the end, MPa | "
                f"handbook J from P (Tada), J/m2 | wall, s |\n|---|---|---|---|---|---|---|\n")
        for a, U, J4, Jl, wl, sg, jt in erows:
            f.write(f"| {a:g} | {U:.4f} | {J4:.0f} | {Jl:.0f} | {sg / 1e6:.3f} | {jt:.0f} | {wl[0]:.0f} |\n")
        f.write("\n| between a, mm | mean a, mm | J_U, J/m2 | mean of the two runs' 4-cell J | mean of their "
                f"{contours[-1]}-cell J |\n|---|---|---|---|---|\n")
        for (a1, U1, J41, Jl1, *_), (a2, U2, J42, Jl2, *_) in zip(erows, erows[1:]):
            JU = -(U2 - U1) / (2 * (a2 - a1) * 1e-3)
            f.write(f"| {a1:g}–{a2:g} | {(a1 + a2) / 2:g} | {JU:.0f} | {(J41 + J42) / 2:.0f} | {(Jl1 + Jl2) / 2:.0f} |\n")
        if len(erows) >= 3:
            (a1, U1, *_), (a3, U3, *_) = erows[0], erows[-1]
            JU = -(U3 - U1) / (2 * (a3 - a1) * 1e-3)
            mid = [e for e in erows if abs(e[0] - (a1 + a3) / 2) < 1e-9]
            if mid:
                f.write(f"\nCentral difference over {a1:g}–{a3:g} mm: J_U = {JU:.0f} J/m2 at a = {mid[0][0]:g} mm, "
                        f"against its 4-cell J {mid[0][2]:.0f} ({mid[0][2] / JU:.3f}) and {contours[-1]}-cell J "
                        f"{mid[0][3]:.0f} ({mid[0][3] / JU:.3f})\n")
    print(open(f"{out}/summary_energy.md").read())

# ---- part 2
gres = []
for g in grows:
    gh, gm, gc = g.split(":")
    run = f"{out}/runs/grow_h{gh}_{gm}_{gc}"
    if not os.path.exists(f"{run}/series.csv"):
        continue
    rows = list(csv.DictReader(open(f"{run}/series.csv")))
    t = [float(r["time"]) for r in rows]
    L0 = [fnum(rows[0], f"crack{c}_length") for c in (0, 1)]
    Lc = [[fnum(r, f"crack{c}_length") for r in rows] for c in (0, 1)]
    x = [[fnum(r, f"crack{c}_end_x") for r in rows] for c in (0, 1)]
    onset = []
    for c in (0, 1):
        k = next((k for k in range(len(rows)) if Lc[c][k] - L0[c] > 0.1e-3), None)
        onset.append(k)
    # last growth: last row where the length rose by more than 0.1 mm over the previous 10 rows
    last = []
    for c in (0, 1):
        k = max((k for k in range(10, len(rows)) if Lc[c][k] - Lc[c][k - 10] > 0.1e-3), default=None)
        last.append(k)
    # peak speed over 2 mm of path (mean speed between rows, the later the first 2 mm further)
    speed = []
    for c in (0, 1):
        best, j = 0.0, 0
        for i in range(len(rows)):
            while j < len(rows) and Lc[c][j] - Lc[c][i] < 2e-3:
                j += 1
            if j >= len(rows):
                break
            best = max(best, (Lc[c][j] - Lc[c][i]) / (t[j] - t[i]))
        speed.append(best)
    # the first run: from onset to the first row after which the crack
    # grows less than 0.1 mm over 40 rows (20 us); its mean speed
    first = []
    for c in (0, 1):
        k = onset[c]
        if k is not None:
            while k + 40 < len(rows) and Lc[c][k + 40] - Lc[c][k] > 0.1e-3:
                k += 1
            while k > onset[c] and Lc[c][k] - Lc[c][k - 1] < 1e-9:
                k -= 1
        first.append(k)
    mean = [((Lc[c][first[c]] - Lc[c][onset[c] - 1]) / (t[first[c]] - t[onset[c] - 1])
             if onset[c] and first[c] is not None and first[c] > onset[c] else float("nan")) for c in (0, 1)]
    xfirst = [x[c][first[c]] if first[c] is not None else float("nan") for c in (0, 1)]
    # J on the row before onset
    jpre = [fnum(rows[onset[c] - 1], f"crack{c}_end_J") if onset[c] else float("nan") for c in (0, 1)]
    gap = x[1][-1] - x[0][-1]
    # load carried: the strain energy's peak before the cracks ran, and its
    # mean and largest value over the last quarter of the run (a plate still
    # joined would store (strain/strain_at_peak)^2 times the peak)
    U = [fnum(r, "strain_energy") for r in rows]
    k0 = min(k for k in onset if k is not None) if any(k is not None for k in onset) else len(rows) - 1
    Upk = max(U[:k0 + 1])
    tail = U[3 * len(U) // 4:]
    Uend = (sum(tail) / len(tail), max(tail))
    # J of tip 0 after its first run: share of rows below zero
    after = [fnum(r, "crack0_end_J") for r in rows[(first[0] or 0) + 1:]]
    neg = sum(1 for v in after if v < 0) / len(after) if after else float("nan")
    ys = [fnum(rows[-1], f"crack{c}_end_y") for c in (0, 1)]
    gres.append(dict(name=f"{gh} mm, {gm}, {gc}-cell", cell=float(gh), onset=onset, t=t, last=last, speed=speed,
                     mean=mean, jpre=jpre, gap=gap, x=[x[0][-1], x[1][-1]], L=[Lc[0][-1], Lc[1][-1]], L0=L0,
                     ys=ys, wall=wall(run), key=g, first=first, xfirst=xfirst, Upk=Upk, Uend=Uend, tpk=t[k0], tend=t[-1], neg=neg))

if gres:
    with open(f"{out}/summary_growth.csv", "w") as f:
        f.write("run,onset0_ms,onset0_strain_pct,onset1_ms,onset1_strain_pct,J_before_onset0,J_before_onset1,"
                "peak_speed0_mps,peak_speed1_mps,mean_speed0_mps,mean_speed1_mps,first_run_end0_ms,first_run_end1_ms,"
                "first_run_tip0_x_mm,first_run_tip1_x_mm,last_growth0_ms,last_growth1_ms,"
                "last_growth_strain_pct,tip0_x_end_mm,tip1_x_end_mm,gap_end_mm,grown0_mm,grown1_mm,"
                "U_peak,U_last_quarter_mean,U_last_quarter_max,U_if_joined,J0_neg_share_after_first_run,wall_s,steps\n")
        for r in gres:
            on = [r["t"][k] if k is not None else float("nan") for k in r["onset"]]
            la = [r["t"][k] if k is not None else float("nan") for k in r["last"]]
            fr = [r["t"][k] if k is not None else float("nan") for k in r["first"]]
            f.write(f"{r['key']},{on[0] * 1e3:.4f},{on[0] * rate * 100:.4f},{on[1] * 1e3:.4f},{on[1] * rate * 100:.4f},"
                    f"{r['jpre'][0]:.1f},{r['jpre'][1]:.1f},{r['speed'][0]:.0f},{r['speed'][1]:.0f},"
                    f"{r['mean'][0]:.0f},{r['mean'][1]:.0f},{fr[0] * 1e3:.4f},{fr[1] * 1e3:.4f},"
                    f"{r['xfirst'][0] * 1e3:.3f},{r['xfirst'][1] * 1e3:.3f},{la[0] * 1e3:.4f},{la[1] * 1e3:.4f},"
                    f"{max(la) * rate * 100:.4f},{r['x'][0] * 1e3:.3f},{r['x'][1] * 1e3:.3f},{r['gap'] * 1e3:.3f},"
                    f"{(r['L'][0] - r['L0'][0]) * 1e3:.3f},{(r['L'][1] - r['L0'][1]) * 1e3:.3f},"
                    f"{r['Upk']:.3f},{r['Uend'][0]:.3f},{r['Uend'][1]:.3f},{r['Upk'] * (r['tend'] / r['tpk']) ** 2:.3f},"
                    f"{r['neg']:.3f},{r['wall'][0]:.1f},{r['wall'][1]}\n")
    with open(f"{out}/summary_growth.md", "w") as f:
        f.write(f"Extension rate {rate} /s (strain = rate x t). Onset: first row with a crack 0.1 mm longer than drawn; "
                "peak speed: the largest mean speed over 2 mm of path; first run: from onset until the crack grows less than "
                "0.1 mm in 20 us, its mean speed and where the tips then are; "
                "last growth: the last row whose crack is 0.1 mm longer than 10 rows (5 us) before\n\n")
        f.write("| run | onset, ms (strain %) crack 0 / 1 | J before onset, J/m2 | peak speed, m/s | first run: mean speed, m/s; "
                "ends at, ms (strain %); tips' x, mm | "
                "last growth, ms (strain %) | tips' x at the end, mm | gap at the end, mm | tips' y at the end, mm | "
                "strain energy: peak before growth / last quarter mean, max / if still joined, J/m | "
                "tip 0's J < 0 after its first run, share of rows | wall, s (steps) |\n"
                "|---|---|---|---|---|---|---|---|---|---|---|---|\n")
        for r in gres:
            on = [r["t"][k] if k is not None else float("nan") for k in r["onset"]]
            la = [r["t"][k] if k is not None else float("nan") for k in r["last"]]
            fr = [r["t"][k] if k is not None else float("nan") for k in r["first"]]
            f.write(f"| {r['name']} | {on[0] * 1e3:.3f} ({on[0] * rate * 100:.3f}) / {on[1] * 1e3:.3f} ({on[1] * rate * 100:.3f}) | "
                    f"{r['jpre'][0]:.0f} / {r['jpre'][1]:.0f} | {r['speed'][0]:.0f} / {r['speed'][1]:.0f} | "
                    f"{r['mean'][0]:.0f} / {r['mean'][1]:.0f}; {fr[0] * 1e3:.3f} / {fr[1] * 1e3:.3f} ({max(fr) * rate * 100:.3f}); "
                    f"{r['xfirst'][0] * 1e3:.2f} / {r['xfirst'][1] * 1e3:.2f} | {la[0] * 1e3:.3f} / {la[1] * 1e3:.3f} ({max(la) * rate * 100:.3f}) | "
                    f"{r['x'][0] * 1e3:.2f} / {r['x'][1] * 1e3:.2f} | {r['gap'] * 1e3:.3f} | "
                    f"{r['ys'][0] * 1e3:.2f} / {r['ys'][1] * 1e3:.2f} | "
                    f"{r['Upk']:.1f} / {r['Uend'][0]:.1f}, {r['Uend'][1]:.1f} / {r['Upk'] * (r['tend'] / r['tpk']) ** 2:.0f} | "
                    f"{r['neg']:.2f} | {r['wall'][0]:.0f} ({r['wall'][1]}) |\n")
    # the snapshots: the load P/w (mean sigma_yy of the plate's particles
    # 65-85 mm high), and the particles that start within 0.5 mm of the
    # crack line and 0.5 mm of the middle (x = 25 mm): their largest
    # sigma_yy and strain_yy; at the last snapshot the opening (mean y
    # travel of the particles that start within 0.6 mm above the line minus
    # those below), its least and largest over 2.5 mm bins of x
    import xml.etree.ElementTree as ET
    with open(f"{out}/summary_growth.md", "a") as f:
        f.write("\nSnapshots: P/w = mean sigma_yy 65-85 mm high (MPa); the particles within 0.5 mm of the "
                "crack line and of x = 25 mm: largest sigma_yy (MPa) and strain_yy\n\n"
                "| run | t, ms: P/w, MPa (gap particles' max sigma_yy, MPa; max strain_yy) | opening at the end over 2.5 mm bins, mm |\n|---|---|---|\n")
        for r in gres:
            gh, gm, gc = r["key"].split(":")
            run = f"{out}/runs/grow_h{gh}_{gm}_{gc}"
            try:
                sets = [(float(d.get("timestep")), d.get("file")) for d in ET.parse(f"{run}/particles.pvd").getroot().iter("DataSet")]
                p0 = vtp(f"{run}/{sets[0][1]}")
            except (OSError, ValueError, ET.ParseError):
                continue
            yc = 0.05 + 0.1 * float(gh) * 1e-3
            start = {i: (p0["position"][3 * k], p0["position"][3 * k + 1]) for k, i in enumerate(p0["particle_id"])}
            cells, op = [], {}
            for n, (tt, fn) in enumerate(sets):
                a = vtp(f"{run}/{fn}")
                band, gs, ge = [], [], []
                for k, (b, i) in enumerate(zip(a["body_id"], a["particle_id"])):
                    if b != 0:
                        continue
                    y = a["position"][3 * k + 1]
                    if 0.065 < y < 0.085:
                        band.append(a["stress"][6 * k + 1])
                    x0, y0 = start[i]
                    if abs(y0 - yc) < 0.5e-3 and abs(x0 - 0.025) < 0.5e-3:
                        gs.append(a["stress"][6 * k + 1])
                        ge.append(a["strain"][6 * k + 1])
                    if n == len(sets) - 1 and abs(y0 - yc) < 0.6e-3:
                        op.setdefault(int(a["position"][3 * k] * 1e3 // 2.5), []).append((y0 > yc, y - y0))
                cells.append(f"{tt * 1e3:.2f}: {sum(band) / len(band) / 1e6:.2f} ({max(gs) / 1e6:.0f}; {max(ge):.3f})")
            opening = []
            for v in op.values():
                up = [d for s_, d in v if s_]
                dn = [d for s_, d in v if not s_]
                if up and dn:
                    opening.append(sum(up) / len(up) - sum(dn) / len(dn))
            f.write(f"| {r['name']} | " + ", ".join(cells) + f" | {min(opening) * 1e3:.3f}–{max(opening) * 1e3:.3f} |\n")
    print(open(f"{out}/summary_growth.md").read())
EOF

if [ "${PLOT:-0}" = 1 ]; then
  python3 - "$OUT" "$CELL_MM" "$RAMP_MS" "$CONTOURS" "$METHODS" "$GROW" "$RATE" <<'EOF'
import csv, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
out, cell, contours, methods, grows, rate = sys.argv[1], sys.argv[2], [int(c) for c in sys.argv[4].split()], \
    sys.argv[5].split(), sys.argv[6].split(), float(sys.argv[7])
fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
rows = list(csv.DictReader(open(f"{out}/summary_j.csv")))
style = {"fijc": ("o-", "adaptive FIJC"), "fijc_fixed": ("s--", "non-adaptive FIJC"), "pijc": ("^:", "PIJC")}
for m in methods:
    r = [x for x in rows if x["method"] == m]
    if r:
        ax[0].plot([int(x["contour_cells"]) for x in r], [float(x["Ja_over_Jref"]) for x in r], style[m][0], label=style[m][1] + " (tip a)")
ax[0].plot([4, 6, 8, 10, 12, 14, 16, 20], [1, 1, 1, 1, 0.6, 0, 0, 0], "k+", ms=10, label="paper, non-adaptive (text)")
ax[0].axhline(1, color="k", lw=0.5)
ax[0].set_xlabel("J contour, cells (0.5 mm)"); ax[0].set_ylabel("J / J_ref (4-cell)")
ax[0].set_title("C4 DENT, tips 6 cells apart, 1 % strain"); ax[0].legend(fontsize=8)
for g in grows:
    gh, gm, gc = g.split(":")
    try:
        s = list(csv.DictReader(open(f"{out}/runs/grow_h{gh}_{gm}_{gc}/series.csv")))
    except OSError:
        continue
    t = [float(r["time"]) * rate * 100 for r in s]
    for c in (0, 1):
        ax[1].plot(t, [float(r[f"crack{c}_end_x"]) * 1e3 for r in s], label=f"{gh} mm cells, {gm}, {gc}-cell: tip {c}")
ax[1].set_xlabel("strain, %"); ax[1].set_ylabel("tip x, mm"); ax[1].set_title("propagation, a/w = b/w = 0.25")
ax[1].axvline(0.4, color="k", lw=0.5, ls=":"); ax[1].legend(fontsize=7)
fig.tight_layout(); fig.savefig("docs/cracks-c4.png", dpi=110)
print("wrote docs/cracks-c4.png")
EOF
fi
