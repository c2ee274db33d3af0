//! What image textures cost where a scene has them: `path` and `whitted` on `textured-box` (tiled
//! floor, plastered walls, a poster: every diffuse hit reads a bilinear texel) against the same box
//! with each texture replaced by one constant colour. Where a scene has no textures they cost
//! nothing: compare `cornell-glass` across commits with `scripts/perf/ab_speed.py` (see
//! docs/architecture.md). Run with `cargo bench --bench texture_cost`.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::path::Path;
use vitrum::integrators::create;
use vitrum::render::{render, RenderOptions};
use vitrum::scene::load_str;

const SCENE: &str = include_str!("../scenes/textured-box.toml");
const SIDE: u32 = 96;
const SPP: u32 = 4;

/// The box with every `texture = { type = "image", … }` line replaced by a constant colour.
fn with_constant_colours(text: &str) -> String {
    text.lines()
        .map(|line| if line.starts_with("texture = { type = \"image\"") { "color = 0.6" } else { line })
        .collect::<Vec<_>>()
        .join("\n")
}

fn bench(c: &mut Criterion) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let textured = load_str(SCENE, "textured-box", Some(&dir)).unwrap();
    let constant_text = with_constant_colours(SCENE);
    let constant = load_str(&constant_text, "textured-box (constant colours)", Some(&dir)).unwrap();
    assert!(!constant_text.contains("type = \"image\""));
    assert_eq!(textured.primitives.len(), constant.primitives.len());
    for method in ["path", "whitted"] {
        let integrator = create(method).unwrap();
        let mut group = c.benchmark_group(format!("textured-box {method} {SIDE}x{SIDE} {SPP}spp"));
        group.sample_size(10);
        for (name, scene) in [("image textures", &textured), ("constant colours", &constant)] {
            let opts =
                RenderOptions { resolution: Some((SIDE, SIDE)), ..RenderOptions::from_scene(scene, SPP) };
            group.bench_function(name, |b| {
                b.iter(|| render(scene, integrator.as_ref(), black_box(&opts), &|_, _| {}))
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
