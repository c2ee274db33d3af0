//! Shape tests across rays (`vitrum::lanes`, the first kernels of issue 20's wavefront engine)
//! against the scalar tests they reproduce bit for bit: the closest hit among the quads and
//! spheres of `soft-shadows` (its walls, light and glass sphere; the cylinder is left out, it has
//! no lane kernel yet), one ray at a time against 16 rays per call, on the same rays.
//!
//! Run with `cargo bench --bench lanes`. Besides criterion's estimates, a `lanes-ratio:` line per
//! instruction set gives scalar time ÷ lane time, measured in alternating pairs.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;
use std::hint::black_box;
use std::path::Path;
use vitrum::geometry::{Quad, Ray, Shape, Sphere};
use vitrum::lanes::{quad_hits, sphere_hits, Isa, Lanes, RayLanes, WIDTH};

/// Rays per measured batch.
const RAYS: usize = 65_536;

/// The quads and spheres of soft-shadows.
fn shapes() -> (Vec<Quad>, Vec<Sphere>) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let scene = vitrum::scene::load(&root.join("soft-shadows.toml")).unwrap();
    let mut quads = Vec::new();
    let mut spheres = Vec::new();
    for p in &scene.primitives {
        match &p.shape {
            Shape::Quad(q) => quads.push(**q),
            Shape::Sphere(s) => spheres.push(**s),
            _ => {}
        }
    }
    (quads, spheres)
}

/// Rays from inside the box in uniform directions, as the bounces of a path are.
fn rays() -> Vec<Ray> {
    let mut rng = Pcg32::seed_from_u64(3);
    (0..RAYS)
        .map(|_| {
            let o = Vec3::new(
                rng.random::<f32>() * 1.8 - 0.9,
                rng.random::<f32>() * 1.8 + 0.1,
                rng.random::<f32>() * 1.8 - 0.9,
            );
            let d =
                Vec3::new(rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5);
            Ray::new(o, d.normalize_or(Vec3::Y))
        })
        .collect()
}

/// The nearest hit of every ray, one ray at a time; returns the sum of the finite distances.
fn scalar(quads: &[Quad], spheres: &[Sphere], rays: &[Ray]) -> f32 {
    let mut sum = 0.0;
    for r in rays {
        let mut t = f32::INFINITY;
        for q in quads {
            t = q.intersect(r, 0.0, t).unwrap_or(t);
        }
        for s in spheres {
            t = s.intersect(r, 0.0, t).unwrap_or(t);
        }
        if t.is_finite() {
            sum += t;
        }
    }
    sum
}

/// The same, 16 rays per call with `isa`.
fn lanes(isa: Isa, quads: &[Quad], spheres: &[Sphere], batches: &[RayLanes]) -> f32 {
    let mut sum = 0.0;
    for rays in batches {
        let mut t: Lanes = [f32::INFINITY; WIDTH];
        for q in quads {
            let hit = quad_hits(isa, q, rays, 0.0, &t);
            t = std::array::from_fn(|k| hit[k].min(t[k]));
        }
        for s in spheres {
            let hit = sphere_hits(isa, s, rays, 0.0, &t);
            t = std::array::from_fn(|k| hit[k].min(t[k]));
        }
        // Lane by lane, in ray order: the scalar loop's sum, to the bit.
        for t in t.into_iter().filter(|t| t.is_finite()) {
            sum += t;
        }
    }
    sum
}

/// Scalar time ÷ lane time in alternating pairs: median and range over `rounds` pairs.
fn paired_ratio(rounds: usize, mut a: impl FnMut(), mut b: impl FnMut()) -> (f64, f64, f64) {
    let time = |f: &mut dyn FnMut()| {
        let start = std::time::Instant::now();
        f();
        start.elapsed().as_secs_f64()
    };
    let mut ratios: Vec<f64> = (0..rounds)
        .map(|k| {
            let (ta, tb) = if k % 2 == 0 {
                let ta = time(&mut a);
                (ta, time(&mut b))
            } else {
                let tb = time(&mut b);
                (time(&mut a), tb)
            };
            ta / tb
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    (ratios[rounds / 2], ratios[0], ratios[rounds - 1])
}

fn bench(c: &mut Criterion) {
    let (quads, spheres) = shapes();
    let rays = rays();
    let batches: Vec<RayLanes> = rays.chunks(WIDTH).map(RayLanes::gather).collect();
    let mut group = c.benchmark_group("lanes soft-shadows closest");
    group.throughput(Throughput::Elements(rays.len() as u64));
    group.bench_function("scalar", |b| b.iter(|| scalar(&quads, &spheres, black_box(&rays))));
    for isa in Isa::available() {
        group.bench_function(format!("{isa:?}"), |b| {
            b.iter(|| lanes(isa, &quads, &spheres, black_box(&batches)))
        });
    }
    group.finish();
    if std::env::args().any(|a| a == "--test" || a == "--list") {
        return;
    }
    // The two give the same hits (the lanes are the scalar tests bit for bit), so the same sum.
    let reference = scalar(&quads, &spheres, &rays);
    for isa in Isa::available() {
        assert_eq!(lanes(isa, &quads, &spheres, &batches).to_bits(), reference.to_bits(), "{isa:?}");
        let (median, lo, hi) = paired_ratio(
            15,
            || {
                black_box(scalar(&quads, &spheres, &rays));
            },
            || {
                black_box(lanes(isa, &quads, &spheres, &batches));
            },
        );
        println!(
            "lanes-ratio: soft-shadows, {} quads and {} sphere(s), {} rays: scalar / {isa:?} lanes = {median:.2} \
             (median of 15 pairs, range {lo:.2}..{hi:.2})",
            quads.len(),
            spheres.len(),
            rays.len()
        );
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
