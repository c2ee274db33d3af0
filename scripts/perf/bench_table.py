#!/usr/bin/env python3
"""Tables of criterion results for docs/performance.md (no dependencies).

    python3 scripts/perf/bench_table.py [TARGET_DIR]

Reads criterion's estimates under TARGET_DIR/criterion (default: target/criterion) as left by
`cargo bench --bench bvh`, `--bench integrators` and `--bench cost_growth`, and prints, for what
it finds:
- bvh: per mesh size and analytic scene, vitrum's closest-hit and occlusion queries in Mrays/s
  next to raw obvhs on the same rays, and the ratio of times (vitrum ÷ obvhs; 1.25 is the bound);
  the build times (obvhs CwBvh alone, vitrum's whole load: OBJ parse, compile, BVH);
- integrators: samples per second of every method per scene;
- threads: path's samples per second at 1 and 2 threads and the scaling;
- cost growth: µs per sample of raycast and path against triangles.
Times are criterion's mean point estimates; every figure comes from one `cargo bench` run.
"""
import json
import os
import sys

ROOT = os.path.join(sys.argv[1] if len(sys.argv) > 1 else "target", "criterion")


def estimate(*parts):
    """Mean time in seconds of one benchmark, or None."""
    path = os.path.join(ROOT, *parts, "new", "estimates.json")
    try:
        with open(path) as f:
            return json.load(f)["mean"]["point_estimate"] * 1e-9
    except (OSError, KeyError, ValueError):
        return None


def throughput(*parts):
    """Elements per iteration of one benchmark (criterion's benchmark.json), or None."""
    path = os.path.join(ROOT, *parts, "new", "benchmark.json")
    try:
        with open(path) as f:
            t = json.load(f).get("throughput") or {}
        return t.get("Elements")
    except (OSError, ValueError):
        return None


def subdirs(*parts):
    path = os.path.join(ROOT, *parts)
    return sorted(d for d in os.listdir(path) if os.path.isdir(os.path.join(path, d)) and d != "report") \
        if os.path.isdir(path) else []


def rate(seconds, elements):
    return elements / seconds if seconds and elements else None


def fmt(x, digits=2):
    return "—" if x is None else f"{x:.{digits}f}"


def bvh_tables():
    rows = []
    for group in ["mesh", "analytic"]:
        params = subdirs(group, "vitrum closest")
        params.sort(key=lambda p: (not p.isdigit(), int(p) if p.isdigit() else p))
        for p in params:
            row = [p]
            for kind in ["closest", "occlusion"]:
                v = estimate(group, f"vitrum {kind}", p)
                o = estimate(group, f"obvhs {kind}", p)
                n = throughput(group, f"vitrum {kind}", p)
                row += [fmt(rate(v, n) and rate(v, n) / 1e6), fmt(rate(o, n) and rate(o, n) / 1e6),
                        fmt(v / o if v and o else None)]
            rows.append(row)
    if rows:
        print("| scene (triangles) | vitrum closest Mrays/s | obvhs closest | ratio | "
              "vitrum occlusion Mrays/s | obvhs occlusion | ratio |")
        print("|---|--:|--:|--:|--:|--:|--:|")
        for r in rows:
            print("| " + " | ".join(r) + " |")
        print()
    builds = subdirs("build", "vitrum load")
    builds.sort(key=lambda p: int(p) if p.isdigit() else 0)
    if builds:
        print("| triangles | obvhs CwBvh build (ms) | vitrum load: OBJ + compile + BVH (ms) |")
        print("|--:|--:|--:|")
        for p in builds:
            o, v = estimate("build", "obvhs cwbvh", p), estimate("build", "vitrum load", p)
            print(f"| {p} | {fmt(o and o * 1e3, 1)} | {fmt(v and v * 1e3, 1)} |")
        print()


def integrator_tables():
    groups = [g for g in subdirs() if g.startswith("samples_")]
    if groups:
        order = ["raycast", "whitted", "ssaa", "distributed", "path", "light", "bpt", "ppm", "bpm", "vcm"]
        found = {m for g in groups for m in subdirs(g)}
        methods = [m for m in order if m in found] + sorted(found - set(order))
        print("| scene | " + " | ".join(f"{m} (Msamples/s)" for m in methods) + " |")
        print("|---|" + "--:|" * len(methods))
        for g in groups:
            cells = [fmt(rate(estimate(g, m), throughput(g, m)) and rate(estimate(g, m), throughput(g, m)) / 1e6, 3)
                     for m in methods]
            print(f"| {g[len('samples_'):]} | " + " | ".join(cells) + " |")
        print()
    for g in [g for g in subdirs() if g.startswith("threads_")]:
        one, two = estimate(g, "1"), estimate(g, "2")
        n = throughput(g, "1")
        print(f"{g[len('threads_'):]}: 1 thread {fmt(rate(one, n) and rate(one, n) / 1e6, 3)} Msamples/s, "
              f"2 threads {fmt(rate(two, n) and rate(two, n) / 1e6, 3)} Msamples/s, "
              f"scaling {fmt(one / two if one and two else None)}x")
        print()


def cost_growth_table():
    methods = subdirs("cost-growth")
    if not methods:
        return
    counts = sorted({int(p) for m in methods for p in subdirs("cost-growth", m) if p.isdigit()})
    print("| triangles | " + " | ".join(f"{m} µs/sample" for m in methods) + " |")
    print("|--:|" + "--:|" * len(methods))
    for n in counts:
        cells = []
        for m in methods:
            t, e = estimate("cost-growth", m, str(n)), throughput("cost-growth", m, str(n))
            cells.append(fmt(t and e and t / e * 1e6, 3))
        print(f"| {n} | " + " | ".join(cells) + " |")
    print()


if __name__ == "__main__":
    if not os.path.isdir(ROOT):
        print(f"bench_table: no criterion results in {ROOT}: run cargo bench first", file=sys.stderr)
        sys.exit(2)
    bvh_tables()
    integrator_tables()
    cost_growth_table()
