//! Every shipped scene parses, compiles and renders at 64×64 with every integrator, every pixel
//! finite; and the embedded default scene is `scenes/cornell-glass.toml`.

mod common;

use vitrum::integrators;
use vitrum::render::{render, RenderOptions};
use vitrum::scene;

#[test]
fn every_scene_renders_finite_with_every_integrator() {
    let files = common::toml_files(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes")));
    assert!(files.len() >= 5, "expected the shipped scenes, found {files:?}");
    for file in files {
        let scene = scene::load(&file).unwrap_or_else(|e| panic!("{e}"));
        assert!(!scene.lights.is_empty(), "{}: no lights", file.display());
        for integrator in integrators::all() {
            let opts = RenderOptions { resolution: Some((64, 64)), ..RenderOptions::from_scene(&scene, 1) };
            let out = render(&scene, integrator.as_ref(), &opts, &|_, _| {});
            assert_eq!(out.image.pixels.len(), 64 * 64);
            assert_eq!(out.non_finite_samples, 0, "{} with {}", file.display(), integrator.name());
            assert_eq!(out.image.non_finite_count(), 0);
            let mean: f32 = out.image.pixels.iter().map(|p| p.element_sum()).sum::<f32>() / (3.0 * 4096.0);
            assert!(mean > 1e-3, "{} with {} renders black", file.display(), integrator.name());
        }
    }
}

#[test]
fn the_embedded_default_is_cornell_glass() {
    let on_disk =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-glass.toml")).unwrap();
    assert_eq!(on_disk, scene::DEFAULT_SCENE);
    let s = scene::load_default();
    assert_eq!((s.camera.width, s.camera.height), (800, 800));
    assert_eq!(s.settings.integrator, "whitted");
}
