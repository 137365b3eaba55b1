#!/usr/bin/env bash
# Particle-steps per second of the damage particle method against the grid
# MPM on the same Kalthoff-Winkler plate (0.1 x 0.1 m, 90 us), back to
# back in one run: scenes/dpm_kalthoff.toml (support 2.5), the same at
# support 1.6, and scenes/d2_kalthoff.toml (grid MPM, 4 particles per
# cell, DFG partitioning, the projectile in contact). The rate is
# particles x steps / the run's wall seconds (setup included). Usage, from
# the repository root after `cargo build --release -p cleave-client`:
#   bash docs/scripts/dpm_speed.sh
set -euo pipefail
dir=${OUT:-/tmp/dpm_speed}
mkdir -p "$dir"
sed 's/^support = .*$/support = 1.6/' scenes/dpm_kalthoff.toml > "$dir/dpm_kalthoff_s16.toml"
for scene in scenes/dpm_kalthoff.toml "$dir/dpm_kalthoff_s16.toml" scenes/d2_kalthoff.toml; do
  name=$(basename "$scene" .toml)
  rm -rf "$dir/$name"
  target/release/cleave run "$scene" --out "$dir/$name" --json 2>/dev/null | python3 -c "
import json, sys
d = json.load(sys.stdin)
rate = d['particles'] * d['steps'] / d['wall_seconds']
print(f\"$name: {d['particles']} particles, {d['steps']} steps, {d['wall_seconds']:.2f} s, {rate / 1e6:.2f} M particle-steps/s\")"
done
