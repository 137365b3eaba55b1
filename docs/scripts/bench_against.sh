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
set -uo pipefail
out=${OUT:-/tmp/bench_against}
mkdir -p "$out"
pin=()
command -v taskset > /dev/null && pin=(taskset -c "${CORES:-0,1}")
for round in $(seq "${ROUNDS:-2}"); do
  for b in old new; do
    bin=$OLD; [ "$b" = new ] && bin=$NEW
    echo "== $b round $round: bench"
    "${pin[@]}" "$bin" bench --out "$out/bench-$b-$round.md" --steps 10 --transfer flip 2>&1 | tail -n 7
    echo "== $b round $round: bench-phase-field"
    "${pin[@]}" "$bin" bench-phase-field --out "$out/pf-$b-$round.md" --warmup 2 --steps 4 \
      --factor-repeats 1 2>&1 | tail -n 12
  done
done
