//! How the cost of a sample grows with the scene: time per camera sample of `raycast` (one ray)
//! and `path` on terrains of 8 to about 10⁶ triangles. A BVH makes it grow with the logarithm of
//! the primitive count, not linearly: on log-log axes a slope near 0, where a linear search
//! would have slope 1.
//!
//! Run with `cargo bench --bench cost_growth`. After measuring it writes the log-log plot of
//! time per sample against triangles (least-squares slope in the legend) to
//! `target/criterion/cost-growth.svg` and `.png`, from criterion's estimates.

use criterion::{BenchmarkId, Criterion, Throughput};
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Duration;
use vitrum::figure::plot::{write_loglog, LogLogPlot, Series};
use vitrum::integrators::create;
use vitrum::render::{render, RenderOptions};
use vitrum::scene;

mod common;
use common::{terrain, write_terrain_scene};

/// Triangle counts asked for (the terrains have 8, 98, 968, … 999,698).
const TRIANGLES: [usize; 6] = [10, 100, 1_000, 10_000, 100_000, 1_000_000];

/// Image side and samples per pixel of a measured render.
const SIDE: u32 = 96;
const SPP: u32 = 4;

/// The integrators measured.
const METHODS: [&str; 2] = ["raycast", "path"];

/// Criterion's output folder.
fn criterion_dir() -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("target"));
    target.join("criterion")
}

fn cost_growth(c: &mut Criterion) -> Vec<(String, Vec<(f64, usize)>)> {
    let dir = tempfile::tempdir().unwrap();
    let mut group = c.benchmark_group("cost-growth");
    group.sample_size(10).warm_up_time(Duration::from_secs(1));
    let mut counts = Vec::new();
    for triangles in TRIANGLES {
        let (vertices, faces) = terrain(triangles);
        let scene = scene::load(&write_terrain_scene(dir.path(), &vertices, &faces)).unwrap();
        counts.push(faces.len());
        for name in METHODS {
            let method = create(name).unwrap();
            let mut opts = RenderOptions::from_scene(&scene, SPP);
            opts.resolution = Some((SIDE, SIDE));
            opts.params.max_depth = 5;
            group.throughput(Throughput::Elements((SIDE * SIDE * SPP) as u64));
            group.bench_with_input(BenchmarkId::new(name, faces.len()), &opts, |b, opts| {
                b.iter(|| render(&scene, method.as_ref(), black_box(opts), &|_, _| {}))
            });
        }
    }
    group.finish();
    METHODS.iter().map(|m| (m.to_string(), counts.iter().map(|&n| (0.0, n)).collect())).collect()
}

/// The mean time of one benchmark (nanoseconds), from criterion's estimates.
fn mean_ns(method: &str, triangles: usize) -> Option<f64> {
    let path = criterion_dir()
        .join("cost-growth")
        .join(method)
        .join(triangles.to_string())
        .join("new/estimates.json");
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path).ok()?).ok()?;
    json["mean"]["point_estimate"].as_f64()
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let measured = cost_growth(&mut c);
    c.final_summary();
    let series: Vec<Series> = measured
        .iter()
        .map(|(name, points)| Series {
            name: name.clone(),
            points: points
                .iter()
                .filter_map(|&(_, n)| {
                    mean_ns(name, n).map(|ns| (n as f64, ns / 1e3 / (SIDE * SIDE * SPP) as f64))
                })
                .collect(),
            intervals: Vec::new(),
            legend: None,
        })
        .collect();
    if series.iter().any(|s| s.points.len() < 2) {
        return; // a filtered or test run: nothing to plot
    }
    for s in &series {
        for (n, us) in &s.points {
            println!("cost-growth: {} {n} triangles: {us:.3} µs per sample", s.name);
        }
    }
    let title = format!("time per sample ({SIDE}×{SIDE}, {SPP} spp, all cores)");
    let plot = LogLogPlot { title: &title, x_label: "triangles", y_label: "µs per sample", series: &series };
    let dir = criterion_dir();
    write_loglog(&plot, &dir.join("cost-growth.svg"), &dir.join("cost-growth.png")).unwrap();
    println!("cost-growth: plot written to {}", dir.join("cost-growth.png").display());
}
