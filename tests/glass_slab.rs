//! Whitted against the closed form for a diffuse emitter seen through a flat glass slab.
//!
//! At normal incidence each face reflects R = ((n−1)/(n+1))²; summing the light that passes
//! after 0, 2, 4, … internal reflections gives L·(1−R)²·Σ R^(2k) = L·(1−R)/(1+R).

mod common;

use glam::Vec2;
use vitrum::integrators::{create, PathContext, RenderParams};
use vitrum::sampler::Sampler;
use vitrum::scene::load_str;

#[test]
fn emitter_through_a_glass_slab_matches_the_closed_form() {
    let scene = load_str(&common::glass_slab(1.5, [0.0; 3]), "slab", None).unwrap();
    let whitted = create("whitted").unwrap();
    let params = RenderParams::with_depth(40);
    let ray = scene.camera.generate_ray(Vec2::new(4.5, 4.5));
    let mut ctx = PathContext::new(Sampler::independent(0, 0, 0));
    let l = whitted.radiance(&scene, &params, &ray, &mut ctx);
    let rays = ctx.rays;
    let r = (0.5f32 / 2.5).powi(2);
    assert!((r - 0.04).abs() < 1e-7);
    let factor = (1.0 - r) / (1.0 + r);
    for (got, emitted) in l.to_array().into_iter().zip([2.0f32, 1.0, 0.5]) {
        let expected = emitted * factor;
        assert!(((got - expected) / expected).abs() < 1e-3, "got {got}, expected {expected}");
    }
    assert!(rays.refracted >= 2 && rays.reflected >= 2, "{rays:?}");
}

#[test]
fn constant_reflectance_option_reproduces_the_thesis_value() {
    let scene = load_str(&common::glass_slab(1.5, [0.0; 3]), "slab", None).unwrap();
    let whitted = create("whitted").unwrap();
    let params = RenderParams { reflectance: Some(0.06), ..RenderParams::with_depth(40) };
    let ray = scene.camera.generate_ray(Vec2::new(4.5, 4.5));
    let l = whitted.radiance(&scene, &params, &ray, &mut PathContext::new(Sampler::independent(0, 0, 0)));
    let expected = 2.0 * (1.0 - 0.06) / (1.0 + 0.06);
    assert!(((l.x - expected) / expected).abs() < 1e-3, "got {}, expected {expected}", l.x);
}

#[test]
fn oblique_incidence_through_the_slab_matches_the_closed_form() {
    // At 45° the ray is displaced and each face reflects the unpolarised R(45°) (the same from
    // both sides of the interface, by Stokes), so the slab still passes L·(1−R)/(1+R). Unlike
    // normal incidence this would notice swapped indices or a flipped normal.
    let scene = load_str(&common::glass_slab(1.5, [0.0; 3]), "slab", None).unwrap();
    let whitted = create("whitted").unwrap();
    let dir = glam::Vec3::new(0.0, -1.0, -1.0).normalize();
    let ray = vitrum::geometry::Ray::new(glam::Vec3::new(0.0, 2.0, 2.5), dir);
    let mut ctx = PathContext::new(Sampler::independent(0, 0, 0));
    let l = whitted.radiance(&scene, &RenderParams::with_depth(40), &ray, &mut ctx);
    let r = vitrum::optics::fresnel_dielectric(std::f32::consts::FRAC_1_SQRT_2, 1.5);
    assert!((r - 0.0502).abs() < 1e-3, "R(45°) = {r}");
    let expected = 2.0 * (1.0 - r) / (1.0 + r);
    assert!(((l.x - expected) / expected).abs() < 1e-3, "got {}, expected {expected}", l.x);
}
