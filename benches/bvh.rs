//! The acceleration structure against its own limit: vitrum's scene queries (closest hit with
//! the full hit record, and occlusion) next to raw obvhs traversal of the same CwBvh layout with
//! obvhs's own triangle test, on the same rays, for meshes of 10³…10⁶ triangles and for the
//! analytic shipped scenes; and the build: vitrum's whole scene load (OBJ parse, compile, BVH)
//! next to obvhs's CwBvh build alone, and the load of a standard Mitsuba scene (Bitterli's
//! `water-caustic`, 103k triangles: XML read, translated, compiled; skipped without
//! `../shared/scenes/bitterli`).
//!
//! Run with `cargo bench --bench bvh`; `python3 scripts/perf/bench_table.py` turns criterion's
//! estimates into tables. One thread: the queries are what a render thread does. Because this
//! machine's speed drifts over a run, the ratios vitrum ÷ obvhs are also measured side by side in
//! alternating pairs after each mesh's criterion measurements (the `bvh-ratio:` lines, the
//! figures docs/performance.md quotes). For the analytic scenes, a `traversal-choice:` line compares the
//! BVH closest-hit query with testing every primitive in turn, one ray at a time (the loop a
//! wavefront engine would run over many rays at once; issue 20's "measure and decide").

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::{Vec3, Vec3A};
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::ray::{Ray as RawRay, RayHit};
use obvhs::triangle::Triangle as RawTriangle;
use obvhs::BvhBuildParams;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;
use vitrum::geometry::Ray;
use vitrum::scene::{self, Scene};

mod common;
use common::{closest_by_every_primitive, paired_ratio, terrain, write_terrain_scene};

/// Rays per measured batch.
const RAYS: usize = 100_000;

/// Triangle counts of the meshes (about; a terrain of n×n quads has 2n² triangles).
const TRIANGLES: [usize; 4] = [1_000, 10_000, 100_000, 1_000_000];

/// Incoherent rays through the scene's bounds: origins uniform in the bounding cube (the box
/// made cubic about its centre) grown by half its side, directions towards uniform points of the
/// cube (most rays hit, as secondary rays do; a flat box would make most rays graze the scene).
fn random_rays(lo: Vec3, hi: Vec3, seed: u64) -> Vec<Ray> {
    let mut rng = Pcg32::seed_from_u64(seed);
    let (centre, side) = (0.5 * (lo + hi), (hi - lo).max_element());
    let mut point = |grow: f32| {
        let u = Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5;
        centre + (1.0 + 2.0 * grow) * side * u
    };
    (0..RAYS)
        .map(|_| {
            let o = point(0.5);
            let target = point(0.0);
            Ray::new(o, (target - o).normalize())
        })
        .collect()
}

/// obvhs's ray for a vitrum ray (direction canonicalised: the CwBvh misses −0.0 components).
fn raw_ray(r: &Ray, tmax: f32) -> RawRay {
    RawRay::new(Vec3A::from(r.origin), Vec3A::from(r.dir) + Vec3A::ZERO, 0.0, tmax)
}

/// Closest-hit and occlusion queries of `scene` on `rays`, in the group `name`, with an
/// optional raw-obvhs baseline `raw` on the same rays.
fn queries(
    c: &mut Criterion,
    name: &str,
    parameter: &str,
    scene: &Scene,
    rays: &[Ray],
    raw: Option<&(obvhs::cwbvh::CwBvh, Vec<RawTriangle>)>,
) {
    // Occlusion rays end halfway to the closest hit (or at distance 1): half are blocked.
    let lengths: Vec<f32> =
        rays.iter().map(|r| scene.intersect(r, f32::INFINITY).map_or(1.0, |h| h.hit.t)).collect();
    let mut group = c.benchmark_group(name);
    group.throughput(Throughput::Elements(rays.len() as u64));
    group.bench_with_input(BenchmarkId::new("vitrum closest", parameter), rays, |b, rays| {
        b.iter(|| rays.iter().filter(|r| scene.intersect(black_box(r), f32::INFINITY).is_some()).count())
    });
    group.bench_with_input(BenchmarkId::new("vitrum occlusion", parameter), rays, |b, rays| {
        b.iter(|| {
            rays.iter()
                .zip(&lengths)
                .filter(|(r, &t)| scene.occluded(black_box(r), 0.75 * t, |_, _| true))
                .count()
        })
    });
    if let Some((bvh, tris)) = raw {
        group.bench_with_input(BenchmarkId::new("obvhs closest", parameter), rays, |b, rays| {
            b.iter(|| {
                rays.iter()
                    .filter(|r| {
                        let mut hit = RayHit::none();
                        bvh.ray_traverse(raw_ray(black_box(r), f32::INFINITY), &mut hit, |ray, id| {
                            tris[id].intersect(ray)
                        })
                    })
                    .count()
            })
        });
        group.bench_with_input(BenchmarkId::new("obvhs occlusion", parameter), rays, |b, rays| {
            b.iter(|| {
                rays.iter()
                    .zip(&lengths)
                    .filter(|(r, &t)| {
                        !bvh.ray_traverse_miss(raw_ray(black_box(r), 0.75 * t), |ray, id| {
                            tris[id].intersect(ray)
                        })
                    })
                    .count()
            })
        });
    }
    group.finish();
}

/// Paired ratios of vitrum's queries to raw obvhs on `rays`, printed as `bvh-ratio:` lines
/// (criterion measures each query alone; these compare them side by side).
fn print_ratios(
    label: &str,
    scene: &Scene,
    rays: &[Ray],
    lengths: &[f32],
    raw: &(obvhs::cwbvh::CwBvh, Vec<RawTriangle>),
) {
    if std::env::args().any(|a| a == "--test" || a == "--list") {
        return;
    }
    let (bvh, tris) = raw;
    let (median, lo, hi) = paired_ratio(
        15,
        || {
            black_box(rays.iter().filter(|r| scene.intersect(r, f32::INFINITY).is_some()).count());
        },
        || {
            black_box(
                rays.iter()
                    .filter(|r| {
                        let mut hit = RayHit::none();
                        bvh.ray_traverse(raw_ray(r, f32::INFINITY), &mut hit, |ray, id| {
                            tris[id].intersect(ray)
                        })
                    })
                    .count(),
            );
        },
    );
    println!("bvh-ratio: {label} closest: vitrum / obvhs = {median:.2} (median of 15 pairs, range {lo:.2}..{hi:.2})");
    let (median, lo, hi) = paired_ratio(
        15,
        || {
            black_box(
                rays.iter().zip(lengths).filter(|(r, &t)| scene.occluded(r, 0.75 * t, |_, _| true)).count(),
            );
        },
        || {
            black_box(
                rays.iter()
                    .zip(lengths)
                    .filter(|(r, &t)| {
                        !bvh.ray_traverse_miss(raw_ray(r, 0.75 * t), |ray, id| tris[id].intersect(ray))
                    })
                    .count(),
            );
        },
    );
    println!("bvh-ratio: {label} occlusion: vitrum / obvhs = {median:.2} (median of 15 pairs, range {lo:.2}..{hi:.2})");
}

fn meshes(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    for triangles in TRIANGLES {
        let (vertices, faces) = terrain(triangles);
        let path = write_terrain_scene(dir.path(), &vertices, &faces);
        let parameter = format!("{}", faces.len());
        let raw_tris: Vec<RawTriangle> = faces
            .iter()
            .map(|f| RawTriangle {
                v0: Vec3A::from(vertices[f[0]]),
                v1: Vec3A::from(vertices[f[1]]),
                v2: Vec3A::from(vertices[f[2]]),
            })
            .collect();
        // Build: obvhs's CwBvh alone (vitrum's preset), and vitrum's whole load.
        let mut group = c.benchmark_group("build");
        group.sample_size(10);
        group.bench_with_input(BenchmarkId::new("obvhs cwbvh", &parameter), &raw_tris, |b, tris| {
            b.iter(|| {
                build_cwbvh_from_tris(
                    black_box(tris),
                    BvhBuildParams::medium_build(),
                    &mut Duration::ZERO.clone(),
                )
            })
        });
        group.bench_with_input(BenchmarkId::new("vitrum load", &parameter), &path, |b, path| {
            b.iter(|| scene::load(black_box(path)).unwrap())
        });
        group.finish();

        let scene = scene::load(&path).unwrap();
        let bvh =
            build_cwbvh_from_tris(&raw_tris, BvhBuildParams::medium_build(), &mut Duration::ZERO.clone());
        // obvhs's slot order, as vitrum reorders its primitives.
        let ordered: Vec<RawTriangle> = bvh.primitive_indices.iter().map(|&i| raw_tris[i as usize]).collect();
        let (lo, hi) = scene.bvh_stats.bounds;
        let rays = random_rays(lo, hi, 7);
        let raw = (bvh, ordered);
        queries(c, "mesh", &parameter, &scene, &rays, Some(&raw));
        let lengths: Vec<f32> =
            rays.iter().map(|r| scene.intersect(r, f32::INFINITY).map_or(1.0, |h| h.hit.t)).collect();
        print_ratios(&format!("mesh {parameter} triangles"), &scene, &rays, &lengths, &raw);
    }
}

fn analytic(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    for name in ["cornell-glass", "soft-shadows"] {
        let scene = scene::load(&root.join(format!("{name}.toml"))).unwrap();
        let (lo, hi) = scene.bvh_stats.bounds;
        let rays = random_rays(lo, hi, 11);
        queries(c, "analytic", name, &scene, &rays, None);
        print_brute_force_ratio(name, &scene, &rays);
    }
}

/// The time of vitrum's BVH closest-hit query over that of [`closest_by_every_primitive`] on the same
/// rays (the `traversal-choice:` line), and how often the two disagree (they must not: the same
/// shape tests decide both).
fn print_brute_force_ratio(name: &str, scene: &Scene, rays: &[Ray]) {
    if std::env::args().any(|a| a == "--test" || a == "--list") {
        return;
    }
    let disagree = rays
        .iter()
        .filter(|r| {
            scene.intersect(r, f32::INFINITY).map(|h| h.hit.t)
                != closest_by_every_primitive(scene, r).map(|(t, _)| t)
        })
        .count();
    let (median, lo, hi) = paired_ratio(
        15,
        || {
            black_box(rays.iter().filter(|r| scene.intersect(r, f32::INFINITY).is_some()).count());
        },
        || {
            black_box(
                rays.iter()
                    .filter(|r| closest_by_every_primitive(scene, r).map(|(t, _)| t).is_some())
                    .count(),
            );
        },
    );
    println!(
        "traversal-choice: {name} ({} primitives): BVH closest / every primitive in turn = {median:.2} \
         (median of 15 pairs, range {lo:.2}..{hi:.2}); {disagree} of {} rays disagree",
        scene.primitives.len(),
        rays.len()
    );
}

/// The whole load of Bitterli's `water-caustic` from its Mitsuba 0.5 XML (read, upgraded,
/// translated to TOML, compiled, BVH built), when the shared scenes are there.
fn mitsuba_import(c: &mut Criterion) {
    let file =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes/bitterli/water-caustic/scene.xml");
    if !file.exists() {
        eprintln!("mitsuba import: skipped, {} is missing", file.display());
        return;
    }
    let mut group = c.benchmark_group("mitsuba import");
    group.sample_size(10);
    group.bench_function("water-caustic", |b| {
        b.iter(|| vitrum::scene::mitsuba::load(black_box(&file), true).unwrap())
    });
    group.finish();
}

criterion_group!(benches, meshes, analytic, mitsuba_import);
criterion_main!(benches);
