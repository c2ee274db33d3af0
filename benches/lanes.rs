//! Shape tests across rays (`vitrum::lanes`, the first kernels of issue 20's wavefront engine)
//! against the scalar tests they reproduce bit for bit, and against the BVH: the closest hit, with
//! its hit record, among every primitive of `soft-shadows` (6 quads, a sphere, a cylinder and its
//! two caps) on the same rays, three ways:
//!
//! - `bvh`: vitrum's `Scene::intersect`, one ray at a time (the renderer today);
//! - `scalar`: every primitive's scalar `intersect` in turn, one ray at a time;
//! - `lanes ISA`: every primitive against 16 rays per call, compiled for that instruction set.
//!
//! The hit records of the nearest hits come from the same scalar `surface_with` in all three.
//! Run with `cargo bench --bench lanes`: criterion's estimates, then `lanes-ratio:` lines (time of
//! `bvh` and of `scalar` ÷ time of the lanes, measured in alternating pairs).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;
use std::hint::black_box;
use std::path::Path;
use vitrum::geometry::{Ray, Shape};
use vitrum::lanes::{
    cylinder_hits, disk_hits, quad_hits, sphere_hits, Isa, LaneScene, Lanes, RayLanes, WIDTH,
};
use vitrum::scene::Scene;

mod common;
use common::{closest_by_every_primitive, paired_ratio};

/// Rays per measured batch.
const RAYS: usize = 65_536;

/// Rays from inside the box in uniform directions, as the bounces of a path are.
fn rays() -> Vec<Ray> {
    let mut rng = Pcg32::seed_from_u64(3);
    let mut unit = move || rng.random::<f32>();
    (0..RAYS)
        .map(|_| {
            let o = Vec3::new(unit() * 1.8 - 0.9, unit() * 1.8 + 0.1, unit() * 1.8 - 0.9);
            let d = Vec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5);
            Ray::new(o, d.normalize_or(Vec3::Y))
        })
        .collect()
}

/// The hit record's distance of primitive `k`'s hit at `t` (what the renderer would read next).
fn record(scene: &Scene, ray: &Ray, k: usize, t: f32) -> f32 {
    scene.primitives[k].shape.surface_with(ray, t, None, false).t
}

/// Closest hits by the BVH; the sum of their distances in ray order.
fn bvh(scene: &Scene, rays: &[Ray]) -> f32 {
    rays.iter().filter_map(|r| scene.intersect(r, f32::INFINITY)).map(|h| h.hit.t).fold(0.0, |s, t| s + t)
}

/// Closest hits by every primitive in turn, one ray at a time.
fn scalar(scene: &Scene, rays: &[Ray]) -> f32 {
    rays.iter().filter_map(|r| closest_by_every_primitive(scene, r)).fold(0.0, |s, (t, _)| s + t)
}

/// One primitive against a batch.
fn hits(isa: Isa, shape: &Shape, rays: &RayLanes, tmax: &Lanes) -> Lanes {
    match shape {
        Shape::Quad(q) => quad_hits(isa, q, rays, 0.0, tmax),
        Shape::Sphere(s) => sphere_hits(isa, s, rays, 0.0, tmax),
        Shape::Cylinder(c) => cylinder_hits(isa, c, rays, 0.0, tmax),
        Shape::Disk(d) => disk_hits(isa, d, rays, 0.0, tmax),
        _ => panic!("soft-shadows has no other shapes"),
    }
}

/// Closest hits by every primitive against 16 rays per call.
fn lanes(isa: Isa, scene: &Scene, rays: &[Ray], batches: &[RayLanes]) -> f32 {
    let mut sum = 0.0;
    for (batch, packed) in rays.chunks(WIDTH).zip(batches) {
        let mut t: Lanes = [f32::INFINITY; WIDTH];
        let mut id = [usize::MAX; WIDTH];
        for (k, p) in scene.primitives.iter().enumerate() {
            let hit = hits(isa, &p.shape, packed, &t);
            for lane in 0..WIDTH {
                if hit[lane] < t[lane] {
                    (t[lane], id[lane]) = (hit[lane], k);
                }
            }
        }
        for (lane, r) in batch.iter().enumerate() {
            if id[lane] != usize::MAX {
                sum += record(scene, r, id[lane], t[lane]);
            }
        }
    }
    sum
}

fn bench(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let scene = vitrum::scene::load(&root.join("soft-shadows.toml")).unwrap();
    let rays = rays();
    let batches: Vec<RayLanes> = rays.chunks(WIDTH).map(RayLanes::gather).collect();
    let mut group = c.benchmark_group("lanes soft-shadows closest");
    group.throughput(Throughput::Elements(rays.len() as u64));
    group.bench_function("bvh", |b| b.iter(|| bvh(&scene, black_box(&rays))));
    group.bench_function("scalar", |b| b.iter(|| scalar(&scene, black_box(&rays))));
    for isa in Isa::available() {
        group.bench_function(format!("lanes {isa:?}"), |b| {
            b.iter(|| lanes(isa, &scene, &rays, black_box(&batches)))
        });
    }
    group.finish();
    if std::env::args().any(|a| a == "--test" || a == "--list") {
        return;
    }
    // The same hits every way (the lanes are the scalar tests bit for bit), summed in ray order.
    let reference = bvh(&scene, &rays);
    assert_eq!(scalar(&scene, &rays).to_bits(), reference.to_bits(), "scalar");
    for isa in Isa::available() {
        assert_eq!(lanes(isa, &scene, &rays, &batches).to_bits(), reference.to_bits(), "{isa:?}");
        let run_lanes = || {
            black_box(lanes(isa, &scene, &rays, &batches));
        };
        let (b, b_lo, b_hi) = paired_ratio(
            15,
            || {
                black_box(bvh(&scene, &rays));
            },
            run_lanes,
        );
        let (s, s_lo, s_hi) = paired_ratio(
            15,
            || {
                black_box(scalar(&scene, &rays));
            },
            run_lanes,
        );
        println!(
            "lanes-ratio: soft-shadows ({} primitives), {} rays, {isa:?}: bvh / lanes = {b:.2} ({b_lo:.2}..{b_hi:.2}), \
             scalar / lanes = {s:.2} ({s_lo:.2}..{s_hi:.2}) (medians of 15 pairs)",
            scene.primitives.len(),
            rays.len()
        );
    }
}

/// Camera rays of `scene`: a 128 × 128 image's pixel centres, row by row (neighbours in a
/// batch, as the wavefront engine's first round has them).
fn camera_rays(scene: &Scene) -> Vec<Ray> {
    let cam = &scene.camera;
    let n = 128;
    (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32 + 0.5, (i / n) as f32 + 0.5);
            cam.generate_ray(glam::Vec2::new(x / n as f32, y / n as f32))
        })
        .collect()
}

/// Closest hits by the BVH one ray at a time, with their records; the sum of the records'
/// distances in ray order.
fn one_ray(scene: &Scene, rays: &[Ray]) -> f32 {
    rays.iter().filter_map(|r| scene.intersect(r, f32::INFINITY)).map(|h| h.hit.t).fold(0.0, |s, t| s + t)
}

/// Closest hits by the lane scene (the BVH traversed by 16 rays at once), with the same records.
fn sixteen_rays(scene: &Scene, lanes: &LaneScene, rays: &[Ray], batches: &[RayLanes]) -> f32 {
    let mut sum = 0.0;
    for (batch, packed) in rays.chunks(WIDTH).zip(batches) {
        let found = lanes.closest(packed, &[f32::INFINITY; WIDTH]);
        for (k, r) in batch.iter().enumerate() {
            if found.t[k].is_finite() {
                sum += scene.record(r, found.t[k], found.primitive[k], found.bary[k]).hit.t;
            }
        }
    }
    sum
}

/// Whether each ray of `rays` is blocked within distance 1.5, one ray at a time; the count.
fn one_ray_shadows(scene: &Scene, rays: &[Ray]) -> usize {
    rays.iter().filter(|r| scene.occluded(r, 1.5, |_, _| true)).count()
}

/// The same, 16 rays at a time.
fn sixteen_shadows(lanes: &LaneScene, batches: &[RayLanes]) -> usize {
    let none = [u32::MAX; WIDTH];
    let reach = [f32::INFINITY; WIDTH];
    batches
        .iter()
        .map(|b| lanes.occluded(b, &[1.5; WIDTH], &none, &reach).iter().filter(|&&x| x).count())
        .sum()
}

/// The 16-ray BVH traversal against 16 one-ray traversals on `scenes/smooth-glass.toml` (968
/// triangles): closest hits of camera rays and of bounce-like rays (uniform directions from inside
/// the box), and shadow rays; `lanes-ratio:` lines give one-ray time ÷ 16-ray time.
fn bench_mesh(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let scene = vitrum::scene::load(&root.join("smooth-glass.toml")).unwrap();
    let sets = [("camera", camera_rays(&scene)), ("bounce", rays())];
    let quick = std::env::args().any(|a| a == "--test" || a == "--list");
    for isa in Isa::available() {
        let lanes = LaneScene::new(&scene, isa).unwrap();
        for (name, rays) in &sets {
            let batches: Vec<RayLanes> = rays.chunks(WIDTH).map(RayLanes::gather).collect();
            let mut group = c.benchmark_group(format!("lanes smooth-glass {name} {isa:?}"));
            group.throughput(Throughput::Elements(rays.len() as u64));
            group.bench_function("one ray", |b| b.iter(|| one_ray(&scene, black_box(rays))));
            group.bench_function("16 rays", |b| {
                b.iter(|| sixteen_rays(&scene, &lanes, rays, black_box(&batches)))
            });
            group.bench_function("one ray shadows", |b| b.iter(|| one_ray_shadows(&scene, black_box(rays))));
            group.bench_function("16 rays shadows", |b| {
                b.iter(|| sixteen_shadows(&lanes, black_box(&batches)))
            });
            group.finish();
            if quick {
                continue;
            }
            // The same hits either way, to the bit.
            let reference = one_ray(&scene, rays);
            assert_eq!(sixteen_rays(&scene, &lanes, rays, &batches).to_bits(), reference.to_bits());
            assert_eq!(sixteen_shadows(&lanes, &batches), one_ray_shadows(&scene, rays));
            let (h, h_lo, h_hi) = paired_ratio(
                15,
                || {
                    black_box(one_ray(&scene, rays));
                },
                || {
                    black_box(sixteen_rays(&scene, &lanes, rays, &batches));
                },
            );
            let (o, o_lo, o_hi) = paired_ratio(
                15,
                || {
                    black_box(one_ray_shadows(&scene, rays));
                },
                || {
                    black_box(sixteen_shadows(&lanes, &batches));
                },
            );
            println!(
                "lanes-ratio: smooth-glass ({} triangles), {} {name} rays, {isa:?}: closest one ray / 16 rays = \
                 {h:.2} ({h_lo:.2}..{h_hi:.2}), occluded one ray / 16 rays = {o:.2} ({o_lo:.2}..{o_hi:.2}) \
                 (medians of 15 pairs)",
                scene.primitives.len(),
                rays.len()
            );
        }
    }
}

criterion_group!(benches, bench, bench_mesh);
criterion_main!(benches);
