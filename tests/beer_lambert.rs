//! Beer–Lambert absorption inside dielectrics against closed forms, through Whitted's recursion
//! (shared with distributed ray tracing) and through its shadow rays.
//!
//! A slab of thickness d with absorption coefficient σ (per scene unit, per RGB channel)
//! transmits exp(−σ·ℓ) over a path of length ℓ inside it. Giving the slab the index of the
//! surrounding air (1.0) removes Fresnel reflection and refraction, so a ray at angle θ to the
//! normal crosses it in a straight line of length d/cos θ and the transmittance is exactly
//! exp(−σd/cos θ). With glass (n = 1.5) at normal incidence each face reflects
//! R = ((n − 1)/(n + 1))², and the light passing after 0, 2, 4, … internal reflections sums to
//! (1 − R)²·e^{−σd}/(1 − R²·e^{−2σd}).

mod common;

use glam::{Vec2, Vec3};
use vitrum::geometry::Ray;
use vitrum::integrators::{create, PathContext, RenderParams};
use vitrum::sampler::Sampler;
use vitrum::scene::{load_str, Scene};

/// Absorption coefficients per channel (per scene unit) and the slab's thickness.
const SIGMA: [f32; 3] = [0.5, 1.0, 2.0];
const THICKNESS: f32 = 1.0;
/// Radiance of the emitter behind the slab.
const EMITTED: [f32; 3] = [2.0, 1.0, 0.5];

/// The slab of `common::glass_slab` (thickness 1) of index `ior` in air, absorbing `SIGMA`.
fn slab(ior: f32) -> Scene {
    assert_eq!((THICKNESS, EMITTED), (1.0, [2.0, 1.0, 0.5]), "the shared slab's numbers");
    load_str(&common::glass_slab(ior, SIGMA), "slab", None).unwrap_or_else(|e| panic!("{e}"))
}

/// Radiance along `ray` by `integrator` (the deterministic ones ignore the stream).
fn radiance(scene: &Scene, integrator: &str, ray: &Ray) -> Vec3 {
    let integrator = create(integrator).unwrap();
    let mut ctx = PathContext::new(Sampler::independent(0, 0, 0));
    integrator.radiance(scene, &RenderParams::with_depth(40), ray, &mut ctx)
}

/// Asserts `got / emitted` equals `expected` within 1e-3 in every channel.
fn assert_transmittance(what: &str, got: Vec3, emitted: Vec3, expected: Vec3) {
    let t = got / emitted;
    println!("{what}: transmittance {t:.6}, expected {expected:.6}");
    for c in 0..3 {
        assert!((t[c] - expected[c]).abs() < 1e-3, "{what}, channel {c}: {} vs {}", t[c], expected[c]);
    }
}

#[test]
fn transmittance_through_an_index_matched_slab_is_exp_minus_sigma_d() {
    let scene = slab(1.0);
    let sigma = Vec3::from_array(SIGMA);
    for theta_deg in [0.0f32, 30.0, 60.0] {
        let theta = theta_deg.to_radians();
        let ray = Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::new(theta.sin(), 0.0, -theta.cos()));
        let expected = (-sigma * THICKNESS / theta.cos()).exp();
        for integrator in ["whitted", "distributed"] {
            let l = radiance(&scene, integrator, &ray);
            assert_transmittance(
                &format!("{integrator}, n = 1, θ = {theta_deg}°"),
                l,
                Vec3::from_array(EMITTED),
                expected,
            );
        }
    }
}

#[test]
fn glass_slab_with_absorption_matches_the_interreflection_closed_form() {
    let scene = slab(1.5);
    let ray = scene.camera.generate_ray(Vec2::new(4.5, 4.5));
    let r = (0.5f32 / 2.5).powi(2);
    let a = (-Vec3::from_array(SIGMA) * THICKNESS).exp();
    let expected = (1.0 - r) * (1.0 - r) * a / (Vec3::ONE - r * r * a * a);
    for integrator in ["whitted", "distributed"] {
        let l = radiance(&scene, integrator, &ray);
        assert_transmittance(
            &format!("{integrator}, n = 1.5, normal incidence"),
            l,
            Vec3::from_array(EMITTED),
            expected,
        );
    }
}

#[test]
fn shadow_rays_through_an_absorbing_slab_are_attenuated_by_exp_minus_sigma_l() {
    // A white Lambertian wall at z = 0 lit by a point light at (0, 0, 4) through a small
    // index-matched slab z ∈ [1.5, 2.5] (x ∈ [−1, 2], y ∈ [−1, 1]); the camera sees the wall
    // from the side, past the slab. The wall's radiance is (1/π)·I·cos θ/r² · exp(−σ·d/cos θ).
    let [r, g, b] = SIGMA;
    let text = format!(
        r#"
[camera]
position = [5.0, 0.0, 3.0]
look_at = [0.0, 0.0, 0.0]

[materials.white]
type = "diffuse"
color = 1.0

[materials.glass]
type = "dielectric"
ior = 1.0
absorption = [{r:?}, {g:?}, {b:?}]

[[objects]]
shape = "quad"
corner = [-5.0, -5.0, 0.0]
u = [10.0, 0.0, 0.0]
v = [0.0, 10.0, 0.0]
material = "white"

[[objects]]
shape = "quad"
corner = [-1.0, -1.0, 2.5]
u = [3.0, 0.0, 0.0]
v = [0.0, 2.0, 0.0]
material = "glass"

[[objects]]
shape = "quad"
corner = [-1.0, -1.0, 1.5]
u = [0.0, 2.0, 0.0]
v = [3.0, 0.0, 0.0]
material = "glass"

[[lights]]
type = "point"
position = [0.0, 0.0, 4.0]
intensity = 10.0
"#
    );
    let scene = load_str(&text, "shadow", None).unwrap_or_else(|e| panic!("{e}"));
    let light = Vec3::new(0.0, 0.0, 4.0);
    let sigma = Vec3::from_array(SIGMA);
    let eye = Vec3::new(5.0, 0.0, 3.0);
    for x in [0.0f32, 2.0] {
        let p = Vec3::new(x, 0.0, 0.0);
        let ray = Ray::new(eye, (p - eye).normalize());
        let to_light = light - p;
        let cos = to_light.normalize().z;
        let unshadowed = 10.0 * cos / to_light.length_squared() / std::f32::consts::PI;
        let expected = (-sigma * THICKNESS / cos).exp();
        for integrator in ["whitted", "distributed"] {
            let l = radiance(&scene, integrator, &ray);
            assert_transmittance(
                &format!("{integrator}, shadow ray at {:.1}°", cos.acos().to_degrees()),
                l,
                Vec3::splat(unshadowed),
                expected,
            );
        }
    }
}
