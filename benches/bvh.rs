//! The acceleration structure against its own limit: vitrum's scene queries (closest hit with
//! the full hit record, and occlusion) next to raw obvhs traversal of the same CwBvh layout with
//! obvhs's own triangle test, on the same rays, for meshes of 10³…10⁶ triangles and for the
//! analytic shipped scenes; and the build: vitrum's whole scene load (OBJ parse, compile, BVH)
//! next to obvhs's CwBvh build alone.
//!
//! Run with `cargo bench --bench bvh`; `python3 scripts/perf/bvh_ratios.py` turns criterion's
//! estimates into the table of ratios (vitrum ÷ raw obvhs) that the README quotes. One thread:
//! the queries are what a render thread does.

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
use common::{terrain, write_terrain_scene};

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
        queries(c, "mesh", &parameter, &scene, &rays, Some(&(bvh, ordered)));
    }
}

fn analytic(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    for name in ["cornell-glass", "soft-shadows"] {
        let scene = scene::load(&root.join(format!("{name}.toml"))).unwrap();
        let (lo, hi) = scene.bvh_stats.bounds;
        let rays = random_rays(lo, hi, 11);
        queries(c, "analytic", name, &scene, &rays, None);
    }
}

criterion_group!(benches, meshes, analytic);
criterion_main!(benches);
