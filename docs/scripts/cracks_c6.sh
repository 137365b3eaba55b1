#!/usr/bin/env bash
# Benchmark C6 of Nairn & Aimene (section 3.7, Fig. 15): Budyn et al.'s
# plate with ten cracks, slow and fast, axial and biaxial loading, by the
# explicit-crack (CRAMP) model with growth. docs/cracks-c6.md has the
# results and the choices behind them (the crack positions among them).
#
# Usage, from the repository root:
#   bash docs/scripts/cracks_c6.sh
# Environment (all optional):
#   CLEAVE  the binary (default target/release/cleave)
#   OUT     output folder (default /tmp/cracks_c6): OUT/<load>_<rate>.toml,
#           OUT/<load>_<rate>/ (each run's out dir), OUT/summary.txt
#   CASES   which runs (default "axial_slow axial_fast biaxial_slow biaxial_fast")
#   GRIPS   bonded (default) or roller: the scene script's --grips (roller
#           grips drive only the velocity along their edge's normal)
#   PNG     the figures' name stem (default docs/cracks-c6)
#   PLOT=1  also draw $PNG.png and $PNG-stress.png
#           (needs matplotlib on PYTHONPATH)
#   RAYON_NUM_THREADS (default 2)
# The slow runs take 5-7 minutes each on two threads, the fast ones under a
# minute; scenes/cramp_ten_cracks.toml is the slow axial scene.
set -euo pipefail
CLEAVE=${CLEAVE:-target/release/cleave}
OUT=${OUT:-/tmp/cracks_c6}
CASES=${CASES:-"axial_slow axial_fast biaxial_slow biaxial_fast"}
export RAYON_NUM_THREADS=${RAYON_NUM_THREADS:-2}
GRIPS=${GRIPS:-bonded}
PNG=${PNG:-docs/cracks-c6}
mkdir -p "$OUT"
# the paper's rates: each end at 0.02 % and 1 % of sqrt(E/rho) = 525 m/s,
# over the 50.8 mm plate
SLOW=$(python3 -c 'import math; print(2 * 2e-4 * math.sqrt(689.4757e6 / 2500) / 0.0508)')
FAST=$(python3 -c 'import math; print(2 * 1e-2 * math.sqrt(689.4757e6 / 2500) / 0.0508)')
args=()
for c in $CASES; do
    load=${c%_*}
    rate=${c#*_}
    python3 docs/scripts/cramp_ten_cracks_scene.py --load "$load" --rate "$rate" --grips "$GRIPS" > "$OUT/$c.toml"
    echo "== $c"
    "$CLEAVE" run "$OUT/$c.toml" --out "$OUT/$c" --quiet 2>&1 | tail -1
    if [ "$rate" = slow ]; then r=$SLOW; else r=$FAST; fi
    args+=(--rate "$r" "$load, $rate=$OUT/$c")
done
plot=()
if [ "${PLOT:-0}" = 1 ]; then
    plot=(--paths "$PNG.png" --curves "$PNG-stress.png")
fi
python3 docs/scripts/plot_cracks_c6.py "${args[@]}" "${plot[@]}" | tee "$OUT/summary.txt"
