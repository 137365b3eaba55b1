#!/usr/bin/env python3
"""E2 (docs/eigen.md, "E2: the authors' model, one change at a time"):
writes variants of scenes/eigen_e2_drop_weight.toml that each change one
thing toward the authors' own model, as their later paper draws it
(`Figure-impact-test.*` and `Figure-impact-test-Damage-vs-Stress-*.png` in
the public repository migmolper/Fracture-MPM-Eigensoftening):

  nose       the hammer 29 mm wide with a semicircular nose of radius
             14.5 mm (read off the authors' snapshot: beam 474 px for
             420 mm, hammer 32-33 px wide, the nose a half circle), the
             same 120.6 kg over the thickness
  wide       the hammer 29 mm wide with the scene's flat face (separates
             the width from the nose)
  cylinders  the supports as the authors' figure draws them: a half disk
             of radius 10 mm on a block (the scene: 10 mm flat blocks)
  notch10    the notch 10 mm wide, as drawn (the scene: 5 mm)
  fine       cells of 1.25 mm (the authors' finest spacing is 1.2 mm at
             mid-span; the scene: 2.5 mm)
  authors    all of the above (nose, cylinders, notch10, fine)
  authors_lme  the same with LME, gamma = 3.5: the authors' kernel is LME
             with gamma = 1.8 on a six-node support, which this code's
             four-node support refuses (gamma >= 3.45); 3.5 is the
             widest it takes
  padE       the scene's hammer with its lowest 5 mm a pad of steel's
             density and Young's modulus E GPa (pad31, pad10, pad3, pad1):
             a contact more compliant than the scene's steel face on
             elastic concrete, as the test's may have been (its tup and
             load cell, and concrete crushing under it, which the model
             has not: it fails in tension only)

Usage: python3 docs/scripts/eigen_e2_variants.py OUTDIR NAME [NAME ...]
writes OUTDIR/NAME.toml for each name."""
import math
import sys

SCENE = "scenes/eigen_e2_drop_weight.toml"
MASS, THICKNESS = 120.6, 0.1
HAMMER = """[[bodies]]
name = "hammer"
shape = { type = "box", min = [-0.01, 0.1], max = [0.01, 0.28] }
material = "hammer"
"""
SUPPORTS = [
    ('shape = { type = "box", min = [-0.155, -0.0125], max = [-0.145, 0.0] }', -0.15),
    ('shape = { type = "box", min = [0.145, -0.0125], max = [0.155, 0.0] }', 0.15),
]
NOTCH = 'holes = [{ type = "box", min = [-0.0025, 0.0], max = [0.0025, 0.05] }]'


def replace(s, old, new):
    assert old in s, old
    return s.replace(old, new)


def polygon(vertices):
    return "[" + ", ".join(f"[{x:.7f}, {y:.7f}]" for x, y in vertices) + "]"


def hammer(s, width, nose):
    """The hammer from y = 0.1 to 0.28 and `width` wide, with a half
    circle of the full width at its lower end if `nose`; the density
    gives it 120.6 kg over the thickness."""
    r, top, bottom = width / 2, 0.28, 0.1
    if nose:
        # the rod's top, then the arc from the left side down round to the
        # right side (a polygon may run either way)
        v = [(r, top), (-r, top)] + [(-r * math.cos(a), bottom + r - r * math.sin(a))
                                     for a in (math.pi * k / 48 for k in range(49))]
        area = width * (top - bottom - r) + math.pi * r * r / 2
        shape = f"shape = {{ type = \"polygon\", vertices = {polygon(v)} }}"
    else:
        area = width * (top - bottom)
        shape = f"shape = {{ type = \"box\", min = [{-r}, {bottom}], max = [{r}, {top}] }}"
    s = replace(s, HAMMER, HAMMER.replace(HAMMER.splitlines()[2], shape))
    return replace(s, "density = 335000.0", f"density = {MASS / (area * THICKNESS):.1f}")


def pad(s, modulus):
    """The hammer's lowest 5 mm a body of its own, of steel's density and
    Young's modulus `modulus`, moving with the hammer; the rest of the
    hammer keeps the total at 120.6 kg."""
    t, width, rho = 0.005, 0.02, 7850.0
    pad_mass = rho * width * t * THICKNESS
    shape = HAMMER.splitlines()[2]
    body = HAMMER.replace(shape, shape.replace("0.1]", f"{0.1 + t:.3f}]"))
    body += f"""velocity = [0.0, -2.64]
particles_per_cell = 4

[[bodies]]
name = "pad"
shape = {{ type = "box", min = [-0.01, 0.1], max = [0.01, {0.1 + t:.3f}] }}
material = "pad"
"""
    s = replace(s, HAMMER + "velocity = [0.0, -2.64]\n", body + "velocity = [0.0, -2.64]\n")
    density = (MASS - pad_mass) / (width * (0.28 - 0.1 - t) * THICKNESS)
    s = replace(s, "density = 335000.0", f"density = {density:.1f}")
    return replace(s, "[materials.hammer]", f"""[materials.pad]
model = "linear_elastic"
density = {rho}
youngs_modulus = {modulus:.4g}
poissons_ratio = 0.3

[materials.hammer]""")


def cylinders(s):
    """Each support a half disk of radius 10 mm (top touching the beam at
    y = 0) on a block down to the grid's floor at y = -12.5 mm."""
    r = 0.01
    for old, x in SUPPORTS:
        v = [(x + r, -0.0125), (x + r, -r)] + [
            (x + r * math.cos(a), -r + r * math.sin(a)) for a in (math.pi * k / 32 for k in range(1, 32))
        ] + [(x - r, -r), (x - r, -0.0125)]
        s = replace(s, old, f"shape = {{ type = \"polygon\", vertices = {polygon(v)} }}")
    return s


def variant(name):
    s = open(SCENE).read()
    authors = name in ("authors", "authors_lme")
    if name == "nose" or authors:
        s = hammer(s, 0.029, True)
    if name == "wide":
        s = hammer(s, 0.029, False)
    if name == "cylinders" or authors:
        s = cylinders(s)
    if name == "notch10" or authors:
        s = replace(s, NOTCH, NOTCH.replace("0.0025", "0.005"))
    if name == "fine" or authors:
        s = replace(s, "cell_size = 0.0025", "cell_size = 0.00125")
        # eps = 2h, as in the scene
        s = replace(s, "epsilon = 0.005", "epsilon = 0.0025")
    if name.startswith("pad"):
        s = pad(s, float(name[3:]) * 1e9)
    if name == "authors_lme":
        s = replace(s, 'shape_function = "linear"', 'shape_function = "lme"\nlme_gamma = 3.5')
    return s


if __name__ == "__main__":
    out = sys.argv[1]
    for name in sys.argv[2:]:
        open(f"{out}/{name}.toml", "w").write(variant(name))
