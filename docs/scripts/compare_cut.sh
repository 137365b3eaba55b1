#!/usr/bin/env bash
# Whether two builds of `cleave` compute the same thing for scenes cut
# short: each scene's `time.end` is scaled so that it takes about STEPS
# steps (default 40; `series_rows` and `snapshots` kept), both builds run
# it with RAYON_NUM_THREADS=THREADS (default 2), and the series values
# (every column but the *_s timing ones) and every VTK file are compared.
# Usage, from the repository root:
#   git worktree add /tmp/old REV && (cd /tmp/old && cargo build --release -p cleave-client)
#   cargo build --release -p cleave-client
#   OLD=/tmp/old/target/release/cleave NEW=target/release/cleave \
#     bash docs/scripts/compare_cut.sh scenes/*.toml
# IGNORE="col1 col2" leaves those series columns out of the comparison
# (a change that corrects one diagnostic), and names the ones that differ.
# Prints one line per scene; a run's outputs are deleted after its
# comparison (P1's VTK files are gigabytes).
set -uo pipefail
steps_wanted=${STEPS:-40}
th=${THREADS:-2}
dir=${OUT:-/tmp/compare_cut}
mkdir -p "$dir"
for scene in "$@"; do
  name=$(basename "$scene" .toml)
  steps=$("$NEW" validate "$scene" --json | python3 -c "import json,sys; print(json.load(sys.stdin)['time_step']['steps'])")
  cut=$dir/$name.toml
  python3 - "$scene" "$cut" "$steps" "$steps_wanted" <<'PY'
import re, sys
src, dst, steps, want = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
t = open(src).read()
f = min(1.0, want / max(steps, 1.0))
head, sep, rest = t.partition("[time]")
rest = re.sub(r"^(end\s*=\s*)([0-9.eE+-]+)",
              lambda m: f"{m.group(1)}{float(m.group(2)) * f!r}", rest, count=1, flags=re.M)
open(dst, "w").write(head + sep + rest)
PY
  for b in old new; do
    bin=$OLD; [ "$b" = new ] && bin=$NEW
    rm -rf "$dir/$name-$b"
    RAYON_NUM_THREADS=$th timeout 1800 "$bin" run "$cut" --out "$dir/$name-$b" --quiet > /dev/null 2>&1 \
      || echo "$name: the $b build exited $?"
  done
  IGNORE=${IGNORE:-} python3 - "$dir/$name-old" "$dir/$name-new" "$name" "$th" <<'PY'
import csv, sys, os, filecmp
old, new, name, th = sys.argv[1:]
ignore = os.environ.get("IGNORE", "").split()
o = list(csv.reader(open(old + "/series.csv")))
w = list(csv.reader(open(new + "/series.csv")))
ho, hn = o[0], w[0]
keep = [c for c in ho if not c.endswith("_s") and c not in ignore]
diff = (sum(a[ho.index(c)] != b[hn.index(c)] for a, b in zip(o[1:], w[1:]) for c in keep)
        if len(o) == len(w) else "rows differ")
moved = [c for c in ignore if c in ho and c in hn and len(o) == len(w)
         and any(a[ho.index(c)] != b[hn.index(c)] for a, b in zip(o[1:], w[1:]))]
snaps = sorted(f for f in os.listdir(old) if f.endswith((".vtp", ".vti")))
bad = [f for f in snaps
       if not os.path.exists(new + "/" + f) or not filecmp.cmp(old + "/" + f, new + "/" + f, shallow=False)]
print(f"{name} threads {th}: rows {len(o) - 1}/{len(w) - 1}, differing values {diff}, "
      f"added columns {[c for c in hn if c not in ho]}, removed {[c for c in ho if c not in hn]}; "
      f"VTK files {len(snaps)}, differing {bad}"
      + (f"; ignored columns that differ {moved}" if ignore else ""))
PY
  rm -rf "$dir/$name-old" "$dir/$name-new"
done
