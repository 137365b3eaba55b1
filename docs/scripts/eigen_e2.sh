#!/usr/bin/env bash
# E2 of issue 34 (docs/eigen.md, "E2"): the drop-weight impact on a
# notched high-strength-concrete beam (scenes/eigen_e2_drop_weight.toml,
# after Zhang et al. 2010), and the same with the floor fixed instead of a
# roller (the supports then cannot slide); prints the peaks against the
# experiment's and draws docs/eigen-e2.png (python3 with matplotlib).
# About a minute and a half on two threads.
# Usage, from the repository root:
#   cargo build --release -p cleave-client
#   [CLEAVE=target/release/cleave] [OUT=/tmp/eigen_e2] bash docs/scripts/eigen_e2.sh
set -euo pipefail
cleave=${CLEAVE:-target/release/cleave}
out=${OUT:-/tmp/eigen_e2}
mkdir -p "$out"
scene=scenes/eigen_e2_drop_weight.toml
cp "$scene" "$out/roller.toml"
sed 's/^bottom = "roller"/bottom = "fixed"/' "$scene" > "$out/fixed.toml"
for k in roller fixed; do
  rm -rf "${out:?}/$k"
  "$cleave" run "$out/$k.toml" --out "$out/$k" --quiet
done
python3 docs/scripts/eigen_e2.py "$out" docs/eigen-e2.png roller fixed
cp "$out/roller/chi_0004.png" docs/eigen-e2-chi.png
