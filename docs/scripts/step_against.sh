#!/usr/bin/env bash
# Two builds of `cleave` on one scene cut short, interleaved (old, new,
# old, new, ...) so that a change to the step can be timed against its
# base on a shared machine. The scene's `time.end` becomes END (s) and
# its snapshots 0; each run's `--json` summary gives the wall time and the
# seconds of the plan stages named in STAGES (default "p2g g2p"), summed.
# Prints one line per run, then min / median of both and their ratios.
# Usage, from the repository root:
#   OLD=/tmp/old/target/release/cleave NEW=target/release/cleave \
#     END=3.0e-6 ROUNDS=6 bash docs/scripts/step_against.sh scenes/d4_brazilian.toml
# THREADS (default 2) sets RAYON_NUM_THREADS; outputs go to OUT (default
# /tmp/step_against) and are deleted after each run.
set -uo pipefail
scene=$1
out=${OUT:-/tmp/step_against}
mkdir -p "$out"
cut=$out/scene.toml
sed -e "s/^end = .*/end = ${END:?set END, the cut time.end in s}/" -e 's/^snapshots = .*/snapshots = 0/' "$scene" > "$cut"
log=$out/runs.txt
: > "$log"
for round in $(seq "${ROUNDS:-6}"); do
  for b in old new; do
    bin=$OLD; [ "$b" = new ] && bin=$NEW
    RAYON_NUM_THREADS=${THREADS:-2} "$bin" run "$cut" --out "$out/run-$b" --json --quiet 2>/dev/null |
      STAGES=${STAGES:-p2g g2p} python3 -c '
import json, os, sys
d = json.load(sys.stdin)
st = {s["stage"]: s["seconds"] for s in d["stage_seconds"]["stages"]}
pick = sum(st.get(k, 0.0) for k in os.environ["STAGES"].split())
print(sys.argv[1], d["steps"], "%.4f" % d["wall_seconds"], "%.4f" % pick)' "$b" | tee -a "$log"
    rm -rf "$out/run-$b"
  done
done
python3 - "$log" "${STAGES:-p2g g2p}" <<'PY'
import statistics, sys
rows = [l.split() for l in open(sys.argv[1]) if l.strip()]
for k, name in [(2, "wall s"), (3, "stages " + sys.argv[2] + " s")]:
    o = [float(r[k]) for r in rows if r[0] == "old"]
    n = [float(r[k]) for r in rows if r[0] == "new"]
    if not o or not n:
        sys.exit("no runs")
    mo, mn = statistics.median(o), statistics.median(n)
    print(f"{name}: old min/median {min(o):.3f}/{mo:.3f}, new {min(n):.3f}/{mn:.3f}, "
          f"new/old {min(n)/min(o):.3f} (min) {mn/mo:.3f} (median), {len(o)} runs each")
PY
