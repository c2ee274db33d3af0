#!/usr/bin/env python3
"""Render one scene with vitrum and with Mitsuba 3 at the same settings; print relMSE and times.

Not part of CI: it needs Mitsuba 3 (set-up and the conventions of the comparison:
docs/mitsuba-export.md, "Installing Mitsuba" and "Checking vitrum against Mitsuba"):

    python3 -m venv "$HOME/mi" && "$HOME/mi/bin/pip" install mitsuba numpy OpenEXR
    "$HOME/mi/bin/python" scripts/reference_check.py scenes/soft-shadows.toml 1024 400 16

Arguments: SCENE SPP RESOLUTION MAX_DEPTH, with RESOLUTION as `N` (N×N) or `WxH` and MAX_DEPTH in
vitrum's convention (bounces; the exported XML says Mitsuba's max_depth = MAX_DEPTH + 1 segments).

Steps: `vitrum export` writes the scene as Mitsuba 3 XML; Mitsuba renders it (`llvm_ad_rgb` when it
works here, otherwise `scalar_rgb`; `--variant` chooses); `vitrum render -i path` renders the same
scene with the same samples, resolution and depth; both images are written to the output folder
and compared with Mitsuba as the reference:

    relMSE = mean((x - r)^2 / (r^2 + 0.01))   over pixels and channels (README.md, "Metrics";
                                              src/metrics.rs)

also on 8x8 block averages (which separates bias from per-pixel noise). `--noise-floor` renders
Mitsuba a second time with another seed and prints the same numbers for Mitsuba against itself: a
vitrum-Mitsuba difference at that level is noise, a converged difference above it is a bug in one
of the two. `--method light` compares vitrum's `light` with Mitsuba's `ptracer` instead.

Exit codes: 0 done; 2 bad arguments; 3 something needed is missing (`vitrum integrators` does not
list the method, Mitsuba is not installed, ...); 1 a render failed.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def fail(code, message):
    print(f"reference_check: {message}", file=sys.stderr)
    sys.exit(code)


def parse_resolution(text):
    try:
        if "x" in text.lower():
            w, h = text.lower().split("x", 1)
            w, h = int(w), int(h)
        else:
            w = h = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"`{text}` is not N or WxH")
    if w < 1 or h < 1:
        raise argparse.ArgumentTypeError(f"`{text}`: width and height must be at least 1")
    return w, h


def find_vitrum(given):
    if given:
        return given
    built = os.path.join(REPO, "target", "release", "vitrum")
    if os.path.isfile(built) and os.access(built, os.X_OK):
        return built
    on_path = shutil.which("vitrum")
    if on_path:
        return on_path
    fail(3, "no vitrum binary: run `cargo build --release` or pass --vitrum PATH")


class CommandFailed(Exception):
    """A command that exited with a non-zero code: `what` it was, its exit `code` and its `stderr`."""

    def __init__(self, what, code, stderr):
        super().__init__(f"{what} failed (exit code {code})")
        self.what, self.code, self.stderr = what, code, stderr


def try_run(cmd, what):
    """Run `cmd` (echoed to stderr), capturing its output; raise CommandFailed if it fails."""
    print("$ " + " ".join(cmd), file=sys.stderr)
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise CommandFailed(what, p.returncode, p.stderr)
    return p


def run(cmd, what):
    """Run `cmd` like try_run; if it fails, print its stderr and exit: 1 if it exited 1, else 2."""
    try:
        return try_run(cmd, what)
    except CommandFailed as e:
        sys.stderr.write(e.stderr)
        fail(1 if e.code == 1 else 2, str(e))


def vitrum_integrators(vitrum):
    p = subprocess.run([vitrum, "integrators"], capture_output=True, text=True)
    if p.returncode != 0:
        fail(3, f"`{vitrum} integrators` failed: {p.stderr.strip()}")
    return [line.split()[0] for line in p.stdout.splitlines() if line.strip()]


def llvm_works(python):
    """Whether llvm_ad_rgb renders here. With LLVM < 19 Mitsuba aborts the whole process at render
    time (not catchable), so try it in a child process."""
    probe = (
        "import mitsuba as mi\n"
        "mi.set_variant('llvm_ad_rgb')\n"
        "s = mi.load_dict({'type': 'scene', 'integrator': {'type': 'path'}, 'sphere': {'type': 'sphere'},\n"
        "    'light': {'type': 'constant'},\n"
        "    'sensor': {'type': 'perspective', 'film': {'type': 'hdrfilm', 'width': 4, 'height': 4}}})\n"
        "mi.render(s, spp=1)\n"
    )
    try:
        p = subprocess.run([python, "-c", probe], capture_output=True, text=True, timeout=600)
    except subprocess.TimeoutExpired:
        return False
    return p.returncode == 0


def read_exr_rgb(path):
    """The R, G, B channels of an EXR file's first part as a float array (H, W, 3)."""
    import numpy as np

    try:
        import OpenEXR
    except ImportError:
        OpenEXR = None
    if OpenEXR is not None and hasattr(OpenEXR, "File"):
        with OpenEXR.File(path) as f:
            channels = f.channels()
            if "RGB" in channels:
                return np.asarray(channels["RGB"].pixels, dtype=np.float64)[..., :3]
            return np.stack([np.asarray(channels[c].pixels, dtype=np.float64) for c in "RGB"], axis=-1)
    if OpenEXR is not None:
        import Imath

        f = OpenEXR.InputFile(path)
        dw = f.header()["dataWindow"]
        w, h = dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1
        pt = Imath.PixelType(Imath.PixelType.FLOAT)
        return np.stack(
            [np.frombuffer(f.channel(c, pt), dtype=np.float32).reshape(h, w) for c in "RGB"], axis=-1
        ).astype(np.float64)
    import mitsuba as mi

    return np.asarray(mi.Bitmap(path), dtype=np.float64)[..., :3]


def rel_mse(x, r):
    """vitrum's relMSE (README.md, "Metrics") over finite values, and the count of non-finite values in
    either image."""
    import numpy as np

    finite = np.isfinite(x) & np.isfinite(r)
    bad = int(np.count_nonzero(~finite))
    d = np.where(finite, x - r, 0.0)
    rr = np.where(finite, r, 0.0)
    return float(np.sum(d * d / (rr * rr + 0.01)) / max(np.count_nonzero(finite), 1)), bad


def blocks(img, k=8):
    """Averages over k×k pixel blocks (the image cropped to whole blocks)."""
    h, w = (img.shape[0] // k) * k, (img.shape[1] // k) * k
    if h == 0 or w == 0:
        return img
    c = img[:h, :w]
    return c.reshape(h // k, k, w // k, k, c.shape[2]).mean(axis=(1, 3))


def mitsuba_render(xml, variant, spp, seed, out):
    import drjit as dr
    import mitsuba as mi
    import numpy as np

    mi.set_variant(variant)
    scene = mi.load_file(xml)
    start = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    arr = np.array(img)
    seconds = time.perf_counter() - start
    mi.Bitmap(img).write(out)
    return arr.astype(np.float64)[..., :3], seconds


def main():
    ap = argparse.ArgumentParser(
        description="Render a scene with vitrum and with Mitsuba 3 at the same settings; print relMSE and times.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("\n\n", 1)[1],
    )
    ap.add_argument("scene", help="scene file (TOML)")
    ap.add_argument("spp", type=int, help="samples per pixel for both renderers")
    ap.add_argument("resolution", type=parse_resolution, help="N (N×N) or WxH")
    ap.add_argument("max_depth", type=int, help="vitrum's maximum depth (bounces)")
    ap.add_argument("--method", choices=["path", "light"], default="path",
                    help="vitrum path vs Mitsuba path (default), or vitrum light vs Mitsuba ptracer")
    ap.add_argument("--variant", choices=["auto", "llvm_ad_rgb", "scalar_rgb"], default="auto",
                    help="Mitsuba variant (auto: llvm_ad_rgb if it works here, else scalar_rgb)")
    ap.add_argument("--seed", type=int, default=0, help="seed of both renders")
    ap.add_argument("--threads", type=int, help="vitrum worker threads (default: all cores)")
    ap.add_argument("--noise-floor", action="store_true",
                    help="also render Mitsuba with seed+1 and compare it with itself")
    ap.add_argument("--out", help="folder for the XML and the images (default: a new temporary folder)")
    ap.add_argument("--vitrum", help="the vitrum binary (default: target/release/vitrum, then PATH)")
    args = ap.parse_args()
    if args.spp < 1:
        fail(2, "spp must be at least 1")
    if args.max_depth < 0:
        fail(2, "max_depth must be 0 or more")
    if not os.path.isfile(args.scene):
        fail(2, f"{args.scene}: no such scene file")

    vitrum = find_vitrum(args.vitrum)
    names = vitrum_integrators(vitrum)
    if args.method not in names:
        fail(3, f"`{vitrum} integrators` lists {', '.join(names)}: there is no `{args.method}` integrator "
                f"yet, so there is nothing to compare with Mitsuba")
    try:
        import mitsuba  # noqa: F401
        import numpy  # noqa: F401
    except ImportError as e:
        fail(3, f"{e}: run this script with the Python that has Mitsuba 3 and numpy "
                f"(see docs/mitsuba-export.md, \"Installing Mitsuba\")")

    out = args.out or tempfile.mkdtemp(prefix="reference-check-")
    os.makedirs(out, exist_ok=True)
    w, h = args.resolution
    res = f"{w}x{h}"
    xml = os.path.join(out, "scene.xml")
    mi_integrator = "path" if args.method == "path" else "ptracer"
    run([vitrum, "export", args.scene, "--format", "mitsuba", "-o", xml, "--spp", str(args.spp),
         "--max-depth", str(args.max_depth), "--resolution", res, "--integrator", mi_integrator],
        "vitrum export")

    variant = args.variant
    if variant == "auto":
        variant = "llvm_ad_rgb" if llvm_works(sys.executable) else "scalar_rgb"
        if variant == "scalar_rgb":
            print("reference_check: llvm_ad_rgb does not render here (LLVM 19 missing?); using scalar_rgb",
                  file=sys.stderr)
    mi_exr = os.path.join(out, f"mitsuba-{variant}.exr")
    print(f"$ mitsuba {variant}: load {xml}, render {args.spp} spp", file=sys.stderr)
    ref, mi_seconds = mitsuba_render(xml, variant, args.spp, args.seed, mi_exr)

    v_exr = os.path.join(out, f"vitrum-{args.method}.exr")
    cmd = [vitrum, "render", args.scene, "-i", args.method, "--spp", str(args.spp), "--resolution", res,
           "--max-depth", str(args.max_depth), "--seed", str(args.seed), "-o", v_exr, "--json"]
    if args.threads:
        cmd += ["--threads", str(args.threads)]
    summary = json.loads(run(cmd, "vitrum render").stdout)
    test = read_exr_rgb(v_exr)
    if test.shape != ref.shape:
        fail(1, f"image sizes differ: vitrum {test.shape}, Mitsuba {ref.shape}")

    full, bad = rel_mse(test, ref)
    block, _ = rel_mse(blocks(test), blocks(ref))
    print(f"scene          {args.scene}")
    print(f"settings       {w}x{h}, {args.spp} spp, max depth {args.max_depth} (Mitsuba {args.max_depth + 1}), "
          f"seed {args.seed}, box filter")
    print(f"vitrum         {args.method}: {summary['seconds']:.2f} s -> {v_exr}")
    print(f"mitsuba        {mi_integrator} ({variant}): {mi_seconds:.2f} s -> {mi_exr}"
          + (" (includes JIT compilation on a cold kernel cache)" if variant.startswith("llvm") else ""))
    print(f"mean RGB       vitrum {test.mean(axis=(0, 1)).round(5).tolist()}  "
          f"mitsuba {ref.mean(axis=(0, 1)).round(5).tolist()}")
    print(f"relMSE         {full:.6g} (vitrum against Mitsuba)")
    print(f"relMSE 8x8     {block:.6g} (8x8 block averages)")
    if bad:
        print(f"non-finite     {bad} values (skipped in relMSE)")
    if args.noise_floor:
        again, _ = mitsuba_render(xml, variant, args.spp, args.seed + 1, os.path.join(out, "mitsuba-seed2.exr"))
        nf, _ = rel_mse(again, ref)
        nfb, _ = rel_mse(blocks(again), blocks(ref))
        print(f"noise floor    relMSE {nf:.6g}, 8x8 {nfb:.6g} (Mitsuba seed {args.seed + 1} against seed {args.seed})")
    print(f"commands       vitrum export/render as above; Mitsuba: mi.load_file('{xml}'), "
          f"mi.render(scene, spp={args.spp}, seed={args.seed})")


if __name__ == "__main__":
    main()
