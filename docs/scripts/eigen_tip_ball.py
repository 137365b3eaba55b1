#!/usr/bin/env python3
"""Eigenerosion's G_p = 2*eps*mean energy density (C_eps = 2 eps rho) at a
crack tip, over Griffith's G, in the mode I Williams field (docs/eigen.md,
"Eigenerosion's C_eps").

The energy density is W = K^2/(2 pi r E) w(theta); the ball of radius eps
about the tip holds K^2 eps A / E with A = (1/2pi) int w dtheta, so
G_p = 2 eps * that / (pi eps^2) = 2 K^2 A / (pi E), against
G = K^2 (1 - nu^2)/E (plane strain) or K^2/E (plane stress).
Usage: python3 docs/scripts/eigen_tip_ball.py [nu]
"""
import math
import sys

nu = float(sys.argv[1]) if len(sys.argv) > 1 else 0.333
n = 200_000
for plane in ("plane_strain", "plane_stress"):
    a = 0.0
    for i in range(n):
        t = -math.pi + (i + 0.5) * 2 * math.pi / n
        c, s = math.cos(t / 2), math.sin(t / 2)
        s3, c3 = math.sin(3 * t / 2), math.cos(3 * t / 2)
        sx, sy, sxy = c * (1 - s * s3), c * (1 + s * s3), c * s * c3
        sz = nu * (sx + sy) if plane == "plane_strain" else 0.0
        # E * W / (K^2/(2 pi r)): the angular part of the energy density
        w = 0.5 * (sx * sx + sy * sy + sz * sz - 2 * nu * (sx * sy + sy * sz + sz * sx)) + (1 + nu) * sxy * sxy
        a += w / n
    griffith = 1 - nu * nu if plane == "plane_strain" else 1.0
    print(f"{plane}, nu = {nu}: A = {a:.4f}, G_p / G = {2 * a / (math.pi * griffith):.4f}")
