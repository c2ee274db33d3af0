#!/usr/bin/env python3
"""vitrum `path` against Mitsuba 3 `path` in one run: speed at equal samples, error at equal time.

Not part of CI: it needs Mitsuba 3 (set-up: docs/mitsuba-export.md, "Installing Mitsuba") and runs
for a quarter of an hour with the defaults:

    "$HOME/mi/bin/python" scripts/perf/mitsuba_speed.py [SCENE] [options]

1. Speed. The scene (default scenes/soft-shadows.toml) is exported with `vitrum export` and
   rendered at --resolution (800) with --spp (16) and --max-depth (16 bounces; Mitsuba's
   max_depth is one more, it counts segments), box filter, all threads, --runs (2) times each:
   vitrum `path`, and Mitsuba `path` in every --variants (llvm_ad_rgb, scalar_rgb; each in its own
   process, llvm after one untimed warm-up render that compiles its kernels). Timed: vitrum's own
   render seconds; Mitsuba's mi.render plus evaluation of the image (not the scene load). Printed:
   samples per second of each and the ratio vitrum ÷ Mitsuba. `--isa avx2` narrows both to AVX2
   (8 lanes) on an AVX-512 machine: vitrum by `VITRUM_ISA=avx2`, Dr.Jit's LLVM backend by its
   `jit_llvm_set_target` (Haswell, 8 lanes).
2. Error at equal time, at --quality-resolution (400). One shared reference: the mean of a
   vitrum and a Mitsuba (first variant) render of --reference-spp (2048) each, other seeds, so
   neither renderer is favoured. Then vitrum renders for --seconds (20) (`--time`), and each
   Mitsuba variant with the sample count its measured rate gives in that time. relMSE against the
   reference (vitrum diff, the README's "Metrics"); since Monte Carlo error falls as 1/time,
   each relMSE is also scaled to exactly --seconds (relMSE × seconds ÷ --seconds) for the ratio
   vitrum ÷ Mitsuba. --mitsuba-sampler picks Mitsuba's sampler (the export writes `independent`;
   `multijitter` or `ldsampler` give it stratification too).

Images, the XML and a JSON of every figure go to --out (default: a new temporary folder).
"""

import argparse
import json
import os
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
import reference_check as rc  # noqa: E402  (find_vitrum, run, llvm_works, fail, read_exr_rgb)

REPO = os.path.dirname(os.path.dirname(HERE))


def narrow_llvm_to_avx2():
    """Make Dr.Jit's LLVM backend compile for AVX2, 8 lanes (Haswell), as on an AVX2 machine:
    `jit_llvm_set_target` of libdrjit-core, which Dr.Jit's Python API does not expose."""
    import ctypes
    import drjit as dr

    lib = ctypes.CDLL(os.path.join(os.path.dirname(dr.__file__), "libdrjit-core.so"))
    set_target = lib["_Z19jit_llvm_set_targetPKcS0_j"]
    set_target.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint32]
    set_target(b"haswell", None, 8)
    width = lib["_Z21jit_llvm_vector_widthv"]
    width.restype = ctypes.c_uint32
    if width() != 8:
        rc.fail(1, f"Dr.Jit's LLVM backend kept {width()} lanes")


def mitsuba_child(xml, variant, spp_list, seed, warm_up, out_prefix, isa):
    """Render `xml` with `variant` at each spp of `spp_list` (in this process); print JSON."""
    import drjit as dr
    import mitsuba as mi
    import numpy as np

    mi.set_variant(variant)
    if isa == "avx2" and variant.startswith("llvm"):
        narrow_llvm_to_avx2()
    scene = mi.load_file(xml)
    results = []
    if warm_up:
        img = mi.render(scene, spp=1, seed=seed)
        dr.eval(img)
    for k, spp in enumerate(spp_list):
        start = time.perf_counter()
        img = mi.render(scene, spp=spp, seed=seed + k)
        dr.eval(img)
        arr = np.array(img)
        seconds = time.perf_counter() - start
        path = f"{out_prefix}-{k}.exr"
        mi.Bitmap(arr).write(path)
        results.append({"spp": spp, "seconds": seconds, "exr": path})
    print(json.dumps({"variant": variant, "mitsuba": mi.__version__, "results": results}))


#: The vector instruction set both renderers use: "native" (the CPU's widest) or "avx2"
#: (`--isa avx2`: vitrum's `VITRUM_ISA=avx2`, Dr.Jit's LLVM target narrowed to Haswell).
ISA = "native"


def mitsuba(xml, variant, spp_list, seed, out_prefix, raise_failure=False):
    """Mitsuba renders in a fresh process (llvm after an untimed warm-up): the child's JSON. A failed
    child exits this process (code 1), or with `raise_failure` raises rc.CommandFailed."""
    cmd = [sys.executable, os.path.abspath(__file__), "--child", xml, variant, ",".join(map(str, spp_list)),
           str(seed), "1" if variant.startswith("llvm") else "0", out_prefix, ISA]
    try:
        p = rc.try_run(cmd, f"Mitsuba {variant}")
    except rc.CommandFailed as e:
        if raise_failure:
            raise
        sys.stderr.write(e.stderr)
        rc.fail(1, str(e))
    return json.loads(p.stdout.strip().splitlines()[-1])


def export(vitrum, scene, xml, spp, depth, res, sampler, run=rc.run):
    """`vitrum export` of `scene` to Mitsuba XML with `path` at these settings (`run`: rc.run, which
    exits on failure, or rc.try_run, which raises); its notes on stderr are returned as lines."""
    cmd = [vitrum, "export", scene, "--format", "mitsuba", "-o", xml, "--spp", str(spp), "--max-depth",
           str(depth), "--resolution", res, "--integrator", "path"]
    notes = run(cmd, "vitrum export").stderr.splitlines()
    if sampler != "independent":
        with open(xml) as f:
            text = f.read()
        if '<sampler type="independent">' not in text:
            rc.fail(1, "the exported XML has no independent sampler to replace")
        with open(xml, "w") as f:
            f.write(text.replace('<sampler type="independent">', f'<sampler type="{sampler}">'))
    return notes


def vitrum_render(vitrum, scene, res, depth, out, budget, seed, run=rc.run):
    """`vitrum render -i path` (all threads) with `budget` (["--spp", N] or ["--time", S]): its JSON."""
    cmd = [vitrum, "render", scene, "-i", "path", "--resolution", res, "--max-depth", str(depth),
           "--seed", str(seed), "-o", out, "--json", "--quiet"] + budget
    return json.loads(run(cmd, "vitrum render").stdout)


def rel_mse(vitrum, test, reference):
    p = rc.run([vitrum, "diff", test, reference, "--json"], "vitrum diff")
    return json.loads(p.stdout)["rel_mse"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("scene", nargs="?", default=os.path.join(REPO, "scenes", "soft-shadows.toml"))
    ap.add_argument("--resolution", type=int, default=800, help="side of the speed renders")
    ap.add_argument("--spp", type=int, default=16, help="samples per pixel of the speed renders")
    ap.add_argument("--max-depth", type=int, default=16, help="vitrum bounces (Mitsuba: one more)")
    ap.add_argument("--runs", type=int, default=2, help="timed renders of each for the speed")
    ap.add_argument("--variants", default="llvm_ad_rgb,scalar_rgb")
    ap.add_argument("--quality-resolution", type=int, default=400)
    ap.add_argument("--seconds", type=float, default=20.0, help="the equal time of the error comparison")
    ap.add_argument("--reference-spp", type=int, default=2048)
    ap.add_argument("--mitsuba-sampler", default="independent",
                    choices=["independent", "stratified", "multijitter", "orthogonal", "ldsampler"])
    ap.add_argument("--skip-quality", action="store_true", help="only the speed comparison")
    ap.add_argument("--out")
    ap.add_argument("--vitrum")
    ap.add_argument("--isa", choices=["native", "avx2"], default="native",
                    help="avx2: both renderers use AVX2 (8 lanes) on an AVX-512 machine")
    args = ap.parse_args()
    global ISA
    ISA = args.isa
    if args.isa == "avx2":
        os.environ["VITRUM_ISA"] = "avx2"
    vitrum = rc.find_vitrum(args.vitrum)
    variants = args.variants.split(",")
    if "llvm_ad_rgb" in variants and not rc.llvm_works(sys.executable):
        rc.fail(3, "llvm_ad_rgb does not render here (LLVM 19 missing? see docs/mitsuba-export.md, \"Installing Mitsuba\")")
    out = args.out or tempfile.mkdtemp(prefix="mitsuba-speed-")
    os.makedirs(out, exist_ok=True)
    report = {"scene": args.scene, "args": vars(args), "speed": {}, "quality": {}}

    # 1. Speed at equal samples.
    res = f"{args.resolution}x{args.resolution}"
    samples = args.resolution * args.resolution * args.spp
    xml = os.path.join(out, "speed.xml")
    export(vitrum, args.scene, xml, args.spp, args.max_depth, res, args.mitsuba_sampler)
    rates = {}
    v = [vitrum_render(vitrum, args.scene, res, args.max_depth, os.path.join(out, f"vitrum-speed-{k}.exr"),
                       ["--spp", str(args.spp)], k)["seconds"] for k in range(args.runs)]
    rates["vitrum"] = samples / (sum(v) / len(v))
    report["speed"]["vitrum"] = v
    for variant in variants:
        r = mitsuba(xml, variant, [args.spp] * args.runs, 0, os.path.join(out, f"mitsuba-speed-{variant}"))
        seconds = [x["seconds"] for x in r["results"]]
        rates[variant] = samples / (sum(seconds) / len(seconds))
        report["speed"][variant] = seconds
        report["mitsuba"] = r["mitsuba"]
    print(f"speed: {args.scene}, {res}, {args.spp} spp, max depth {args.max_depth} (Mitsuba {args.max_depth + 1}), "
          f"Mitsuba sampler {args.mitsuba_sampler}, {args.runs} runs each, vector ISA {args.isa}")
    print("| renderer | seconds per run | Msamples/s | vitrum ÷ it |")
    print("|---|---|--:|--:|")
    for name, rate in rates.items():
        runs = report["speed"][name]
        print(f"| {'vitrum path' if name == 'vitrum' else 'Mitsuba ' + name} | "
              f"{', '.join(f'{s:.2f}' for s in runs)} | {rate / 1e6:.3f} | {rates['vitrum'] / rate:.2f} |")

    # 2. Error at equal time against one shared reference.
    if not args.skip_quality:
        import numpy as np
        import mitsuba as mi

        mi.set_variant("scalar_rgb")
        qres = f"{args.quality_resolution}x{args.quality_resolution}"
        qxml = os.path.join(out, "quality.xml")
        export(vitrum, args.scene, qxml, args.reference_spp, args.max_depth, qres, args.mitsuba_sampler)
        ref_v = os.path.join(out, "reference-vitrum.exr")
        vitrum_render(vitrum, args.scene, qres, args.max_depth, ref_v, ["--spp", str(args.reference_spp)], 1000)
        ref_m = mitsuba(qxml, variants[0], [args.reference_spp], 1000, os.path.join(out, "reference-mitsuba"))
        a, b = rc.read_exr_rgb(ref_v), rc.read_exr_rgb(ref_m["results"][0]["exr"])
        reference = os.path.join(out, "reference.exr")
        mi.Bitmap(((a + b) / 2).astype(np.float32)).write(reference)
        report["quality"]["reference_halves_rel_mse"] = rel_mse(vitrum, ref_v, ref_m["results"][0]["exr"])
        pixels = args.quality_resolution ** 2
        rows = []
        test = os.path.join(out, "vitrum-equal-time.exr")
        s = vitrum_render(vitrum, args.scene, qres, args.max_depth, test, ["--time", str(args.seconds)], 7)
        rows.append(("vitrum path", s["spp"], s["seconds"], rel_mse(vitrum, test, reference)))
        for variant in variants:
            spp = max(1, round(args.seconds * rates[variant] / pixels))
            r = mitsuba(qxml, variant, [spp], 7, os.path.join(out, f"mitsuba-equal-time-{variant}"))["results"][0]
            rows.append((f"Mitsuba {variant}", spp, r["seconds"], rel_mse(vitrum, r["exr"], reference)))
        scaled = {name: e * sec / args.seconds for name, _, sec, e in rows}
        print()
        print(f"error at equal time: {qres}, {args.seconds:g} s each, reference = mean of vitrum and Mitsuba "
              f"{variants[0]} at {args.reference_spp} spp (the two halves differ by relMSE "
              f"{report['quality']['reference_halves_rel_mse']:.3g})")
        print("| renderer | spp | seconds | relMSE | relMSE at exactly the equal time | vitrum ÷ it |")
        print("|---|--:|--:|--:|--:|--:|")
        for name, spp, sec, e in rows:
            print(f"| {name} | {spp} | {sec:.2f} | {e:.4g} | {scaled[name]:.4g} | "
                  f"{scaled['vitrum path'] / scaled[name]:.2f} |")
        report["quality"]["rows"] = rows
    with open(os.path.join(out, "mitsuba-speed.json"), "w") as f:
        json.dump(report, f, indent=1)
    print(f"\nimages, XML and mitsuba-speed.json in {out}")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        xml, variant, spps, seed, warm, prefix, isa = sys.argv[2:9]
        mitsuba_child(xml, variant, [int(s) for s in spps.split(",")], int(seed), warm == "1", prefix, isa)
    else:
        main()
