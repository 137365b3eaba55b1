#!/usr/bin/env bash
# The explicit step (`cleave bench`, FLIP, up to 1 M particles) and the
# phase-field step (`cleave bench-phase-field`, P1 at the paper's size) of
# two builds, interleaved (old, new, old, new) on the same two cores, so a
# redesign can be held to "within 3 % of before". Usage, from the
# repository root:
#   git worktree add /tmp/old REV && (cd /tmp/old && cargo build --release -p cleave-client)
#   cargo build --release -p cleave-client
#   OLD=/tmp/old/target/release/cleave NEW=target/release/cleave bash docs/scripts/bench_against.sh
# CORES (default 0,1) pins both to those cores when taskset exists;
# ROUNDS (default 2) alternations; the tables go to OUT (default /tmp/bench_against).
# TRANSFER (default flip) the explicit step's transfers (e.g. flip,apic);
# PF=0 leaves the phase-field step out.
set -uo pipefail
out=${OUT:-/tmp/bench_against}
mkdir -p "$out"
pin=()
command -v taskset > /dev/null && pin=(taskset -c "${CORES:-0,1}")
for round in $(seq "${ROUNDS:-2}"); do
  for b in old new; do
    bin=$OLD; [ "$b" = new ] && bin=$NEW
    echo "== $b round $round: bench"
    "${pin[@]}" "$bin" bench --out "$out/bench-$b-$round.md" --steps 10 --transfer "${TRANSFER:-flip}" 2>&1 \
      | grep -E "^ *([a-z_]+ +)?(flip|pic|apic) +[0-9]" | tee "$out/rows-$b-$round.txt"
    [ "${PF:-1}" = 0 ] && continue
    echo "== $b round $round: bench-phase-field"
    "${pin[@]}" "$bin" bench-phase-field --out "$out/pf-$b-$round.md" --warmup 2 --steps 4 \
      --factor-repeats 1 2>&1 | tail -n 12
  done
done
# the explicit step's ms per step, median over the rounds, new against old
python3 - "$out" <<'PY'
import glob, statistics, sys
ms = {}
for f in glob.glob(f"{sys.argv[1]}/rows-*.txt"):
    b = f.split("/")[-1].split("-")[1]
    for line in open(f):
        w = line.split()[-6:]  # transfer, particles, threads, ms/step, Mp-steps/s, speed-up
        ms.setdefault((w[0], int(w[1]), int(w[2])), {}).setdefault(b, []).append(float(w[3]))
print("| transfer | particles | threads | old ms/step (median) | new ms/step (median) | new / old |")
print("|---|---:|---:|---:|---:|---:|")
for k in sorted(ms):
    o, n = statistics.median(ms[k].get("old", [float("nan")])), statistics.median(ms[k].get("new", [float("nan")]))
    print(f"| {k[0]} | {k[1]} | {k[2]} | {o:.2f} | {n:.2f} | {n / o:.3f} |")
PY
