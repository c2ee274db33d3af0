//! Whitted ray tracing: Phong local shading plus recursive mirror reflection and refraction.
//!
//! At a dielectric the reflected and refracted rays are weighted by the exact Fresnel
//! reflectance (or a constant, as in the thesis), with total internal reflection sending all
//! light back. Shadow rays pass straight through glass, attenuated by its Fresnel
//! transmittance. Light is never bent *towards* a light source, so there are no caustics:
//! that is the method's design, not a bug.

use super::{Integrator, RenderParams};
use crate::geometry::{spawn_origin, Ray};
use crate::lighting::{dielectric_reflectance, emitted, interface_indices, phong_local, ShadowMode};
use crate::material::Bsdf;
use crate::optics::{reflect, refract};
use crate::sampler::Sampler;
use crate::scene::effects::Support;
use crate::scene::{Effect, Scene};
use crate::stats::RayCounts;
use glam::Vec3;

/// Recursive reflection and refraction with Fresnel weights.
pub struct Whitted;

impl Integrator for Whitted {
    fn name(&self) -> &'static str {
        "whitted"
    }

    fn description(&self) -> &'static str {
        "Whitted ray tracing: recursive reflection and refraction, Fresnel, shadows through glass; no caustics"
    }

    fn support(&self, effect: Effect) -> Support {
        match effect {
            Effect::SoftShadows => Support::Approximates("an area light acts as a point light at its centre"),
            Effect::Textures | Effect::Meshes => Support::Simulates,
        }
    }

    fn radiance(
        &self,
        scene: &Scene,
        params: &RenderParams,
        ray: &Ray,
        _: &mut Sampler,
        rays: &mut RayCounts,
    ) -> Vec3 {
        trace(scene, params, ray, 0, rays)
    }
}

/// Radiance along `ray`, which is the `depth`-th bounce from the camera.
fn trace(scene: &Scene, params: &RenderParams, ray: &Ray, depth: u32, rays: &mut RayCounts) -> Vec3 {
    let Some(isect) = scene.intersect(ray, f32::INFINITY) else {
        return scene.settings.background;
    };
    let hit = &isect.hit;
    let wo = -ray.dir;
    let material = scene.material_of(isect.primitive);
    let shadows = ShadowMode::FresnelThroughGlass { reflectance: params.reflectance };
    let mut l =
        emitted(scene, isect.primitive, hit, wo) + phong_local(scene, material, hit, wo, shadows, rays);
    if depth >= params.max_depth {
        return l;
    }
    // The normal on the side the ray came from.
    let n = if hit.n.dot(wo) >= 0.0 { hit.n } else { -hit.n };
    let spawn = |dir: Vec3, rays: &mut RayCounts| {
        trace(scene, params, &Ray::new(spawn_origin(hit, dir), dir), depth + 1, rays)
    };
    match &material.bsdf {
        Bsdf::Diffuse(_) => {}
        Bsdf::Mirror(color) => {
            if *color != Vec3::ZERO {
                rays.reflected += 1;
                l += *color * spawn(reflect(wo, n), rays);
            }
        }
        Bsdf::Dielectric { .. } => {
            let (n_i, n_t) =
                interface_indices(&material.bsdf, ray.dir, hit.n).expect("a dielectric has indices");
            let transmitted = refract(wo, n, n_t / n_i);
            let r = match transmitted {
                Some(_) => dielectric_reflectance(wo.dot(n), n_i, n_t, params.reflectance),
                None => 1.0,
            };
            if r > 0.0 {
                rays.reflected += 1;
                l += r * spawn(reflect(wo, n), rays);
            }
            if let Some(wt) = transmitted.filter(|_| r < 1.0) {
                rays.refracted += 1;
                l += (1.0 - r) * spawn(wt, rays);
            }
        }
    }
    l
}
