//! Effects: every shipped scene calls for exactly the effects expected of it, and a render draws
//! the lens, time and wavelength sampling dimensions only for the scenes (and modes) that need
//! them — a static, non-dispersive, pinhole scene asks the sampler for none of them.

use std::path::{Path, PathBuf};
use vitrum::integrators;
use vitrum::render::{camera_pass, DimensionRequests, RenderOptions};
use vitrum::sampler::Dim;
use vitrum::scene::{self, Scene, SpectralMode};

/// The effects each shipped scene calls for, as `Effects::names()` lists them (canonical order of
/// `Effect::ALL`: dispersion, absorption, motion-blur, depth-of-field, soft-shadows, glossy,
/// textures, meshes; `none` when empty). Every scene file must have a row.
const EXPECTED: &[(&str, &str)] = &[
    ("coloured-glass.toml", "absorption,textures"),
    ("cornell-glass.toml", "textures"),
    ("depth-of-field.toml", "depth-of-field,textures"),
    ("dispersion.toml", "dispersion,soft-shadows,textures"),
    ("drinking-glass.toml", "soft-shadows,textures"),
    ("frosted-glass.toml", "soft-shadows,glossy,textures"),
    ("glass-bowl.toml", "textures"),
    ("glass-in-sky.toml", "environment"),
    ("glass-of-water.toml", "dispersion,soft-shadows,textures"),
    ("hollow-spheres.toml", "textures"),
    ("light-through-a-door.toml", "textures"),
    ("metals.toml", "soft-shadows,glossy"),
    ("motion-blur.toml", "motion-blur,textures"),
    ("shapes-gallery.toml", "soft-shadows,textures,meshes"),
    ("small-glass-ball-far-light.toml", "textures"),
    ("smooth-glass.toml", "textures,meshes"),
    ("soft-shadows.toml", "soft-shadows,textures"),
    ("textured-box.toml", "soft-shadows,textures"),
];

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")
}

/// The scene files in `scenes/`, sorted by name.
fn scene_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(scenes_dir())
        .expect("scenes/ is readable")
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
}

fn load(name: &str) -> Scene {
    let path = scenes_dir().join(name);
    scene::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn every_shipped_scene_lists_the_expected_effects() {
    let files = scene_files();
    assert!(!files.is_empty(), "no scene files found in {}", scenes_dir().display());
    let mut missing = Vec::new();
    let mut wrong = Vec::new();
    for file in &files {
        let name = file.file_name().unwrap().to_str().unwrap();
        let Some(&(_, expected)) = EXPECTED.iter().find(|(n, _)| *n == name) else {
            missing.push(name.to_string());
            continue;
        };
        let scene = scene::load(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let actual = scene.effects.names();
        if actual != expected {
            wrong.push(format!("{name}: expected `{expected}`, got `{actual}` ({:?})", scene.effects.0));
        }
    }
    assert!(missing.is_empty(), "scenes without an expected effect list in tests/effects.rs: {missing:?}");
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    // No stale rows: every expectation names a scene that exists.
    for (name, _) in EXPECTED {
        assert!(scenes_dir().join(name).is_file(), "EXPECTED lists {name}, which is not in scenes/");
    }
}

/// Size and samples of the small renders below.
const SIZE: u32 = 16;
const SPP: u32 = 4;
/// Camera samples of one such render: every camera-sample dimension is requested this often.
const SAMPLES: u64 = (SIZE * SIZE * SPP) as u64;

/// Render `scene` with `distributed` at 16×16, 4 spp, and return the sampler requests.
fn requests(scene: &Scene, spectral: SpectralMode) -> DimensionRequests {
    let distributed = integrators::create("distributed").expect("distributed is registered");
    let opts =
        RenderOptions { resolution: Some((SIZE, SIZE)), spectral, ..RenderOptions::from_scene(scene, SPP) };
    let (out, requests) = camera_pass(scene, distributed.as_ref(), &opts, &|_, _| {});
    assert_eq!(out.image.pixels.len(), (SIZE * SIZE) as usize);
    assert_eq!(out.non_finite_samples, 0);
    requests
}

/// (lens, time, wavelength) request counts.
fn camera_dims(r: &DimensionRequests) -> (u64, u64, u64) {
    (r.get(Dim::Lens), r.get(Dim::Time), r.get(Dim::Wavelength))
}

#[test]
fn a_static_non_dispersive_pinhole_scene_draws_no_lens_time_or_wavelength() {
    let scene = load("cornell-glass.toml");
    assert!(!scene.camera.has_lens());
    let r = requests(&scene, scene.settings.spectral);
    assert_eq!(camera_dims(&r), (0, 0, 0), "{r:?}");
    // The pixel position is drawn once per camera sample.
    assert_eq!(r.get(Dim::Pixel), SAMPLES);
}

#[test]
fn each_effect_scene_draws_exactly_its_own_dimension_once_per_camera_sample() {
    for (name, expected) in [
        ("depth-of-field.toml", (SAMPLES, 0, 0)),
        ("motion-blur.toml", (0, SAMPLES, 0)),
        ("dispersion.toml", (0, 0, SAMPLES)),
    ] {
        let scene = load(name);
        let r = requests(&scene, scene.settings.spectral);
        assert_eq!(camera_dims(&r), expected, "{name}: (lens, time, wavelength) requests; all: {r:?}");
        assert_eq!(r.get(Dim::Pixel), SAMPLES, "{name}");
    }
}

#[test]
fn spectral_on_turns_on_wavelengths_for_a_non_dispersive_scene() {
    let scene = load("cornell-glass.toml");
    // From the render options...
    let r = requests(&scene, SpectralMode::On);
    assert_eq!(camera_dims(&r), (0, 0, SAMPLES), "{r:?}");
    // ...and from the scene file.
    let text = std::fs::read_to_string(scenes_dir().join("cornell-glass.toml")).unwrap();
    let text = text.replacen("[render]\n", "[render]\nspectral = \"on\"\n", 1);
    let forced = scene::load_str(&text, "cornell-glass with spectral = on", Some(&scenes_dir())).unwrap();
    assert_eq!(forced.settings.spectral, SpectralMode::On);
    assert_eq!(forced.effects.names(), "textures", "forcing spectral mode adds no effect");
    let r = requests(&forced, forced.settings.spectral);
    assert_eq!(camera_dims(&r), (0, 0, SAMPLES), "{r:?}");
    // And `off` removes them from a dispersive scene.
    let dispersion = load("dispersion.toml");
    let r = requests(&dispersion, SpectralMode::Off);
    assert_eq!(camera_dims(&r), (0, 0, 0), "{r:?}");
}

#[test]
fn a_declared_but_zero_aperture_and_velocity_cost_no_dimensions() {
    let text = std::fs::read_to_string(scenes_dir().join("cornell-glass.toml")).unwrap();
    let text = text
        .replacen("[camera]\n", "[camera]\naperture = 0.0\nfocus_distance = 3.8\nshutter = [0.0, 1.0]\n", 1)
        .replacen("name = \"glass sphere\"\n", "name = \"glass sphere\"\nvelocity = [0.0, 0.0, 0.0]\n", 1)
        .replacen("name = \"glass cylinder\"\n", "name = \"glass cylinder\"\nvelocity = [0, 0, 0]\n", 1);
    assert_eq!(text.matches("velocity").count(), 2, "the test edits both glass bodies");
    let scene = scene::load_str(&text, "cornell-glass, zero aperture and velocity", Some(&scenes_dir()))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.effects.names(), "textures");
    assert!(!scene.camera.has_lens());
    assert!(scene.primitives.iter().all(|p| p.velocity.is_none()), "a zero velocity is no motion");
    let r = requests(&scene, scene.settings.spectral);
    assert_eq!(camera_dims(&r), (0, 0, 0), "{r:?}");

    // A moving object with a closed shutter (open = close) does not blur either.
    let closed = text.replacen("shutter = [0.0, 1.0]", "shutter = [0.5, 0.5]", 1).replacen(
        "velocity = [0.0, 0.0, 0.0]",
        "velocity = [1.0, 0.0, 0.0]",
        1,
    );
    let scene = scene::load_str(&closed, "cornell-glass, closed shutter", Some(&scenes_dir()))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.effects.names(), "textures");
    let r = requests(&scene, scene.settings.spectral);
    assert_eq!(camera_dims(&r), (0, 0, 0), "{r:?}");
}
