#!/usr/bin/env python3
"""Write scenes/meshes/smooth-sphere.obj: a UV sphere of radius 1 at the origin with vertex normals (vn, the
normalised position: smooth shading) and texture coordinates (vt: u = longitude / 360°,
v = colatitude / 180°, with a seam column and pole texels of their own, so that faces index
positions and texture coordinates separately).

    python3 scripts/meshes/make_smooth_sphere.py [RINGS]   (default 16: 960 triangles)
"""
import math
import sys

rings = int(sys.argv[1]) if len(sys.argv) > 1 else 16
segments = 2 * rings
out = [
    f"# UV sphere, radius 1, centred at the origin: {rings} rings x {segments} segments,",
    f"# {4 * rings * rings - 4 * rings} triangles wound outwards. vn = the normalised position (smooth shading);",
    "# vt = (longitude / 360, colatitude / 180). Written by scripts/meshes/make_smooth_sphere.py.",
]
# Positions and normals: the poles once, the rings shared around the seam.
out.append("v 0 1 0")
for i in range(1, rings):
    theta = math.pi * i / rings
    for j in range(segments):
        phi = 2 * math.pi * j / segments
        out.append(f"v {math.sin(theta) * math.cos(phi):.7f} {math.cos(theta):.7f} {math.sin(theta) * math.sin(phi):.7f}")
out.append("v 0 -1 0")
out.append("vn 0 1 0")
for i in range(1, rings):
    theta = math.pi * i / rings
    for j in range(segments):
        phi = 2 * math.pi * j / segments
        out.append(f"vn {math.sin(theta) * math.cos(phi):.7f} {math.cos(theta):.7f} {math.sin(theta) * math.sin(phi):.7f}")
out.append("vn 0 -1 0")
# Texture coordinates: a full (rings + 1) x (segments + 1) grid (the seam column twice).
for i in range(rings + 1):
    for j in range(segments + 1):
        out.append(f"vt {j / segments:.7f} {i / rings:.7f}")

south = 2 + (rings - 1) * segments


def pos(i, j):
    """1-based index of the position on ring i (0 = north pole, rings = south pole), column j."""
    if i == 0:
        return 1
    if i == rings:
        return south
    return 2 + (i - 1) * segments + j % segments


def tex(i, j):
    return 1 + i * (segments + 1) + j


def corner(i, j):
    p, t = pos(i, j), tex(i, j)
    return f"{p}/{t}/{p}"


for j in range(segments):
    out.append(f"f {corner(0, j)} {corner(1, j + 1)} {corner(1, j)}")
    for i in range(1, rings - 1):
        a, b, c, d = corner(i, j), corner(i, j + 1), corner(i + 1, j), corner(i + 1, j + 1)
        out.append(f"f {a} {b} {c}")
        out.append(f"f {b} {d} {c}")
    out.append(f"f {corner(rings, j)} {corner(rings - 1, j)} {corner(rings - 1, j + 1)}")
import os

target = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scenes", "meshes", "smooth-sphere.obj")
with open(target, "w") as f:
    f.write("\n".join(out) + "\n")
