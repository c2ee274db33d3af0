#!/usr/bin/env python3
"""Two vitrum binaries side by side: samples per second of every method, in alternating runs.

    python3 scripts/perf/ab_speed.py OLD_VITRUM NEW_VITRUM [--scenes a.toml,b.toml] [--spp 4]
                                     [--resolution 800] [--rounds 4] [--integrators path,light]

For a performance change: build the commit before it and the commit after it, then compare them
here in one run. Each round renders every (scene, method) once with OLD and once with NEW; which
goes first alternates over rounds and pairs, so that drift of the machine's speed over the run
falls on both alike. Timed: vitrum's own render seconds (`--json`). Images go to a temporary
folder and are compared between the two binaries (a change that should not alter images must
not). Printed: the median samples per second of each and the ratio NEW / OLD, as a Markdown table.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
METHODS = ["raycast", "whitted", "ssaa", "distributed", "path", "light"]


def render(vitrum, scene, method, args, out):
    """One render; returns (samples per second, output file)."""
    cmd = [vitrum, "render", scene, "-i", method, "--spp", str(args.spp), "--resolution",
           f"{args.resolution}x{args.resolution}", "-o", out, "--json", "--quiet"]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed ({p.returncode}): {p.stderr.strip()}")
    summary = json.loads(p.stdout)
    samples = args.resolution * args.resolution * args.spp
    return samples / summary["seconds"], out


def identical(vitrum, a, b):
    """Whether two EXR renders have the same pixels: `vitrum diff` MSE 0 and no non-finite pixel
    in either (an image with NaN or Inf counts as differing; +0 and -0 count as equal)."""
    p = subprocess.run([vitrum, "diff", a, b, "--json"], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"vitrum diff {a} {b} failed ({p.returncode}): {p.stderr.strip()}")
    d = json.loads(p.stdout)
    return d["mse"] == 0.0 and d["non_finite_test"] == 0 and d["non_finite_reference"] == 0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--scenes", default=",".join(os.path.join(REPO, "scenes", s)
                                                 for s in ("cornell-glass.toml", "soft-shadows.toml")))
    ap.add_argument("--integrators", default=",".join(METHODS))
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--resolution", type=int, default=800)
    ap.add_argument("--rounds", type=int, default=4)
    args = ap.parse_args()
    scenes = args.scenes.split(",")
    methods = args.integrators.split(",")
    rates = {}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            for pair, (scene, method) in enumerate((s, m) for s in scenes for m in methods):
                key = (os.path.basename(scene), method)
                order = [("old", args.old), ("new", args.new)]
                if (r + pair) % 2:  # each binary first equally often over rounds and pairs
                    order.reverse()
                files = {}
                for which, vitrum in order:
                    rate, files[which] = render(vitrum, scene, method, args,
                                                os.path.join(tmp, f"{which}.exr"))
                    rates.setdefault(key, {"old": [], "new": []})[which].append(rate)
                if not identical(args.new, files["new"], files["old"]):
                    rates[key]["differs"] = True
    print(f"{args.resolution}x{args.resolution}, {args.spp} spp, {args.rounds} alternating rounds; "
          f"median Msamples/s")
    print("| scene | method | old | new | new / old | images |")
    print("|---|---|--:|--:|--:|---|")
    for (scene, method), r in rates.items():
        old, new = statistics.median(r["old"]) / 1e6, statistics.median(r["new"]) / 1e6
        same = "differ" if r.get("differs") else "identical"
        print(f"| {scene} | {method} | {old:.3f} | {new:.3f} | {new / old:.2f} | {same} |")


if __name__ == "__main__":
    main()
