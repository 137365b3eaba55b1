#!/usr/bin/env bash
# Two builds of `cleave` on the same cut P1 scene, pinned to two cores: the
# f32 factorization (a build of 0c5db81) against the f64 factorization
# rounded to f32 (fe30322 and later). Usage, from the repository root:
#   git worktree add /tmp/old 0c5db81 && (cd /tmp/old && cargo build --release -p cleave-client)
#   cargo build --release -p cleave-client
#   OLD=/tmp/old/target/release/cleave NEW=target/release/cleave OUT=/tmp/cmp \
#     bash docs/scripts/factorization_on_two_cores.sh
# Each run's --json summary (phase_field.factorization / factorizations) is
# in $OUT/{old,new}.json, its series in $OUT/{old,new}-series.csv.
set -euo pipefail
mkdir -p "$OUT"
sed -e 's/^end = 8.0e-5/end = 3.0e-6/' -e 's/^snapshots = 9/snapshots = 0/' \
  scenes/p1_plate.toml > "$OUT/p1_cut.toml"
lscpu | grep -E "Model name" > "$OUT/cpu.txt" || true
for b in old new; do
  bin=$OLD; [ "$b" = new ] && bin=$NEW
  /usr/bin/time -f "%e s %M KB" env RAYON_NUM_THREADS=2 taskset -c 0,1 \
    "$bin" run "$OUT/p1_cut.toml" --out "$OUT/o-$b" --json --quiet \
    > "$OUT/$b.json" 2> "$OUT/$b.err"
  tail -1 "$OUT/$b.err"
  cp "$OUT/o-$b/series.csv" "$OUT/$b-series.csv"
done
