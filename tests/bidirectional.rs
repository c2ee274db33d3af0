//! The bidirectional engine (`bpt`, `ppm`, `bpm`, `vcm`) against closed forms and against `path`
//! where `path` is unbiased, plus robustness on the hard cases.

mod common;

use common::{
    block_chi2, closed_sphere, glass_furnace, hollow_spheres_with_a_quad_light, image_mean_and_error,
    render_opts, render_with_variance, toml_files,
};
use vitrum::image::Image;
use vitrum::render::RenderOptions;
use vitrum::sampler::SamplerKind;
use vitrum::scene::{load, load_str, Scene};

const METHODS: [&str; 4] = ["bpt", "ppm", "bpm", "vcm"];

/// The mean over all pixels of `k` renders equals `expected` within 4 standard errors (of the
/// render-to-render spread of the image mean).
fn assert_mean(scene: &Scene, method: &str, spp: u32, k: u64, expected: f64, what: &str) {
    let (mean, error) = image_mean_and_error(scene, method, spp, k);
    println!("{what}: mean {mean:.5} ± {error:.5}");
    assert!(
        (mean - expected).abs() <= 4.0 * error + 1e-4,
        "{what}: mean {mean} vs {expected} (standard error {error})"
    );
}

#[test]
fn a_point_light_in_a_closed_diffuse_sphere_gives_one_everywhere() {
    // Intensity π at the centre of a unit sphere of albedo ½: L = 0.5 / (1 − 0.5) = 1. The
    // radiance field is uniform, so the merge kernel adds no bias either: every method must give 1.
    let light = "[[lights]]\ntype = \"point\"\nposition = [0.0, 0.0, 0.0]\nintensity = 3.14159265";
    for method in METHODS {
        let scene = closed_sphere(method, light);
        let spp = if method == "bpm" { 64 } else { 8 };
        assert_mean(&scene, method, spp, 32, 1.0, &format!("{method}: point light in a sphere"));
    }
}

#[test]
fn an_emitting_closed_sphere_gives_one_everywhere() {
    // Emission ½ and albedo ½ on the inside: L = 0.5 / (1 − 0.5) = 1.
    for method in ["bpt", "vcm"] {
        let scene = closed_sphere(method, "emission = 0.5");
        assert_mean(&scene, method, 8, 32, 1.0, &format!("{method}: emitting sphere"));
    }
}

#[test]
fn the_white_furnace_with_smooth_and_rough_glass_stays_one() {
    // Rough glass's multiply scattered samples are followed like specular ones and never
    // connected or merged at: the furnace shows whether that rule loses or adds energy. The
    // environment is a light: light sub-paths start on it, next-event estimation samples it and
    // escaping camera paths are weighted against both.
    for roughness in [0.0, 0.3] {
        for method in METHODS {
            let scene = glass_furnace(roughness, 16);
            // Photons on rough glass are few and carry a peaked BSDF: more iterations.
            let spp = if matches!(method, "ppm" | "bpm") { 128 } else { 8 };
            assert_mean(&scene, method, spp, 32, 1.0, &format!("{method}: furnace, roughness {roughness}"));
        }
    }
}

#[test]
fn a_diffuse_sphere_under_the_environment_shows_its_albedo() {
    // A convex diffuse body sees only the sky: irradiance π·L everywhere, so its radiance is the
    // albedo times L (no interreflection). The camera sees nothing but the sphere, so light
    // tracing, which cannot see the environment itself, must give the same. Every light path
    // starts on the environment's bounding disk, every connection and merge is of sky light. The
    // sphere within a distance r of one of its points has the area π r² exactly, so the uniform
    // field carries no kernel bias at the merge radius 0.1.
    let scene = load_str(
        r#"
[camera]
position = [0.0, 0.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov = 10.0
resolution = [16, 16]
[render.ppm]
radius = 0.1
[render.bpm]
radius = 0.1
[materials.grey]
type = "diffuse"
color = 0.4
[[objects]]
shape = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "grey"
[[lights]]
type = "environment"
radiance = 1.5
"#,
        "sky-sphere",
        None,
    )
    .unwrap();
    for method in ["bpt", "ppm", "bpm", "vcm", "light", "path"] {
        assert_mean(&scene, method, 16, 32, 0.6, &format!("{method}: diffuse sphere under the sky"));
    }
}

#[test]
fn bpt_and_vcm_match_path_where_path_is_unbiased() {
    // soft-shadows has an area light: `path` is unbiased there, and so must `bpt` and `vcm` be.
    // The 8×8 block means of each agree with a `path` render in their standard errors: χ² over
    // the 16 blocks below its 99.99% quantile (about 42), so a real bias of a few percent fails.
    // hollow-spheres (glass shells with swapped indices inside) with its point light replaced by
    // a quad light of the same power (`common::hollow_spheres_with_a_quad_light`).
    // depth-of-field (a thin lens) likewise: the light connects to sampled lens points.
    let lens = std::fs::read_to_string("scenes/depth-of-field.toml").unwrap().replace(
        "type = \"point\"\nposition = [0.0, 1.8, 0.0]\nintensity = 5.0",
        "type = \"quad\"\ncorner = [-0.3, 1.98, -0.3]\nu = [0.6, 0.0, 0.0]\nv = [0.0, 0.0, 0.6]\nradiance = 13.9",
    );
    assert!(lens.contains("type = \"quad\""), "the point light of depth-of-field.toml moved");
    let scenes = [
        ("soft-shadows", load(std::path::Path::new("scenes/soft-shadows.toml")).unwrap()),
        ("hollow-spheres with a quad light", hollow_spheres_with_a_quad_light()),
        ("depth-of-field with a quad light", load_str(&lens, "lens-quad.toml", None).unwrap()),
    ];
    for (name, scene) in &scenes {
        let reference = render_with_variance(scene, "path", 32, 1024, 71);
        for method in ["bpt", "vcm"] {
            let render = render_with_variance(scene, method, 32, 256, 5);
            let (chi2, blocks) = block_chi2(&render, &reference);
            println!("{name}, {method}: χ² {chi2:.1} over {blocks} blocks");
            assert_eq!(blocks, 16);
            assert!(chi2 < 42.0, "{name}, {method}: block χ² {chi2} over {blocks} blocks against path");
        }
    }
}

#[test]
fn photon_mapping_bias_shrinks_with_the_iterations() {
    // On soft-shadows `ppm` and `bpm` are consistent, not unbiased: the squared error of their
    // 8×8 block means against `path`, minus both variance parts, is the bias part; at 4× the
    // iterations (the radius shrinking by the Knaus–Zwicker schedule) it is lower.
    let scene = load(std::path::Path::new("scenes/soft-shadows.toml")).unwrap();
    let reference = render_with_variance(&scene, "path", 32, 1024, 71);
    for method in ["ppm", "bpm"] {
        let bias = |spp: u32| {
            let r = render_with_variance(&scene, method, 32, spp, 9);
            let (chi2, blocks) = block_chi2(&r, &reference);
            chi2 / blocks as f64
        };
        let (few, many) = (bias(16), bias(64));
        println!("{method}: block χ²/block {few:.2} at 16 iterations, {many:.2} at 64");
        assert!(many < few, "{method}: χ²/block {many} at 64 iterations, {few} at 16");
    }
}

#[test]
fn every_hard_case_stays_finite_with_every_bidirectional_method() {
    for file in toml_files(std::path::Path::new("scenes/hard")) {
        let scene = load(&file).unwrap();
        for method in METHODS {
            let integrator = vitrum::integrators::create(method).unwrap();
            let mut opts = RenderOptions::for_method(&scene, integrator.as_ref(), 2);
            opts.resolution = Some((24, 24));
            let out = render_opts(&scene, method, &opts);
            assert_eq!(out.non_finite_samples, 0, "{method} on {}: non-finite samples", file.display());
            assert!(out.image.pixels.iter().all(|p| p.is_finite() && p.min_element() >= 0.0));
        }
    }
}

#[test]
fn the_engines_light_tracing_strategy_alone_equals_light_tracing() {
    // `--strategy splat` renders the engine's connections of light vertices to the camera alone,
    // unweighted: an independent implementation of light tracing. On the thesis scene (point
    // light, glass: `light` sees the caustics, not the glass) and on soft-shadows (a quad light)
    // its 8×8 block means agree with `light`'s within their standard errors.
    for file in ["scenes/cornell-glass.toml", "scenes/soft-shadows.toml"] {
        let scene = load(std::path::Path::new(file)).unwrap();
        let light = render_with_variance(&scene, "light", 32, 512, 3);
        let integrator = vitrum::integrators::create("bpt").unwrap();
        let mut opts = RenderOptions::for_method(&scene, integrator.as_ref(), 512);
        opts.resolution = Some((32, 32));
        opts.sampler = SamplerKind::Independent;
        opts.seed = 4;
        opts.params.merging.only = Some(vitrum::integrators::Strategy::CameraSplat);
        let out = render_opts(&scene, "bpt", &opts);
        assert_eq!(out.non_finite_samples, 0);
        let splats = (out.image, out.variance.unwrap());
        let (chi2, blocks) = block_chi2(&splats, &light);
        println!("{file}: splats alone vs light: χ² {chi2:.1} over {blocks} blocks");
        assert_eq!(blocks, 16);
        assert!(chi2 < 42.0, "{file}: block χ² {chi2} over {blocks} blocks");
        let mean = |i: &Image| i.pixels.iter().map(|p| p.element_sum()).sum::<f32>();
        assert!(mean(&splats.0) > 0.0, "{file}: not a black image");
    }
}

/// The image mean of `k` independent renders of `scene` by `method` at 32×32 with `max_light_paths`
/// light paths per iteration at most, and its standard error (of the spread of the renders' means).
fn capped_image_mean(scene: &Scene, method: &str, spp: u32, k: u64, max_light_paths: u32) -> (f64, f64) {
    let integrator = vitrum::integrators::create(method).unwrap();
    let means: Vec<f64> = (0..k)
        .map(|seed| {
            let mut opts = RenderOptions::for_method(scene, integrator.as_ref(), spp);
            opts.resolution = Some((32, 32));
            opts.sampler = SamplerKind::Independent;
            opts.seed = 300 + seed;
            opts.params.merging.max_light_paths = max_light_paths;
            let out = render_opts(scene, method, &opts);
            assert_eq!(out.non_finite_samples, 0, "{method}: non-finite samples");
            let image = out.image;
            image.pixels.iter().map(|p| p.element_sum() as f64).sum::<f64>() / (3 * image.pixels.len()) as f64
        })
        .collect();
    let mean = means.iter().sum::<f64>() / k as f64;
    let var = means.iter().map(|m| (m - mean) * (m - mean)).sum::<f64>() / (k - 1) as f64;
    (mean, (var / k as f64).sqrt())
}

#[test]
fn capped_light_paths_keep_the_estimate_unbiased() {
    // 256 light paths for the 1024 pixels of a 32×32 image: camera path j connects to light
    // path j mod 256, merges with the photons of the 256 and the splats are normalised by 256.
    // On soft-shadows (a quad light: `path` is unbiased) the capped `bpt` and `vcm` agree with
    // `path`: the image means of 32 renders within 4 standard errors of their difference, and
    // the 8×8 block means within their standard errors (χ² below 42 over 16 blocks, as in
    // `bpt_and_vcm_match_path_where_path_is_unbiased`; a camera path and its light path's other
    // partners are 8 rows apart, in other blocks).
    const CAP: u32 = 256;
    let scene = load(std::path::Path::new("scenes/soft-shadows.toml")).unwrap();
    let merging = vitrum::params::MergeParams { max_light_paths: CAP, ..Default::default() };
    assert_eq!(
        vitrum::integrators::light_paths_per_iteration(32 * 32, &merging),
        CAP as usize,
        "the cap binds"
    );
    let (path_mean, path_error) = capped_image_mean(&scene, "path", 16, 32, CAP);
    let reference = render_with_variance(&scene, "path", 32, 1024, 71);
    for method in ["bpt", "vcm"] {
        let (mean, error) = capped_image_mean(&scene, method, 16, 32, CAP);
        let se = (error * error + path_error * path_error).sqrt();
        println!(
            "{method}, {CAP} light paths: mean {mean:.5} ± {error:.5}, path {path_mean:.5} ± {path_error:.5}"
        );
        assert!((mean - path_mean).abs() <= 4.0 * se, "{method}: mean {mean} vs path {path_mean} (SE {se})");
        let integrator = vitrum::integrators::create(method).unwrap();
        let mut opts = RenderOptions::for_method(&scene, integrator.as_ref(), 256);
        opts.resolution = Some((32, 32));
        opts.sampler = SamplerKind::Independent;
        opts.seed = 5;
        opts.params.merging.max_light_paths = CAP;
        let out = render_opts(&scene, method, &opts);
        let (chi2, blocks) = block_chi2(&(out.image, out.variance.unwrap()), &reference);
        println!("{method}, {CAP} light paths: χ² {chi2:.1} over {blocks} blocks against path");
        assert_eq!(blocks, 16);
        assert!(chi2 < 42.0, "{method}: block χ² {chi2} over {blocks} blocks against path");
    }
}

#[test]
fn the_default_merge_radius_follows_the_pixel_footprint_above_256_squared() {
    use vitrum::integrators::{initial_radius, DEFAULT_RADIUS_FRACTION};
    let scene = load(std::path::Path::new("scenes/cornell-glass.toml")).unwrap();
    let merging = vitrum::params::MergeParams::default();
    let (lo, hi) = scene.bvh_stats.bounds;
    let scene_rule = DEFAULT_RADIUS_FRACTION * (hi - lo).length();
    let at = |w, h| initial_radius(&scene, &merging, Some((w, h)));
    assert_eq!(at(32, 32), scene_rule, "small images keep the scene-size rule");
    assert_eq!(at(256, 256), scene_rule);
    for (size, factor) in [(512, 0.5), (1024, 0.25), (4096, 1.0 / 16.0)] {
        let r = at(size, size);
        assert!((r / scene_rule - factor).abs() < 1e-5, "{size}²: radius {r} vs {factor} of {scene_rule}");
    }
    let explicit = vitrum::params::MergeParams { radius: Some(0.05), ..merging };
    assert_eq!(initial_radius(&scene, &explicit, Some((4096, 4096))), 0.05, "an explicit radius wins");
}
