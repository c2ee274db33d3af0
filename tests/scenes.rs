//! Every shipped scene parses, compiles and renders at 64×64 with every integrator, every pixel
//! finite; the embedded default scene is `scenes/cornell-glass.toml`; and each method reads its
//! own settings from its `[render.METHOD]` table.

mod common;

use std::path::Path;
use vitrum::integrators::{self, create};
use vitrum::render::{render, RenderOptions};
use vitrum::scene::{self, desc, load_str};

#[test]
fn every_scene_renders_finite_with_every_integrator() {
    let files = common::toml_files(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes")));
    assert!(files.len() >= 5, "expected the shipped scenes, found {files:?}");
    for file in files {
        let scene = scene::load(&file).unwrap_or_else(|e| panic!("{e}"));
        assert!(!scene.lights.is_empty(), "{}: no lights", file.display());
        for integrator in integrators::all() {
            // The method's own settings, as `vitrum render -i METHOD` takes them.
            let opts = RenderOptions {
                resolution: Some((64, 64)),
                params: scene.settings.params(integrator.as_ref(), None),
                ..RenderOptions::from_scene(&scene, 1)
            };
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

#[test]
fn every_scene_file_of_the_repository_parses() {
    // The hard cases and the scripts' scenes too (the hard cases render in `hard_cases.rs`).
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dirs = ["scenes", "scenes/hard", "scripts/reference"];
    let files: Vec<_> = dirs.iter().flat_map(|d| common::toml_files(&root.join(d))).collect();
    assert!(files.len() >= 30, "{files:?}");
    for file in files {
        scene::load(&file).unwrap_or_else(|e| panic!("{e}"));
    }
}

/// A small scene with `render` as its `[render]` tables.
fn with_render(render: &str) -> Result<scene::Scene, scene::SceneError> {
    let text = format!(
        "[camera]\nposition = [0.0, 0.0, 3.0]\nlook_at = [0.0, 0.0, 0.0]\nresolution = [4, 4]\n{render}\n\
         [materials.grey]\ntype = \"diffuse\"\n[[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\n\
         radius = 1.0\nmaterial = \"grey\"\n[[lights]]\ntype = \"environment\"\nradiance = 1.0\n"
    );
    load_str(&text, "methods.toml", None)
}

#[test]
fn each_method_reads_its_own_depth_and_the_command_line_overrides_it() {
    let scene = with_render(
        "[render]\nintegrator = \"ssaa\"\n[render.whitted]\nmax_depth = 7\n[render.path]\nmax_depth = 9\n\
         [render.ssaa]\nmax_depth = 3\nlevels = 2\n[render.raycast]\n",
    )
    .unwrap();
    let depth = |name: &str, cli: Option<u32>| scene.settings.max_depth(create(name).unwrap().as_ref(), cli);
    // The scene's table, else the method's own default (5; 256 for path and light).
    let expected =
        [("raycast", 5), ("whitted", 7), ("ssaa", 3), ("distributed", 5), ("path", 9), ("light", 256)];
    for (name, d) in expected {
        assert_eq!(depth(name, None), d, "{name}");
        assert_eq!(depth(name, Some(2)), 2, "{name}: --max-depth wins");
    }
    assert_eq!(scene.settings.ssaa.levels, 2);
    // `from_scene` is for the scene's own integrator (`ssaa` here).
    assert_eq!(RenderOptions::from_scene(&scene, 1).params.max_depth, 3);
    let ssaa = scene.settings.params(create("ssaa").unwrap().as_ref(), None);
    assert_eq!((ssaa.max_depth, ssaa.ssaa.levels), (3, 2));
}

#[test]
fn every_integrator_has_a_table_that_takes_a_depth_exactly_when_it_has_one() {
    assert_eq!(integrators::names(), desc::METHOD_TABLES, "one [render.METHOD] table per integrator");
    for name in integrators::names() {
        assert!(with_render(&format!("[render.{name}]\n")).is_ok(), "{name}: an empty table");
        let depth = with_render(&format!("[render.{name}]\nmax_depth = 4\n"));
        assert_eq!(depth.is_ok(), desc::has_max_depth(name), "{name}: {:?}", depth.err());
        let err = with_render(&format!("[render.{name}]\nsamples = 4\n")).err().expect("refused");
        assert!(err.to_string().contains("unknown field `samples`"), "{name}: {err}");
    }
}

#[test]
fn the_shipped_scenes_cut_only_the_whitted_style_methods() {
    // `[render] max_depth` cut every method, the reference `path` included; now each scene sets
    // the depth of the recursive methods only, and `path` and `light` trace to 256.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for dir in ["scenes", "scenes/hard"] {
        for file in common::toml_files(&root.join(dir)) {
            let scene = scene::load(&file).unwrap();
            for name in ["path", "light"] {
                let depth = scene.settings.max_depth(create(name).unwrap().as_ref(), None);
                assert_eq!(depth, 256, "{}: {name}", file.display());
            }
        }
    }
    let cornell = scene::load_default();
    assert_eq!(cornell.settings.max_depths.get("whitted"), Some(&5));
}
