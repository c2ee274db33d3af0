//! Direct lighting shared by the deterministic methods: shadow rays (optionally through glass)
//! and the empirical Phong model.

use crate::geometry::{spawn_origin, Ray, SurfaceHit};
use crate::material::{Bsdf, Material};
use crate::optics::fresnel_dielectric;
use crate::scene::Scene;
use crate::stats::RayCounts;
use glam::Vec3;
use std::f32::consts::PI;

/// Most surfaces a shadow ray passes through before it gives up (bounded work in any scene).
pub const MAX_SHADOW_CROSSINGS: u32 = 64;

/// How shadow rays treat dielectrics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShadowMode {
    /// Every surface blocks light (classic ray casting).
    Opaque,
    /// Dielectrics pass light attenuated by their Fresnel transmittance at each crossing (no
    /// refraction of the shadow ray: Whitted cannot bend light towards lights; no caustics).
    FresnelThroughGlass {
        /// Constant reflectance instead of exact Fresnel (the thesis's 0.06).
        reflectance: Option<f32>,
    },
}

/// Refractive indices on the incident and transmitted sides when a ray travelling along `dir`
/// crosses a dielectric with outward normal `n`.
#[inline]
pub fn interface_indices(bsdf: &Bsdf, dir: Vec3, n: Vec3) -> Option<(f32, f32)> {
    match *bsdf {
        Bsdf::Dielectric { ior_inside, ior_outside } => {
            if dir.dot(n) < 0.0 {
                Some((ior_outside, ior_inside))
            } else {
                Some((ior_inside, ior_outside))
            }
        }
        _ => None,
    }
}

/// Reflectance of a dielectric crossing with incidence cosine `cos_i` from index `n_i` into
/// `n_t`, exact or the constant override; 1 under total internal reflection either way.
#[inline]
pub fn dielectric_reflectance(cos_i: f32, n_i: f32, n_t: f32, constant: Option<f32>) -> f32 {
    let exact = fresnel_dielectric(cos_i, n_t / n_i);
    match constant {
        Some(r) if exact < 1.0 => r,
        _ => exact,
    }
}

/// Fraction of the light at `target` that reaches the surface point `from` (0 if blocked).
/// `light` is the emitter primitive's light index, which does not block its own light.
pub fn transmittance(
    scene: &Scene,
    from: &SurfaceHit,
    target: Vec3,
    light: Option<u32>,
    mode: ShadowMode,
    rays: &mut RayCounts,
) -> f32 {
    let to_light = target - from.p;
    let dir = to_light.normalize();
    let mut origin = spawn_origin(from, dir);
    let mut t = 1.0f32;
    for _ in 0..MAX_SHADOW_CROSSINGS {
        rays.shadow += 1;
        let remaining = (target - origin).dot(dir);
        if remaining <= 0.0 {
            return t;
        }
        let ray = Ray::new(origin, dir);
        let Some(hit) = scene.intersect(&ray, remaining * (1.0 - 1e-5)) else {
            return t;
        };
        if light.is_some() && scene.light_of(hit.primitive) == light {
            return t;
        }
        let ShadowMode::FresnelThroughGlass { reflectance } = mode else {
            return 0.0;
        };
        let bsdf = &scene.material_of(hit.primitive).bsdf;
        let Some((n_i, n_t)) = interface_indices(bsdf, dir, hit.hit.n) else {
            return 0.0;
        };
        t *= 1.0 - dielectric_reflectance(dir.dot(hit.hit.n).abs(), n_i, n_t, reflectance);
        if t == 0.0 {
            return 0.0;
        }
        origin = spawn_origin(&hit.hit, dir);
    }
    0.0
}

/// Phong local illumination at `hit` seen from direction `wo` (pointing away from the surface):
/// ambient plus, for every light, diffuse and normalised specular terms weighted by the light's
/// irradiance and shadow transmittance (see [`crate::material::Phong`]).
pub fn phong_local(
    scene: &Scene,
    material: &Material,
    hit: &SurfaceHit,
    wo: Vec3,
    mode: ShadowMode,
    rays: &mut RayCounts,
) -> Vec3 {
    let ph = material.phong;
    let color = material.phong_color(hit.p);
    let mut l = ph.ambient * color * scene.settings.ambient;
    if ph.diffuse == 0.0 && ph.specular == 0.0 {
        return l;
    }
    // Two-sided shading: the normal facing the viewer.
    let n = if hit.n.dot(wo) >= 0.0 { hit.n } else { -hit.n };
    for (index, light) in scene.lights.iter().enumerate() {
        let source = light.as_point_from(hit.p);
        let to_light = source.position - hit.p;
        let dist2 = to_light.length_squared();
        let wi = to_light / dist2.sqrt();
        let cos = n.dot(wi);
        if cos <= 0.0 || source.intensity == Vec3::ZERO {
            continue;
        }
        let vis = transmittance(scene, hit, source.position, Some(index as u32), mode, rays);
        if vis == 0.0 {
            continue;
        }
        let irradiance = source.intensity * (vis * cos / dist2);
        let mut f = ph.diffuse * color / PI;
        if ph.specular > 0.0 {
            let r = crate::optics::reflect(wi, n);
            let rv = r.dot(wo).max(0.0);
            f += Vec3::splat(ph.specular * (ph.shininess + 2.0) / (2.0 * PI) * rv.powf(ph.shininess));
        }
        l += f * irradiance;
    }
    l
}

/// Radiance emitted by the primitive of `hit` towards `wo`, if it is a light's emitting side.
pub fn emitted(scene: &Scene, primitive: u32, hit: &SurfaceHit, wo: Vec3) -> Vec3 {
    match scene.light_of(primitive).map(|i| &scene.lights[i as usize]) {
        Some(crate::light::Light::Quad { radiance, .. }) if hit.n.dot(wo) > 0.0 => *radiance,
        _ => Vec3::ZERO,
    }
}
