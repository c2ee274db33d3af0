//! What image textures cost where a scene has them: `path` and `whitted` on `textured-box` (tiled
//! floor, plastered walls, a poster: every diffuse hit reads a bilinear texel) against the same box
//! with each texture replaced by its mean colour. Where a scene has no textures they cost
//! nothing: compare `cornell-glass` across commits with `scripts/perf/ab_speed.py` (see
//! docs/architecture.md). Run with `cargo bench --bench texture_cost`.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::path::Path;
use vitrum::integrators::create;
use vitrum::material::{Bsdf, Texture};
use vitrum::render::{render, RenderOptions};
use vitrum::scene::{load_str, Scene};

const SCENE: &str = include_str!("../scenes/textured-box.toml");
const SIDE: u32 = 96;
const SPP: u32 = 4;

/// The compiled box with every image texture replaced by its mean texel: the same mean albedo
/// (so paths bounce about as often), no texel lookups.
fn with_mean_colours(scene: &mut Scene) {
    for m in &mut scene.materials {
        let t = match &mut m.bsdf {
            Bsdf::Diffuse { albedo: t, .. } | Bsdf::Mirror { color: t, .. } => t,
            Bsdf::Conductor(_)
            | Bsdf::Dielectric { .. }
            | Bsdf::ThinDielectric { .. }
            | Bsdf::Plastic { .. }
            | Bsdf::RoughPlastic { .. } => continue,
        };
        if let Texture::Image(_) = t {
            *t = Texture::Constant(t.mean());
        }
    }
}

fn bench(c: &mut Criterion) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let textured = load_str(SCENE, "textured-box", Some(&dir)).unwrap();
    let mut constant = load_str(SCENE, "textured-box", Some(&dir)).unwrap();
    with_mean_colours(&mut constant);
    assert!(constant
        .materials
        .iter()
        .all(|m| !matches!(m.bsdf, Bsdf::Diffuse { albedo: Texture::Image(_), .. })));
    for method in ["path", "whitted"] {
        let integrator = create(method).unwrap();
        let mut group = c.benchmark_group(format!("textured-box {method} {SIDE}x{SIDE} {SPP}spp"));
        group.sample_size(10);
        for (name, scene) in [("image textures", &textured), ("mean colours", &constant)] {
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
