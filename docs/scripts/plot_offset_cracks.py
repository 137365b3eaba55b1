#!/usr/bin/env python3
"""Measure and plot runs of two offset edge cracks (Nairn & Aimene 3.6, C5).

    python3 docs/scripts/plot_offset_cracks.py LABEL=RUN_DIR [LABEL=RUN_DIR ...]
        [--rate 3.75] [--inside 0.005] [--figures docs/figures]

Each RUN_DIR is the --out of `cleave run` on a scene like
scenes/cramp_offset_cracks.toml (two cracks, crack 0 from the left edge,
crack 1 from the right, each 5 mm into a 50 mm wide plate). From its
series.csv and its last cracks_NNNN.vtp it prints, per run:

- initiation: the first row where either crack is 0.05 mm longer than at
  t = 0, its time and strain (strain = rate × t: the grips move at a
  constant speed, slowed by under 0.5 % in these runs);
- g(t) = 50 mm − ℓ0 − ℓ1, ℓ the path length inside the plate (the
  series' crack length minus the part drawn outside the edge);
- the peak crack speed, each crack, over 2 mm of path;
- when the tips pass each other (tip 0's x beyond tip 1's) and the
  last growth of each;
- the final crack planes (points, mm).

Needs matplotlib for the figures (without it, only the numbers):
cramp_offset_g.png (g against time, every run) and
cramp_offset_paths.png (the final crack planes, every run).
"""
import csv
import os
import re
import struct
import sys

WIDTH = 0.05
RATE = [3.75]


def read_series(path):
    rows = list(csv.DictReader(open(path)))
    cols = {k: [float(r[k]) for r in rows] for k in rows[0]}
    return cols


def read_cracks(path):
    """Lines of a cracks_NNNN.vtp (raw appended data, UInt64 headers):
    a list of dicts with crack, surface (0 plane, 1 above, 2 below) and
    points [(x, y)]."""
    data = open(path, 'rb').read()
    head, _, rest = data.partition(b'<AppendedData encoding="raw">')
    raw = rest[rest.index(b'_') + 1:]
    h = head.decode()
    nlines = int(re.search(r'NumberOfLines="(\d+)"', h).group(1))
    arrays = {}
    for m in re.finditer(r'<DataArray type="(\w+)" Name="(\w+)" NumberOfComponents="(\d+)" '
                         r'format="appended" offset="(\d+)"', h):
        typ, name, off = m.group(1), m.group(2), int(m.group(4))
        nbytes = struct.unpack_from('<Q', raw, off)[0]
        fmt = {'UInt32': 'I', 'Float64': 'd', 'Int64': 'q'}[typ]
        n = nbytes // struct.calcsize(fmt)
        arrays[name] = struct.unpack_from('<%d%s' % (n, fmt), raw, off + 8)
    pos, conn, offs = arrays['position'], arrays['connectivity'], arrays['offsets']
    lines, start = [], 0
    for i in range(nlines):
        ids = conn[start:offs[i]]
        start = offs[i]
        lines.append({'crack': arrays['crack'][i], 'surface': arrays['surface'][i],
                      'points': [(pos[3 * k], pos[3 * k + 1]) for k in ids]})
    return lines


def last_cracks(run):
    files = sorted(f for f in os.listdir(run) if re.fullmatch(r'cracks_\d{4}\.vtp', f))
    return os.path.join(run, files[-1]), read_cracks(os.path.join(run, files[-1]))


def peak_speed(t, l, window=0.002):
    """The largest window / (time to grow `window` more path), m/s, and
    when that stretch began."""
    best, when, j = 0.0, None, 0
    for i in range(len(t)):
        j = max(j, i)
        while j < len(t) and l[j] - l[i] < window:
            j += 1
        if j == len(t):
            break
        v = (l[j] - l[i]) / (t[j] - t[i])
        if v > best:
            best, when = v, t[i]
    return best, when


def measure(label, run, rate, inside):
    s = read_series(os.path.join(run, 'series.csv'))
    t = s['time']
    ell = []
    for c in (0, 1):
        L = s['crack%d_length' % c]
        ell.append([x - (L[0] - inside) for x in L])
    g = [WIDTH - a - b for a, b in zip(*ell)]
    out = {'label': label, 'run': run, 't': t, 'g': g, 'ell': ell}
    grown = [i for i in range(len(t)) if ell[0][i] > inside + 5e-5 or ell[1][i] > inside + 5e-5]
    i0 = grown[0] if grown else None
    out['t_init'] = t[i0] if grown else None
    out['eps_init'] = rate * t[i0] if grown else None
    out['J_before'] = [s['crack%d_end_J' % c][i0 - 1] for c in (0, 1)] if grown else None
    out['speed'] = [peak_speed(t, ell[c]) for c in (0, 1)]
    # g's steepest fall over 4 mm of g (both cracks' 2 mm), m/s
    out['g_rate'] = peak_speed(t, [-x for x in g], 0.004)
    fast = [i for i in range(len(t)) if out['t_init'] is not None and t[i] >= out['t_init']]
    # the mean closing speed from initiation until g reaches 0
    zero = next((i for i in fast if g[i] <= 0.0), None)
    out['t_g0'] = t[zero] if zero is not None else None
    x0, x1 = s['crack0_end_x'], s['crack1_end_x']
    passed = [i for i in range(len(t)) if x0[i] > x1[i]]
    out['t_pass'] = t[passed[0]] if passed else None
    out['last_growth'] = []
    for c in (0, 1):
        L = ell[c]
        k = max((i for i in range(1, len(t)) if L[i] > L[i - 1] + 1e-5), default=None)
        out['last_growth'].append(t[k] if k is not None else None)
    out['g_end'] = g[-1]
    out['g_min'] = min(g)
    out['t_end'] = t[-1]
    out['eps_end'] = rate * t[-1]
    out['tips_end'] = [(s['crack%d_end_x' % c][-1], s['crack%d_end_y' % c][-1]) for c in (0, 1)]
    path, lines = last_cracks(run)
    out['vtp'] = path
    out['planes'] = {l['crack']: l['points'] for l in lines if l['surface'] == 0}
    # each final tip's distance to the other crack's plane
    out['gap'] = [dist_to_polyline(out['planes'][c][-1], out['planes'][1 - c]) for c in (0, 1)]
    return out


def dist_to_polyline(p, line):
    best = float('inf')
    for (ax, ay), (bx, by) in zip(line, line[1:]):
        dx, dy = bx - ax, by - ay
        L2 = dx * dx + dy * dy
        u = 0.0 if L2 == 0 else max(0.0, min(1.0, ((p[0] - ax) * dx + (p[1] - ay) * dy) / L2))
        qx, qy = ax + u * dx - p[0], ay + u * dy - p[1]
        best = min(best, (qx * qx + qy * qy) ** 0.5)
    return best


def report(m):
    mm = 1e3
    print('== %s (%s)' % (m['label'], m['run']))
    if m['t_init'] is None:
        print('  no growth')
    else:
        print('  initiation: t = %.3f ms, strain = %.3f %% (J on the row before: %.1f, %.1f J/m²)'
              % (m['t_init'] * 1e3, m['eps_init'] * 100, *m['J_before']))
    for c in (0, 1):
        v, when = m['speed'][c]
        print('  crack %d: peak speed over 2 mm of path %.0f m/s (from t = %.4f ms), last growth t = %s ms'
              % (c, v, (when or 0) * 1e3,
                 '%.3f' % (m['last_growth'][c] * 1e3) if m['last_growth'][c] else '-'))
    print('  g: steepest fall over 4 mm of g %.0f m/s (both cracks together), g = 0 at t = %s ms'
          % (m['g_rate'][0], '%.4f' % (m['t_g0'] * 1e3) if m['t_g0'] else '-'))
    print('  tips pass: %s' % ('t = %.4f ms' % (m['t_pass'] * 1e3) if m['t_pass'] else 'never'))
    print('  end: t = %.3f ms (strain %.3f %%), g = %.2f mm (min %.2f), tips (%.2f, %.2f) and (%.2f, %.2f) mm'
          % (m['t_end'] * 1e3, m['eps_end'] * 100, m['g_end'] * mm, m['g_min'] * mm,
             m['tips_end'][0][0] * mm, m['tips_end'][0][1] * mm,
             m['tips_end'][1][0] * mm, m['tips_end'][1][1] * mm))
    print('  final tips to the other crack: %.2f mm (tip 0), %.2f mm (tip 1)' % (m['gap'][0] * mm, m['gap'][1] * mm))
    print('  g(t), mm, every 0.05 ms from initiation:')
    t, g = m['t'], m['g']
    if m['t_init'] is not None:
        marks, k = [], 0
        tm = m['t_init']
        while tm <= t[-1] + 1e-12:
            while k < len(t) - 1 and t[k] < tm - 1e-12:
                k += 1
            marks.append('%.2f:%.1f' % (t[k] * 1e3, g[k] * mm))
            tm += 5e-5
        print('   ', ' '.join(marks))
    print('  final crack planes (%s), mm:' % os.path.basename(m['vtp']))
    for c, p in sorted(m['planes'].items()):
        print('   crack %d (%d points): %s' % (c, len(p), ' '.join('(%.2f,%.2f)' % (x * mm, y * mm) for x, y in p)))


def plot(ms, figdir):
    try:
        import matplotlib
        matplotlib.use('Agg')
        import matplotlib.pyplot as plt
    except ImportError:
        print('(no matplotlib: no figures)')
        return
    os.makedirs(figdir, exist_ok=True)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, (lo, hi) in zip(axes, ((0.0, None), (0.35, 0.8))):
        for m in ms:
            ax.plot([x * 1e3 for x in m['t']], [x * 1e3 for x in m['g']], label=m['label'])
        ax.axhline(0, color='k', lw=0.5)
        ax.set_xlim(lo, hi)
        ax.set_xlabel('time, ms (strain = %g/s × t)' % RATE[0])
        ax.set_ylabel('g = 50 − ℓ₁ − ℓ₂, mm')
    axes[0].set_title('g against time')
    axes[1].set_title('the fast run and the turn (0.35–0.8 ms)')
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    p = os.path.join(figdir, 'cramp_offset_g.png')
    fig.savefig(p, dpi=120)
    print('wrote', p)
    n = len(ms)
    cols = min(n, 2)
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(6.0 * cols, 2.9 * rows), squeeze=False)
    for ax in axes.flat[n:]:
        ax.axis('off')
    for ax, m in zip(axes.flat, ms):
        ax.axvline(0, color='0.6', lw=0.8)
        ax.axvline(50, color='0.6', lw=0.8)
        for c, p in sorted(m['planes'].items()):
            ax.plot([x * 1e3 for x, _ in p], [y * 1e3 for _, y in p], '.-', ms=2, lw=1,
                    color=('C0', 'C3')[c % 2])
        ax.set_xlim(-1, 51)
        ax.set_ylim(42, 58)
        ax.set_aspect('equal')
        ax.set_title('%s (g = %.1f mm)' % (m['label'], m['g_end'] * 1e3), fontsize=9)
        ax.set_xlabel('x, mm')
        ax.set_ylabel('y, mm')
    fig.suptitle('Final crack planes (crack 0 blue, crack 1 red; y 42–58 mm of the 100 mm plate)', fontsize=10)
    fig.tight_layout()
    p = os.path.join(figdir, 'cramp_offset_paths.png')
    fig.savefig(p, dpi=120)
    print('wrote', p)


def main(argv):
    rate, inside, figdir, runs = 3.75, 0.005, None, []
    it = iter(argv)
    for a in it:
        if a == '--rate':
            rate = float(next(it))
        elif a == '--inside':
            inside = float(next(it))
        elif a == '--figures':
            figdir = next(it)
        else:
            label, _, run = a.partition('=')
            runs.append((label, run or label))
    if not runs:
        sys.exit(__doc__)
    RATE[0] = rate
    ms = [measure(label, run, rate, inside) for label, run in runs]
    for m in ms:
        report(m)
    if figdir:
        plot(ms, figdir)


if __name__ == '__main__':
    main(sys.argv[1:])
