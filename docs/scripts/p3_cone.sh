#!/usr/bin/env bash
# P3's Hertzian cone index (Kakouris & Triantafyllou, section 5.3.4,
# Figs. 30-31): SCENE (by default scenes/p3_sphere_beam_coarse.toml, case
# (i) at h = l0 = 0.25 mm) to the paper's t = 16 us at each projectile
# speed of SPEEDS (m/s; the paper's 33, 20 to 180 in steps of 5, by
# default), JOBS runs at a time (2) on one thread each; then
# docs/scripts/p3_cone.py reads the index from each run's last snapshot
# and draws PNG (docs/p3-cone.png; PNG= draws none) and PANELS
# (docs/p3-cone-panels.png; python3 with numpy and matplotlib).
# Coarse: about 37 s a run here, 11 minutes in all on two cores; at the
# paper's resolution (SCENE=scenes/p3_sphere_beam.toml) about 6 minutes a
# run on one thread.
# Usage, from the repository root:
#   cargo build --release -p cleave-client
#   [CLEAVE=target/release/cleave] [OUT=/tmp/p3_cone] [SPEEDS="20 100 180"] bash docs/scripts/p3_cone.sh
set -euo pipefail
cleave=${CLEAVE:-target/release/cleave}
scene=${SCENE:-scenes/p3_sphere_beam_coarse.toml}
out=${OUT:-/tmp/p3_cone}
speeds=${SPEEDS:-$(seq 20 5 180)}
mkdir -p "$out"
for v in $speeds; do
  mkdir -p "$out/v$v"
  sed "s/^velocity = \[20.0, 0.0\]/velocity = [$v.0, 0.0]/; s/^end = .*/end = 1.6e-5/; s/^snapshots = .*/snapshots = 2/; s/^series_rows = .*/series_rows = 33/" \
    "$scene" > "$out/v$v/scene.toml"
  grep -q "^velocity = \[$v.0, 0.0\]" "$out/v$v/scene.toml"
done
export cleave out
printf '%s\n' $speeds | xargs -P "${JOBS:-2}" -I{} env RAYON_NUM_THREADS=1 bash -c \
  '"$cleave" run "$out/v{}/scene.toml" --out "$out/v{}" --quiet --json > "$out/v{}/summary.json"'
png=${PNG-docs/p3-cone.png}
python3 docs/scripts/p3_cone.py "$out" ${png:+--plot "$png"} --panels "${PANELS:-docs/p3-cone-panels.png}"
