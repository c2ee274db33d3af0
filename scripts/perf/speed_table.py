#!/usr/bin/env python3
"""vitrum `path` against Mitsuba 3 `path` on every shipped scene: one Markdown table of samples/s.

Not part of CI: it needs Mitsuba 3 with its LLVM variants (docs/mitsuba-export.md, "Installing
Mitsuba"). Issue 34's speed target, measured by one command:

    python3 scripts/perf/speed_table.py [--isa avx2] [--resolution 400] [--spp 16] [--runs 2]

For each scene of scenes/*.toml and scenes/hard/*.toml (or --scenes), `vitrum info --json` gives the
primitive count, the triangle count (primitives of mesh objects), the engine `path` runs on
(`path_engine`) and whether `path` renders the scene spectrally: `--spectral on`, or `auto` with a
`dispersion` effect that `path` simulates (the render's own JSON, `spectral`, is checked against
it). The scene is exported with `vitrum export` (scripts/perf/mitsuba_speed.py's `export`) at
--resolution (square), --spp and --max-depth (vitrum bounces; Mitsuba's max_depth is one more),
box filter; then --runs times, alternating, vitrum `path` renders it (all threads; vitrum's own
render seconds) and Mitsuba `path` renders it (`llvm_ad_spectral` where vitrum renders spectrally,
else `llvm_ad_rgb`; a fresh process per run with one untimed warm-up render that compiles the
kernels; timed: mi.render plus evaluating the image, as in mitsuba_speed.py). Samples/s of each is
pixels × spp ÷ the mean seconds; ratio = vitrum ÷ Mitsuba. Target (issue 34): ratio ≥ 2 on scenes
of analytic shapes only (no triangle), ≥ 1.5 on scenes with meshes.

A scene that `vitrum export` refuses, or that Mitsuba or vitrum fails to render, is listed under the
table with the reason. `--isa avx2` narrows both renderers to AVX2 (8 lanes) on an AVX-512 machine,
as mitsuba_speed.py does. The samplers differ (vitrum's default Owen-scrambled Sobol', the export's
Mitsuba `independent`): this compares samples per second, not error.

Exit codes: 0 done (whatever the ratios); 2 bad arguments; 3 Mitsuba's LLVM variant does not render
here, or no vitrum binary.
"""

import argparse
import glob
import json
import os
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))
import mitsuba_speed as ms  # noqa: E402  (export, vitrum_render, mitsuba, ISA)
import reference_check as rc  # noqa: E402  (find_vitrum, try_run, CommandFailed, llvm_works, fail)

REPO = os.path.dirname(os.path.dirname(HERE))

#: Issue 34's targets: vitrum ÷ Mitsuba samples/s on scenes of analytic shapes, and with meshes.
TARGET_ANALYTIC, TARGET_MESHES = 2.0, 1.5


def shipped_scenes():
    """Every shipped scene: scenes/*.toml, then scenes/hard/*.toml, each sorted by name."""
    return sorted(glob.glob(os.path.join(REPO, "scenes", "*.toml"))) + sorted(
        glob.glob(os.path.join(REPO, "scenes", "hard", "*.toml")))


def describe(vitrum, scene):
    """What `vitrum info --json` says that the table needs: primitives, triangles, `path`'s engine and
    whether `path` renders the scene spectrally."""
    info = json.loads(rc.try_run([vitrum, "info", scene, "--json"], "vitrum info").stdout)
    triangles = sum(o["primitives"] for o in info["objects"] if o["kind"] == "mesh")
    dispersion = any(e["effect"] == "dispersion" and e["integrators"].get("path") == "simulates"
                     for e in info["effects"])
    mode = info["render"]["spectral"]
    spectral = mode == "on" or (mode == "auto" and dispersion)
    return {"primitives": info["bvh"]["primitives"], "triangles": triangles,
            "engine": info["path_engine"]["name"], "engine_reason": info["path_engine"]["reason"],
            "spectral": spectral, "effects": [e["effect"] for e in info["effects"]]}


def reason_of(error):
    """One line for the table's list of skipped scenes: the failure and the last line of its stderr."""
    lines = [line.strip() for line in error.stderr.splitlines() if line.strip()]
    return f"{error}: {lines[-1]}" if lines else str(error)


def measure(vitrum, scene, args, out):
    """One scene's row (a dict); `skipped` holds the reason when there is no ratio."""
    name = os.path.relpath(scene, os.path.join(REPO, "scenes"))
    if name.startswith(".."):
        name = scene
    row = {"scene": name}
    try:
        row.update(describe(vitrum, scene))
    except rc.CommandFailed as e:
        row["skipped"] = reason_of(e)
        return row
    row["variant"] = "llvm_ad_spectral" if row["spectral"] else "llvm_ad_rgb"
    stem = os.path.join(out, name.strip(os.sep).replace(os.sep, "-").removesuffix(".toml"))
    xml = stem + ".xml"
    res = f"{args.resolution}x{args.resolution}"
    try:
        row["export_notes"] = ms.export(vitrum, scene, xml, args.spp, args.max_depth, res, "independent", run=rc.try_run)
    except rc.CommandFailed as e:
        row["skipped"] = "vitrum export: " + reason_of(e)
        return row
    row["vitrum_seconds"], row["mitsuba_seconds"] = [], []
    for k in range(args.runs):
        try:
            v = ms.vitrum_render(vitrum, scene, res, args.max_depth, f"{stem}-vitrum-{k}.exr",
                                 ["--spp", str(args.spp)], k, run=rc.try_run)
        except rc.CommandFailed as e:
            row["skipped"] = "vitrum render: " + reason_of(e)
            return row
        if v["engine"]["name"] != row["engine"] or v["spectral"] != row["spectral"]:
            row["note"] = (f"the render ran engine {v['engine']['name']}, spectral {v['spectral']}; "
                           f"`vitrum info` said {row['engine']}, spectral {row['spectral']}")
        row["vitrum_seconds"].append(v["seconds"])
        try:
            m = ms.mitsuba(xml, row["variant"], [args.spp], k, f"{stem}-mitsuba-{k}", raise_failure=True)
        except rc.CommandFailed as e:
            row["skipped"] = f"Mitsuba {row['variant']}: " + reason_of(e)
            return row
        row["mitsuba_seconds"].append(m["results"][0]["seconds"])
        row["mitsuba_version"] = m["mitsuba"]
    samples = args.resolution * args.resolution * args.spp
    row["vitrum_msamples_per_s"] = samples / (sum(row["vitrum_seconds"]) / args.runs) / 1e6
    row["mitsuba_msamples_per_s"] = samples / (sum(row["mitsuba_seconds"]) / args.runs) / 1e6
    row["ratio"] = row["vitrum_msamples_per_s"] / row["mitsuba_msamples_per_s"]
    row["target"] = TARGET_MESHES if row["triangles"] else TARGET_ANALYTIC
    row["holds"] = row["ratio"] >= row["target"]
    return row


def table(rows):
    """The Markdown table of the measured rows, then the skipped scenes with their reasons."""
    lines = ["| scene | primitives (triangles) | vitrum engine | Mitsuba variant | vitrum Msamples/s "
             "| Mitsuba Msamples/s | vitrum ÷ Mitsuba | target | holds |",
             "|---|--:|---|---|--:|--:|--:|--:|---|"]
    for r in rows:
        if "ratio" in r:
            lines.append(f"| {r['scene']} | {r['primitives']} ({r['triangles']}) | {r['engine']} | {r['variant']} "
                         f"| {r['vitrum_msamples_per_s']:.2f} | {r['mitsuba_msamples_per_s']:.2f} "
                         f"| {r['ratio']:.2f} | {r['target']:g}× | {'yes' if r['holds'] else 'no'} |")
    measured = [r for r in rows if "ratio" in r]
    held = sum(r["holds"] for r in measured)
    lines.append("")
    lines.append(f"Target held on {held} of {len(measured)} measured scenes; {len(rows) - len(measured)} not measured.")
    for r in rows:
        if "skipped" in r:
            lines.append(f"- {r['scene']}: not measured: {r['skipped']}")
        if "note" in r:
            lines.append(f"- {r['scene']}: {r['note']}")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("--isa", choices=["avx512", "avx2"], default="avx512",
                    help="avx512: each renderer's widest (the machine's); avx2: both narrowed to AVX2, 8 lanes")
    ap.add_argument("--resolution", type=int, default=400, help="side of the square image")
    ap.add_argument("--spp", type=int, default=16, help="samples per pixel")
    ap.add_argument("--max-depth", type=int, default=16, help="vitrum bounces (Mitsuba: one more)")
    ap.add_argument("--runs", type=int, default=2, help="timed renders of each, alternating")
    ap.add_argument("--scenes", nargs="+", help="scene files (default: every shipped scene)")
    ap.add_argument("--out", help="JSON file of every figure (images and XML go next to it)")
    ap.add_argument("--vitrum", help="the vitrum binary (default: target/release/vitrum, then PATH)")
    args = ap.parse_args()
    for name in ("resolution", "spp", "runs"):
        if getattr(args, name) < 1:
            rc.fail(2, f"--{name} must be at least 1")
    if args.max_depth < 0:
        rc.fail(2, "--max-depth must be 0 or more")
    scenes = args.scenes or shipped_scenes()
    for s in scenes:
        if not os.path.isfile(s):
            rc.fail(2, f"{s}: no such scene file")
    if args.isa == "avx2":
        os.environ["VITRUM_ISA"] = "avx2"
        ms.ISA = "avx2"
    flags = next((line.split(":", 1)[1].split() for line in open("/proc/cpuinfo") if line.startswith("flags")), [])
    if args.isa == "avx512" and "avx512f" not in flags:
        print("speed_table: this CPU has no AVX-512: the figures are each renderer's widest instruction set",
              file=sys.stderr)
    vitrum = rc.find_vitrum(args.vitrum)
    if not rc.llvm_works(sys.executable):
        rc.fail(3, "llvm_ad_rgb does not render here (LLVM 19 missing? see docs/mitsuba-export.md, "
                   "\"Installing Mitsuba\")")
    folder = os.path.dirname(os.path.abspath(args.out)) if args.out else tempfile.mkdtemp(prefix="speed-table-")
    work = os.path.join(folder, "speed-table-files")
    os.makedirs(work, exist_ok=True)
    started = time.time()
    rows = []
    for s in scenes:
        rows.append(measure(vitrum, os.path.abspath(s), args, work))
        r = rows[-1]
        print(f"speed_table: {r['scene']}: " + (f"{r['ratio']:.2f}" if "ratio" in r else r["skipped"]),
              file=sys.stderr)
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if line.startswith("model name")),
               "unknown")
    report = {"args": {k: v for k, v in vars(args).items() if k != "scenes"}, "scenes": scenes,
              "cpu": cpu, "avx512f": "avx512f" in flags, "cores": os.cpu_count(),
              "load_average_at_end": os.getloadavg(), "minutes": (time.time() - started) / 60,
              "rows": rows}
    print(f"vitrum `path` vs Mitsuba 3 `path`: {args.resolution}x{args.resolution}, {args.spp} spp, max depth "
          f"{args.max_depth} (Mitsuba {args.max_depth + 1}), box filter, all threads, {args.runs} alternating runs "
          f"each, ISA {args.isa}")
    print()
    print(table(rows))
    if args.out:
        with open(args.out, "w") as f:
            json.dump(report, f, indent=1)
        print(f"\nevery figure in {args.out}; XML and images in {work}")


if __name__ == "__main__":
    main()
