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
import sys
sys.path.insert(0, "docs/scripts")
from scene_edit import put, after, drop, initiation_box
n, support, tol, notrack, track, normal, jitter = int(sys.argv[1]), *sys.argv[2:8]
h = 0.1 / n
t = open("scenes/dpm_kalthoff.toml").read()
t = put(t, "cell_size", repr(h))
# the grid reaches 0.01 m beyond the plate on the left, right and top
k = round(0.01 / h)
t = t.replace("\nmin = [-0.01, 0.0]\n", f"\nmin = [{-k * h!r}, 0.0]\n")
t = t.replace("\nmax = [0.11, 0.11]\n", f"\nmax = [{0.1 + k * h!r}, {0.1 + k * h!r}]\n")
t = initiation_box(t, (0.05, 0.025), 1.5 * h)
for key, value in [("support", support), ("tol", tol)]:
    if value:
        t = put(t, key, value)
if track:
    t = drop(t, "tracking_radius")
for anchor, key, value in [("tol", "tracking_radius", track), ("tol", "normal_radius", normal),
                           ("support", "jitter", jitter)]:
    if value:
        t = after(t, anchor, key, value)
if notrack:
    t = drop(t, "initiation")
print(t, end="")
PY
  rm -rf "$dir/$tag"
  /usr/bin/time -f "$tag: %e s wall" target/release/cleave run "$dir/$tag.toml" --out "$dir/$tag" --quiet
  python3 docs/scripts/dpm_kalthoff.py "$dir/$tag"
done
