#!/usr/bin/env python3
"""Newton steps of the 1D LME solve (src/grid/shape.rs, lme_1d), modelled
in Python: the same start (the two nearest nodes' exact solution), bracket
(+-(2 gamma + 2)), bisection fallback and stopping rules, at 1000
positions per locality gamma. Prints the most and the mean number of
steps, and the largest residual |r| left (cell units). docs/eigen.md
quotes it.

    python3 docs/scripts/lme_newton_model.py
"""
import math


def solve(f, g):
    d = [f + 1, f, f - 1, f - 2]
    a = [-g * x * x for x in d]

    def moments(l):
        s = [a[k] + l * d[k] for k in range(4)]
        t = max(s)
        e = [math.exp(x - t) for x in s]
        z = sum(e)
        p = [x / z for x in e]
        r = sum(p[k] * d[k] for k in range(4))
        m2 = sum(p[k] * d[k] * d[k] for k in range(4))
        return r, m2 - r * r

    bound = 2 * g + 2
    lo, hi = -bound, bound
    l = g * (2 * f - 1) + math.log((1 - f) / f) if f > 0 else 0.0
    l = min(max(l, lo), hi)
    r, j = moments(l)
    steps = 0
    while steps < 100:
        if abs(r) <= 1e-15:
            break
        if r > 0:
            hi = l
        else:
            lo = l
        step = r / j if j > 0 else float("inf")
        n = l - step
        if not (lo < n < hi):
            n = 0.5 * (lo + hi)
        l = n
        r, j = moments(l)
        steps += 1
        if abs(step) <= 1e-15 * (1 + abs(l)):
            break
    return steps, r


print(f"{'gamma':>8} {'most':>5} {'mean':>6} {'largest |r|':>12}")
for g in [3.4539, 4.0, 10.0, 30.0, 100.0]:
    runs = [solve(k / 1000.0, g) for k in range(1000)]
    steps = [s for s, _ in runs]
    worst = max(abs(r) for _, r in runs)
    print(f"{g:8.4g} {max(steps):5d} {sum(steps) / len(steps):6.2f} {worst:12.2e}")
