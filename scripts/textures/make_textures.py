#!/usr/bin/env python3
"""The textures of scenes/textured-box.toml and the sky of scenes/glass-in-sky.toml, generated
procedurally and deterministically (no randomness but a fixed integer hash), so that the
committed files can be rebuilt byte for byte:

    python3 scripts/textures/make_textures.py        # writes scenes/textures/*.png, *.exr

- tiles.png (256x256): 4 x 4 floor tiles, two warm stone colours in a checker, grey grout lines,
  a faint mottle per tile. With `scale = [2, 2]` on the 2 m floor the tiles are 25 cm.
- plaster.png (256x256): off-white plaster with a fine mottle and, a quarter of the way up, a
  horizontal colour band in the faculty's spirit (a deep blue stripe between two thin light ones).
- poster.png (256x320): a framed poster: a dark frame, a pale mount and a picture of a glass
  sphere's caustic (concentric rings brightening to a focus) over a gradient.
- uv-grid.png (256x256): a test image for texture coordinates (scenes/figures/texture-coordinates.toml):
  8 x 8 cells whose red grows with u (left to right) and green with v (bottom to top), white grid
  lines, a black corner mark at uv (0, 0) (bottom left) and a blue one at (1, 1) (top right).
- sky.exr (256x128, half float, linear): an equirectangular sky in vitrum's (Mitsuba's) layout,
  +Y up: a gradient from a blue zenith to a pale horizon, a dim ground below the horizon, and a
  sun disk of angular radius 2.5 degrees at elevation 35 degrees, towards (-0.42, 0, -0.91) in
  azimuth (behind the glass bodies, to the left), radiance 3000.
"""

import math
import os
import sys

sys.path.insert(0, os.path.dirname(__file__))
from images import write_exr, write_png  # noqa: E402

OUT = os.path.join(os.path.dirname(__file__), "..", "..", "scenes", "textures")


def hash01(*xs):
    """A deterministic value in [0, 1) from integers (a 32-bit integer hash)."""
    h = 0x811C9DC5
    for x in xs:
        h ^= x & 0xFFFFFFFF
        h = (h * 0x01000193) & 0xFFFFFFFF
        h ^= h >> 15
        h = (h * 0x2C1B3C6D) & 0xFFFFFFFF
        h ^= h >> 12
    return h / 2**32


def tiles(x, y):
    n = 64  # texels per tile
    tx, ty, fx, fy = x // n, y // n, x % n, y % n
    if fx < 2 or fy < 2:
        return (120, 118, 112)  # grout
    base = (196, 170, 132) if (tx + ty) % 2 == 0 else (150, 112, 82)
    mottle = 0.92 + 0.08 * hash01(x // 4, y // 4, 7) + 0.04 * hash01(tx, ty, 3)
    return tuple(c * mottle for c in base)


def plaster(x, y):
    # y = 0 is the top row: the band a quarter of the way up is near y = 0.75 * 256.
    band = 192
    if band - 14 <= y < band - 10 or band + 10 <= y < band + 14:
        return (226, 222, 210)
    if band - 10 <= y < band + 10:
        return (40, 52, 132)
    mottle = 0.94 + 0.04 * hash01(x // 2, y // 2, 11) + 0.02 * hash01(x // 16, y // 16, 5)
    return tuple(c * mottle for c in (232, 228, 218))


def poster(x, y):
    w, h = 256, 320
    frame, mount = 12, 28
    if x < frame or y < frame or x >= w - frame or y >= h - frame:
        return (58, 40, 28)
    if x < mount or y < mount or x >= w - mount or y >= h - mount:
        return (236, 232, 222)
    # The picture: a gradient with a caustic's rings around a focus.
    u, v = (x - mount) / (w - 2 * mount), (y - mount) / (h - 2 * mount)
    r = math.hypot(u - 0.5, v - 0.62)
    rings = 0.5 + 0.5 * math.cos(r * 60.0)
    focus = math.exp(-(r / 0.06) ** 2)
    base = (30 + 50 * v, 60 + 40 * v, 110 + 60 * (1 - v))
    glow = rings * math.exp(-r * 6.0) * 150 + focus * 200
    return (base[0] + glow, base[1] + glow * 0.9, base[2] + glow * 0.6)


def uv_grid(x, y, size=256):
    u, v = (x + 0.5) / size, 1.0 - (y + 0.5) / size  # v up from the bottom row
    if u < 0.12 and v < 0.12:
        return (0, 0, 0)
    if u > 0.88 and v > 0.88:
        return (30, 60, 255)
    if x % 32 in (0, 31) or y % 32 in (0, 31):
        return (255, 255, 255)
    cu, cv = int(u * 8) / 7, int(v * 8) / 7
    return (40 + 200 * cu, 40 + 200 * cv, 60)


SUN = (math.radians(35.0), (-0.42, -0.91))  # elevation; azimuth direction (x, z)
SUN_RADIUS = math.radians(2.5)


def sky(x, y, width=256, height=128):
    # The direction of the texel centre in the equirectangular layout (u from atan2(x, -z)).
    phi = 2.0 * math.pi * (x + 0.5) / width
    theta = math.pi * (y + 0.5) / height
    d = (math.sin(phi) * math.sin(theta), math.cos(theta), -math.cos(phi) * math.sin(theta))
    elevation, (sx, sz) = SUN
    norm = math.hypot(sx, sz)
    s = (math.cos(elevation) * sx / norm, math.sin(elevation), math.cos(elevation) * sz / norm)
    cos_to_sun = sum(a * b for a, b in zip(d, s))
    if cos_to_sun >= math.cos(SUN_RADIUS):
        return (3000.0, 2850.0, 2600.0)
    if d[1] < 0.0:
        return (0.18, 0.16, 0.14)  # the ground below the horizon
    t = d[1]
    horizon, zenith = (1.1, 1.15, 1.2), (0.25, 0.45, 0.95)
    glow = 0.6 * max(0.0, cos_to_sun) ** 8  # a brighter sky around the sun
    return tuple(h + (z - h) * t ** 0.5 + glow for h, z in zip(horizon, zenith))


def main():
    os.makedirs(OUT, exist_ok=True)
    write_png(os.path.join(OUT, "tiles.png"), 256, 256, tiles)
    write_png(os.path.join(OUT, "plaster.png"), 256, 256, plaster)
    write_png(os.path.join(OUT, "poster.png"), 256, 320, poster)
    write_png(os.path.join(OUT, "uv-grid.png"), 256, 256, uv_grid)
    write_exr(os.path.join(OUT, "sky.exr"), 256, 128, sky)
    for name in sorted(os.listdir(OUT)):
        print(name, os.path.getsize(os.path.join(OUT, name)), "bytes")


if __name__ == "__main__":
    main()
