#!/usr/bin/env python3
"""The fracture energy of a crack's damage band, from cleave's particle
snapshots (numpy only). Used for the measurements in docs/phase-field.md,
"The damage band of an opening crack".

  crack_band.py profile SNAPSHOT.vtp --l0 L0 --y Y0 --at X1,X2,... [--half H]
      Across a crack that runs along x at height Y0: at each X, the column
      of particles within half a particle spacing of X and within H of Y0,
      sorted by y; the integral across of the crack density of eq. 4 (2nd
      order), Z = (c-1)^2/(4 l0) + l0 (dc/dy)^2, over the material (each
      particle stands for one particle spacing; an opened crack's gap
      counts for nothing), with dc/dy from differences of the particles' c. An optimal (1D) profile gives
      1: the fracture energy per unit crack length is Gc times this
      number. Also the widths of c < 0.1 and c < 0.5, and with --gc GC
      (J/m2) and a snapshot that has it, the same integral from the
      run's own fracture_energy_density (nodal c and its gradient at the
      particles) as a check.

  crack_band.py split EARLY.vtp LATE.vtp --body B --thickness T [--gc-area J]
      [--reference FIRST.vtp]
      Where body B's fracture energy goes between two snapshots: the sum of
      volume * fracture_energy_density (the run's Psi_f of B) at both
      times, and its increment within R = 0.5, 1, 2, 3 mm (city-block
      distance on a raster of the particle spacing) of the crack, the
      particles of B with c < 0.1 in LATE, and outside; the same material
      points (particle_id) in both snapshots. With --gc-area, increments
      are also given against Gc*A_f (J). With --reference, every particle's
      volume is its volume in FIRST (the undeformed body) instead of its
      present one: the functional integrated over the reference
      configuration. (A run with `volumes = "reference"` writes densities
      per present volume, so that volume * density is already its own
      measure: no --reference needed there.)

  crack_band.py slices FIRST.vtp EARLY.vtp LATE.vtp --gc GC --y Y --start X0 --end X1
      [--width W] [--half H] [--body B] [--thickness T] [--reference]
      For a crack along x near height Y: in slices of width W (default
      1 mm) from X0 to X1 by the particles' positions in FIRST (the
      undeformed body), the fracture energy within |y - Y| < H (default
      3 mm) at EARLY and at LATE, in units of Gc * thickness * W: what
      each slice of the crack holds per unit length, against 1 for an
      ideal crack. With --reference, over FIRST's volumes (as split's).
"""
import argparse, math, re
from pathlib import Path

import numpy as np


def read_vtp(path, names=None):
    """The point arrays of a cleave .vtp (raw appended, UInt64 headers)."""
    b = open(path, 'rb').read()
    at = b.index(b'<AppendedData')
    head, start = b[:at].decode(), b.index(b'_', at) + 1
    out = {}
    pat = r'<DataArray type="(\w+)" Name="(\w+)" NumberOfComponents="(\d+)" format="appended" offset="(\d+)"'
    for m in re.finditer(pat, head):
        ty, name, k, off = m.group(1), m.group(2), int(m.group(3)), int(m.group(4))
        if names and name not in names:
            continue
        n = int(np.frombuffer(b[start + off:start + off + 8], np.uint64)[0])
        a = np.frombuffer(b[start + off + 8:start + off + 8 + n], {'Float64': np.float64, 'UInt32': np.uint32, 'Int64': np.int64}[ty])
        out[name] = a.reshape(-1, k) if k > 1 else a
    return out


def snapshots(out, partial=False):
    """(time, path) of every particle snapshot of run directory `out`, from
    its particles.pvd. With `partial`, a run still going (no .pvd yet)
    gives the snapshots written so far with their times unknown (NaN)."""
    pvd = Path(out) / "particles.pvd"
    if partial and not pvd.exists():
        return [(math.nan, str(f)) for f in sorted(Path(out).glob("particles_*.vtp"))]
    return [(float(t), f"{out}/{f}")
            for t, f in re.findall(r'timestep="([^"]+)".*?file="([^"]+)"', pvd.read_text())]


def linked_to(pts, tip, start, link):
    """Which of the points `pts` (n x 2) are linked to `tip`: those closer
    to it than `start`, and every point closer than `link` to a linked
    one (the crack of broken particles that grows from a notch tip)."""
    return grown(pts, np.hypot(*(pts - tip).T) < start, link)


def grown(pts, seen, link):
    """The mask `seen` of points `pts` grown by every point closer than
    `link` to a point in it, until none is."""
    seen = seen.copy()
    front = list(np.where(seen)[0])
    while front:
        i = front.pop()
        near = np.where((~seen) & (np.hypot(*(pts - pts[i]).T) < link))[0]
        seen[near] = True
        front.extend(near.tolist())
    return seen


def read_body(path, body, names):
    """The arrays `names` of body `body`'s particles, in particle_id order
    (so that two snapshots line up particle by particle)."""
    d = read_vtp(path, names)
    m = d['body_id'] == body
    o = np.argsort(d['particle_id'][m])
    return {k: v[m][o] for k, v in d.items()}


def profile(a):
    d = read_vtp(a.snapshot, ['phase_field', 'position', 'volume', 'fracture_energy_density'])
    x, y, c = d['position'][:, 0], d['position'][:, 1], d['phase_field']
    density = d.get('fracture_energy_density') if a.gc else None
    sp = np.sqrt(np.median(d['volume']) / a.thickness)
    for x0 in a.at:
        # centre on the particle column nearest x0 (taken away from the
        # crack), so that no two columns mix
        far = np.argmin((x - x0) ** 2 + (y - a.y - a.half) ** 2)
        sel = (np.abs(x - x[far]) < sp / 2) & (np.abs(y - a.y) < a.half)
        o = np.argsort(y[sel])
        yy, cc = y[sel][o], c[sel][o]
        # Material quadrature: each particle stands for one spacing sp of
        # material, and an interval between neighbours for at most sp (an
        # opened crack's gap holds no material).
        dy = np.diff(yy)
        local = np.sum((cc - 1) ** 2 / (4 * a.l0)) * sp
        grad = np.sum(a.l0 * (np.diff(cc) / dy) ** 2 * np.minimum(dy, sp))
        w01, w05 = np.sum(cc < 0.1) * sp / a.l0, np.sum(cc < 0.5) * sp / a.l0
        own = f"; the run's own, sum of density * spacing / Gc: {np.sum(density[sel]) * sp / a.gc:.3f}" if density is not None else ""
        print(f"x = {x0 * 1e3:7.2f} mm: {sel.sum():4d} particles, min c {cc.min():.3f}, "
              f"integral of Z {local + grad:.3f} (local {local:.3f}, gradient {grad:.3f}); "
              f"width of c < 0.1 {w01:.2f} l0, of c < 0.5 {w05:.2f} l0{own}")


def split(a):
    names = ['phase_field', 'position', 'particle_id', 'volume', 'body_id', 'fracture_energy_density']
    A, B = read_body(a.early, a.body, names), read_body(a.late, a.body, names)
    assert np.array_equal(A['particle_id'], B['particle_id']), "not the same particles"
    x = B['position'][:, :2]
    crack = B['phase_field'] < 0.1
    sp = np.sqrt(np.median(B['volume']) / a.thickness)
    vA, vB = A['volume'], B['volume']
    if a.reference:
        O = read_body(a.reference, a.body, names)
        assert np.array_equal(O['particle_id'], B['particle_id']), "not the same particles"
        vA = vB = O['volume']
    eA = vA * A['fracture_energy_density']
    eB = vB * B['fracture_energy_density']
    rel = lambda e: f" ({100 * (e / a.gc_area - 1):+.1f} % against Gc*A_f)" if a.gc_area else ""
    print(f"{len(x)} particles, spacing {sp * 1e3:.4f} mm; {crack.sum()} with c < 0.1 in the later snapshot, "
          f"x {x[crack, 0].min() * 1e3:.2f} to {x[crack, 0].max() * 1e3:.2f} mm, y {x[crack, 1].min() * 1e3:.2f} to {x[crack, 1].max() * 1e3:.2f} mm")
    print(f"Psi_f: {eA.sum():.4f} J -> {eB.sum():.4f} J, increment {eB.sum() - eA.sum():.4f} J{rel(eB.sum() - eA.sum())}")
    lo = x.min(0)
    ij = np.floor((x - lo) / sp).astype(int)
    n = tuple(ij.max(0) + 1)
    cur = np.zeros(n, bool)
    cur[ij[crack, 0], ij[crack, 1]] = True
    dist = np.where(cur, 0.0, np.inf)
    for k in range(1, int(3e-3 / sp) + 2):
        nxt = cur.copy()
        nxt[1:, :] |= cur[:-1, :]
        nxt[:-1, :] |= cur[1:, :]
        nxt[:, 1:] |= cur[:, :-1]
        nxt[:, :-1] |= cur[:, 1:]
        dist[nxt & ~cur] = k * sp
        cur = nxt
    dp = dist[ij[:, 0], ij[:, 1]]
    for r in [0.5e-3, 1e-3, 2e-3, 3e-3]:
        m = dp <= r
        inc_in = eB[m].sum() - eA[m].sum()
        print(f"within {r * 1e3:.1f} mm: {eA[m].sum():.4f} -> {eB[m].sum():.4f} J, increment {inc_in:.4f} J{rel(inc_in)}; "
              f"outside: increment {eB[~m].sum() - eA[~m].sum():.4f} J")


def slices(a):
    """Per slice of the crack path (by the particles' positions in FIRST,
    the undeformed body), the fracture energy within the strip |y - Y| <
    HALF at EARLY and LATE, in units of Gc * thickness * slice width."""
    names = ['position', 'particle_id', 'volume', 'body_id', 'fracture_energy_density']
    O, A, B = (read_body(f, a.body, names) for f in (a.first, a.early, a.late))
    x, y = O['position'][:, 0], O['position'][:, 1]
    vA, vB = (O['volume'], O['volume']) if a.reference else (A['volume'], B['volume'])
    eA = vA * A['fracture_energy_density']
    eB = vB * B['fracture_energy_density']
    unit = a.gc * a.thickness * a.width
    for x0 in np.arange(a.start, a.end - 1e-12, a.width):
        m = (x >= x0) & (x < x0 + a.width)
        strip = m & (np.abs(y - a.y) < a.half)
        print(f"x {x0 * 1e3:7.2f} to {(x0 + a.width) * 1e3:7.2f} mm: {eA[strip].sum() / unit:6.3f} -> {eB[strip].sum() / unit:6.3f}, "
              f"increment {(eB[strip].sum() - eA[strip].sum()) / unit:6.3f}; outside the strip {(eB[m & ~strip].sum() - eA[m & ~strip].sum()) / unit:6.3f}")


if __name__ == '__main__':
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest='cmd', required=True)
    q = sub.add_parser('profile')
    q.add_argument('snapshot')
    q.add_argument('--l0', type=float, required=True)
    q.add_argument('--y', type=float, required=True)
    q.add_argument('--at', type=lambda s: [float(v) for v in s.split(',')], required=True)
    q.add_argument('--half', type=float, default=0.008)
    q.add_argument('--thickness', type=float, default=1.0)
    q.add_argument('--gc', type=float, help='the body\'s Gc-bar (J/m2): also integrate the snapshot\'s fracture_energy_density')
    q = sub.add_parser('split')
    q.add_argument('early')
    q.add_argument('late')
    q.add_argument('--body', type=int, default=0)
    q.add_argument('--thickness', type=float, default=1.0)
    q.add_argument('--gc-area', type=float)
    q.add_argument('--reference', help='the undeformed snapshot: integrate over its volumes')
    q = sub.add_parser('slices')
    q.add_argument('first')
    q.add_argument('early')
    q.add_argument('late')
    q.add_argument('--body', type=int, default=0)
    q.add_argument('--thickness', type=float, default=1.0)
    q.add_argument('--gc', type=float, required=True)
    q.add_argument('--y', type=float, required=True)
    q.add_argument('--half', type=float, default=3e-3)
    q.add_argument('--start', type=float, required=True)
    q.add_argument('--end', type=float, required=True)
    q.add_argument('--width', type=float, default=1e-3)
    q.add_argument('--reference', action='store_true', help="integrate over FIRST's volumes")
    a = p.parse_args()
    {'profile': profile, 'split': split, 'slices': slices}[a.cmd](a)
