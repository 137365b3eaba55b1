#!/usr/bin/env python3
"""Why the phase-field multigrid (src/fracture/phase_field/multigrid.rs)
slows down where the material is broken: a model of its V-cycle in numpy and
scipy, on eq. 57's operator as src/fracture/phase_field/system.rs
assembles it, K = sum_p V_p [(1 + 4 l0 H_p/Gc) N N^T + 4 l0^2 grad N grad N^T]
(k_f = 0), with quadratic B-splines on the unit square, 2 x 2 particles per
cell, h = l0/4, and 4 l0 H_p/Gc set per case. The V-cycle is
the module's: Galerkin coarse levels from the two-scale mask [1,3,3,1]/4,
Chebyshev smoothing in D^-1 K on [lo*lambda, lambda] of degree d before and
after, lambda the Gershgorin bound of D^-1/2 K D^-1/2, the coarsest level
(<= 400 unknowns) solved directly. Prints the CG iterations to a relative
residual of 1e-8 from zero, against Jacobi-preconditioned CG.

  python3 docs/scripts/mg_reaction_model.py [CELLS]     # default 64

Where 4 l0 H/Gc >> 4 (l0/h)^2 the reaction term dominates the diffusion and
K is, row for row, a B-spline mass matrix: its Jacobi-scaled spectrum is
[0.059, 3.31] in 2D for quadratic B-splines (1D stencil [1,26,66,26,1]/120:
16/66 at the highest frequency, 120/66 at the lowest), and its small
eigenvalues belong to the highest frequencies, which no coarse level holds
and which a smoother tuned to [lambda/20, lambda] leaves alone.
"""
import sys
import numpy as np
import scipy.sparse as sp


def m3(t):
    """The cardinal quadratic B-spline on [0, 3] and its derivative."""
    v, d = np.zeros_like(t), np.zeros_like(t)
    m = (t >= 0) & (t < 1); v[m] = t[m] ** 2 / 2; d[m] = t[m]
    m = (t >= 1) & (t < 2); v[m] = (-2 * t[m] ** 2 + 6 * t[m] - 3) / 2; d[m] = -2 * t[m] + 3
    m = (t >= 2) & (t < 3); v[m] = (3 - t[m]) ** 2 / 2; d[m] = -(3 - t[m])
    return v, d


def assemble(n, a_of, b):
    """K on n x n cells; a_of(x, y) gives each particle's reaction
    coefficient 1 + 4 l0 H/Gc, NaN for no particle there (an opened gap);
    b is the diffusion coefficient 4 l0^2."""
    h = 1.0 / n
    q = (np.arange(2) + 0.5) / 2
    xs = (np.arange(n)[:, None] + q[None, :]).ravel() * h
    X, Y = (g.ravel() for g in np.meshgrid(xs, xs, indexing='ij'))
    a = a_of(X, Y)
    on = np.isfinite(a)
    X, Y, a = X[on], Y[on], a[on]
    vol, nf = h * h / 4, n + 2
    ix, iy = np.floor(X / h).astype(int), np.floor(Y / h).astype(int)
    val, grad, dof = [], [], []
    for kx in range(3):
        for ky in range(3):
            i, j = ix - 2 + kx, iy - 2 + ky
            vx, dx = m3(X / h - i)
            vy, dy = m3(Y / h - j)
            val.append(vx * vy)
            grad.append(np.stack([dx * vy / h, vx * dy / h]))
            dof.append((i + 2) * nf + j + 2)
    rows, cols, ent = [], [], []
    for p in range(9):
        for r in range(9):
            rows.append(dof[p]); cols.append(dof[r])
            ent.append(vol * (a * val[p] * val[r] + b * (grad[p] * grad[r]).sum(0)))
    k = sp.coo_matrix((np.concatenate(ent), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(nf * nf, nf * nf)).tocsr()
    active = k.diagonal() > 0
    return k[active][:, active], nf, active


class Level:
    pass


def hierarchy(k, nf, active, degree, lower):
    levels, a, m = [], k, nf
    while True:
        lv = Level()
        lv.a, lv.degree, lv.lower = a, degree, lower
        d = a.diagonal()
        lv.inv = 1 / d
        s = 1 / np.sqrt(d)
        lv.lam = abs(a).multiply(s[None, :]).multiply(s[:, None]).sum(1).max()
        levels.append(lv)
        if a.shape[0] <= 400:
            lv.direct = np.linalg.pinv(a.toarray(), rcond=1e-12, hermitian=True)
            return levels
        mc = (m + 3) // 2 + 1
        p1 = sp.lil_matrix((m, mc))
        for c in range(mc):
            for t, w in enumerate([0.25, 0.75, 0.75, 0.25]):
                if 0 <= 2 * c + t - 3 < m:
                    p1[2 * c + t - 3, c] = w
        p = sp.kron(p1.tocsr(), p1.tocsr()).tocsr()[active]
        ac = (p.T @ a @ p).tocsr()
        active = ac.diagonal() > 1e-12 * ac.diagonal().max()
        lv.p = p[:, active].tocsr()
        a, m = (lv.p.T @ a @ lv.p).tocsr(), mc


def chebyshev(lv, x, b):
    up = lv.lam
    lo = lv.lower * up
    theta, delta = (up + lo) / 2, (up - lo) / 2
    sigma = theta / delta
    rho = 1 / sigma
    d = lv.inv * (b - lv.a @ x) / theta
    for k in range(1, lv.degree + 1):
        x = x + d
        if k == lv.degree:
            return x
        rho_new = 1 / (2 * sigma - rho)
        d = rho_new * rho * d + 2 * rho_new / delta * lv.inv * (b - lv.a @ x)
        rho = rho_new


def v_cycle(levels, l, b):
    lv = levels[l]
    if hasattr(lv, 'direct'):
        return lv.direct @ b
    x = chebyshev(lv, np.zeros_like(b), b)
    x = x + lv.p @ v_cycle(levels, l + 1, lv.p.T @ (b - lv.a @ x))
    return chebyshev(lv, x, b)


def cg(a, b, precondition, tol=1e-8, cap=500):
    x, r = np.zeros_like(b), b.copy()
    z = precondition(r)
    p, rz = z.copy(), r @ z
    for it in range(1, cap + 1):
        ap = a @ p
        alpha = rz / (p @ ap)
        x += alpha * p
        r -= alpha * ap
        if np.linalg.norm(r) < tol * np.linalg.norm(b):
            return it
        z = precondition(r)
        rz, rz_old = r @ z, rz
        p = z + rz / rz_old * p
    return cap


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 64
    l0 = 4.0 / n
    band = lambda x: np.abs(x - 0.5) < 2 * l0
    cases = [
        ('intact (4l0H/Gc = 0)', lambda x, y: 1 + 0 * x),
        ('a damaged disk, 4l0H/Gc = 100', lambda x, y: 1 + 100 * ((x - .5) ** 2 + (y - .5) ** 2 < .04)),
        ('all at 4l0H/Gc = 100', lambda x, y: 101 + 0 * x),
        ('all at 4l0H/Gc = 1e4', lambda x, y: 1 + 1e4 + 0 * x),
        ('a crack band, 4l0H/Gc = 1e4 within 2 l0', lambda x, y: 1 + 1e4 * band(x)),
        ('the band opened: no particles within h', lambda x, y: np.where(np.abs(x - .5) < 1.0 / n, np.nan, 1 + 1e4 * band(x))),
    ]
    smoothers = [(3, 0.05), (3, 0.01), (5, 0.01), (8, 0.01)]
    print('case | unknowns | ' + ' | '.join(f'degree {d} on [{lo}, 1] lambda' for d, lo in smoothers) + ' | Jacobi')
    for name, a_of in cases:
        k, nf, active = assemble(n, a_of, 4 * l0 * l0)
        b = np.random.default_rng(0).standard_normal(k.shape[0])
        its = []
        for degree, lower in smoothers:
            levels = hierarchy(k, nf, active, degree, lower)
            its.append(cg(k, b, lambda r: v_cycle(levels, 0, r)))
        its.append(cg(k, b, lambda r: r / k.diagonal()))
        print(f'{name} | {k.shape[0]} | ' + ' | '.join(map(str, its)), flush=True)


if __name__ == '__main__':
    main()
