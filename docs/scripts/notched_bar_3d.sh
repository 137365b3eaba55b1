#!/usr/bin/env bash
# The 3D notched bar's dissipation against G_f × its ligament (7.2 mJ),
# changing one thing of scenes/notched_bar_3d.toml at a time: the table in
# docs/verification.md ("Damage in 3D"). Usage, from the repository root,
# after `cargo build --release -p cleave-client`:
#   bash docs/scripts/notched_bar_3d.sh            # about 3 minutes
#   FINE=1 bash docs/scripts/notched_bar_3d.sh     # + h = 1 mm (4 more)
set -euo pipefail
bin=${BIN:-target/release/cleave}
scene=scenes/notched_bar_3d.toml
dir=$(mktemp -d /tmp/notched_bar_3d.XXXXXX)
trap 'rm -rf "$dir"' EXIT
variant() {
  local name=$1 edit=$2
  sed -e "$edit" "$scene" > "$dir/v.toml"
  "$bin" run "$dir/v.toml" --out "$dir/out" --quiet > /dev/null 2>&1
  python3 - "$dir/out/series.csv" "$name" <<'PY'
import csv, sys
r = list(csv.DictReader(open(sys.argv[1])))[-1]
g = 100.0 * 0.006 * 0.012
d = float(r["fracture_energy"])
print(f"| {sys.argv[2]} | {1e3 * d:.2f} mJ ({100 * (d / g - 1):+.1f} %) | "
      f"{1e3 * float(r['strain_energy']):.3f} mJ | {int(float(r['fragments']))} | "
      f"{1e3 * float(r['energy_balance']):+.3f} mJ |")
PY
  rm -rf "$dir/out"
}
echo "| variant | dissipated vs G_f·A = 7.20 mJ | strain energy at the end | fragments | energy balance |"
echo "|---|---|---|---|---|"
variant "the scene (GIMP, l_ch = h, ±0.025 m/s, notch 4 mm)" ''
variant "pull ×2 (±0.05 m/s)" 's/-0.025\]/-0.05]/; s/, 0.025\]/, 0.05]/; s/^end = 2.4e-3/end = 1.2e-3/'
variant "pull ×½ (±0.0125 m/s)" 's/-0.025\]/-0.0125]/; s/, 0.025\]/, 0.0125]/; s/^end = 2.4e-3/end = 4.8e-3/'
variant "l_ch = √2 h" 's/char_length = 0.002/char_length = 0.0028284271247461905/'
variant "l_ch = √3 h (the default)" 's/, char_length = 0.002//'
variant "linear shape functions" 's/"gimp"/"linear"/'
variant "quadratic B-splines" 's/"gimp"/"quadratic_bspline"/'
variant "notch 2 mm (one cell)" 's/min = \[0.010, 0.0039, 0.0039\], max = \[0.014,/min = [0.011, 0.0039, 0.0039], max = [0.013,/'
variant "σ_f = 10 MPa (l_mat 10 mm)" 's/strength = 5.0e6/strength = 1.0e7/'
variant "notch 1 mm (one particle layer, x 11–12 mm)" 's/min = \[0.010, 0.0039, 0.0039\], max = \[0.014,/min = [0.011, 0.0039, 0.0039], max = [0.012,/'
variant "an initial crack instead of the notch: a flat rectangle through the layer x = 11.5 mm, y < 9.9 mm, the whole depth (its 72 particles start broken)" \
  's/^holes = .*$/cracks = [{ points = [[0.0115, 0.003, 0.003], [0.0115, 0.0099, 0.003], [0.0115, 0.0099, 0.017], [0.0115, 0.003, 0.017]] }]\ncrack_origin = [0.0115, 0.0099, 0.010]/'
if [ -n "${FINE:-}" ]; then
  variant "h = 1 mm, l_ch = h" 's/cell_size = 0.002/cell_size = 0.001/; s/char_length = 0.002/char_length = 0.001/'
fi
