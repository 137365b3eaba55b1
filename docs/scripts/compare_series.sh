#!/usr/bin/env bash
# Whether two builds of `cleave` write the same series.csv for a scene: the
# values of every column but the wall-time ones (*_s), and the columns the
# newer one adds. Usage, from the repository root:
#   git worktree add /tmp/old REV && (cd /tmp/old && cargo build --release -p cleave-client)
#   cargo build --release -p cleave-client
#   OLD=/tmp/old/target/release/cleave NEW=target/release/cleave \
#     bash docs/scripts/compare_series.sh scenes/two_disks.toml [seconds]
set -uo pipefail
scene=$1
name=$(basename "$scene" .toml)
out=${OUT:-/tmp/compare_series}
mkdir -p "$out"
for b in old new; do
  bin=$OLD; [ "$b" = new ] && bin=$NEW
  timeout "${2:-300}" env RAYON_NUM_THREADS=1 "$bin" run "$scene" --out "$out/$name-$b" --quiet \
    > /dev/null 2>&1 || echo "$name: the $b build exited $?"
done
python3 - "$out/$name-old/series.csv" "$out/$name-new/series.csv" "$name" <<'PY'
import csv, sys
old, new, name = sys.argv[1:]
o = list(csv.reader(open(old)))
w = list(csv.reader(open(new)))
ho, hn = o[0], w[0]
keep = [c for c in ho if not c.endswith("_s")]
if len(o) != len(w):
    sys.exit(f"{name}: {len(o) - 1} rows against {len(w) - 1}")
diff = sum(a[ho.index(c)] != b[hn.index(c)] for a, b in zip(o[1:], w[1:]) for c in keep)
print(name, "rows", len(o) - 1, "differing values", diff,
      "added columns", [c for c in hn if c not in ho])
PY
