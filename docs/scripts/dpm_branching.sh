#!/usr/bin/env bash
# Dynamic crack branching by the damage particle method (Wei & Chen R3) at
# several spacings: scenes/dpm_branching.toml (h = 4e-4 m) rewritten to
# each H given, the crack moved to half a spacing above y = 0.02 and the
# initiation box to 1.5 spacings about its tip; SUPPORT and TOL override
# the scene's, NOTRACK=1 removes the initiation box (every particle a
# candidate from the start: criterion 27 then moot); TRACK sets criterion
# 27's tracking_radius (in spacings); TRACKAT its track_at (the damage
# at which a particle's neighbours become candidates); JITTER the
# arrangement's jitter (spacings); GF and FT the fracture energy (J/m2) and
# the strength (Pa); PLANE=plane_stress the plane assumption; NORMAL sets
# normal_radius (a starting segment's normal from the stress averaged over
# that many spacings). Prints the crack front, the branches and the dissipation
# (docs/scripts/dpm_branching.py). Usage, from the repository root after
# `cargo build --release -p cleave-client`:
#   bash docs/scripts/dpm_branching.sh 8e-4 4e-4 2e-4
#   SUPPORT=1.6 bash docs/scripts/dpm_branching.sh 4e-4
set -euo pipefail
dir=${OUT:-/tmp/dpm_branching}
mkdir -p "$dir"
for h in "$@"; do
  tag=h$h${SUPPORT:+-s$SUPPORT}${TOL:+-t$TOL}${TRACK:+-r$TRACK}${NOTRACK:+-notrack}${NORMAL:+-n$NORMAL}${TRACKAT:+-a$TRACKAT}${JITTER:+-j$JITTER}${GF:+-g$GF}${FT:+-f$FT}${PLANE:+-$PLANE}
  python3 - "$h" "${SUPPORT:-}" "${TOL:-}" "${NOTRACK:-}" "${NORMAL:-}" "${TRACK:-}" "${TRACKAT:-}" "${JITTER:-}" "${GF:-}" "${FT:-}" "${PLANE:-}" > "$dir/$tag.toml" <<'PY'
import sys
sys.path.insert(0, "docs/scripts")
from scene_edit import put, after, drop, initiation_box
h, support, tol, notrack, normal, track, track_at, jitter, gf, ft, plane = float(sys.argv[1]), *sys.argv[2:12]
t = open("scenes/dpm_branching.toml").read()
t = put(t, "cell_size", repr(h))
# the grid reaches 2.4 mm beyond the plate (a whole number of spacings)
k = round(0.0024 / h)
t = t.replace("\nmin = [-0.0024, -0.0024]\n", f"\nmin = [{-k * h!r}, {-k * h!r}]\n")
t = t.replace("\nmax = [0.1024, 0.0424]\n", f"\nmax = [{0.1 + k * h!r}, {0.04 + k * h!r}]\n")
y = 0.02 + 0.5 * h
t = t.replace("[[0.0, 0.0202], [0.05, 0.0202]]", f"[[0.0, {y!r}], [0.05, {y!r}]]")
t = initiation_box(t, (0.05, y), 1.5 * h)
for key, value in [("support", support), ("tol", tol), ("fracture_energy", gf), ("strength", ft),
                   ("plane", plane and f'"{plane}"')]:
    if value:
        t = put(t, key, value)
for anchor, key, value in [("tol", "normal_radius", normal), ("tol", "tracking_radius", track),
                           ("tol", "track_at", track_at), ("support", "jitter", jitter)]:
    if value:
        t = after(t, anchor, key, value)
if notrack:
    t = drop(t, "initiation")
print(t, end="")
PY
  rm -rf "$dir/$tag"
  /usr/bin/time -f "$tag: %e s wall" target/release/cleave run "$dir/$tag.toml" --out "$dir/$tag" --quiet
  python3 docs/scripts/dpm_branching.py "$dir/$tag"
done
