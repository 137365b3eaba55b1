#!/usr/bin/env bash
# P3 in 3D (scenes/p3_sphere_beam_3d.toml): runs the scene, prints Ψ_f,
# the beam's strain energy and the smallest c every 15 µs, and copies the
# phase-field pictures at 75 and 150 µs to docs/figures/ (docs/phase-field.md,
# "In 3D"). Usage, from the repository root, after
# `cargo build --release -p cleave-client`:
#   bash docs/scripts/p3_sphere_beam_3d.sh        # about 7 minutes on 2 cores
set -euo pipefail
bin=${BIN:-target/release/cleave}
dir=$(mktemp -d /tmp/p3_sphere_beam_3d.XXXXXX)
trap 'rm -rf "$dir"' EXIT
start=$(date +%s)
"$bin" run scenes/p3_sphere_beam_3d.toml --out "$dir/out" --quiet > /dev/null
echo "wall time $(( $(date +%s) - start )) s"
python3 - "$dir/out/series.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
print("| t (µs) | Ψ_f beam (J) | Ψ_f sphere (J) | kinetic (J) | strain (J) |")
print("|---|---|---|---|---|")
for r in rows[::15] + ([rows[-1]] if (len(rows) - 1) % 15 else []):
    print(f"| {1e6 * float(r['time']):.0f} | {float(r['fracture_energy_b0']):.4f} | "
          f"{float(r['fracture_energy_b1']):.2e} | {float(r['kinetic_energy']):.3f} | "
          f"{float(r['strain_energy']):.3f} |")
PY
cp "$dir/out/phase_field_0003.png" docs/figures/p3_sphere_beam_3d_75us.png
cp "$dir/out/phase_field_0006.png" docs/figures/p3_sphere_beam_3d_150us.png
