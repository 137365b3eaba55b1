#!/usr/bin/env bash
# Kalthoff-Winkler with DFG (seed 000 D2): scenes/d2_kalthoff.toml
# rewritten one option at a time, each run summarised by
# docs/scripts/d2_kalthoff.py (angle from the notch tip, or a gap's upper corner, at 20/40/60/90 us,
# length, speed, fracture energy). Options (environment; absent: the
# scene's):
#   H      cell size (m; the grid's bounds are kept)
#   SHAPE  grid.shape_function (gimp, quadratic_bspline, cubic_bspline, linear)
#   DMIN   dfg.separability
#   PROJ   the projectile's length along x (m; the scene's 0.05, Table II's 0.1)
#   GAP    the notch as a gap of this width (m) cut out of the plate
#          (a hole) instead of two failed particle rows
#   SF=1   a single velocity field (the [dfg] table removed)
# Usage, from the repository root after
# `cargo build --release -p cleave-client`:
#   bash docs/scripts/d2_kalthoff.sh base
#   SHAPE=gimp bash docs/scripts/d2_kalthoff.sh gimp
set -euo pipefail
dir=${OUT:-/tmp/d2}
mkdir -p "$dir"
tag=${1:?a name for the run}
python3 - "${H:-}" "${SHAPE:-}" "${DMIN:-}" "${PROJ:-}" "${GAP:-}" "${SF:-}" > "$dir/$tag.toml" <<'PY'
import re
import sys
sys.path.insert(0, "docs/scripts")
from scene_edit import put
h, shape, dmin, proj, gap, sf = sys.argv[1:7]
t = open("scenes/d2_kalthoff.toml").read()
if h:
    t = put(t, "cell_size", h)
if shape:
    t = put(t, "shape_function", f'"{shape}"')
if dmin:
    t = put(t, "separability", dmin)
if proj:
    # the projectile keeps its right face 0.5 mm off the plate; the grid
    # reaches 1.5 mm beyond its left face
    left = round(-0.0005 - float(proj), 9)
    t, n = re.subn(r"min = \[-?[0-9.e-]+, 0\.0\], max = \[-0\.0005, 0\.025\]",
                   f"min = [{left!r}, 0.0], max = [-0.0005, 0.025]", t)
    assert n == 1, "the projectile's box"
    t, n = re.subn(r"\nmin = \[-?[0-9.e-]+, 0\.0\]\n", f"\nmin = [{round(left - 0.0015, 9)!r}, 0.0]\n", t, count=1)
    assert n == 1, "the grid's min"
if gap:
    w = float(gap)
    t = t.replace("cracks = [{ points = [[0.05, 0.025], [-0.001, 0.025]] }]",
                  f'holes = [{{ type = "box", min = [-0.001, {0.025 - w / 2!r}], max = [0.05, {0.025 + w / 2!r}] }}]\n'
                  f"crack_origin = [0.05, {0.025 + w / 2!r}]")
if sf:
    t = re.sub(r"\n\[dfg\]\nseparability = .*\n", "\n", t)
print(t, end="")
PY
rm -rf "${dir:?}/$tag"
/usr/bin/time -f "$tag: %e s wall" target/release/cleave run "$dir/$tag.toml" --out "$dir/$tag" --quiet
# a gap's crack starts at its upper corner
tip=0.05,$(python3 -c "print(0.025 + ${GAP:-0} / 2)")
python3 docs/scripts/d2_kalthoff.py --tip "$tip" "$dir/$tag"
