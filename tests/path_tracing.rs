//! `path` against analytic answers: the white furnace, a closed diffuse sphere, caustics and the
//! 1/N convergence of Monte Carlo.

mod common;

use common::{closed_sphere, glass_furnace, mean_and_error, render_with};
use glam::Vec3;
use vitrum::image::Image;
use vitrum::integrators::create;
use vitrum::render::{render, RenderOptions};
use vitrum::sampler::SamplerKind;
use vitrum::scene::load_str;

/// The mean of all pixels and channels equals `expected` within 3 standard errors, and no pixel
/// is more than 5 of its own standard errors away (a floor of 1e-4 for noise-free pixels).
fn assert_everywhere(mean: &[Vec3], error: &[Vec3], expected: f32, what: &str) {
    let n = mean.len() as f32;
    let overall = mean.iter().map(|m| m.element_sum()).sum::<f32>() / (3.0 * n);
    // Channels may be fully correlated (a grey scene): bound the error of their mean by the mean
    // of their errors; pixels are independent.
    let overall_error = (error.iter().map(|e| (e.element_sum() / 3.0).powi(2)).sum::<f32>()).sqrt() / n;
    println!("{what}: mean {overall:.5} ± {overall_error:.5}");
    assert!(
        (overall - expected).abs() <= 3.0 * overall_error + 1e-5,
        "{what}: mean {overall} vs {expected} (standard error {overall_error})"
    );
    for (i, (m, e)) in mean.iter().zip(error).enumerate() {
        let bound = 5.0 * e.max(Vec3::splat(1e-4 * expected));
        assert!(
            ((*m - Vec3::splat(expected)).abs() - bound).max_element() <= 0.0,
            "{what}: pixel {i} = {m} (standard error {e})"
        );
    }
}

#[test]
fn white_furnace_smooth_glass_sphere_renders_one() {
    let scene = glass_furnace(0.0, 24);
    let (mean, error) = mean_and_error(&scene, "path", 4, 32);
    assert_everywhere(&mean, &error, 1.0, "smooth glass furnace");
}

#[test]
fn white_furnace_rough_glass_sphere_renders_one() {
    // Single-scattering microfacet glass loses light between facets (a sphere of roughness 0.3
    // rendered 0.961); the random walk through the microsurface keeps all of it, so the furnace
    // stays white, grazing rims included. Below roughness 0.2 a sphere traps light by total
    // internal reflection for more than the 256 bounces allowed (roughness 0.1 renders 0.9993),
    // which is a depth limit, not lost energy.
    for roughness in [0.2, 0.3, 0.6, 1.0] {
        let scene = glass_furnace(roughness, 24);
        let (mean, error) = mean_and_error(&scene, "path", 4, 32);
        assert_everywhere(&mean, &error, 1.0, &format!("rough glass furnace, roughness {roughness}"));
    }
}

#[test]
fn closed_diffuse_sphere_with_emission_is_uniformly_one() {
    // L = Le + ρ·L  ⇒  L = 0.5 / (1 − 0.5) = 1 everywhere inside.
    // Inside a sphere light sampling and BSDF sampling have the same density, so every bounce
    // adds exactly ρ^k·Le and only Russian roulette is random: a skewed estimator (most paths
    // stop early, a few carry large weights), hence the many samples per batch.
    let scene = closed_sphere("path", "emission = 0.5");
    let (mean, error) = mean_and_error(&scene, "path", 32, 32);
    assert_everywhere(&mean, &error, 1.0, "emitting sphere");
}

#[test]
fn closed_diffuse_sphere_around_a_point_light_is_uniformly_one() {
    // Intensity π at the centre of a unit sphere: E = π, direct L = ρ·E/π = 0.5, and every
    // bounce adds the same fraction: L = 0.5 / (1 − 0.5) = 1.
    let scene = closed_sphere(
        "path",
        "[[lights]]\ntype = \"point\"\nposition = [0.0, 0.0, 0.0]\nintensity = 3.14159265",
    );
    let (mean, error) = mean_and_error(&scene, "path", 32, 32);
    assert_everywhere(&mean, &error, 1.0, "point light in a sphere");
}

#[test]
fn emissive_ball_lights_the_floor_as_the_closed_form() {
    // A ball of radius r and radiance L whose centre is d above a floor of albedo ρ gives the
    // point below it the irradiance π L (r/d)², so the floor's radiance is ρ L (r/d)². The ball is
    // black, so there is no interreflection, and the camera sees only a 1° patch of floor. A
    // point sampled on the far half of the ball is hidden by its near half: counting it made the
    // ball twice as bright.
    let scene = load_str(
        r#"
[camera]
position = [0.0, 0.5, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, 1.0]
fov = 1.0
resolution = [8, 8]
[render]
background = 0.0
[materials.floor]
type = "diffuse"
color = 0.5
[materials.lamp]
type = "diffuse"
color = 0.0
emission = 1.0
[[objects]]
shape = "quad"
corner = [-5.0, 0.0, -5.0]
u = [0.0, 0.0, 10.0]
v = [10.0, 0.0, 0.0]
material = "floor"
[[objects]]
shape = "sphere"
center = [0.0, 1.0, 0.0]
radius = 0.25
material = "lamp"
"#,
        "emissive-ball",
        None,
    )
    .unwrap();
    let expected = 0.5 * 0.25f32.powi(2);
    for integrator in ["path", "distributed"] {
        let (mean, error) = mean_and_error(&scene, integrator, 64, 16);
        // The patch spans ±0.0044 around the axis: the closed form varies by < 1e-4 over it.
        assert_everywhere(&mean, &error, expected, &format!("{integrator}: floor under an emissive ball"));
    }
}

/// A floor just past the focus of a glass ball lens (f = nR / 2(n − 1) = 0.45 from its centre),
/// lit by a small area light, seen from between the ball and the floor.
const CAUSTIC: &str = r#"
[camera]
position = [0.0, 0.65, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, 1.0]
fov = 150.0
resolution = [33, 33]
[materials.floor]
type = "diffuse"
color = 0.8
[materials.glass]
type = "dielectric"
ior = 1.5
[[objects]]
shape = "quad"
corner = [-5.0, 0.5, -5.0]
u = [0.0, 0.0, 10.0]
v = [10.0, 0.0, 0.0]
material = "floor"
[[objects]]
shape = "sphere"
center = [0.0, 1.0, 0.0]
radius = 0.3
material = "glass"
[[lights]]
type = "quad"
corner = [-0.1, 4.0, -0.1]
u = [0.2, 0.0, 0.0]
v = [0.0, 0.0, 0.2]
radiance = 400.0
"#;

#[test]
fn glass_sphere_focuses_a_caustic_in_path_but_not_in_whitted() {
    let with_sphere = load_str(CAUSTIC, "caustic", None).unwrap();
    let without = load_str(&CAUSTIC.replace("radius = 0.3", "radius = 0.001"), "no sphere", None).unwrap();
    let centre = |img: &Image| {
        let c = img.width / 2;
        let mut sum = 0.0;
        for y in c - 1..=c + 1 {
            for x in c - 1..=c + 1 {
                sum += img.get(x, y).y;
            }
        }
        sum / 9.0
    };
    let (path, path_lit) = (render_with(&with_sphere, "path", 256, 1), render_with(&without, "path", 256, 1));
    let (whitted, whitted_lit) =
        (render_with(&with_sphere, "whitted", 1, 1), render_with(&without, "whitted", 1, 1));
    // The unshadowed floor is the same in both methods (direct light only: nothing else is lit).
    assert!((centre(&path_lit) / centre(&whitted_lit) - 1.0).abs() < 0.05);
    // Path tracing focuses the light under the sphere above the unshadowed level; Whitted's
    // straight shadow rays through glass can only dim it.
    let (p, p0) = (centre(&path), centre(&path_lit));
    let (w, w0) = (centre(&whitted), centre(&whitted_lit));
    assert!(p > 1.5 * p0, "path: {p} under the sphere vs {p0} without it");
    assert!(w < w0, "whitted: {w} under the sphere vs {w0} without it");
}

#[test]
fn path_tracing_error_halves_with_each_doubling_of_samples() {
    // Diffuse Cornell box with an area light: MSE against a 4096-spp reference over four
    // doublings (independent sampling, whose variance is exactly proportional to 1/N; the
    // reference's own variance shifts the last ratio by under 3%).
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/soft-shadows.toml")).unwrap();
    let no_glass = text.replace("material = \"glass\"", "material = \"white\"");
    let scene = load_str(&no_glass, "diffuse box", None).unwrap();
    let small = |spp, seed| {
        let mut opts = RenderOptions::from_scene(&scene, spp);
        opts.resolution = Some((32, 32));
        opts.seed = seed;
        opts.sampler = SamplerKind::Independent;
        render(&scene, create("path").unwrap().as_ref(), &opts, &|_, _| {}).image
    };
    let reference = small(4096, 99);
    let mse = |img: &Image| {
        img.pixels.iter().zip(&reference.pixels).map(|(a, b)| (*a - *b).length_squared() as f64).sum::<f64>()
            / (3 * img.pixels.len()) as f64
    };
    // Average each level over several seeds so the MSE estimates themselves are stable.
    let level = |spp: u32| (0..16).map(|s| mse(&small(spp, 10 + s))).sum::<f64>() / 16.0;
    let errors: Vec<f64> = [8, 16, 32, 64, 128].into_iter().map(level).collect();
    for pair in errors.windows(2) {
        let ratio = pair[1] / pair[0];
        assert!((ratio - 0.5).abs() <= 0.5 * 0.15, "MSE ratio {ratio} ({errors:?})");
    }
}
