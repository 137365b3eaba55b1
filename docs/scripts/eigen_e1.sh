#!/usr/bin/env bash
# E1 of issue 34 (docs/eigen.md, "E1"): the edge-cracked square panel with
# eigenerosion, with LME shape functions (scenes/eigen_e1_panel.toml) and
# with the linear hat (the same scene with shape_function = "linear"),
# and the J integral of the initial crack (the same panel with an
# explicit crack, no erosion, to 26 s) as the reference for the onset;
# then both kernels again under the Newmark predictor-corrector
# (stress_update = "newmark", the paper's scheme) instead of MUSL.
# Prints the table of docs/eigen.md, draws docs/eigen-e1.png (python3
# with matplotlib) and copies the LME run's χ at 40 s to
# docs/eigen-e1-chi.png. About two minutes on one thread.
# Usage, from the repository root:
#   cargo build --release -p cleave-client
#   [CLEAVE=target/release/cleave] [OUT=/tmp/eigen_e1] bash docs/scripts/eigen_e1.sh
set -euo pipefail
cleave=${CLEAVE:-target/release/cleave}
out=${OUT:-/tmp/eigen_e1}
mkdir -p "$out"
scene=scenes/eigen_e1_panel.toml
cp "$scene" "$out/lme.toml"
sed 's/shape_function = "lme"/shape_function = "linear"/; /^lme_gamma/d' "$scene" > "$out/linear.toml"
for k in lme linear; do
  sed 's/stress_update = "musl"/stress_update = "newmark"/' "$out/$k.toml" > "$out/${k}_newmark.toml"
done
python3 - "$scene" "$out/j.toml" <<'PY'
import sys
s = open(sys.argv[1]).read()
s = s.replace('shape_function = "lme"', 'shape_function = "linear"').replace('lme_gamma = 3.5\n', '')
s = s.replace('eigen = { model = "erosion", fracture_energy = 1.0e-4, epsilon = 0.05 }\n', '')
s = s.replace('cracks = [{ points = [[-0.05, 0.5], [0.25, 0.5]] }]\ncrack_origin = [0.25, 0.5]',
              'explicit_cracks = [{ points = [[-0.05, 0.5], [0.25, 0.5]] }]')
s = s.replace('end = 40.0', 'end = 26.0').replace('snapshots = 6', 'snapshots = 0')
assert 'explicit_cracks' in s and 'eigen' not in s.split('[[bodies]]')[0].split('[materials.panel]')[1]
open(sys.argv[2], 'w').write(s)
PY
for k in lme linear j lme_newmark linear_newmark; do
  rm -rf "${out:?}/$k"
  # a run that fails (debris leaving the grid after the panel broke)
  # keeps its series up to the failure; the summary says where it ended
  RAYON_NUM_THREADS=1 "$cleave" run "$out/$k.toml" --out "$out/$k" --quiet || echo "$k failed"
done
python3 docs/scripts/eigen_e1.py "$out" docs/eigen-e1.png
# the LME run's last χ image: the crack through the panel
cp "$out/lme/chi_0005.png" docs/eigen-e1-chi.png
