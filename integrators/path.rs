//! Unidirectional Monte Carlo path tracing: the reference every other method is measured against.
//!
//! At every non-specular vertex one light is chosen uniformly and sampled (next-event
//! estimation); area lights and the environment are also reached by BSDF sampling, and the two
//! strategies are combined by multiple importance sampling with the power heuristic. Point lights
//! are reached only by next-event estimation, so light from a point light that passes through
//! glass before reaching a diffuse surface (a caustic) is not found: use an area light.
//! Specular chains through glass follow the sampled delta lobes; light that rough glass scatters
//! between several microfacets (which `eval` does not cover) is, like a delta lobe, reached only by
//! BSDF sampling and never weighted by MIS. Russian roulette starts after
//! three bounces and uses the path weight with the η² radiance scaling of refraction undone, so
//! light inside glass is not killed early. Media absorb by Beer–Lambert's law. In spectral mode
//! the path carries three wavelengths (see [`crate::spectrum`]); the first time it refracts
//! through dispersive glass (or meets rough dispersive glass) it ends the secondary ones and goes
//! on with the hero wavelength alone ([`PathContext::secondaries_after`]).

use super::{pick_light, sample_bsdf, Integrator, PathContext, RenderParams};
use crate::bsdf::{Scattering, ShadingFrame, TransportMode};
use crate::geometry::{spawn_origin, Ray, SurfaceHit};
use crate::lighting::{crossing, transmittance, ShadowMode, ShadowRays};
use crate::sampler::Dim;
use crate::scene::effects::Support;
use crate::scene::{Effect, Scene};
use glam::Vec3;

/// Bounces after which Russian roulette may end a path.
const ROULETTE_DEPTH: u32 = 3;

/// The default maximum depth of `path` and `light` (bounces): the largest allowed. Rough glass
/// traps light by total internal reflection for hundreds of bounces (a glass sphere of roughness
/// 0.2 in a white furnace renders 0.9968 when paths stop at 64, 1.0000 at 256), and Russian
/// roulette rightly spares such lossless paths, so only a depth limit ends them; the few that go
/// deep cost little.
pub const DEFAULT_PATH_DEPTH: u32 = crate::scene::compile::MAX_DEPTH;

/// Monte Carlo path tracing with next-event estimation and MIS.
pub struct Path;

/// The power heuristic (β = 2) weight of a strategy with density `a` against one with `b`.
#[inline]
pub(super) fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2.is_infinite() {
        return 1.0;
    }
    if a2 + b2 == 0.0 {
        0.0
    } else {
        a2 / (a2 + b2)
    }
}

impl Integrator for Path {
    fn name(&self) -> &'static str {
        "path"
    }

    fn description(&self) -> &'static str {
        "Monte Carlo path tracing: next-event estimation + MIS, specular chains, Russian roulette; the reference"
    }

    fn support(&self, _: Effect) -> Support {
        Support::Simulates
    }

    fn default_max_depth(&self) -> u32 {
        DEFAULT_PATH_DEPTH
    }

    fn radiance(
        &self,
        scene: &Scene,
        params: &RenderParams,
        camera_ray: &Ray,
        ctx: &mut PathContext,
    ) -> Vec3 {
        let light_pick = 1.0 / scene.lights.len().max(1) as f32;
        let mut l = Vec3::ZERO;
        let mut beta = Vec3::ONE;
        let mut eta_scale = 1.0f32;
        let mut ray = *camera_ray;
        let mut skip_mis = true;
        let mut bsdf_pdf = 0.0f32;
        let mut absorption = Vec3::ZERO;
        let mut depth = 0;
        loop {
            let Some(isect) = scene.intersect(&ray, f32::INFINITY) else {
                if absorption == Vec3::ZERO {
                    l += beta * ctx.channels.colour(escaped(scene, ray.dir, skip_mis, bsdf_pdf, light_pick));
                }
                break;
            };
            let hit = isect.hit;
            if absorption != Vec3::ZERO {
                beta *= (-absorption * hit.t).exp();
            }
            let wo = -ray.dir;
            // Emission reached by BSDF sampling (or seen directly), weighted against NEE.
            if let Some(index) = scene.light_of(isect.primitive) {
                let light = &scene.lights[index as usize];
                let le = light.emitted(&hit, wo);
                if le != Vec3::ZERO {
                    let w = if skip_mis {
                        1.0
                    } else {
                        power_heuristic(bsdf_pdf, light_pick * light.pdf_li(ray.origin, hit.p, hit.n))
                    };
                    l += beta * ctx.channels.colour(le) * w;
                }
            }
            if depth >= params.max_depth {
                break;
            }
            let material = scene.material_of(isect.primitive);
            let bsdf = Scattering::at(material, hit.p, hit.uv, &ctx.channels);
            beta *= ctx.end_secondaries_at(&material.bsdf, &bsdf);
            let frame = ShadingFrame::at(&hit, wo);
            let wo_local = frame.to_local(wo);
            if !bsdf.is_delta() && !scene.lights.is_empty() {
                l += beta * next_event(scene, &bsdf, &frame, wo_local, &hit, ray.time, light_pick, ctx);
            }
            let Some(s) = sample_bsdf(&bsdf, wo_local, TransportMode::Radiance, &mut ctx.sampler) else {
                break;
            };
            if s.pdf <= 0.0 || s.f == Vec3::ZERO {
                break;
            }
            let wi = frame.to_world(s.wi);
            let shading = frame.factor(wo, wi, TransportMode::Radiance);
            if shading == 0.0 {
                break;
            }
            beta *=
                s.f * (s.wi.z.abs() / s.pdf) * ctx.secondaries_after(&material.bsdf, &s, wo_local) * shading;
            skip_mis = !s.is_evaluable();
            bsdf_pdf = s.pdf;
            if let Some(c) = crossing(&material.bsdf, ray.dir, hit.n, ctx.channels.hero()) {
                let medium = if s.is_transmission { c.transmitted } else { c.incident };
                absorption = ctx.channels.colour(medium.absorption);
            }
            if s.is_transmission {
                eta_scale *= s.eta * s.eta;
            }
            if wi.dot(hit.n) * wo.dot(hit.n) > 0.0 {
                ctx.rays.reflected += 1;
            } else {
                ctx.rays.refracted += 1;
            }
            ray = ray.spawn(spawn_origin(&hit, wi), wi);
            depth += 1;
            if depth > ROULETTE_DEPTH {
                let rr = (beta * eta_scale).max_element();
                if rr < 1.0 {
                    let q = (1.0 - rr).max(0.0);
                    if ctx.sampler.get_1d(Dim::Other) < q {
                        break;
                    }
                    beta /= 1.0 - q;
                }
            }
        }
        l
    }
}

/// Radiance of the environment for a ray of direction `dir` that leaves the scene, weighted
/// against next-event estimation of the environment light (the plain background when there is
/// none).
fn escaped(scene: &Scene, dir: Vec3, skip_mis: bool, bsdf_pdf: f32, light_pick: f32) -> Vec3 {
    match scene.environment_light() {
        Some(i) if !skip_mis => {
            let env = &scene.lights[i];
            env.environment_radiance(dir) * power_heuristic(bsdf_pdf, light_pick * env.environment_pdf(dir))
        }
        _ => scene.background(dir),
    }
}

/// Next-event estimation: one uniformly chosen light, sampled, tested for visibility (every
/// surface, glass included, blocks the straight shadow ray) and weighted by MIS.
#[allow(clippy::too_many_arguments)]
fn next_event(
    scene: &Scene,
    bsdf: &Scattering,
    frame: &ShadingFrame,
    wo_local: Vec3,
    hit: &SurfaceHit,
    time: f32,
    light_pick: f32,
    ctx: &mut PathContext,
) -> Vec3 {
    let index = pick_light(scene.lights.len(), &mut ctx.sampler);
    let light = &scene.lights[index];
    let u = ctx.sampler.get_2d(Dim::Light);
    let Some(ls) = light.sample_li(hit.p, u) else { return Vec3::ZERO };
    let wi_local = frame.to_local(ls.wi);
    let f = bsdf.eval(wo_local, wi_local, TransportMode::Radiance)
        * (wi_local.z.abs() * frame.factor(Vec3::ZERO, ls.wi, TransportMode::Radiance));
    if f == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let shadow = ShadowRays { mode: ShadowMode::Opaque, channels: ctx.channels, time };
    let target =
        if ls.distance.is_finite() { ls.position } else { hit.p + ls.wi * scene.far_distance(hit.p) };
    let visible = transmittance(scene, hit, target, Some(index as u32), shadow, &mut ctx.rays);
    if visible == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let pdf = light_pick * ls.pdf;
    let w = if ls.delta { 1.0 } else { power_heuristic(pdf, bsdf.pdf(wo_local, wi_local)) };
    f * ctx.channels.colour(ls.radiance) * visible * (w / pdf)
}
