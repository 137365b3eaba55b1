#!/usr/bin/env bash
# Whether two builds of `cleave` write the same series.csv for a scene: the
# values of every column but the wall-time ones (*_s), and the columns the
# newer one adds. With THREADS="1 2" each build runs at each count
# (RAYON_NUM_THREADS) and every run is compared with the old build's at
# the first count. Usage, from the repository root:
#   git worktree add /tmp/old REV && (cd /tmp/old && cargo build --release -p cleave-client)
#   cargo build --release -p cleave-client
#   OLD=/tmp/old/target/release/cleave NEW=target/release/cleave [THREADS="1 2"] \
#     bash docs/scripts/compare_series.sh scenes/two_disks.toml [seconds]
set -uo pipefail
scene=$1
name=$(basename "$scene" .toml)
out=${OUT:-/tmp/compare_series}
threads=(${THREADS:-1})
mkdir -p "$out"
runs=()
for t in "${threads[@]}"; do
  for b in old new; do
    bin=$OLD; [ "$b" = new ] && bin=$NEW
    tag=$b; [ "${#threads[@]}" -gt 1 ] && tag=$b-$t
    timeout "${2:-300}" env RAYON_NUM_THREADS="$t" "$bin" run "$scene" --out "$out/$name-$tag" --quiet \
      > /dev/null 2>&1 || echo "$name: the $tag run exited $?"
    runs+=("$out/$name-$tag/series.csv")
  done
done
python3 - "$name" "${runs[@]}" <<'PY'
import csv, sys
name, base, *others = sys.argv[1:]
o = list(csv.reader(open(base)))
ho = o[0]
keep = [c for c in ho if not c.endswith("_s")]
for other in others:
    w = list(csv.reader(open(other)))
    hn = w[0]
    tag = other.split("/")[-2]
    if len(o) != len(w):
        print(f"{name}: {len(o) - 1} rows against {len(w) - 1} ({tag})")
        continue
    diff = sum(a[ho.index(c)] != b[hn.index(c)] for a, b in zip(o[1:], w[1:]) for c in keep)
    print(name, tag, "rows", len(o) - 1, "values", (len(o) - 1) * len(keep),
          "differing values", diff, "added columns", [c for c in hn if c not in ho])
PY
