//! What an effect costs when the scene does not call for it: `distributed` on `soft-shadows`
//! in automatic mode (RGB: nothing disperses) against spectral mode forced on; and the same scene
//! with a thin lens and motion that are declared but have zero aperture and zero velocity,
//! against the plain scene. Run with `cargo bench --bench effects_cost`.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use vitrum::integrators::create;
use vitrum::render::{render, RenderOptions};
use vitrum::scene::{load_str, Scene, SpectralMode};

const SCENE: &str = include_str!("../scenes/soft-shadows.toml");
const SIDE: u32 = 96;
const SPP: u32 = 4;

/// The scene text with a zero-aperture lens, an open shutter and zero velocity on every object.
fn with_inert_lens_and_motion(text: &str) -> String {
    text.replace("[camera]\n", "[camera]\naperture = 0.0\nfocus_distance = 3.8\nshutter = [0.0, 1.0]\n")
        .replace("[[objects]]\n", "[[objects]]\nvelocity = [0.0, 0.0, 0.0]\n")
}

fn bench(c: &mut Criterion) {
    let plain = load_str(SCENE, "soft-shadows", None).unwrap();
    let inert_text = with_inert_lens_and_motion(SCENE);
    let inert = load_str(&inert_text, "soft-shadows (inert lens and motion)", None).unwrap();
    assert!(inert_text.contains("velocity") && inert.effects == plain.effects);
    let distributed = create("distributed").unwrap();
    let mut group = c.benchmark_group("soft-shadows distributed 96x96 4spp");
    group.sample_size(10);
    let variants: [(&str, &Scene, SpectralMode); 3] = [
        ("plain (auto: RGB)", &plain, SpectralMode::Auto),
        ("spectral forced on", &plain, SpectralMode::On),
        ("zero aperture + zero velocity declared", &inert, SpectralMode::Auto),
    ];
    for (name, scene, spectral) in variants {
        let opts = RenderOptions {
            resolution: Some((SIDE, SIDE)),
            spectral,
            ..RenderOptions::from_scene(scene, SPP)
        };
        group.bench_function(name, |b| {
            b.iter(|| render(scene, distributed.as_ref(), black_box(&opts), &|_, _| {}))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
