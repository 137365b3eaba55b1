#!/usr/bin/env bash
# The largest total-energy drift of the two-body collision (Sulsky's disks
# in 2D, the same as spheres in 3D), by cell size and material model: the
# table in docs/verification.md ("3D: the explicit core"). Usage, from the
# repository root, after `cargo build --release -p cleave-client`:
#   bash docs/scripts/spheres_energy.sh            # h = 0.05 and 0.025 (a minute)
#   SIZES="0.05 0.025 0.0125" bash docs/scripts/spheres_energy.sh   # + 3 min in 3D
set -euo pipefail
bin=${BIN:-target/release/cleave}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
drift() {
  python3 - "$1" <<'PY'
import csv, sys
r = list(csv.DictReader(open(sys.argv[1] + "/series.csv")))
e = [float(x["kinetic_energy"]) + float(x["strain_energy"]) for x in r]
print(f"largest drift {100 * max(abs(a - e[0]) / e[0] for a in e):.2f} %, "
      f"final {100 * (e[-1] - e[0]) / e[0]:+.2f} %")
PY
}
for h in ${SIZES:-0.05 0.025}; do
  for model in linear_elastic neo_hookean; do
    sed -e "s/^cell_size = .*/cell_size = $h/" -e "s/^model = .*/model = \"$model\"/" \
      scenes/two_spheres_3d.toml > "$dir/s.toml"
    "$bin" run "$dir/s.toml" --out "$dir/o3" --quiet > /dev/null 2>&1
    echo "3D spheres, h = $h, $model: $(drift "$dir/o3")"
  done
  sed -e "s/^cell_size = .*/cell_size = $h/" -e "s/^snapshots = .*/snapshots = 0/" \
    scenes/two_disks.toml > "$dir/d.toml"
  "$bin" run "$dir/d.toml" --out "$dir/o2" --quiet > /dev/null 2>&1
  echo "2D disks,   h = $h, linear_elastic: $(drift "$dir/o2")"
done
