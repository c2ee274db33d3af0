//! Unidirectional Monte Carlo path tracing: the reference every other method is measured against.
//!
//! At every non-specular vertex one light is chosen uniformly and sampled (next-event
//! estimation); area lights and the environment are also reached by BSDF sampling, and the two
//! strategies are combined by multiple importance sampling with the power heuristic. Delta lights
//! (point, spot, directional) are reached only by next-event estimation, so light from them that
//! passes through glass before reaching a diffuse surface (a caustic) is not found: use an area
//! light, or a bidirectional method.
//! Specular chains through glass follow the sampled delta lobes; light that rough glass scatters
//! between several microfacets (which `eval` does not cover) is, like a delta lobe, reached only by
//! BSDF sampling and never weighted by MIS. Russian roulette starts after
//! three bounces and uses the path weight with the η² radiance scaling of refraction undone, so
//! light inside glass is not killed early. Media absorb by Beer–Lambert's law. In spectral mode
//! the path carries three wavelengths (see [`crate::spectrum`]); the first time it refracts
//! through dispersive glass (or meets rough dispersive glass) it ends the secondary ones and goes
//! on with the hero wavelength alone ([`PathContext::secondaries_after`]).

use super::EngineChoice;
use super::{pick_light, sample_bsdf, Integrator, PathContext, RenderParams};
use crate::bsdf::{Scattering, ShadingFrame, TransportMode};
use crate::geometry::{spawn_origin, Ray, SurfaceHit};
use crate::lanes::Real;
use crate::lighting::{crossing, ShadowRay};
use crate::render::RenderOptions;
use crate::sampler::Dim;
use crate::scene::effects::Support;
use crate::scene::{Effect, Intersection, Scene};
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

/// The power heuristic (β = 2) weight of a strategy with density `a` against one with `b`:
/// `a²/(a² + b²)`, 1 where `a²` is infinite, 0 where both are 0. For one path or across lanes.
#[inline(always)]
pub(crate) fn power_heuristic<R: Real>(a: R, b: R) -> R {
    let (a2, b2) = (a * a, b * b);
    let zero = R::splat(0.0);
    let w = R::select((a2 + b2).eq(zero), zero, a2 / (a2 + b2));
    R::select(a2.is_infinite(), R::splat(1.0), w)
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
        let mut path = PathState::new(*camera_ray);
        loop {
            let isect = scene.intersect(&path.ray, f32::INFINITY);
            let step = path.advance(scene, params, isect, ctx);
            if let Some(light) = step.light {
                path.resolve(&light, light.shadow.is_none_or(|s| !s.blocked(scene)));
            }
            if !step.goes_on {
                return path.l;
            }
        }
    }

    fn engine(&self, scene: &Scene, opts: &RenderOptions) -> EngineChoice {
        super::wavefront::choose(scene, opts)
    }
}

/// One camera path in flight: everything `path` carries from one vertex to the next. The
/// scalar engine ([`Path::radiance`]) advances one path at a time; the wavefront engine
/// (`integrators/wavefront.rs`) advances many, asking the scene for their closest hits and
/// their shadow rays across lanes. Both run the same [`PathState::advance`], so they estimate
/// the same image with the same random numbers.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PathState {
    /// The ray to trace next.
    pub ray: Ray,
    /// Radiance gathered so far.
    pub l: Vec3,
    /// Throughput from the camera to the ray's origin.
    beta: Vec3,
    /// Product of η² over the refractions so far (undone for Russian roulette).
    eta_scale: f32,
    /// Whether the last scattering was not evaluable (delta or multiple): no MIS on what it hits.
    skip_mis: bool,
    /// The density of the last BSDF sample (for MIS against next-event estimation).
    bsdf_pdf: f32,
    /// Absorption coefficient of the medium the ray travels in.
    absorption: Vec3,
    /// Bounces so far.
    depth: u32,
}

/// What one vertex asks of the scene besides its next ray: a shadow ray towards a sampled light,
/// whose contribution counts when nothing blocks it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PendingLight {
    /// The visibility query; `None` when nothing can block the light (it is visible).
    pub shadow: Option<ShadowRay>,
    /// The path throughput at the vertex.
    beta: Vec3,
    /// The light's contribution at the vertex if it is visible (f·Le·w/pdf).
    value: Vec3,
}

/// The outcome of [`PathState::advance`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Step {
    /// Whether the path goes on along its new ray.
    pub goes_on: bool,
    /// The shadow ray of next-event estimation, if a light was sampled and could be visible.
    pub light: Option<PendingLight>,
}

impl Step {
    const END: Step = Step { goes_on: false, light: None };
}

impl PathState {
    /// A path starting along the camera ray `ray`.
    pub fn new(ray: Ray) -> PathState {
        PathState {
            ray,
            l: Vec3::ZERO,
            beta: Vec3::ONE,
            eta_scale: 1.0,
            skip_mis: true,
            bsdf_pdf: 0.0,
            absorption: Vec3::ZERO,
            depth: 0,
        }
    }

    /// Adds the pending light `light` of this path's last step, `visible` or not.
    #[inline]
    pub fn resolve(&mut self, light: &PendingLight, visible: bool) {
        self.l += light.beta * if visible { light.value } else { Vec3::ZERO };
    }

    /// One vertex: the closest hit `isect` of [`ray`](Self::ray) (or its escape), its emission
    /// weighted against next-event estimation, next-event estimation (returned as a pending
    /// shadow ray), the BSDF sample that makes the next ray, and Russian roulette.
    #[inline]
    pub fn advance(
        &mut self,
        scene: &Scene,
        params: &RenderParams,
        isect: Option<Intersection>,
        ctx: &mut PathContext,
    ) -> Step {
        let light_pick = 1.0 / scene.lights.len().max(1) as f32;
        let ray = self.ray;
        let Some(isect) = isect else {
            if self.absorption == Vec3::ZERO {
                self.l += self.beta
                    * ctx.channels.colour(escaped(scene, ray.dir, self.skip_mis, self.bsdf_pdf, light_pick));
            }
            return Step::END;
        };
        let hit = isect.hit;
        if self.absorption != Vec3::ZERO {
            self.beta *= (-self.absorption * hit.t).exp();
        }
        let wo = -ray.dir;
        // Emission reached by BSDF sampling (or seen directly), weighted against NEE.
        if let Some(index) = scene.light_of(isect.primitive) {
            let light = &scene.lights[index as usize];
            let le = light.emitted(&hit, wo);
            if le != Vec3::ZERO {
                let w = if self.skip_mis {
                    1.0
                } else {
                    power_heuristic(self.bsdf_pdf, light_pick * light.pdf_li(ray.origin, hit.p, hit.n))
                };
                self.l += self.beta * ctx.channels.colour(le) * w;
            }
        }
        if self.depth >= params.max_depth {
            return Step::END;
        }
        let material = scene.material_of(isect.primitive);
        let bsdf = Scattering::at(material, hit.p, hit.uv, &ctx.channels);
        self.beta *= ctx.end_secondaries_at(&material.bsdf, &bsdf);
        let frame = ShadingFrame::at(&hit, wo);
        let wo_local = frame.to_local(wo);
        let light = if !bsdf.is_delta() && !scene.lights.is_empty() {
            next_event(scene, &bsdf, &frame, wo_local, &hit, ray.time, light_pick, ctx)
                .map(|(shadow, value)| PendingLight { shadow, beta: self.beta, value })
        } else {
            None
        };
        let end = Step { goes_on: false, light };
        let Some(s) = sample_bsdf(&bsdf, wo_local, TransportMode::Radiance, &mut ctx.sampler) else {
            return end;
        };
        if s.pdf <= 0.0 || s.f == Vec3::ZERO {
            return end;
        }
        let wi = frame.to_world(s.wi);
        let shading = frame.factor(wo, wi, TransportMode::Radiance);
        if shading == 0.0 {
            return end;
        }
        self.beta *=
            s.f * (s.wi.z.abs() / s.pdf) * ctx.secondaries_after(&material.bsdf, &s, wo_local) * shading;
        self.skip_mis = !s.is_evaluable();
        self.bsdf_pdf = s.pdf;
        if let Some(c) = crossing(&material.bsdf, ray.dir, hit.n, ctx.channels.hero()) {
            let medium = if s.is_transmission { c.transmitted } else { c.incident };
            self.absorption = ctx.channels.colour(medium.absorption);
        }
        if s.is_transmission {
            self.eta_scale *= s.eta * s.eta;
        }
        if wi.dot(hit.n) * wo.dot(hit.n) > 0.0 {
            ctx.rays.reflected += 1;
        } else {
            ctx.rays.refracted += 1;
        }
        self.ray = ray.spawn(spawn_origin(&hit, wi), wi);
        self.depth += 1;
        if self.depth > ROULETTE_DEPTH {
            let rr = (self.beta * self.eta_scale).max_element();
            if rr < 1.0 {
                let q = (1.0 - rr).max(0.0);
                if ctx.sampler.get_1d(Dim::Other) < q {
                    return end;
                }
                self.beta /= 1.0 - q;
            }
        }
        Step { goes_on: true, light }
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

/// Next-event estimation: one uniformly chosen light, sampled; the shadow ray that decides its
/// visibility (every surface, glass included, blocks it) and its contribution f·Le·w/pdf
/// (weighted by MIS) if visible; `None` when it carries nothing.
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
) -> Option<(Option<ShadowRay>, Vec3)> {
    let index = pick_light(scene.lights.len(), &mut ctx.sampler);
    let light = &scene.lights[index];
    let u = ctx.sampler.get_2d(Dim::Light);
    let ls = light.sample_li(hit.p, u)?;
    let wi_local = frame.to_local(ls.wi);
    let f = bsdf.eval(wo_local, wi_local, TransportMode::Radiance)
        * (wi_local.z.abs() * frame.factor(Vec3::ZERO, ls.wi, TransportMode::Radiance));
    if f == Vec3::ZERO {
        return None;
    }
    let target =
        if ls.distance.is_finite() { ls.position } else { hit.p + ls.wi * scene.far_distance(hit.p) };
    let shadow = ShadowRay::new(hit, target, Some(index as u32), time, &mut ctx.rays);
    let pdf = light_pick * ls.pdf;
    let w = if ls.delta { 1.0 } else { power_heuristic(pdf, bsdf.pdf(wo_local, wi_local)) };
    let value = f * ctx.channels.colour(ls.radiance) * (w / pdf);
    Some((shadow, value))
}
