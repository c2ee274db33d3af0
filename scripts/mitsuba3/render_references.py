#!/usr/bin/env python3
"""Mitsuba 3 references for vitrum's Mitsuba import: `tests/data/mitsuba3/NAME.exr` for every
`tests/data/mitsuba3/NAME.xml`, the assets those files name, and `manifest.toml`, which
`tests/mitsuba_reference.rs` reads.

How to run (from the repository root; Mitsuba 3.9.1 made the committed files):

    pip install mitsuba numpy OpenEXR
    python3 scripts/mitsuba3/render_references.py            # assets, every case, Bitterli
    python3 scripts/mitsuba3/render_references.py cube envmap  # only these cases (manifest merged)
    python3 scripts/mitsuba3/render_references.py --assets    # only the assets

What it does:
- Writes the assets the XML files name: `texture.png` (8x8 sRGB, every texel different, so a
  mirrored or turned uv layout shows), `sky.exr` (32x16 latitude-longitude, a bright warm
  patch at one azimuth, different colours in each quadrant), `quad.obj` (a unit quad with
  texture coordinates), `quad.ply` (the same quad as a PLY with `u v`), `mesh.obj` (an octahedron with smooth vertex normals) and `mesh.ply`
  (the same octahedron, binary, flat), `bump.obj` (a smooth bump without vertex normals, a uv
  seam across its middle).
- Renders each XML with the `scalar_rgb` variant, `RENDERS` times, with the sampler seeds
  `SEEDS` and `SPP` samples per pixel each (the XML's `$spp` and `$seed` defaults overridden;
  the XMLs' own `spp` default is what vitrum renders). The stored image is the mean of those
  renders; its per-pixel variance (the squared standard error of that mean, from the spread of
  the renders) is stored beside it as the channels `variance.R/G/B` (half floats), the layout
  of vitrum's own EXRs, so the test can put the reference's noise into its tolerances.
- Two of Bitterli's scenes (`../shared/scenes/bitterli/`, Mitsuba 0.5 files, never copied into
  the repository) are rendered the same way: `cornell-box` at 64x64 as the file says (its tent
  filter, its one-sided diffuse walls) to `cornell-box.exr`, and `veach-mis` at 160x90 with a
  box filter (vitrum's) to `veach-mis.exr`, which `tests/standard_scenes.rs` compares with. Mitsuba
  3 refuses some of their legacy parameters (`strictNormals`, ldrfilm's `gamma`, `banner` and
  `fileFormat`, the conductor's `extEta`); the script strips them from the text in memory (each
  exact to drop: `bitterli_text`) and writes the film as an `hdrfilm` of the size above.
- `manifest.toml` records, per case, the settings (variant, spp, seeds, size) and the
  reference's mean and noise (the mean standard error of a pixel, and of the image mean).
"""

import argparse
import math
import os
import re
import struct
import sys
import time

import numpy as np

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
DATA = os.path.join(ROOT, "tests", "data", "mitsuba3")
SHARED = os.path.join(ROOT, "..", "shared", "scenes", "bitterli")
VARIANT = "scalar_rgb"
# Samples per pixel of each render and the sampler seeds of the renders averaged.
SPP = 4096
SEEDS = [1, 2, 3, 4]
RENDERS = len(SEEDS)
# The Bitterli scenes rendered: (width, height, tent filter replaced by a box).
BITTERLI = {"cornell-box": (64, 64, False), "veach-mis": (160, 90, True)}
# Parameters of those Mitsuba 0.5 files that Mitsuba 3 refuses, stripped in memory.
BITTERLI_STRIPPED = ["strictNormals", "gamma", "banner", "fileFormat", "extEta"]


# ---------------------------------------------------------------- assets
def write_texture(path):
    """8x8 sRGB texels, each different: red rises to the right, green upwards in the file's
    rows from the bottom, blue in a diagonal stripe; the top-left texel is white."""
    import mitsuba as mi

    img = np.zeros((8, 8, 3), dtype=np.uint8)
    for row in range(8):
        for col in range(8):
            img[row, col] = (30 + 30 * col, 30 + 30 * (7 - row), 220 if (row + col) % 4 == 0 else 40)
    img[0, 0] = (255, 255, 255)
    mi.Bitmap(img, pixel_format=mi.Bitmap.PixelFormat.RGB).write(path)


def write_envmap(path):
    """32x16 latitude-longitude radiance: a dim sky gradient, a different tint per quadrant of
    azimuth, and a bright warm patch (radiance 20) 3x2 texels wide just above the horizon."""
    import mitsuba as mi

    w, h = 32, 16
    img = np.zeros((h, w, 3), dtype=np.float32)
    tints = [(1.0, 0.3, 0.2), (0.2, 1.0, 0.3), (0.2, 0.4, 1.0), (0.9, 0.9, 0.2)]
    for row in range(h):
        for col in range(w):
            up = 1.0 - (row + 0.5) / h
            img[row, col] = np.array(tints[col * 4 // w], dtype=np.float32) * (0.2 + 0.8 * up)
    img[5:7, 9:12] = (20.0, 16.0, 10.0)
    mi.Bitmap(img).write(path)


def write_quad_obj(path):
    """The unit quad [-1, 1]^2 at z = 0 facing +z, uv (0, 0) at its bottom-left corner."""
    with open(path, "w") as f:
        f.write("# A unit quad facing +z with texture coordinates (render_references.py)\n")
        for x, y in [(-1, -1), (1, -1), (1, 1), (-1, 1)]:
            f.write(f"v {x} {y} 0\n")
        for u, v in [(0, 0), (1, 0), (1, 1), (0, 1)]:
            f.write(f"vt {u} {v}\n")
        f.write("vn 0 0 1\n")
        f.write("f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n")


def write_quad_ply(path):
    """The quad of write_quad_obj as an ASCII PLY with `u v` per vertex (Mitsuba's PLY loader
    keeps the file's v, its OBJ loader flips it)."""
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\ncomment A unit quad facing +z with texture coordinates "
                "(render_references.py)\nelement vertex 4\nproperty float x\nproperty float y\n"
                "property float z\nproperty float u\nproperty float v\nelement face 2\n"
                "property list uchar int vertex_indices\nend_header\n")
        for (x, y), (u, v) in zip([(-1, -1), (1, -1), (1, 1), (-1, 1)], [(0, 0), (1, 0), (1, 1), (0, 1)]):
            f.write(f"{x} {y} 0 {u} {v}\n")
        f.write("3 0 1 2\n3 0 2 3\n")


OCTAHEDRON_V = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
OCTAHEDRON_F = [
    (0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4),
    (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5),
]


def write_mesh_obj(path):
    """An octahedron with its vertex normals along the vertices (smooth shading)."""
    with open(path, "w") as f:
        f.write("# An octahedron with smooth vertex normals (render_references.py)\n")
        for v in OCTAHEDRON_V:
            f.write("v %d %d %d\n" % v)
        for v in OCTAHEDRON_V:
            f.write("vn %d %d %d\n" % v)
        for a, b, c in OCTAHEDRON_F:
            f.write(f"f {a+1}//{a+1} {b+1}//{b+1} {c+1}//{c+1}\n")


def write_mesh_ply(path):
    """The octahedron of write_mesh_obj as a binary little-endian PLY without normals (ply.xml
    renders it with face_normals: the OBJ's smooth normals meet a known difference at the
    silhouette, see tests/mitsuba_reference.rs; this one checks the placement alone)."""
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        "comment An octahedron without normals (render_references.py)\n"
        f"element vertex {len(OCTAHEDRON_V)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        f"element face {len(OCTAHEDRON_F)}\n"
        "property list uchar int vertex_indices\nend_header\n"
    )
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        for v in OCTAHEDRON_V:
            f.write(struct.pack("<3f", *v))
        for face in OCTAHEDRON_F:
            f.write(struct.pack("<B3i", 3, *face))


def write_bump_obj(path):
    """A smooth bump y = 0.35 exp(-2 (x^2 + z^2)) over [-1, 1]^2 as a 9x9 grid of vertices
    without vertex normals (Mitsuba computes them), with texture coordinates that jump at x = 0:
    the left half's u runs over [0, 0.5], the right half's over [0.6, 1.1], so the vertices on
    the seam are two vertices each and the smooth normals make a crease there."""
    n = 8
    coords = [-1 + 2 * i / n for i in range(n + 1)]
    with open(path, "w") as f:
        f.write("# A bump without vertex normals, a uv seam at x = 0 (render_references.py)\n")
        for z in coords:
            for x in coords:
                y = 0.35 * math.exp(-2 * (x * x + z * z))
                f.write(f"v {x:.6f} {y:.6f} {z:.6f}\n")
        # Texture coordinates: one set for the left half's columns, one for the right half's.
        for half in (0, 1):
            for z in coords:
                for x in coords:
                    f.write(f"vt {(x + 1) / 2 + 0.1 * half:.6f} {(z + 1) / 2:.6f}\n")
        per_half = (n + 1) * (n + 1)
        for j in range(n):
            for i in range(n):
                half = 0 if i < n // 2 else 1
                a, b = j * (n + 1) + i + 1, j * (n + 1) + i + 2
                c, d = b + n + 1, a + n + 1
                t = [k + half * per_half for k in (a, b, c, d)]
                # Counter-clockwise seen from +y.
                f.write(f"f {a}/{t[0]} {d}/{t[3]} {c}/{t[2]}\nf {a}/{t[0]} {c}/{t[2]} {b}/{t[1]}\n")


def write_assets():
    write_texture(os.path.join(DATA, "texture.png"))
    write_envmap(os.path.join(DATA, "sky.exr"))
    write_quad_obj(os.path.join(DATA, "quad.obj"))
    write_quad_ply(os.path.join(DATA, "quad.ply"))
    write_mesh_obj(os.path.join(DATA, "mesh.obj"))
    write_mesh_ply(os.path.join(DATA, "mesh.ply"))
    write_bump_obj(os.path.join(DATA, "bump.obj"))


# ---------------------------------------------------------------- renders
def render_mean_and_variance(load):
    """The mean of RENDERS renders (one per seed) and the variance of that mean per pixel."""
    import mitsuba as mi

    images = []
    for seed in SEEDS:
        scene = load(seed)
        img = np.array(mi.render(scene, spp=SPP, seed=seed), dtype=np.float64)[:, :, :3]
        images.append(img)
    stack = np.stack(images)
    mean = stack.mean(axis=0)
    variance = stack.var(axis=0, ddof=1) / RENDERS
    return mean, variance


def write_exr(path, mean, variance, rgb=np.float32):
    """R, G, B as `rgb` (float32, or half floats for the large Bitterli images, whose noise is
    far above a half's precision) and variance.R/G/B as half floats, ZIP-compressed."""
    import OpenEXR

    channels = {}
    for i, c in enumerate("RGB"):
        channels[c] = np.ascontiguousarray(mean[:, :, i].astype(rgb))
        channels["variance." + c] = np.ascontiguousarray(variance[:, :, i].astype(np.float16))
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as f:
        f.write(path)


def summary(name, mean, variance, seconds):
    h, w = mean.shape[:2]
    n = mean.size
    return {
        "name": name,
        "width": w,
        "height": h,
        "mean": float(mean.mean()),
        "pixel_std_error": float(np.sqrt(variance).mean()),
        "mean_std_error": float(math.sqrt(variance.sum()) / n),
        "seconds": round(seconds, 1),
    }


def render_case(name):
    import mitsuba as mi

    path = os.path.join(DATA, name + ".xml")
    start = time.time()
    mean, variance = render_mean_and_variance(lambda seed: mi.load_file(path, spp=SPP, seed=seed))
    write_exr(os.path.join(DATA, name + ".exr"), mean, variance)
    return summary(name, mean, variance, time.time() - start)


def bitterli_text(name):
    """A Bitterli scene's text as Mitsuba 3 renders it here: the legacy parameters it refuses
    stripped (BITTERLI_STRIPPED; each is exact to drop: strictNormals changes no image of these
    scenes, gamma, banner and the PNG filename are ldrfilm's output options, fileFormat png is not
    hdrfilm's, and
    every extEta is 1, the default), the film an hdrfilm of BITTERLI[name]'s size, and, where
    BITTERLI says so, its tent filter replaced by a box."""
    width, height, box = BITTERLI[name]
    text = open(os.path.join(SHARED, name, "scene.xml")).read()
    for param in BITTERLI_STRIPPED:
        text = re.sub(r'<\w+ name="%s" value="[^"]*"\s*/>' % param, "", text)
    # ldrfilm's output file name (a PNG) is no parameter of hdrfilm.
    text = re.sub(r'<string name="filename" value="[^"]*\.png"\s*/>', "", text)
    text = text.replace('type="ldrfilm"', 'type="hdrfilm"')
    text = re.sub(r'(<integer name="width" value=")\d+', r"\g<1>%d" % width, text)
    text = re.sub(r'(<integer name="height" value=")\d+', r"\g<1>%d" % height, text)
    if box:
        text = text.replace('<rfilter type="tent" />', '<rfilter type="box" />')
    return text


def render_bitterli(name):
    import mitsuba as mi

    text = bitterli_text(name)
    folder = os.path.join(SHARED, name)
    start = time.time()

    def load(seed):
        mi.file_resolver().prepend(folder)
        return mi.load_string(text)

    mean, variance = render_mean_and_variance(load)
    write_exr(os.path.join(DATA, name + ".exr"), mean, variance, rgb=np.float16)
    return summary(name, mean, variance, time.time() - start)


# ---------------------------------------------------------------- manifest
def read_manifest(path):
    """The cases of an existing manifest, as dicts (the script's own simple layout)."""
    cases, current = {}, None
    if not os.path.exists(path):
        return cases
    for line in open(path):
        m = re.match(r"^\[cases\.\"?([\w.-]+)\"?\]", line)
        if m:
            current = cases.setdefault(m.group(1), {"name": m.group(1)})
            continue
        m = re.match(r"^(\w+) = (.*)$", line.strip())
        if m and current is not None:
            key, value = m.groups()
            current[key] = float(value) if "." in value or "e" in value else int(value)
    return cases


def write_manifest(cases):
    import mitsuba as mi

    lines = [
        "# Written by scripts/mitsuba3/render_references.py: do not edit by hand.",
        "# Each case NAME is NAME.xml rendered by Mitsuba 3 `renders` times (sampler seeds `seeds`,",
        "# `spp` samples per pixel each); NAME.exr holds the mean of those renders (R, G, B) and the",
        "# variance of that mean per pixel (variance.R/G/B). `mean` is the image mean over pixels and",
        "# channels, `pixel_std_error` the mean standard error of a pixel, `mean_std_error` the",
        "# standard error of the image mean. vitrum renders NAME.xml as it is (its `spp` default).",
        f'mitsuba = "{mi.__version__}"',
        f'variant = "{VARIANT}"',
        f"spp = {SPP}",
        f"seeds = {SEEDS}",
        f"renders = {RENDERS}",
        "",
    ]
    for name in sorted(cases):
        c = cases[name]
        lines.append(f'[cases."{name}"]')
        for key in ["width", "height", "mean", "pixel_std_error", "mean_std_error", "seconds"]:
            v = c[key]
            lines.append(f"{key} = {v:.6g}" if isinstance(v, float) else f"{key} = {v}")
        lines.append("")
    with open(os.path.join(DATA, "manifest.toml"), "w") as f:
        f.write("\n".join(lines))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("cases", nargs="*", help="case names (default: every XML, and the Bitterli scenes)")
    parser.add_argument("--assets", action="store_true", help="write the assets only")
    args = parser.parse_args()
    import mitsuba as mi

    mi.set_variant(VARIANT)
    write_assets()
    if args.assets:
        return
    every = sorted(f[:-4] for f in os.listdir(DATA) if f.endswith(".xml"))
    names = args.cases or every + sorted(BITTERLI)
    cases = read_manifest(os.path.join(DATA, "manifest.toml"))
    for name in names:
        if name in BITTERLI:
            if not os.path.exists(os.path.join(SHARED, name)):
                print(f"{name}: {SHARED}/{name} not found, skipped", file=sys.stderr)
                continue
            c = render_bitterli(name)
        elif name in every:
            c = render_case(name)
        else:
            sys.exit(f"no case {name}: the cases are {', '.join(every + sorted(BITTERLI))}")
        cases[name] = c
        print(f"{name}: mean {c['mean']:.5g} ± {c['mean_std_error']:.2g}, {c['seconds']} s", flush=True)
        write_manifest(cases)


if __name__ == "__main__":
    main()
