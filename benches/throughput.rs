//! Ray throughput on the default scene (`cornell-glass`): primary rays (closest hit only) and
//! complete Whitted renders. Run with `cargo bench --bench throughput`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec2;
use std::hint::black_box;
use vitrum::integrators::create;
use vitrum::render::{render, RenderOptions};
use vitrum::scene::load_default;

const SIDE: u32 = 200;

fn primary_rays(c: &mut Criterion) {
    let scene = load_default();
    let camera = vitrum::render::camera_for(&scene, Some((SIDE, SIDE)));
    let rays: Vec<_> = (0..SIDE * SIDE)
        .map(|i| camera.generate_ray(Vec2::new((i % SIDE) as f32 + 0.5, (i / SIDE) as f32 + 0.5)))
        .collect();
    let mut group = c.benchmark_group("cornell-glass");
    group.throughput(Throughput::Elements(rays.len() as u64));
    group.bench_function("primary rays, closest hit, 1 thread", |b| {
        b.iter(|| rays.iter().filter(|r| scene.intersect(black_box(r), f32::INFINITY).is_some()).count())
    });
    group.finish();
}

fn whitted_render(c: &mut Criterion) {
    let scene = load_default();
    let mut group = c.benchmark_group("cornell-glass");
    group.sample_size(10);
    for name in ["raycast", "whitted"] {
        let integrator = create(name).unwrap();
        let opts = RenderOptions { resolution: Some((SIDE, SIDE)), ..RenderOptions::from_scene(&scene, 1) };
        // Throughput in rays of every kind, measured once (the count is deterministic).
        let rays = render(&scene, integrator.as_ref(), &opts, &|_, _| {}).rays.total();
        group.throughput(Throughput::Elements(rays));
        group.bench_function(format!("{name} render {SIDE}x{SIDE}, all threads"), |b| {
            b.iter(|| render(&scene, integrator.as_ref(), black_box(&opts), &|_, _| {}))
        });
    }
    group.finish();
}

criterion_group!(benches, primary_rays, whitted_render);
criterion_main!(benches);
