#!/usr/bin/env python3
"""Write the image pairs and NVIDIA's reference FLIP results that tests/flip.rs checks src/flip.rs against.

Not part of CI (the Rust test only reads what this writes). It needs the reference implementation
and numpy:

    pip install flip-evaluator==1.7 numpy
    python3 scripts/flip/make_pairs.py            # writes tests/data/flip/

Everything is deterministic (fixed seeds; the render pair uses fixed vitrum seeds). The render pair
runs vitrum: `target/release/vitrum` when it exists (or $VITRUM), else `cargo run --release --`.

Files, in tests/data/flip/:
  NAME.reference.pfm, NAME.test.pfm   float32 RGB inputs (linear), standard PFM: "PF", width height,
                                      -1.0 (little-endian), rows from the bottom up
  CASE.flip.pfm                       the reference implementation's per-pixel FLIP ("Pf", 1 channel)
  manifest.json                       per case: inputs, mode (HDR/LDR), parameters given, and the
                                      reference's mean FLIP and exposures (start, stop, count); plus
                                      the flip-evaluator and numpy versions used

Cases:
  gradient_noise   smooth HDR gradient (0.01 to ~20, log-spaced, tinted) against it with noise
  hot_spot         dim scene with a hot spot peaking at 500 (range > 1000:1) against the spot moved
                   one pixel, 20% dimmer, plus mild noise
  hot_spot_hable   the same pair with explicit settings: 30 ppd, exposures -4..3 in 5 steps, Hable
  edges_shift      HDR shapes and thin lines against a copy with a block shifted by 2 px, one edge
                   blurred and a line removed
  edges_ldr        LDR-FLIP (linear inputs) on the edges pair scaled by 0.25 and clamped to [0, 1]
  cornell_render   vitrum render of scenes/cornell-glass.toml, path tracing, 96x96: 64 spp (reference)
                   against 4 spp (test)
"""

import json
import os
import subprocess
import sys
import tempfile
from importlib.metadata import version
from pathlib import Path

import numpy as np
import flip_evaluator as flip

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "tests" / "data" / "flip"


def write_pfm(path, image):
    """Write an HxWx3 or HxW float32 array as little-endian PFM (rows bottom up)."""
    image = np.asarray(image, dtype=np.float32)
    colour = image.ndim == 3
    height, width = image.shape[:2]
    with open(path, "wb") as f:
        f.write(b"PF\n" if colour else b"Pf\n")
        f.write(f"{width} {height}\n-1.0\n".encode())
        f.write(np.ascontiguousarray(image[::-1]).astype("<f4").tobytes())


def gradient_noise(rng):
    h, w = 48, 64
    x = np.linspace(0.0, 1.0, w, dtype=np.float64)[None, :]
    y = np.linspace(0.0, 1.0, h, dtype=np.float64)[:, None]
    lum = 0.01 * np.power(2000.0, x) * (0.6 + 0.4 * y)
    ref = np.stack([lum * (1.0 + 0.3 * y), lum, lum * (1.2 - 0.5 * x)], axis=-1)
    noise = rng.normal(0.0, 0.15, size=ref.shape) * ref
    test = np.maximum(ref + noise, 0.0)
    return ref, test


def hot_spot(rng):
    h, w = 64, 80
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    background = 0.05 + 0.45 * (xx / w) * (0.5 + 0.5 * np.sin(yy / 5.0) ** 2)
    base = np.stack([background, 0.8 * background, 0.6 * background + 0.02], axis=-1)

    def spot(cx, cy, peak):
        r2 = (xx - cx) ** 2 + (yy - cy) ** 2
        s = peak * np.exp(-r2 / (2.0 * 2.0**2))
        return np.stack([s, 0.9 * s, 0.7 * s], axis=-1)

    ref = base + spot(30.0, 25.0, 500.0)
    test = base + spot(31.0, 25.0, 400.0)
    test = np.maximum(test * (1.0 + rng.normal(0.0, 0.03, size=test.shape)), 0.0)
    return ref, test


def edges_shift(rng):
    h, w = 60, 80
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    ref = np.zeros((h, w, 3)) + np.array([0.2, 0.25, 0.3])
    ref[10:30, 8:30] = [4.0, 1.0, 0.5]  # bright red block
    disc = (xx - 55.0) ** 2 + (yy - 20.0) ** 2 < 9.0**2
    ref[disc] = [0.3, 2.0, 6.0]  # blue-green disc
    ref[40:42, 5:75] = [8.0, 8.0, 8.0]  # thin bright line
    ref[35:58, 60] = [0.0, 0.0, 0.0]  # thin dark line
    ref[45:55, 20:40] = [1.0, 1.0, 1.0] * (0.5 + (xx[45:55, 20:40] - 20) / 20.0)[..., None]
    test = ref.copy()
    test[10:30, 10:32] = ref[10:30, 8:30]  # block shifted right by 2 px
    test[10:30, 8:10] = [0.2, 0.25, 0.3]
    # Blur the disc's edge with a 3x3 box.
    padded = np.pad(test, ((1, 1), (1, 1), (0, 0)), mode="edge")
    box = sum(padded[dy : dy + h, dx : dx + w] for dy in range(3) for dx in range(3)) / 9.0
    ring = ((xx - 55.0) ** 2 + (yy - 20.0) ** 2 < 11.0**2) & ~((xx - 55.0) ** 2 + (yy - 20.0) ** 2 < 7.0**2)
    test[ring] = box[ring]
    test[35:58, 60] = ref[35:58, 61]  # dark line removed
    test = np.maximum(test + rng.normal(0.0, 0.01, size=test.shape), 0.0)
    return ref, test


def vitrum_command():
    if "VITRUM" in os.environ:
        return [os.environ["VITRUM"]]
    binary = ROOT / "target" / "release" / "vitrum"
    if binary.exists():
        return [str(binary)]
    return ["cargo", "run", "--release", "--quiet", "--"]


def cornell_render():
    with tempfile.TemporaryDirectory() as tmp:
        images = []
        for spp, seed in [(64, 2), (4, 1)]:
            out = Path(tmp) / f"{spp}.exr"
            subprocess.run(
                vitrum_command()
                + ["render", "scenes/cornell-glass.toml", "-i", "path", "--spp", str(spp), "--resolution", "96x96"]
                + ["--seed", str(seed), "--threads", "1", "--quiet", "-o", str(out)],
                cwd=ROOT,
                check=True,
            )
            images.append(flip.load(str(out)))
    return images[0], images[1]


def evaluate(ref, test, mode, parameters):
    ref = np.ascontiguousarray(ref, dtype=np.float32)
    test = np.ascontiguousarray(test, dtype=np.float32)
    error, mean, used = flip.evaluate(
        ref, test, mode, inputsRGB=False, applyMagma=False, computeMeanError=True, parameters=dict(parameters)
    )
    return error[..., 0], float(mean), used


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(20240607)
    pairs = {
        "gradient_noise": gradient_noise(rng),
        "hot_spot": hot_spot(rng),
        "edges_shift": edges_shift(rng),
        "cornell_render": cornell_render(),
    }
    inputs = {}
    for name, (ref, test) in pairs.items():
        ref, test = np.float32(ref), np.float32(test)
        inputs[name] = (ref, test)
        write_pfm(OUT / f"{name}.reference.pfm", ref)
        write_pfm(OUT / f"{name}.test.pfm", test)

    # (case, input pair, mode, parameters given to the reference, LDR scale applied to both inputs)
    cases = [
        ("gradient_noise", "gradient_noise", "HDR", {}, None),
        ("hot_spot", "hot_spot", "HDR", {}, None),
        (
            "hot_spot_hable",
            "hot_spot",
            "HDR",
            {"ppd": 30.0, "startExposure": -4.0, "stopExposure": 3.0, "numExposures": 5, "tonemapper": "hable"},
            None,
        ),
        ("edges_shift", "edges_shift", "HDR", {}, None),
        ("edges_ldr", "edges_shift", "LDR", {}, 0.25),
        ("cornell_render", "cornell_render", "HDR", {}, None),
    ]
    manifest = {
        "flip_evaluator_version": version("flip-evaluator"),
        "numpy_version": np.__version__,
        "generator": "scripts/flip/make_pairs.py",
        "cases": [],
    }
    for case, pair, mode, parameters, ldr_scale in cases:
        ref, test = inputs[pair]
        if ldr_scale is not None:
            ref = np.clip(ref * np.float32(ldr_scale), 0.0, 1.0)
            test = np.clip(test * np.float32(ldr_scale), 0.0, 1.0)
        error, mean, used = evaluate(ref, test, mode, parameters)
        write_pfm(OUT / f"{case}.flip.pfm", error)
        entry = {
            "name": case,
            "inputs": pair,
            "mode": mode,
            "width": int(ref.shape[1]),
            "height": int(ref.shape[0]),
            "parameters": parameters,
            "ldr_scale": ldr_scale,
            "mean": mean,
            "ppd": float(used["ppd"]),
        }
        if mode == "HDR":
            entry["start_exposure"] = float(used["startExposure"])
            entry["stop_exposure"] = float(used["stopExposure"])
            entry["exposures"] = int(used["numExposures"])
        manifest["cases"].append(entry)
        print(f"{case}: {mode} mean FLIP {mean:.6f} {used}", file=sys.stderr)
    with open(OUT / "manifest.json", "w") as f:
        json.dump(manifest, f, indent=2)
        f.write("\n")


if __name__ == "__main__":
    main()
