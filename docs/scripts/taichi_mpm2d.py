#!/usr/bin/env python3
"""The `cleave bench --taichi` 2D problem in Taichi, for a same-run comparison.

The 2D port of `taichi_mpm3d.py`: a neo-Hookean block of n^2 cells with
2 x 2 particles per cell (plane strain) in a grid with a 4-cell margin on
every side, quadratic B-splines, APIC (MLS-MPM
form: the affine matrix C carries the velocity gradient, and the stress
enters P2G as the MLS force term), f64 throughout, spinning and stretching
with the same initial velocity gradient as the Rust bench. The time step is
given on the command line (the bench passes the one its CFL gave), so both
codes take the same steps.

Prints one line `rate <particle-steps per second>` after `--warmup` steps,
timing `--steps` steps between two `ti.sync()`s.

    python taichi_mpm2d.py --cells 256 --threads 1 --steps 20 --dt 1.5e-5

`cleave bench --taichi PYTHON` runs it (embedded in the binary) itself. A
Python for it (Taichi 1.7.4 has wheels for CPython 3.7-3.11):

    python3.11 -m venv /tmp/taichi-venv
    /tmp/taichi-venv/bin/pip install taichi==1.7.4
    cargo run --release -p cleave-client -- bench --taichi /tmp/taichi-venv/bin/python
"""
import argparse
import time

import taichi as ti


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cells", type=int, required=True)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--warmup", type=int, default=3)
    ap.add_argument("--dt", type=float, required=True)
    a = ap.parse_args()

    ti.init(arch=ti.cpu, default_fp=ti.f64, cpu_max_num_threads=a.threads,
            offline_cache=True, log_level=ti.WARN)

    n = a.cells
    h = 1.0 / n
    margin = 4
    nodes = n + 2 * margin + 1
    ppc = 2  # per axis: 4 per cell, as the Rust bench
    np_ = (n * ppc) ** 2
    rho, E, nu = 1000.0, 1.0e7, 0.3
    mu = E / (2 * (1 + nu))
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    vol0 = (h / ppc) ** 2
    mass = rho * vol0
    dt = a.dt
    inv_h = 1.0 / h
    origin = -margin * h

    x = ti.Vector.field(2, ti.f64, np_)
    v = ti.Vector.field(2, ti.f64, np_)
    C = ti.Matrix.field(2, 2, ti.f64, np_)
    F = ti.Matrix.field(2, 2, ti.f64, np_)
    gm = ti.field(ti.f64, (nodes, nodes))
    gv = ti.Vector.field(2, ti.f64, (nodes, nodes))
    # the Rust scene's velocity_gradient (row-major), v = L x
    L = ti.Matrix([[1.0, -2.0], [2.0, -1.0]], ti.f64)

    @ti.kernel
    def seed():
        m = n * ppc
        for p in range(np_):
            i = p % m
            j = p // m
            xp = ti.Vector([i + 0.5, j + 0.5], ti.f64) * (h / ppc)
            x[p] = xp
            v[p] = L @ xp
            C[p] = L
            F[p] = ti.Matrix.identity(ti.f64, 2)

    @ti.kernel
    def substep():
        for I in ti.grouped(gm):
            gm[I] = 0.0
            gv[I] = ti.Vector.zero(ti.f64, 2)
        for p in range(np_):
            xi = (x[p] - origin) * inv_h
            base = ti.cast(xi - 0.5, ti.i32)
            fx = xi - base
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2]
            Fp = F[p]
            J = Fp.determinant()
            # Kirchhoff stress of the compressible neo-Hookean solid in
            # plane strain (F33 = 1), tau = J sigma = mu (F F^T - I) + lam ln J I
            tau = mu * (Fp @ Fp.transpose() - ti.Matrix.identity(ti.f64, 2)) \
                + lam * ti.log(J) * ti.Matrix.identity(ti.f64, 2)
            # quadratic B-splines: D^-1 = 4 / h^2; the force term of MLS-MPM
            stress = -dt * vol0 * 4.0 * inv_h * inv_h * tau
            affine = stress + mass * C[p]
            for a_, b_ in ti.static(ti.ndrange(3, 3)):
                off = ti.Vector([a_, b_])
                dpos = (off.cast(ti.f64) - fx) * h
                wt = w[a_][0] * w[b_][1]
                gv[base + off] += wt * (mass * v[p] + affine @ dpos)
                gm[base + off] += wt * mass
        for I in ti.grouped(gm):
            if gm[I] > 0:
                vel = gv[I] / gm[I]
                # the Rust scene's grid has no walls but its edges; clamp
                # the outermost nodes as both codes' particles never get
                # there in the timed steps
                for d in ti.static(range(2)):
                    if I[d] < 1 or I[d] > nodes - 2:
                        vel[d] = 0.0
                gv[I] = vel
        for p in range(np_):
            xi = (x[p] - origin) * inv_h
            base = ti.cast(xi - 0.5, ti.i32)
            fx = xi - base
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2]
            nv = ti.Vector.zero(ti.f64, 2)
            nC = ti.Matrix.zero(ti.f64, 2, 2)
            for a_, b_ in ti.static(ti.ndrange(3, 3)):
                off = ti.Vector([a_, b_])
                dpos = (off.cast(ti.f64) - fx) * h
                wt = w[a_][0] * w[b_][1]
                gvel = gv[base + off]
                nv += wt * gvel
                nC += 4.0 * inv_h * inv_h * wt * gvel.outer_product(dpos)
            v[p] = nv
            C[p] = nC
            F[p] = (ti.Matrix.identity(ti.f64, 2) + dt * nC) @ F[p]
            x[p] += dt * nv

    seed()
    for _ in range(a.warmup):
        substep()
    ti.sync()
    t0 = time.perf_counter()
    for _ in range(a.steps):
        substep()
    ti.sync()
    secs = time.perf_counter() - t0
    print(f"rate {np_ * a.steps / secs:.6e}")
    print(f"particles {np_}", flush=True)


if __name__ == "__main__":
    main()
