#!/usr/bin/env bash
# Kalthoff-Winkler by the damage particle method at several resolutions:
# scenes/dpm_kalthoff.toml (150 x 150 cells over the plate) rewritten to
# N x N cells (N = 4k + 2, so that the crack at y = 0.025 lies half a
# spacing between two rows of particles), with SUPPORT, TOL and TRACK
# (criterion 27's tracking_radius; default the scene's, each); the initiation box is kept at
# 1.5 spacings about the tip (NOTRACK=1 removes it: every particle a
# candidate from the start, criterion 27 then moot); NORMAL sets
# normal_radius (a starting segment's normal from the stress averaged over
# that many spacings); JITTER the arrangement's jitter (spacings). Prints the crack's length, angle and the
# dissipation of each (docs/scripts/dpm_kalthoff.py). Usage, from the
# repository root after `cargo build --release -p cleave-client`:
#   bash docs/scripts/dpm_kalthoff.sh 150 250 350
#   SUPPORT=1.6 TOL=0.5 bash docs/scripts/dpm_kalthoff.sh 150
set -euo pipefail
dir=${OUT:-/tmp/dpm_kalthoff}
mkdir -p "$dir"
for n in "$@"; do
  tag=n$n${SUPPORT:+-s$SUPPORT}${TOL:+-t$TOL}${TRACK:+-r$TRACK}${NOTRACK:+-notrack}${NORMAL:+-n$NORMAL}${JITTER:+-j$JITTER}
  python3 - "$n" "${SUPPORT:-}" "${TOL:-}" "${NOTRACK:-}" "${TRACK:-}" "${NORMAL:-}" "${JITTER:-}" > "$dir/$tag.toml" <<'PY'
import re, sys
n, support, tol, notrack, track, normal, jitter = int(sys.argv[1]), *sys.argv[2:8]
h = 0.1 / n
t = open("scenes/dpm_kalthoff.toml").read()
t = re.sub(r"^cell_size = .*$", f"cell_size = {h!r}", t, flags=re.M)
# the grid reaches 0.01 m beyond the plate on the left, right and top
k = round(0.01 / h)
t = re.sub(r"^min = \[-0.01, 0.0\]$", f"min = [{-k * h!r}, 0.0]", t, flags=re.M)
t = re.sub(r"^max = \[0.11, 0.11\]$", f"max = [{0.1 + k * h!r}, {0.1 + k * h!r}]", t, flags=re.M)
if support:
    t = re.sub(r"^support = .*$", f"support = {support}", t, flags=re.M)
if tol:
    t = re.sub(r"^tol = .*$", f"tol = {tol}", t, flags=re.M)
r = 1.5 * h
t = re.sub(r"initiation = \{ shape = \{ type = \"box\", min = \[[^]]*\], max = \[[^]]*\] \}",
           f"initiation = {{ shape = {{ type = \"box\", min = [{0.05 - r!r}, {0.025 - r!r}], max = [{0.05 + r!r}, {0.025 + r!r}] }}", t)
if track:
    t = re.sub(r"^tracking_radius = .*\n", "", t, flags=re.M)
    t = re.sub(r"^(tol = .*)$", f"\\1\ntracking_radius = {track}", t, count=1, flags=re.M)
if normal:
    t = re.sub(r"^(tol = .*)$", f"\\1\nnormal_radius = {normal}", t, count=1, flags=re.M)
if jitter:
    t = re.sub(r"^(support = .*)$", f"\\1\njitter = {jitter}", t, count=1, flags=re.M)
if notrack:
    t = re.sub(r"^initiation = .*\n", "", t, flags=re.M)
print(t, end="")
PY
  rm -rf "$dir/$tag"
  /usr/bin/time -f "$tag: %e s wall" target/release/cleave run "$dir/$tag.toml" --out "$dir/$tag" --quiet
  python3 docs/scripts/dpm_kalthoff.py "$dir/$tag"
done
