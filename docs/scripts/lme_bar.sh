#!/usr/bin/env bash
# The ringing-bar table of docs/eigen.md: scenes/lme_ringing_bar.toml with
# each kernel, γ and stress update, and the energy's fast part ("noise").
# BIN: the cleave binary (default target/release/cleave); OUT: a scratch
# folder (default /tmp/lme_bar).
set -euo pipefail
cd "$(dirname "$0")/../.."
BIN=${BIN:-target/release/cleave}
OUT=${OUT:-/tmp/lme_bar}
mkdir -p "$OUT"
base=scenes/lme_ringing_bar.toml
run() { # name, stress update, shape-function lines
    local name=$1 su=$2 sf=$3
    python3 - "$base" "$OUT/$name.toml" "$su" "$sf" <<'PY'
import sys
text = open(sys.argv[1]).read()
text = text.replace('shape_function = "lme"\nlme_gamma = 3.5', sys.argv[4].replace('\\n', '\n'))
text = text.replace('stress_update = "musl"', f'stress_update = "{sys.argv[3]}"')
open(sys.argv[2], 'w').write(text)
PY
    "$BIN" run "$OUT/$name.toml" --out "$OUT/$name" --quiet --json > "$OUT/$name.json" 2>/dev/null || true
}
for su in musl usl; do
    run "linear_$su" $su 'shape_function = "linear"'
    for g in 3.46 3.5 4.0 6.0 10.0 30.0; do
        run "lme${g}_$su" $su "shape_function = \"lme\"\\nlme_gamma = $g"
    done
    run "quadratic_$su" $su 'shape_function = "quadratic_bspline"'
done
python3 - "$OUT" <<'PY'
import csv, json, math, os, sys
out = sys.argv[1]
print(f"{'run':18s} {'finished':>9s} {'steps':>6s} {'min':>6s} {'max':>6s} {'end':>6s} {'noise':>9s}")
for name in sorted(f[:-5] for f in os.listdir(out) if f.endswith('.json')):
    rows = list(csv.DictReader(open(f"{out}/{name}/series.csv")))
    e = [float(r['kinetic_energy']) + float(r['strain_energy']) for r in rows]
    status = json.load(open(f"{out}/{name}.json")).get('status', '?')
    w = 5
    dev = [e[i] - sum(e[i - w:i + w + 1]) / (2 * w + 1) for i in range(w, len(e) - w)]
    noise = math.sqrt(sum(d * d for d in dev) / len(dev)) / e[0] if dev else float('nan')
    print(f"{name:18s} {status:>9s} {len(e) - 1:6d} {min(e) / e[0]:6.3f} {max(e) / e[0]:6.3f} {e[-1] / e[0]:6.3f} {noise:9.2e}")
PY
