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
import re, sys
h, support, tol, notrack, normal, track, track_at, jitter, gf, ft, plane = float(sys.argv[1]), *sys.argv[2:12]
t = open("scenes/dpm_branching.toml").read()
t = re.sub(r"^cell_size = .*$", f"cell_size = {h!r}", t, flags=re.M)
# the grid reaches 2.4 mm beyond the plate (a whole number of spacings)
k = round(0.0024 / h)
t = re.sub(r"^min = \[-0.0024, -0.0024\]$", f"min = [{-k * h!r}, {-k * h!r}]", t, flags=re.M)
t = re.sub(r"^max = \[0.1024, 0.0424\]$", f"max = [{0.1 + k * h!r}, {0.04 + k * h!r}]", t, flags=re.M)
y = 0.02 + 0.5 * h
t = t.replace("[[0.0, 0.0202], [0.05, 0.0202]]", f"[[0.0, {y!r}], [0.05, {y!r}]]")
if support:
    t = re.sub(r"^support = .*$", f"support = {support}", t, flags=re.M)
if tol:
    t = re.sub(r"^tol = .*$", f"tol = {tol}", t, flags=re.M)
r = 1.5 * h
t = re.sub(r"initiation = \{ shape = \{ type = \"box\", min = \[[^]]*\], max = \[[^]]*\] \}",
           f"initiation = {{ shape = {{ type = \"box\", min = [{0.05 - r!r}, {y - r!r}], max = [{0.05 + r!r}, {y + r!r}] }}", t)
if normal:
    t = re.sub(r"^(tol = .*)$", f"\\1\nnormal_radius = {normal}", t, count=1, flags=re.M)
if track:
    t = re.sub(r"^(tol = .*)$", f"\\1\ntracking_radius = {track}", t, count=1, flags=re.M)
if track_at:
    t = re.sub(r"^(tol = .*)$", f"\\1\ntrack_at = {track_at}", t, count=1, flags=re.M)
if jitter:
    t = re.sub(r"^(support = .*)$", f"\\1\njitter = {jitter}", t, count=1, flags=re.M)
if gf:
    t = re.sub(r"^fracture_energy = .*$", f"fracture_energy = {gf}", t, count=1, flags=re.M)
if ft:
    t = re.sub(r"^strength = .*$", f"strength = {ft}", t, count=1, flags=re.M)
if plane:
    t = re.sub(r'^plane = ".*"$', f'plane = "{plane}"', t, count=1, flags=re.M)
if notrack:
    t = re.sub(r"^initiation = .*\n", "", t, flags=re.M)
print(t, end="")
PY
  rm -rf "$dir/$tag"
  /usr/bin/time -f "$tag: %e s wall" target/release/cleave run "$dir/$tag.toml" --out "$dir/$tag" --quiet
  python3 docs/scripts/dpm_branching.py "$dir/$tag"
done
