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
//! the path carries three wavelengths (see [`crate::spectrum`]); where smooth dispersive glass
//! parts them it splits into one branch per wavelength, run one after the other
//! ([`PathContext::split_wavelengths`]). At rough dispersive glass a wavelength chosen uniformly
//! samples the direction and, after one facet, all three go on weighted by MIS over their
//! densities (hero-wavelength MIS, Wilkie et al. 2014), next-event estimation evaluating each
//! wavelength and weighing with the same mean density; light scattered between several facets
//! has no density, so there the wavelengths whose walks do the same split as at smooth glass
//! (`integrators/wavelengths.rs` says why this keeps every channel unbiased). What the
//! camera ray sees directly is added in RGB ([`PathContext::radiance_seen`]).

use super::{light_index, Integrator, PartedWavelength, PathContext, RenderParams};
use super::{CameraEstimator, EngineChoice, Method, Progression};
use crate::bsdf::{BsdfSample, Scattering, ShadingFrame, TransportMode};
use crate::geometry::{offset_origin, Ray};
use crate::lanes::{Mask3, Real, Vector};
use crate::light::LightSampleOf;
use crate::lighting::{crossing, ShadowRay};
use crate::params::{ManifoldParams, Seeding};
use crate::render::RenderOptions;
use crate::sampler::Dim;
use crate::scene::effects::Support;
use crate::scene::{Effect, Intersection, Scene};
use crate::spectrum::Channels;
use glam::Vec3;

use super::ROULETTE_DEPTH;
use crate::render::Branch;
pub(crate) use crate::render::PathState;

pub use crate::methods::DEFAULT_PATH_DEPTH;

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
    fn method(&self) -> Method {
        Method::Path
    }

    fn support(&self, _: Effect) -> Support {
        Support::Simulates
    }

    fn progression(&self) -> Progression<'_> {
        Progression::Camera(self)
    }
}

impl CameraEstimator for Path {
    fn radiance(
        &self,
        scene: &Scene,
        params: &RenderParams,
        camera_ray: &Ray,
        ctx: &mut PathContext,
    ) -> Vec3 {
        // The sample's mode, once: RGB paths are traced without wavelength splitting's work.
        if ctx.channels.is_spectral() {
            trace::<true>(scene, params, camera_ray, ctx)
        } else {
            trace::<false>(scene, params, camera_ray, ctx)
        }
    }

    fn engine(&self, scene: &Scene, opts: &RenderOptions) -> EngineChoice {
        super::wavefront::choose(scene, opts)
    }
}

/// The radiance `path` estimates along `camera_ray` with the scalar engine, the channels of
/// `ctx` spectral where `SPECTRAL` ([`PathState::advance`]).
#[inline(always)]
fn trace<const SPECTRAL: bool>(
    scene: &Scene,
    params: &RenderParams,
    camera_ray: &Ray,
    ctx: &mut PathContext,
) -> Vec3 {
    let world = OneRay { scene };
    let mut path = PathState::new(*camera_ray);
    loop {
        let isect = scene.intersect(&path.ray(), f32::INFINITY);
        let step = path.advance::<SPECTRAL, _>(&world, params, &isect, ctx);
        if step.light.pending {
            path.resolve(&step.light, step.light.shadow.is_none_or(|s| !s.blocked(scene)));
        }
        if !step.goes_on {
            return path.l;
        }
    }
}

/// What a path vertex asks of the world it is shaded in: the scene's own enums for one ray
/// ([`OneRay`]), or tables read across 16 lanes (the wavefront engine's stages). The physics
/// and the order of the random numbers are [`PathState::advance`]'s, written once; a world only
/// fetches a vertex's data (its surface, material, light, medium) and counts what it traces.
/// Every method takes `active`, the lanes that need its answer (a `bool` for one ray): what
/// other lanes get is never used.
pub(crate) trait PathWorld {
    /// Numbers: `f32`, or one per lane.
    type R: Real;
    /// Vectors of them.
    type V: Vector<Real = Self::R>;
    /// What the closest-hit stage found along the path's ray.
    type Hit;
    /// The scattering model at a vertex.
    type Bsdf: VertexBsdf<Self::V>;
    /// The shading frame at a vertex.
    type Frame: VertexFrame<Self::V>;
    /// A light chosen for next-event estimation.
    type Light: Copy;
    /// The shadow ray of a light sample.
    type Shadow: Copy;
    /// The path's random stream, counters and channels.
    type Context;

    /// Lights in the scene.
    fn light_count(&self) -> usize;
    /// Whether the scene has smooth glass for manifold next-event estimation to chain through.
    fn has_casters(&self) -> bool;
    /// Which paths are there (idle lanes are not).
    fn live(&self, hit: &Self::Hit) -> Mask3<Self::V>;
    /// Where the ray found a surface.
    fn found(&self, hit: &Self::Hit) -> Mask3<Self::V>;
    /// The hit's distance along the ray, point, geometric normal and the point's error bound.
    fn surface(&self, hit: &Self::Hit) -> (Self::R, Self::V, Self::V, Self::R);
    /// The radiance of the environment along `dir` (leaving the scene), in the path's channels,
    /// weighted against next-event estimation of the environment light (`light_pick`: the
    /// probability of choosing one light) unless `skip_mis`; the plain background without one.
    /// Where the camera ray itself escapes (`seen`) in spectral mode, the background goes to the
    /// context in RGB instead ([`PathContext::seen_rgb`]) and the radiance returned is 0.
    #[allow(clippy::too_many_arguments)]
    fn escaped(
        &self,
        dir: Self::V,
        skip_mis: Mask3<Self::V>,
        bsdf_pdf: Self::R,
        light_pick: Self::R,
        seen: Mask3<Self::V>,
        active: Mask3<Self::V>,
        ctx: &mut Self::Context,
    ) -> Self::V;
    /// The hit's emission towards `wo` (where it is not zero), in the path's channels, and the
    /// solid-angle density with which the light's sampling would have reached it from `origin`.
    /// Where the camera ray itself hit it (`seen`) in spectral mode, the emission goes to the
    /// context in RGB instead ([`PathContext::seen_rgb`]) and none is returned.
    fn emission(
        &self,
        hit: &Self::Hit,
        origin: Self::V,
        wo: Self::V,
        seen: Mask3<Self::V>,
        active: Mask3<Self::V>,
        ctx: &mut Self::Context,
    ) -> (Mask3<Self::V>, Self::V, Self::R);
    /// The hit's scattering model, and the factor the path's throughput takes there before
    /// anything is sampled (a `hero_alone` spectral path ending its secondary wavelengths at
    /// rough dispersive glass; 1 otherwise).
    fn bsdf(&self, hit: &Self::Hit, active: Mask3<Self::V>, ctx: &mut Self::Context)
        -> (Self::Bsdf, Self::V);
    /// The hit's shading frame for the direction `wo` back along the path.
    fn frame(&self, hit: &Self::Hit, wo: Self::V) -> Self::Frame;
    /// The next number of the stream for `purpose`, where `active` (which alone draw it).
    fn draw_1d(&self, ctx: &mut Self::Context, purpose: Dim, active: Mask3<Self::V>) -> Self::R;
    /// The next two numbers of the stream for `purpose`, where `active`.
    fn draw_2d(&self, ctx: &mut Self::Context, purpose: Dim, active: Mask3<Self::V>) -> (Self::R, Self::R);
    /// The light with index `⌊u·count⌋` (the last for u → 1).
    fn light_at(&self, u: Self::R) -> Self::Light;
    /// Light `light` sampled from the hit with the numbers `u`.
    fn sample_light(
        &self,
        hit: &Self::Hit,
        light: Self::Light,
        u: (Self::R, Self::R),
        active: Mask3<Self::V>,
        ctx: &Self::Context,
    ) -> LightDraw<Self::V>;
    /// No shadow ray.
    fn no_shadow(&self) -> Self::Shadow;
    /// The shadow ray from the hit to `target` on `light`, counted where `active`.
    fn shadow(
        &self,
        hit: &Self::Hit,
        target: Self::V,
        light: Self::Light,
        time: Self::R,
        active: Mask3<Self::V>,
        ctx: &mut Self::Context,
    ) -> Self::Shadow;
    /// The factor a spectral path's throughput takes after the BSDF sample `s` of its lead
    /// wavelength (or, where the wavelengths mix, of the one
    /// [`sample_wavelengths`](Self::sample_wavelengths) chose), drawn with the numbers `uc`
    /// and `u` from `path` (the state at the vertex, not yet updated): where dispersive glass
    /// parts the wavelengths, the sampling wavelength's channel alone, every other wavelength
    /// set aside in the context as a branch of its own ([`PathContext::split_wavelengths`]); 1
    /// otherwise. Asked wherever the sample is there, also where the path itself cannot go on
    /// along it (the branches can).
    #[allow(clippy::too_many_arguments)]
    fn split_wavelengths(
        &self,
        hit: &Self::Hit,
        s: &BsdfSample<Self::V>,
        wo_local: Self::V,
        uc: Self::R,
        u: (Self::R, Self::R),
        path: &PathState<Self::V>,
        active: Mask3<Self::V>,
        ctx: &mut Self::Context,
    ) -> Self::V;
    /// Where the hit is rough dispersive glass whose wavelengths a spectral path carries on
    /// together, weighted by MIS over their densities ([`PathContext::mixes_wavelengths`];
    /// `integrators/wavelengths.rs`).
    fn mixes_wavelengths(
        &self,
        hit: &Self::Hit,
        active: Mask3<Self::V>,
        ctx: &Self::Context,
    ) -> Mask3<Self::V>;
    /// Where the wavelengths mix (`active`): f at each channel's wavelength for the local
    /// directions `wo`, `wi`, and the mean of their densities ([`PathContext::eval_wavelengths`]).
    fn eval_wavelengths(
        &self,
        hit: &Self::Hit,
        wo: Self::V,
        wi: Self::V,
        active: Mask3<Self::V>,
        ctx: &Self::Context,
    ) -> (Self::V, Self::R);
    /// Where the wavelengths mix (`active`): the BSDF sample of the wavelength the lobe number
    /// `uc` chooses, with f per channel and the mean density after one facet
    /// ([`PathContext::sample_wavelengths`]), and where there is one.
    fn sample_wavelengths(
        &self,
        hit: &Self::Hit,
        wo: Self::V,
        uc: Self::R,
        u: (Self::R, Self::R),
        active: Mask3<Self::V>,
        ctx: &Self::Context,
    ) -> (Mask3<Self::V>, BsdfSample<Self::V>);
    /// Where a path has `ended`, the next branch its context holds put in its place in `path`
    /// (the radiance gathered kept): the paths that go on with one.
    fn resume(
        &self,
        path: &mut PathState<Self::V>,
        ended: Mask3<Self::V>,
        ctx: &mut Self::Context,
    ) -> Mask3<Self::V>;
    /// Where the hit is a dielectric interface, the absorption of the medium the scattered ray
    /// travels in (the one it stays in when reflected, enters when transmitted); elsewhere the
    /// medium does not change.
    fn medium_after(
        &self,
        hit: &Self::Hit,
        dir: Self::V,
        transmitted: Mask3<Self::V>,
        active: Mask3<Self::V>,
        ctx: &Self::Context,
    ) -> (Mask3<Self::V>, Self::V);
    /// Counts a scattered ray, reflected or refracted, where `active`.
    fn count_scattered(ctx: &mut Self::Context, reflected: Mask3<Self::V>, active: Mask3<Self::V>);
    /// Manifold next-event estimation ([`crate::manifold::sample`]) from the hit to `light`,
    /// with the numbers `u` (the light's point) and `u_seed` (the solver's seeds), at the
    /// path's `time`, where `active`: where a chain through glass is found, the direction
    /// towards it and its radiance over its density (the light's choice left out), in the
    /// path's channels. Its segments count as shadow rays.
    #[allow(clippy::too_many_arguments)]
    fn manifold(
        &self,
        hit: &Self::Hit,
        light: Self::Light,
        u: (Self::R, Self::R),
        u_seed: Self::R,
        settings: &ManifoldParams,
        time: Self::R,
        active: Mask3<Self::V>,
        ctx: &mut Self::Context,
    ) -> (Mask3<Self::V>, Self::V, Self::V);
    /// Where the hit is smooth glass that manifold chains cross ([`crate::manifold::is_caster`]).
    fn is_caster(&self, hit: &Self::Hit, active: Mask3<Self::V>) -> Mask3<Self::V>;
}

/// A scattering model at a vertex, for one ray or per lane (radiance transport).
pub(crate) trait VertexBsdf<V: Vector> {
    /// Whether it scatters only into delta lobes (nothing for next-event estimation to evaluate).
    fn is_delta(&self) -> Mask3<V>;
    /// Whether its sample draws a lobe choice.
    fn chooses_lobe(&self) -> Mask3<V>;
    /// f(wo, wi) in the local frame.
    fn eval(&self, wo: V, wi: V) -> V;
    /// The solid-angle density of sampling `wi` from `wo`.
    fn pdf(&self, wo: V, wi: V) -> V::Real;
    /// A direction for `wo` from the lobe choice `uc` and the pair `u`, and where there is one.
    fn sample(
        &self,
        wo: V,
        uc: V::Real,
        u: (V::Real, V::Real),
        active: Mask3<V>,
    ) -> (Mask3<V>, BsdfSample<V>);
}

/// A shading frame at a vertex, for one ray or per lane.
pub(crate) trait VertexFrame<V: Vector> {
    /// World-space `v` in the local frame.
    fn to_local(&self, v: V) -> V;
    /// Local `v` in world space.
    fn to_world(&self, v: V) -> V;
    /// [`ShadingFrame::factor`] for radiance transport.
    fn factor(&self, wo: V, wi: V) -> V::Real;
}

/// A light sampled for next-event estimation: the sample (its radiance in the path's channels),
/// whether the light is a delta, and the point a shadow ray aims at.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LightDraw<V: Vector> {
    /// The sample.
    pub sample: LightSampleOf<V>,
    /// Whether the light is a delta (no MIS).
    pub delta: Mask3<V>,
    /// The shadow ray's target.
    pub target: V,
}

/// A light sample waiting for its shadow ray: whose contribution counts when nothing blocks it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PendingLight<V: Vector, S> {
    /// Where a light was sampled that can contribute.
    pub pending: Mask3<V>,
    /// The visibility query.
    pub shadow: S,
    /// The path throughput at the vertex.
    beta: V,
    /// The light's contribution at the vertex if it is visible (f·Le·w/pdf).
    value: V,
}

/// The outcome of [`PathState::advance`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Step<V: Vector, S> {
    /// Where the path goes on along its new ray.
    pub goes_on: Mask3<V>,
    /// The light sampled by next-event estimation, pending its shadow ray.
    pub light: PendingLight<V, S>,
}

impl PathState {
    /// A path starting along the camera ray `ray`.
    pub fn new(ray: Ray) -> PathState {
        PathState { origin: ray.origin, dir: ray.dir, time: ray.time, ..PathState::fresh() }
    }

    /// The ray to trace next.
    #[inline]
    pub fn ray(&self) -> Ray {
        Ray { origin: self.origin, dir: self.dir, time: self.time }
    }
}

impl<V: Vector> PathState<V> {
    /// Paths about to start along rays still to be set: unit throughput, no medium, no MIS on
    /// what the camera sees.
    pub fn fresh() -> PathState<V> {
        let (zero, one) = (V::Real::splat(0.0), V::Real::splat(1.0));
        let origin = V::splat(Vec3::ZERO);
        PathState {
            origin,
            dir: origin,
            time: zero,
            l: origin,
            beta: V::splat(Vec3::ONE),
            eta_scale: one,
            skip_mis: V::Real::mask(true),
            bsdf_pdf: zero,
            absorption: origin,
            depth: zero,
            chain: V::Real::splat(-1.0),
        }
    }

    /// Adds the pending light `light` of this path's last step where it is `visible`.
    #[inline(always)]
    pub fn resolve<S>(&mut self, light: &PendingLight<V, S>, visible: Mask3<V>) {
        self.l = V::select(light.pending & visible, self.l + light.beta * light.value, self.l);
    }

    /// One vertex: the closest hit `hit` of the path's ray (or its escape), its emission
    /// weighted against next-event estimation, next-event estimation (returned as a pending
    /// shadow ray), the BSDF sample that makes the next ray, and Russian roulette. The random
    /// numbers are drawn in this order: a light choice (with several lights) and a point on the
    /// light where the vertex is not a delta, a lobe choice where the model chooses one, the
    /// direction pair, and a roulette number where roulette plays.
    ///
    /// A spectral path that smooth dispersive glass splits into branches, one per wavelength
    /// ([`PathContext::split_wavelengths`]), goes on with the next branch where this one ends.
    /// `SPECTRAL` says whether the paths' channels are wavelengths, a mode fixed for a whole
    /// render: an RGB path (`false`) compiles without the wavelengths' work (the split, the
    /// branches, the light seen directly in RGB), so RGB renders pay nothing for it.
    #[inline(always)]
    pub fn advance<const SPECTRAL: bool, W: PathWorld<V = V, R = V::Real>>(
        &mut self,
        world: &W,
        params: &RenderParams,
        hit: &W::Hit,
        ctx: &mut W::Context,
    ) -> Step<V, W::Shadow> {
        let mut step = self.vertex::<SPECTRAL, W>(world, params, hit, ctx);
        if SPECTRAL {
            let ended = world.live(hit) & !step.goes_on;
            if V::Real::any(ended) {
                step.goes_on = step.goes_on | world.resume(self, ended, ctx);
            }
        }
        step
    }

    /// The manifold chain counter ([`PathState::chain`]) after the BSDF sample `s` at the hit,
    /// where `active`: 0 where the manifold strategy ran (`starts`) and `s` is an evaluable lobe
    /// (which the strategy's BSDF value covers); one more where the path turns at smooth glass
    /// as the strategy's chains do (any turn for SMS; refraction or total internal reflection
    /// for the straight seeds), up to `max_chain`; −1 otherwise.
    #[inline(always)]
    fn chain_after<W: PathWorld<V = V, R = V::Real>>(
        &self,
        world: &W,
        hit: &W::Hit,
        s: &BsdfSample<V>,
        starts: Mask3<V>,
        settings: &ManifoldParams,
        active: Mask3<V>,
    ) -> V::Real {
        let (zero, one) = (V::Real::splat(0.0), V::Real::splat(1.0));
        let starts = starts & s.is_evaluable();
        let follows = active & !starts & self.chain.ge(zero) & s.is_specular;
        let mut turn = if V::Real::any(follows) { world.is_caster(hit, follows) & follows } else { follows };
        if settings.seeding == Seeding::Straight {
            turn = turn & (s.is_transmission | s.pdf.ge(one));
        }
        let next = self.chain + one;
        let next = V::Real::select(turn & next.le(V::Real::splat(settings.max_chain as f32)), next, -one);
        let next = V::Real::select(starts, zero, next);
        V::Real::select(active, next, self.chain)
    }

    /// [`advance`](Self::advance) but for the branches: one vertex of the branch in flight.
    #[inline(always)]
    fn vertex<const SPECTRAL: bool, W: PathWorld<V = V, R = V::Real>>(
        &mut self,
        world: &W,
        params: &RenderParams,
        hit: &W::Hit,
        ctx: &mut W::Context,
    ) -> Step<V, W::Shadow> {
        let (zero, one) = (V::Real::splat(0.0), V::Real::splat(1.0));
        let none = V::Real::mask(false);
        let vzero = V::splat(Vec3::ZERO);
        let lights = world.light_count();
        let light_pick = V::Real::splat(1.0 / lights.max(1) as f32);
        let found = world.found(hit);
        let mut step = Step {
            goes_on: none,
            light: PendingLight { pending: none, shadow: world.no_shadow(), beta: vzero, value: vzero },
        };
        // A ray that leaves the scene outside any medium sees the environment.
        let escapes = !found & world.live(hit) & self.absorption.is_zero();
        // What the camera ray itself sees (its throughput is 1), set aside in RGB by a spectral
        // path only.
        let seen = if SPECTRAL { self.depth.eq(zero) } else { none };
        if V::Real::any(escapes) {
            let le = world.escaped(self.dir, self.skip_mis, self.bsdf_pdf, light_pick, seen, escapes, ctx);
            self.l = V::select(escapes, self.l + self.beta * le, self.l);
        }
        if !V::Real::any(found) {
            return step;
        }
        let (t, p, n, p_error) = world.surface(hit);
        let absorbs = found & !self.absorption.is_zero();
        if V::Real::any(absorbs) {
            self.beta = V::select(absorbs, self.beta * (-self.absorption * t).exp_where(absorbs), self.beta);
        }
        let wo = -self.dir;
        // Emission reached by BSDF sampling (or seen directly), weighted against NEE.
        let (emits, le, pdf_li) = world.emission(hit, self.origin, wo, seen, found, ctx);
        let emits = emits & found;
        if V::Real::any(emits) {
            let mut w =
                V::Real::select(self.skip_mis, one, power_heuristic(self.bsdf_pdf, light_pick * pdf_li));
            if params.manifold.is_some() {
                // A chain through glass from the last non-delta vertex: manifold next-event
                // estimation's (the two partition such paths).
                w = V::Real::select(self.chain.ge(one), zero, w);
            }
            self.l = V::select(emits, self.l + self.beta * le * w, self.l);
        }
        let scatters = found & self.depth.lt(V::Real::splat(params.max_depth as f32));
        if !V::Real::any(scatters) {
            return step;
        }
        let (bsdf, ends_secondaries) = world.bsdf(hit, scatters, ctx);
        self.beta = V::select(scatters, self.beta * ends_secondaries, self.beta);
        let frame = world.frame(hit, wo);
        let wo_local = frame.to_local(wo);
        // Rough dispersive glass whose wavelengths go on together, weighted by MIS over them.
        let mixed = if SPECTRAL { world.mixes_wavelengths(hit, scatters, ctx) & scatters } else { none };
        // Next-event estimation: one uniformly chosen light, sampled.
        let nee = scatters & !bsdf.is_delta() & V::Real::mask(lights > 0);
        if V::Real::any(nee) {
            let choice = if lights > 1 { world.draw_1d(ctx, Dim::Light, nee) } else { zero };
            let light = world.light_at(choice);
            let u = world.draw_2d(ctx, Dim::Light, nee);
            let LightDraw { sample: ls, delta, target } = world.sample_light(hit, light, u, nee, ctx);
            let wi_local = frame.to_local(ls.wi);
            let mut f = bsdf.eval(wo_local, wi_local);
            // Where the wavelengths mix: f at each and the mean of their densities.
            let mut mixture = (none, zero);
            if SPECTRAL && V::Real::any(mixed & nee) {
                let (fm, pm) = world.eval_wavelengths(hit, wo_local, wi_local, mixed & nee, ctx);
                f = V::select(mixed & nee, fm, f);
                mixture = (mixed & nee, pm);
            }
            let f = f * (wi_local.z().abs() * frame.factor(vzero, ls.wi));
            let pending = nee & ls.sampled & !f.is_zero();
            let shadow = world.shadow(hit, target, light, self.time, pending, ctx);
            let pdf = light_pick * ls.pdf;
            // A delta light has no density for BSDF sampling to match: no MIS.
            let weighted = pending & !delta;
            let w = if V::Real::any(weighted) {
                let mut bsdf_pdf = bsdf.pdf(wo_local, wi_local);
                if SPECTRAL {
                    bsdf_pdf = V::Real::select(mixture.0, mixture.1, bsdf_pdf);
                }
                V::Real::select(weighted, power_heuristic(pdf, bsdf_pdf), one)
            } else {
                one
            };
            step.light =
                PendingLight { pending, shadow, beta: self.beta, value: f * ls.radiance * (w / pdf) };
        }
        // Manifold next-event estimation: one uniformly chosen light, reached through glass.
        let chains_start = match &params.manifold {
            Some(settings) if world.has_casters() => {
                let mnee = scatters & !bsdf.is_delta() & V::Real::mask(lights > 0);
                if V::Real::any(mnee) {
                    let choice = if lights > 1 { world.draw_1d(ctx, Dim::Light, mnee) } else { zero };
                    let light = world.light_at(choice);
                    let u = world.draw_2d(ctx, Dim::Light, mnee);
                    let u_seed = world.draw_1d(ctx, Dim::Other, mnee);
                    let (found, wi, radiance) =
                        world.manifold(hit, light, u, u_seed, settings, self.time, mnee, ctx);
                    let found = found & mnee;
                    if V::Real::any(found) {
                        let wi_local = frame.to_local(wi);
                        let mut f = bsdf.eval(wo_local, wi_local);
                        if SPECTRAL && V::Real::any(found & mixed) {
                            let (fm, _) = world.eval_wavelengths(hit, wo_local, wi_local, found & mixed, ctx);
                            f = V::select(found & mixed, fm, f);
                        }
                        let f = f * (wi_local.z().abs() * frame.factor(vzero, wi));
                        let value = self.beta * f * radiance * (one / light_pick);
                        self.l = V::select(found, self.l + value, self.l);
                    }
                }
                mnee
            }
            _ => none,
        };
        // The BSDF sample that makes the next ray.
        let uc = world.draw_1d(ctx, Dim::Bsdf, scatters & bsdf.chooses_lobe());
        let u = world.draw_2d(ctx, Dim::Bsdf, scatters);
        let (sampled, s) = if SPECTRAL && V::Real::any(mixed) {
            // Where the wavelengths mix, the sample of one chosen by `uc`, weighted for all.
            let (sampled, s) = bsdf.sample(wo_local, uc, u, scatters & !mixed);
            let (mixed_sampled, m) = world.sample_wavelengths(hit, wo_local, uc, u, mixed, ctx);
            ((mixed & mixed_sampled) | (!mixed & sampled), BsdfSample::select(mixed, &m, &s))
        } else {
            bsdf.sample(wo_local, uc, u, scatters)
        };
        let sampled = scatters & sampled & !(s.pdf.le(zero) | s.f.is_zero());
        let wi = frame.to_world(s.wi);
        let shading = frame.factor(wo, wi);
        // The wavelengths dispersive glass parts, set aside as branches even where the sampled
        // one cannot go on.
        let split = if SPECTRAL && V::Real::any(sampled) {
            world.split_wavelengths(hit, &s, wo_local, uc, u, self, sampled, ctx)
        } else {
            V::splat(Vec3::ONE)
        };
        let scatters = sampled & shading.ne(zero);
        if !V::Real::any(scatters) {
            return step;
        }
        if let Some(settings) = &params.manifold {
            self.chain = self.chain_after(world, hit, &s, chains_start, settings, scatters);
        }
        let mut beta = s.f * (s.wi.z().abs() / s.pdf);
        if SPECTRAL {
            beta = beta * split;
        }
        let beta = self.beta * (beta * shading);
        let (crosses, absorption) = world.medium_after(hit, self.dir, s.is_transmission, scatters, ctx);
        let eta_scale = V::Real::select(s.is_transmission, self.eta_scale * (s.eta * s.eta), self.eta_scale);
        W::count_scattered(ctx, (wi.dot(n) * wo.dot(n)).gt(zero), scatters);
        let origin = offset_origin(p, n, p_error, wi);
        let depth = self.depth + 1.0;
        // Russian roulette, on the throughput with the η² of refraction undone.
        let rr = (beta * eta_scale).max_element();
        let plays = scatters & depth.gt(V::Real::splat(ROULETTE_DEPTH as f32)) & rr.lt(one);
        let q = (V::Real::splat(1.0) - rr).max(zero);
        let dies = plays & world.draw_1d(ctx, Dim::Other, plays).lt(q);
        let beta = V::select(plays, beta / (V::Real::splat(1.0) - q), beta);
        self.beta = V::select(scatters, beta, self.beta);
        self.skip_mis = (scatters & !s.is_evaluable()) | (!scatters & self.skip_mis);
        self.bsdf_pdf = V::Real::select(scatters, s.pdf, self.bsdf_pdf);
        self.absorption = V::select(scatters & crosses, absorption, self.absorption);
        self.eta_scale = V::Real::select(scatters, eta_scale, self.eta_scale);
        self.origin = V::select(scatters, origin, self.origin);
        self.dir = V::select(scatters, wi + vzero, self.dir);
        self.depth = V::Real::select(scatters, depth, self.depth);
        step.goes_on = scatters & !dies;
        step
    }
}

/// A BSDF sample that is not there (where a lane has none).
#[inline(always)]
pub(crate) fn no_sample<V: Vector>() -> BsdfSample<V> {
    let (zero, no) = (V::Real::splat(0.0), V::Real::mask(false));
    let v = V::splat(Vec3::ZERO);
    BsdfSample { wi: v, f: v, pdf: zero, is_specular: no, is_multiple: no, is_transmission: no, eta: zero }
}

impl PathContext {
    /// Wavelength splitting at smooth dispersive glass (`isect`), for `path`: the factor the
    /// throughput of `path` (its state at the vertex, not yet updated) takes after `s`, the
    /// sample of its lead wavelength drawn with the numbers `u` = (lobe choice, pair) for the
    /// direction `wo` (local frame), as [`part_wavelengths`](Self::part_wavelengths) decides.
    /// Every wavelength it parts from the path becomes a branch of its own (its channel's
    /// throughput, direction, origin, medium, η² and MIS state), set aside in
    /// [`pending`](Self::pending) to run when the path ends, replaying the path's numbers from
    /// dimension `replay` on. At rough dispersive glass whose wavelengths mix, a sample that
    /// scattered several times splits the wavelengths whose walks do too
    /// ([`part_multiple`](Self::part_multiple)).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn split_wavelengths(
        &mut self,
        scene: &Scene,
        isect: &Intersection,
        s: &BsdfSample,
        wo_local: Vec3,
        (uc, u): (f32, (f32, f32)),
        path: &PathState,
        replay: u32,
    ) -> Vec3 {
        if !self.channels.is_spectral() {
            return Vec3::ONE;
        }
        let material = scene.material_of(isect.primitive);
        let multiple = !s.is_evaluable() && self.mixes_wavelengths(material, &isect.hit);
        if self.hero_only && !multiple {
            return Vec3::ONE;
        }
        let (wo, mode) = (-path.dir, TransportMode::Radiance);
        let frame = ShadingFrame::at(&isect.hit, wo);
        let numbers = (uc, u);
        let (factor, parted) = if multiple {
            // Rough dispersive glass scattered several times: no density to weigh with.
            self.part_multiple(material, &isect.hit, &frame, wo, s, wo_local, numbers, mode)
        } else {
            self.part_wavelengths(material, &isect.hit, &frame, wo, s, wo_local, (uc, u.into()), mode)
        };
        for p in parted.iter().flatten() {
            self.set_aside(scene, isect, path, p, replay);
        }
        factor
    }

    /// Sets aside the wavelength `p` parted from `path` (its state at the vertex `isect`, not yet
    /// updated) as a branch of its own, to run when the path in flight ends, replaying its
    /// numbers from dimension `replay` on.
    pub(super) fn set_aside(
        &mut self,
        scene: &Scene,
        isect: &Intersection,
        path: &PathState,
        p: &PartedWavelength,
        replay: u32,
    ) {
        let si = &p.sample;
        let (crosses, absorption) = medium_after(scene, isect, path.dir, si.is_transmission, &p.channels);
        let branch = PathState {
            origin: offset_origin(isect.hit.p, isect.hit.n, isect.hit.p_error, p.wi),
            dir: p.wi,
            time: path.time,
            l: Vec3::ZERO,
            beta: path.beta * p.weight,
            eta_scale: if si.is_transmission { path.eta_scale * (si.eta * si.eta) } else { path.eta_scale },
            skip_mis: !si.is_evaluable(),
            bsdf_pdf: si.pdf,
            absorption: if crosses { absorption } else { path.absorption },
            depth: path.depth + 1.0,
            chain: path.chain,
        };
        self.pending.push(Branch { channel: p.channel, state: branch, replay });
    }
}

impl PathContext {
    /// The RGB radiance `rgb` a path meets, in its channels; but where the camera ray itself
    /// meets it (`seen`) in spectral mode, added to [`seen_rgb`](Self::seen_rgb) in RGB and 0
    /// returned. The expectation over the wavelengths of the spectral estimate of light seen
    /// directly is its RGB exactly (the upsampling keeps every RGB under the colour weights:
    /// [`crate::spectrum`]), so adding the RGB removes its colour noise and changes nothing else.
    #[inline]
    pub(crate) fn radiance_seen(&mut self, rgb: Vec3, seen: bool) -> Vec3 {
        if seen && self.channels.is_spectral() {
            self.seen_rgb += rgb;
            return Vec3::ZERO;
        }
        self.channels.colour(rgb)
    }

    /// Puts the next branch waiting (if one does) in the place of `path`, which has ended: its
    /// state, the radiance gathered kept, and its wavelength the one indices are taken at. The
    /// dimension of the random stream it replays from, which the caller sets.
    #[inline]
    pub(crate) fn resume_branch(&mut self, path: &mut PathState) -> Option<u32> {
        let branch = self.pending.resume(&mut self.channels)?;
        *path = PathState { l: path.l, ..branch.state };
        Some(branch.replay)
    }
}

mod one_ray;

use one_ray::medium_after;
pub(crate) use one_ray::{light_draw, manifold_draw, OneRay};

#[cfg(test)]
mod tests;
