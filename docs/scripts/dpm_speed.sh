#!/usr/bin/env bash
# Particle-steps per second of the damage particle method against the grid
# MPM on the same plates, back to back in one run: the Kalthoff-Winkler
# plate (0.1 x 0.1 m, 90 us) by scenes/dpm_kalthoff.toml (support 2.5),
# the same at support 1.6, and scenes/d2_kalthoff.toml (grid MPM, 4
# particles per cell, DFG partitioning, the projectile in contact); the
# branching plate (0.1 x 0.04 m, 80 us) by scenes/dpm_branching.toml
# (h = 4e-4 m, support 2.5) and scenes/p1_plate_coarse.toml (grid MPM with
# the implicit phase field, 4 particles per 5e-4 m cell). The rate is
# particles x steps / the run's wall seconds (setup included). Usage, from
# the repository root after `cargo build --release -p cleave-client`:
#   bash docs/scripts/dpm_speed.sh
set -euo pipefail
dir=${OUT:-/tmp/dpm_speed}
mkdir -p "$dir"
sed 's/^support = .*$/support = 1.6/' scenes/dpm_kalthoff.toml > "$dir/dpm_kalthoff_s16.toml"
for scene in scenes/dpm_kalthoff.toml "$dir/dpm_kalthoff_s16.toml" scenes/d2_kalthoff.toml \
  scenes/dpm_branching.toml scenes/p1_plate_coarse.toml; do
  name=$(basename "$scene" .toml)
  rm -rf "$dir/$name"
  target/release/cleave run "$scene" --out "$dir/$name" --json 2>/dev/null | python3 -c "
import json, sys
d = json.load(sys.stdin)
rate = d['particles'] * d['steps'] / d['wall_seconds']
print(f\"$name: {d['particles']} particles, {d['steps']} steps, {d['wall_seconds']:.2f} s, {rate / 1e6:.2f} M particle-steps/s\")"
done
