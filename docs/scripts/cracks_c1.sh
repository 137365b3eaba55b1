#!/usr/bin/env bash
# Benchmark C1 of Nairn & Aimene, "J-integral methods for interacting
# cracks", section 3.1 (Fig. 4A, Fig. 7): a single-edge-notched plate in
# tension (SENT, w = 50 x L = 100 mm, plane stress, E = 2500 MPa,
# nu = 0.33) with a horizontal edge crack H of a = 25 mm at mid-height and
# a vertical crack V of 50 mm centred on H's line at x = b. J of H's tip
# at 1 % end strain, normalised by the paper's single-crack
# G0 = 13 402 J/m2, for a set of b/w, by the explicit-crack (CRAMP) model.
# docs/cracks-c1.md has the results and the reasoning behind every choice.
#
# Usage, from the repository root (one run at a time, one thread each):
#   CLEAVE=target/release/cleave OUT=/tmp/cracks_c1 bash docs/scripts/cracks_c1.sh
# Environment (all optional):
#   CLEAVE   the binary (default target/release/cleave)
#   OUT      output folder (default /tmp/cracks_c1): OUT/scenes/*.toml,
#            OUT/runs/<case>/ (each run's out dir), OUT/summary.md, OUT/summary.csv
#   CELL_MM  cell size in mm, 1 (contours 2, 4, 8 cells) or 0.5 (4, 8, 16
#            cells): the paper's 2, 4 and 8 mm contours either way (default 1)
#   BW       the b/w values run with FIJC (default below)
#   PIJC_BW  the b/w values also run with j_method = "pijc" (BW="" or PIJC_BW="": none)
#   RAMP_MS, HOLD_MS  the end-displacement ramp and the hold after it
#            (default 1.0 and 0.5 ms); J is the mean over the hold
#   SINGLE=0        leave out the single-crack run (it is the reference of
#            the summary's J/Js columns, so run it once per CELL_MM)
#   SUMMARY_ONLY=1  only rewrite the summary from runs already there
#   CRAMP_EXTRA  lines added to every scene's [cramp] table, e.g.
#            'contact_passes = 2' (the paper's two crack-contact passes;
#            the default is one)
#   RAYON_NUM_THREADS (default 1)
set -euo pipefail
CLEAVE=${CLEAVE:-target/release/cleave}
OUT=${OUT:-/tmp/cracks_c1}
CELL_MM=${CELL_MM:-1}
BW=${BW-"0.9 0.8 0.7 0.6 0.58 0.55 0.54 0.52 0.48 0.46 0.45 0.42 0.4 0.3 0.2"}
PIJC_BW=${PIJC_BW-"0.55 0.52 0.48 0.45"}
RAMP_MS=${RAMP_MS:-1.0}
HOLD_MS=${HOLD_MS:-0.5}
export RAYON_NUM_THREADS=${RAYON_NUM_THREADS:-1}
mkdir -p "$OUT/scenes" "$OUT/runs"

# ---------------------------------------------------------------- scenes
cat > "$OUT/gen_c1.py" <<'EOF'
"""gen_c1.py OUT.toml CASE METHOD CELL_MM RAMP_MS HOLD_MS
CASE: 'single' (no V crack) or b/w; METHOD: fijc | fijc_fixed | pijc."""
import math, os, sys

out, case, method = sys.argv[1], sys.argv[2], sys.argv[3]
h = float(sys.argv[4]) * 1e-3
ramp, hold = float(sys.argv[5]) * 1e-3, float(sys.argv[6]) * 1e-3

w, L, a, lb = 0.05, 0.10, 0.025, 0.05   # width, height, H length, V length
yc = L / 2 + 0.1 * h                    # H's line: off node rows and particle rows
rho, E, nu = 1005.0, 2.5e9, 0.33        # as scenes/cramp_offset_cracks.toml
tg, u0 = 0.002, 0.5e-3                  # grip thickness; each end's displacement (1 %)
grip = 1e8                              # grips: 1e8 x as dense and as stiff (same wave speed)
rho_g, E_g = rho * grip, E * grip
contours = [int(round(c / (h * 1e3))) for c in (2, 4, 8)]   # 2, 4, 8 mm

# H: from 3.9 cells outside the left edge (beyond the kernel's reach) to
# the tip at x = a, a point every half cell, listed edge -> tip, so the
# series' crack0_end_* is the tip
xs = [-3.9 * h] + [k * 0.5 * h for k in range(-7, int(round(a / (0.5 * h))) + 1)]
cracks = [[(x, yc) for x in xs]]
if case != "single":
    xv = float(case) * w + 0.1 * h      # V: off the node columns and particle columns
    n = int(round(lb / (0.5 * h)))
    cracks.append([(xv, yc - lb / 2 + k * 0.5 * h) for k in range(n + 1)])

# The grips follow u(t) = u0 (t/T - sin(2 pi t/T)/(2 pi)) (no jump in the
# displacement, velocity or acceleration at either end of the ramp): the
# traction on a grip's outer face is its mass per area times
# a(t) = u0 (2 pi/T^2) sin(2 pi t/T); 200 intervals (a coarser table
# under-drives it: 40 intervals left the ends 0.2 % short).
N = 200
tab = [(ramp * k / N, rho_g * tg * u0 * 2 * math.pi / ramp ** 2 * math.sin(2 * math.pi * k / N))
       for k in range(N + 1)]
tab[-1] = (ramp, 0.0)
tab.append((ramp + hold, 0.0))
table = ", ".join("[%.6e, %.6e]" % p for p in tab)
end = ramp + hold
pts = lambda c: ", ".join("[%.7g, %.7g]" % p for p in c)
what = "no V crack (single-crack reference)" if case == "single" else "V crack at b/w = %s (x = %.4g mm)" % (case, cracks[1][0][0] * 1e3)

open(out, "w").write(f"""# Nairn & Aimene section 3.1 (C1): SENT 50 x 100 mm, H edge crack a/w = 0.5,
# {what}; J method {method}; {h * 1e3:g} mm cells.
# Written by docs/scripts/cracks_c1.sh (see docs/cracks-c1.md). Ends
# displaced 0.5 mm each (1 % strain) through bonded grips {grip:g} x as
# dense and stiff as the plate, pushed by a traction that gives them
# u0 (t/T - sin(2 pi t/T)/2 pi), T = {ramp * 1e3:g} ms; held to {end * 1e3:g} ms.
[meta]
name = "cracks_c1_{case}_{method}"
description = "Nairn & Aimene C1: SENT with a vertical second crack ({case}, {method})"

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
""" + "".join("    { points = [" + pts(c) + "] },\n" for c in cracks) + f"""]

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
EOF

# ---------------------------------------------------------------- runs
cases=()
[ "${SINGLE:-1}" = 1 ] && cases+=("single:fijc")
for bw in $BW; do cases+=("$bw:fijc"); done
for bw in $PIJC_BW; do cases+=("$bw:pijc"); done

if [ "${SUMMARY_ONLY:-0}" != 1 ]; then
  for c in "${cases[@]}"; do
    bw=${c%%:*}; m=${c##*:}
    name="h${CELL_MM}_${bw}_${m}"
    python3 "$OUT/gen_c1.py" "$OUT/scenes/$name.toml" "$bw" "$m" "$CELL_MM" "$RAMP_MS" "$HOLD_MS"
    echo "== $name" >&2
    "$CLEAVE" run "$OUT/scenes/$name.toml" --out "$OUT/runs/$name" --json --quiet \
      > "$OUT/runs/$name.json" 2> "$OUT/runs/$name.err" || { echo "   failed: $OUT/runs/$name.err" >&2; continue; }
    python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); print("   %s, %d steps, %.1f s" % (d["status"], d["steps"], d["wall_seconds"]))' "$OUT/runs/$name.json" >&2
  done
fi

# ---------------------------------------------------------------- summary
python3 - "$OUT" "$CELL_MM" "$RAMP_MS" "${cases[@]}" <<'EOF'
import csv, json, math, os, re, struct, sys
out, cell, ramp = sys.argv[1], sys.argv[2], float(sys.argv[3]) * 1e-3
cases = sys.argv[4:]
h = float(cell) * 1e-3
G0 = 13402.0
cont = [int(round(c / float(cell))) for c in (2, 4, 8)]

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

def grip_stretch(run):
    """Mean y travel of the top grip minus the bottom grip's, m (snapshots 0 and 1)."""
    try:
        a0, a1 = vtp(f"{run}/particles_0000.vtp"), vtp(f"{run}/particles_0001.vtp")
    except (OSError, ValueError):
        return float("nan")
    y0 = {i: (b, a0["position"][3 * k + 1]) for k, (i, b) in enumerate(zip(a0["particle_id"], a0["body_id"]))}
    s = {1: [], 2: []}
    for k, (i, b) in enumerate(zip(a1["particle_id"], a1["body_id"])):
        if b in s:
            s[b].append(a1["position"][3 * k + 1] - y0[i][1])
    return sum(s[2]) / len(s[2]) - sum(s[1]) / len(s[1])

def v_line_x(run, y):
    """x of the V crack's plane (crack 1) at height y at the end (cracks_0001.vtp)."""
    try:
        a = vtp(f"{run}/cracks_0001.vtp")
    except (OSError, ValueError):
        return float("nan")
    s = 0
    for line, (crack, surf, e) in enumerate(zip(a["crack"], a["surface"], a["offsets"])):
        if crack == 1 and surf == 0:
            pts = [(a["position"][3 * a["connectivity"][j]], a["position"][3 * a["connectivity"][j] + 1]) for j in range(s, e)]
            return min(pts, key=lambda p: abs(p[1] - y))[0]
        s = e
    return float("nan")

def crossed(r, n):
    """Whether V crosses the square n-cell contour about the node nearest
    H's tip, at the end (both cracks move with the material)."""
    if r["bw"] == "single":
        return False
    return abs(r["xv"] - r["node"] * h) < n / 2 * h

res = []
for c in cases:
    bw, m = c.split(":")
    name = f"h{cell}_{bw}_{m}"
    run = f"{out}/runs/{name}"
    if not os.path.exists(f"{run}/series.csv"):
        continue
    rows = [r for r in csv.DictReader(open(f"{run}/series.csv")) if float(r["time"]) >= ramp - 1e-9]
    if not rows:   # still running, or stopped before the hold
        continue
    cols = ["crack0_end_J"] + [f"crack0_end_J{n}" for n in cont[1:]]
    J, sd = [], []
    for col in cols:
        v = [float(r[col]) for r in rows]
        mu = sum(v) / len(v)
        J.append(mu)
        sd.append(math.sqrt(sum((x - mu) ** 2 for x in v) / len(v)) / abs(mu) if mu else float("nan"))
    try:
        wall = json.load(open(f"{run}.json"))["wall_seconds"]
    except (OSError, ValueError, KeyError):
        wall = float("nan")
    allrows = list(csv.DictReader(open(f"{run}/series.csv")))
    tipx = [float(r["crack0_end_x"]) for r in allrows]
    nodes = [round(x / h) for x in tipx]      # the node column nearest the tip (grid min -4 mm)
    switch = [float(allrows[k]["time"]) for k in range(1, len(nodes)) if nodes[k] != nodes[k - 1]]
    yt = float(allrows[-1]["crack0_end_y"])
    res.append(dict(bw=bw, method=m, J=J, sd=sd, wall=wall, stretch=grip_stretch(run), rows=len(rows),
                    tip0=tipx[0], tip=tipx[-1], node=nodes[-1], switch=switch, xv=v_line_x(run, yt)))

single = next((r for r in res if r["bw"] == "single"), None)
with open(f"{out}/summary_h{cell}.csv", "w") as f:
    f.write("b_over_w,method," + ",".join(f"J_{c}mm,J_{c}mm_over_G0,J_{c}mm_rel_sd,J_{c}mm_crossed" for c in (2, 4, 8))
            + ",tip_x0_mm,tip_x_end_mm,ring_node_x_mm,ring_switch_ms,v_x_end_mm,grip_stretch_mm,wall_s\n")
    for r in res:
        f.write(f"{r['bw']},{r['method']}," + ",".join(
            f"{J:.1f},{J / G0:.4f},{s:.4f},{int(crossed(r, n))}" for J, s, n in zip(r["J"], r["sd"], cont))
            + f",{r['tip0'] * 1e3:.4f},{r['tip'] * 1e3:.4f},{r['node'] * h * 1e3:g},"
            + " ".join(f"{t * 1e3:.3f}" for t in r["switch"])
            + f",{r['xv'] * 1e3:.4f},{r['stretch'] * 1e3:.5f},{r['wall']:.1f}\n")
with open(f"{out}/summary_h{cell}.md", "w") as f:
    f.write(f"{cell} mm cells (contours {cont} cells = 2, 4, 8 mm); J = mean over the hold "
            f"({res[0]['rows'] if res else 0} rows); J/G0 with G0 = 13 402 J/m2; * = the V crack crosses that contour\n\n")
    f.write("| b/w | method | J2/G0 | J4/G0 | J8/G0 | J2/J2s | J4/J4s | J8/J8s | tip x end, mm | ring node, mm (switched at, ms) | V x at H, mm | ends' travel, mm | wall, s |\n"
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n")
    for r in res:
        g = " | ".join(f"{J / G0:.3f}{'*' if crossed(r, n) else ''}" for J, n in zip(r["J"], cont))
        s = " | ".join(f"{J / Js:.3f}" for J, Js in zip(r["J"], single["J"])) if single else " | | "
        sw = f" ({', '.join(f'{t * 1e3:.2f}' for t in r['switch'])})" if r["switch"] else ""
        f.write(f"| {r['bw']} | {r['method']} | {g} | {s} | {r['tip'] * 1e3:.3f} | {r['node'] * h * 1e3:g}{sw} | "
                f"{r['xv'] * 1e3:.2f} | {r['stretch'] * 1e3:.4f} | {r['wall']:.0f} |\n")
print(open(f"{out}/summary_h{cell}.md").read())
EOF
