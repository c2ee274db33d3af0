//! `path`'s wavefront engine against its scalar engine (`--engine scalar`), on the scenes where
//! every stage runs across lanes (`soft-shadows`) and where only the hits and shadow rays do
//! (`cornell-glass`, a point light): 200×200, 8 samples, 16 bounces (as
//! `scripts/perf/mitsuba_speed.py` renders), both threads.
//!
//! Run with `cargo bench --bench wavefront` (`VITRUM_ISA=avx2` for the AVX2 kernels on an
//! AVX-512 machine): criterion's estimates, then per scene a `wavefront-ratio:` line (scalar
//! time ÷ wavefront time, measured in alternating pairs, with the images checked equal to the
//! bit) and a `wavefront-occupancy:` line (the lanes used of those issued by the hit and the
//! shadow-ray stages).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::path::Path;
use std::sync::Arc;
use vitrum::integrators::{create, EngineOption, Wavefront};
use vitrum::lanes::Isa;
use vitrum::render::{camera_film, camera_film_on, EngineChoice, RenderOptions};
use vitrum::scene::{load, Scene};

mod common;
use common::paired_ratio;

const SIZE: u32 = 200;
const SPP: u32 = 8;
const DEPTH: u32 = 16;

fn options(scene: &Scene, engine: EngineOption) -> RenderOptions {
    let path = create("path").unwrap();
    let mut opts = RenderOptions::for_method(scene, path.as_ref(), SPP);
    opts.resolution = Some((SIZE, SIZE));
    opts.params.max_depth = DEPTH;
    opts.params.engine = engine;
    opts
}

fn render(scene: &Scene, opts: &RenderOptions) -> vitrum::render::Film {
    camera_film(scene, create("path").unwrap().as_ref(), opts, &|_, _| {})
}

fn bench(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut group = c.benchmark_group("wavefront");
    group.sample_size(10);
    group.throughput(Throughput::Elements(SIZE as u64 * SIZE as u64 * SPP as u64));
    let mut lines = Vec::new();
    for name in ["soft-shadows", "cornell-glass"] {
        let scene = load(&root.join(format!("{name}.toml"))).unwrap();
        let (scalar, wavefront) =
            (options(&scene, EngineOption::Scalar), options(&scene, EngineOption::Wavefront));
        let engine = create("path").unwrap().engine(&scene, &wavefront).describe();
        group.bench_function(format!("{name}/scalar"), |b| b.iter(|| render(&scene, &scalar)));
        group.bench_function(format!("{name}/wavefront"), |b| b.iter(|| render(&scene, &wavefront)));
        // The engine's own statistics: it is held here to read them after the render.
        let held = Arc::new(Wavefront::new(&scene, &wavefront));
        let on_held = EngineChoice::shared(held.clone(), "held by the bench");
        let path = create("path").unwrap();
        let a = render(&scene, &scalar);
        let b = camera_film_on(&scene, path.as_ref(), &wavefront, on_held, &|_, _| {});
        assert_eq!(a.sum, b.sum, "{name}: the engines' images differ");
        let (median, low, high) =
            paired_ratio(6, || drop(render(&scene, &scalar)), || drop(render(&scene, &wavefront)));
        lines.push(format!(
            "wavefront-ratio: {name}: scalar / wavefront = {median:.2} (range {low:.2}-{high:.2}; {}; {engine})",
            Isa::detect().name()
        ));
        let o = held.occupancy();
        lines.push(format!(
            "wavefront-occupancy: {name}: hits {:.3} ({} of {} lanes), shadow rays {:.3} ({} of {})",
            o.closest.fraction(),
            o.closest.used,
            o.closest.issued,
            o.shadow.fraction(),
            o.shadow.used,
            o.shadow.issued
        ));
    }
    group.finish();
    for line in lines {
        println!("{line}");
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
