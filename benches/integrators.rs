//! Samples per second of every integrator on `cornell-glass` and `soft-shadows` at 800×800 (all
//! threads), and the thread scaling of `path` from 1 to 2 threads.
//!
//! Run with `cargo bench --bench integrators`; throughput is in camera samples (light paths for
//! `light`), so criterion's `thrpt` is samples per second. Sampling methods render 4 samples per
//! pixel, `raycast` and `whitted` one (the pixel centre), `ssaa` its adaptive pattern; depths are
//! those of `vitrum render` (the scene's `[render.METHOD] max_depth`, else the method's default).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;
use vitrum::integrators::{self, create};
use vitrum::render::{render, RenderOptions};
use vitrum::scene::{self, Scene};

/// Image side of the measured renders.
const SIDE: u32 = 800;

fn load(name: &str) -> Scene {
    scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(format!("{name}.toml"))).unwrap()
}

/// The options of a measured render of `scene` by `integrator` at `side`×`side`: those of
/// `vitrum render SCENE -i INTEGRATOR` (the scene's `[render.METHOD]` depth, else the method's default).
fn options(scene: &Scene, integrator: &str, side: u32) -> RenderOptions {
    let spp = if matches!(integrator, "raycast" | "whitted" | "ssaa") { 1 } else { 4 };
    let mut opts = RenderOptions::from_scene(scene, spp);
    opts.resolution = Some((side, side));
    opts.params = scene.settings.params(create(integrator).unwrap().as_ref(), None);
    opts
}

fn samples_per_second(c: &mut Criterion) {
    for name in ["cornell-glass", "soft-shadows"] {
        let scene = load(name);
        let mut group = c.benchmark_group(format!("samples/{name} {SIDE}x{SIDE}"));
        group.sample_size(10).warm_up_time(Duration::from_secs(1));
        for method in integrators::all() {
            let opts = options(&scene, method.name(), SIDE);
            // The sample count of one render (deterministic): camera samples or light paths.
            let samples = render(&scene, method.as_ref(), &opts, &|_, _| {}).rays.primary;
            group.throughput(Throughput::Elements(samples));
            group.bench_function(method.name(), |b| {
                b.iter(|| render(&scene, method.as_ref(), black_box(&opts), &|_, _| {}))
            });
        }
        group.finish();
    }
}

fn thread_scaling(c: &mut Criterion) {
    let scene = load("soft-shadows");
    let path = create("path").unwrap();
    let opts = options(&scene, "path", 400);
    let samples = render(&scene, path.as_ref(), &opts, &|_, _| {}).rays.primary;
    let mut group = c.benchmark_group("threads/soft-shadows path 400x400");
    group.sample_size(10).warm_up_time(Duration::from_secs(1));
    group.throughput(Throughput::Elements(samples));
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        group.bench_with_input(BenchmarkId::from_parameter(threads), &threads, |b, _| {
            b.iter(|| pool.install(|| render(&scene, path.as_ref(), black_box(&opts), &|_, _| {})))
        });
    }
    group.finish();
}

criterion_group!(benches, samples_per_second, thread_scaling);
criterion_main!(benches);
