//! Manifold next-event estimation: light that reaches a shading point from a light source
//! through a chain of smooth dielectric interfaces (a caustic), found by solving for the chain
//! with Newton's method (Hanika et al. 2015, "Manifold next event estimation"; Zeltner et al.
//! 2020, "Specular manifold sampling"). `path`'s shadow rays cannot bend, so without it the
//! caustic of a point light through glass is black in `path`, and the caustic of a small area
//! light is found only by rare BSDF samples.
//!
//! # The solve
//! A chain leaves a point `y` of the light in the direction `ω` and follows the interfaces it
//! meets: at each one it refracts or reflects (its *turns*, fixed for a solve), until it meets a
//! surface that is not smooth glass. Write `X(ω)` for the point where that last ray crosses the
//! tangent plane of the shading point `x`. The solver finds `ω` with `X(ω) = x` by Newton's
//! method in two coordinates of the direction (a tangent plane of the unit sphere at the current
//! `ω`), with the 2×2 Jacobian `∂X/∂ω` by finite differences of traced chains ("shooting"), so
//! it needs no surface derivatives: it works alike on analytic shapes and on meshes with smooth
//! normals, and it refracts by the same interface model as every other method
//! ([`RoughDielectric::specular_sample`], [`ShadingFrame`]). Total internal reflection is a turn
//! like any other; absorption (Beer–Lambert) is applied along every segment; a step that changes
//! the chain's interfaces is halved. The chain is valid when the last ray's first hit is `x`
//! itself, which checks every segment's visibility on the way.
//!
//! # Giving up early
//! Most solves fail, and the failures cost most of the rays: on `cornell-glass` 381 of the 408
//! straight seeds that meet glass find no chain, 119 rays each against 23 for a solve that
//! converges. They end against an object's silhouette, where the chain would change and the
//! landing error has a local minimum off `x`. So a solve gives up when a Newton step finds no
//! decrease within 4 halvings (10 before), or when the residual has not halved over the last
//! 3 steps none of which the largest step limited (a far seed that closes in at
//! the largest step is not stalled); and an SMS trial whose seed chain turns otherwise than the
//! chain found is not solved at all (a solve keeps its seed's turns, so it could not match).
//! The rule changes which seeds converge, never what a converged solve finds, and it is one
//! deterministic map from seed to chain for the seed and every trial alike: SMS's `p` is the
//! chance that this solver, from a random seed, finds the chain, and the Bernoulli trials
//! estimate `1/p` of the same solver, so the estimate stays unbiased (up to the trial cap, which
//! bites a little more where a chain's basin shrinks). Measured on 4256 shading points of
//! `cornell-glass` (the unit tests' `solve_statistics`, which also tries other rules): straight
//! seeds find the same 27 chains with 37% of the rays (50.6k → 18.6k); SMS (8 samples a point)
//! traces 0.42M rays instead of 1.62M (the skipped trials alone: 0.89M, the same estimates to
//! the bit), and 6% fewer of its solves converge (669 against 708). 6 halvings instead of 4
//! found the same chains with more rays; a window of 2 steps or a factor of 0.25 lost more
//! converging SMS solves (603, 623).
//!
//! # The estimate
//! Light leaving `y` into the solid angle `dω` lands on the area `|det ∂X/∂ω| dω` around `x`, so
//! the chain's irradiance at `x` is `I(ω)·T/|det ∂X/∂ω|`, where `I` is the point light's
//! intensity (or an area light's `Le·|cos θ_y|` over the density of `y`, uniform over the area)
//! and `T` the product of the interfaces' Fresnel factors (power, as light tracing counts them)
//! and the media's transmittance. The caller weights it by the BSDF at `x` like any light sample
//! ([`ManifoldSample::radiance`] is that irradiance over `|cos θ_x|`).
//!
//! # Variants ([`Seeding`])
//! - **`straight`, Hanika's MNEE (the default):** the seed is the straight line from `y` to
//!   `x`, every turn a refraction (reflection only under total internal reflection), one solve.
//!   It is cheap and noiseless, but deterministic: where several chains reach `x` (inside the
//!   fold of a caustic) it finds one, and chains with a partial Fresnel reflection are never
//!   found, so it is biased low there. Measured against `vcm` on `cornell-glass` (64², 512
//!   samples): 1–2% low on the walls (the glass's reflections), 7% and 18% low in the two
//!   blocks of 8×8 pixels with the most reflected caustic light.
//! - **`sms`, specular manifold sampling:** the seed direction is random, towards a uniformly
//!   chosen caster's bounding sphere, and each turn is a reflection with probability
//!   `clamp(F, 0.1, 0.9)` at the seed (1 under total internal reflection), so every chain of
//!   every turn sequence has a chance `p` to be found. The estimate of `1/p` is the number of
//!   further independent seeds, drawn the same way, until one solves to the same chain again (a
//!   geometric count, Zeltner et al.'s Bernoulli trials), so the expectation over the chains is
//!   their sum, up to `max_trials`. Solves that identify a chain are polished past the
//!   tolerance (`POLISH_STEPS`) so that two solves of one chain agree far below
//!   `SAME_CHAIN` even in a bright caustic, where the tolerance alone leaves the direction
//!   uncertain by up to 1e-2 rad (a missed match overcounts `1/p`). At one light point SMS
//!   averages to the sum over the chains enumerated from a dense grid of seeds (unit tests).
//!   The cap is a bias of its own: a chain found with probability `p` keeps
//!   `1 − (1 − p)^max_trials` of its light (measured 0.74 for a chain reflected inside the
//!   ball, p = 0.005, at 256 trials). It agrees with `vcm` on `cornell-glass` and
//!   `hollow-spheres` (`tests/mnee.rs`), but its estimates are heavy-tailed (probably because
//!   near a caustic's fold a chain's irradiance and its `1/p` grow together): a few samples
//!   carry much of a bright caustic, a render's replicas understate its error, and a typical
//!   render at a few samples per pixel is low (on an area light's caustic through a ball, 32²
//!   pixels, the block of the caustic at 38% of `path`'s at 32 samples, 82–109% over four
//!   seeds at 512 with `max_trials` 4096). Use it to study the estimator, not for references.
//!
//! `path` with manifold next-event estimation (the `mnee` method) counts the chains found here
//! and drops what BSDF sampling finds of the same class (a chain of at most `max_chain` such
//! turns from a non-delta vertex to an area light): the two partition the paths, so their
//! weights sum to 1. Their densities cannot be compared for MIS: the solve's density is not
//! known (SMS estimates only its reciprocal).

use crate::bsdf::{Scattering, ShadingFrame, TransportMode};
use crate::geometry::{offset_origin, spawn_origin, Ray, SurfaceHit};
use crate::light::{uniform_sphere, Light};
use crate::lighting::crossing;
use crate::material::Bsdf;
use crate::params::{ManifoldParams, Seeding};
use crate::scene::Scene;
use crate::spectrum::Channels;
use glam::{Vec2, Vec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;

/// The longest chain the solver follows, whatever the setting asks (a fixed array).
pub const MAX_CHAIN: usize = 16;

/// Newton iterations before a solve gives up.
const MAX_ITERATIONS: usize = 16;

/// Halvings of a Newton step before a solve gives up.
const MAX_HALVINGS: usize = 10;

/// How a solve gives up before [`MAX_ITERATIONS`]: the same for every solve of a render, so
/// that the solver is one deterministic map from seed to chain (SMS's basins).
#[derive(Clone, Copy, Debug)]
struct Stop {
    /// Stop when the residual has not shrunk below `factor` of what it was `window` Newton
    /// steps before, none of which the largest step ([`MAX_STEP`]) limited (0: never).
    window: usize,
    /// See `window`.
    factor: f32,
    /// Halvings of a Newton step before the solve gives up.
    halvings: usize,
}

impl Stop {
    /// The solver's rule.
    const RULE: Stop = Stop { window: 3, factor: 0.5, halvings: 4 };
    /// No early stop: every solve runs until it converges, a step fails after
    /// [`MAX_HALVINGS`] halvings, or [`MAX_ITERATIONS`] run out (the rule before the stops).
    #[cfg(test)]
    const NONE: Stop = Stop { window: 0, factor: 0.0, halvings: MAX_HALVINGS };
}

/// The largest Newton step (radians).
const MAX_STEP: f32 = 0.25;

/// Finite-difference step of the Newton Jacobian and of the final determinant (radians).
const DIFFERENCE: f32 = 2e-4;

/// Convergence: the landing point within this fraction of the light's distance of `x`.
const TOLERANCE: f32 = 2e-5;

/// Newton steps after convergence that SMS takes to pin its solutions down ([`Solver::solve`]).
const POLISH_STEPS: usize = 4;

/// Two solves found the same chain when their directions differ by less than this (radians),
/// with the same interfaces and turns: far below the distance of distinct solutions, far above
/// the precision of a converged one (about `TOLERANCE`).
const SAME_CHAIN: f32 = 1e-3;

/// A smooth dielectric object that seeds chains: its bounding sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Caster {
    /// Centre.
    pub centre: Vec3,
    /// Radius.
    pub radius: f32,
}

/// Whether a material is one manifold next-event estimation chains through: a dielectric whose
/// every lobe is a delta (smooth glass, water).
pub fn is_caster(bsdf: &Bsdf) -> bool {
    matches!(bsdf, Bsdf::Dielectric { .. }) && bsdf.is_specular()
}

/// One interface of a chain: the object, and whether the chain reflects there.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Turn {
    /// The object turned at ([`Scene::object_of`]): a mesh is one interface, so a Newton step
    /// may move across its triangles.
    object: u32,
    reflects: bool,
}

/// How a traced chain turns at its interfaces.
enum Turns<'a> {
    /// As a solved chain did, at the same objects.
    Fixed(&'a [Turn]),
    /// Refraction, reflection only under total internal reflection (MNEE's seed).
    Refract,
    /// Reflection with probability `clamp(F, 0.1, 0.9)` (1 under total internal reflection),
    /// with these numbers (SMS's seeds).
    Random(&'a mut Pcg32),
}

/// A chain traced from the light.
#[derive(Clone, Copy, Debug)]
struct Shot {
    /// Its interfaces, the first `len`.
    turns: [Turn; MAX_CHAIN],
    /// How many.
    len: usize,
    /// Where the ray after the last interface crosses the tangent plane of `x`.
    landing: Vec3,
    /// Its first hit, a surface that is not smooth glass.
    end: Vec3,
    /// Its direction.
    arriving: Vec3,
    /// The Fresnel factors and the media's transmittance, in the path's channels.
    throughput: Vec3,
    /// Whether an interface is dispersive.
    dispersive: bool,
}

/// The light at a point, as the chain leaves it.
#[derive(Clone, Copy, Debug)]
struct Source<'a> {
    light: &'a Light,
    /// The point, with its normal and error bound (the position of a point light).
    at: SurfaceHit,
    /// Whether it is a point or spot light.
    delta: bool,
    /// The reciprocal of the point's area density (1 for a point light).
    area: f32,
}

impl Source<'_> {
    /// Intensity towards `dir` over the point's density: `I(ω)` of a point or spot light,
    /// `Le(y, ω)·|cos θ_y|·area` of an area light.
    fn intensity(&self, dir: Vec3) -> Vec3 {
        if self.delta {
            return self.light.intensity_towards(dir);
        }
        self.light.emitted(&self.at, dir) * (self.at.n.dot(dir).abs() * self.area)
    }

    /// The first ray of a chain along `dir`.
    fn ray(&self, dir: Vec3, time: f32) -> Ray {
        let origin = if self.delta { self.at.p } else { spawn_origin(&self.at, dir) };
        Ray { origin, dir, time }
    }
}

/// The shading point a chain must reach.
#[derive(Clone, Copy, Debug)]
pub struct Receiver {
    /// The point.
    pub p: Vec3,
    /// Its geometric normal.
    pub n: Vec3,
    /// Its time (moving objects).
    pub time: f32,
}

/// A chain found from a light to a shading point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ManifoldSample {
    /// The unit direction from the shading point towards the chain's last interface.
    pub wi: Vec3,
    /// The irradiance the chain brings, over `|cos θ|` of `wi` at the shading point's geometric
    /// normal and over the density of the light's point, in the path's channels: weighted by
    /// the BSDF like a light sample's radiance over its density.
    pub radiance: Vec3,
}

/// Manifold next-event estimation from the shading point `x` to light `light` of `scene`: the
/// light's point from `u` (uniform over an area light; a point light is itself), the seeds and
/// trials from `u_seed`, the chain's indices in `channels` (a dispersive chain carries the lead
/// wavelength alone, weighted as a hero path is, unless `hero_only` says the path already does).
/// `rays` counts the traced segments. `None` where no chain is found (no caster, a light at
/// infinity, a seed that does not converge, or no chain at all).
#[allow(clippy::too_many_arguments)]
pub fn sample(
    scene: &Scene,
    x: &Receiver,
    light: usize,
    u: Vec2,
    u_seed: f32,
    params: &ManifoldParams,
    channels: &Channels,
    hero_only: bool,
    rays: &mut u64,
) -> Option<ManifoldSample> {
    sample_stopping(scene, x, light, u, u_seed, params, channels, hero_only, Stop::RULE, rays)
}

/// [`sample`] with the solves stopping by `stop`.
#[allow(clippy::too_many_arguments)]
fn sample_stopping(
    scene: &Scene,
    x: &Receiver,
    light: usize,
    u: Vec2,
    u_seed: f32,
    params: &ManifoldParams,
    channels: &Channels,
    hero_only: bool,
    stop: Stop,
    rays: &mut u64,
) -> Option<ManifoldSample> {
    let casters = scene.casters();
    if casters.is_empty() {
        return None;
    }
    let light = &scene.lights[light];
    let source = match light {
        Light::Point { position, .. } | Light::Spot { position, .. } => Source {
            light,
            at: SurfaceHit {
                t: 0.0,
                p: *position,
                n: Vec3::Z,
                shading_n: Vec3::Z,
                uv: Vec2::ZERO,
                p_error: 0.0,
            },
            delta: true,
            area: 1.0,
        },
        _ => {
            let (at, area) = light.area_point(u)?;
            Source { light, at, delta: false, area }
        }
    };
    let max_chain = (params.max_chain as usize).min(MAX_CHAIN);
    let solver = Solver { scene, x: *x, source, channels, max_chain, stop };
    let distance = (x.p - source.at.p).length();
    if distance <= 0.0 || !distance.is_finite() {
        return None;
    }
    let (solution, trials) = solver.estimate(params, u_seed, distance, rays)?;
    let det = solver.determinant(&solution, rays)?;
    let cos_x = solution.shot.arriving.dot(x.n).abs();
    if det <= 0.0 || cos_x <= 0.0 || !det.is_finite() {
        return None;
    }
    let hero = if solution.shot.dispersive && !hero_only { crate::spectrum::HERO_ONLY } else { Vec3::ONE };
    let radiance =
        source.intensity(solution.dir) * solution.shot.throughput * hero * (trials / (det * cos_x));
    radiance.is_finite().then_some(ManifoldSample { wi: -solution.shot.arriving, radiance })
}

/// A seed direction from `y` towards one of `casters` chosen uniformly: uniform within the cone
/// of its bounding sphere, or over the whole sphere of directions from inside it.
fn random_seed(y: Vec3, casters: &[Caster], rng: &mut Pcg32) -> Vec3 {
    let c = casters[rng.random_range(0..casters.len())];
    cone_seed(y, c, Vec2::new(rng.random::<f32>(), rng.random::<f32>()))
}

/// The seed direction from `y` towards the caster `c` for the numbers `u`: uniform within the
/// cone of its bounding sphere, or over the whole sphere of directions from inside it.
fn cone_seed(y: Vec3, c: Caster, u: Vec2) -> Vec3 {
    let to = c.centre - y;
    let d = to.length();
    if d <= c.radius * 1.0001 {
        return uniform_sphere(u);
    }
    let axis = to / d;
    let sin_max = c.radius / d;
    let cos_max = (1.0 - sin_max * sin_max).max(0.0).sqrt();
    let cos = 1.0 - u.x * (1.0 - cos_max);
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    let (t, b) = axis.any_orthonormal_pair();
    (t * (sin * phi.cos()) + b * (sin * phi.sin()) + axis * cos).normalize()
}

/// A converged chain.
#[derive(Clone, Copy, Debug)]
struct Solution {
    /// The direction it leaves the light in.
    dir: Vec3,
    /// The chain traced along it.
    shot: Shot,
}

impl Solution {
    /// Whether `other` is the same chain: the same interfaces and turns, the same direction.
    fn same_chain(&self, other: &Solution) -> bool {
        self.shot.len == other.shot.len
            && self.shot.turns[..self.shot.len] == other.shot.turns[..other.shot.len]
            && (self.dir - other.dir).length() < SAME_CHAIN
    }
}

/// What one manifold solve works with.
struct Solver<'a> {
    scene: &'a Scene,
    x: Receiver,
    source: Source<'a>,
    channels: &'a Channels,
    max_chain: usize,
    /// When a solve gives up.
    stop: Stop,
}

impl Solver<'_> {
    /// The chain leaving the light along `dir`, turning as `turns` says; `None` where it leaves
    /// the scene, meets no glass first, is longer than the setting, changes from the fixed turns,
    /// or misses the tangent plane of `x`.
    fn shoot(&self, dir: Vec3, turns: &mut Turns, rays: &mut u64) -> Option<Shot> {
        let scene = self.scene;
        let mut ray = self.source.ray(dir, self.x.time);
        let mut shot = Shot {
            turns: [Turn::default(); MAX_CHAIN],
            len: 0,
            landing: Vec3::ZERO,
            end: Vec3::ZERO,
            arriving: dir,
            throughput: Vec3::ONE,
            dispersive: false,
        };
        let mut absorption = None;
        loop {
            *rays += 1;
            let isect = scene.intersect(&ray, f32::INFINITY)?;
            let material = scene.material_of(isect.primitive);
            let h = &isect.hit;
            if !is_caster(&material.bsdf) {
                if shot.len == 0 || matches!(turns, Turns::Fixed(t) if t.len() != shot.len) {
                    return None;
                }
                let along = ray.dir.dot(self.x.n);
                let t = (self.x.p - ray.origin).dot(self.x.n) / along;
                if !(t > 0.0 && t.is_finite()) {
                    return None;
                }
                if let Some(sigma) = absorption {
                    shot.throughput *= transmittance(sigma, h.t);
                }
                shot.landing = ray.origin + ray.dir * t;
                shot.end = h.p;
                shot.arriving = ray.dir;
                return Some(shot);
            }
            if shot.len == self.max_chain {
                return None;
            }
            let c = crossing(&material.bsdf, ray.dir, h.n, self.channels.hero())?;
            shot.throughput *= transmittance(self.channels.colour(c.incident.absorption), h.t);
            let wo = -ray.dir;
            let frame = ShadingFrame::at(h, wo);
            let wo_local = frame.to_local(wo);
            let Scattering::Dielectric(model) = Scattering::at(material, h.p, h.uv, self.channels) else {
                return None;
            };
            let sample = |uc: f32| {
                let (valid, s) = model.specular_sample(wo_local, uc, TransportMode::Importance);
                valid.then_some(s)
            };
            let s = match turns {
                Turns::Fixed(fixed) => {
                    let turn = fixed.get(shot.len)?;
                    if turn.object != scene.object_of(isect.primitive) {
                        return None;
                    }
                    sample(if turn.reflects { 0.0 } else { 1.0 })?
                }
                Turns::Refract => sample(1.0).or_else(|| sample(0.0))?,
                Turns::Random(rng) => match sample(1.0) {
                    // The transmitted sample's density is 1 − F.
                    Some(t) => {
                        let reflectance = (1.0 - t.pdf).clamp(0.1, 0.9);
                        if rng.random::<f32>() < reflectance {
                            sample(0.0)?
                        } else {
                            t
                        }
                    }
                    None => sample(0.0)?,
                },
            };
            let wi = frame.to_world(s.wi);
            let shading = frame.factor(wo, wi, TransportMode::Importance);
            if shading == 0.0 || s.f == Vec3::ZERO {
                return None;
            }
            shot.throughput *= s.f * (s.wi.z.abs() * shading);
            let medium = if s.is_transmission { c.transmitted } else { c.incident };
            absorption = Some(self.channels.colour(medium.absorption));
            shot.dispersive |= material.bsdf.is_dispersive();
            shot.turns[shot.len] =
                Turn { object: scene.object_of(isect.primitive), reflects: !s.is_transmission };
            shot.len += 1;
            ray = Ray { origin: offset_origin(h.p, h.n, h.p_error, wi), dir: wi, time: ray.time };
        }
    }

    /// One chain from the seeds of `params` (numbers from `u_seed`) with the estimate of the
    /// reciprocal of its probability (1 for the straight seed): `None` where the seed finds none.
    fn estimate(
        &self,
        params: &ManifoldParams,
        u_seed: f32,
        distance: f32,
        rays: &mut u64,
    ) -> Option<(Solution, f32)> {
        let casters = self.scene.casters();
        let y = self.source.at.p;
        let mut rng = Pcg32::seed_from_u64(u64::from(u_seed.to_bits()) ^ 0x6D6E_6565_5F73_6565);
        match params.seeding {
            Seeding::Straight => {
                let seed = (self.x.p - y) / distance;
                Some((self.solve(seed, Turns::Refract, None, distance, false, rays)?, 1.0))
            }
            Seeding::Sms => {
                let dir = random_seed(y, casters, &mut rng);
                let found = self.solve(dir, Turns::Random(&mut rng), None, distance, true, rays)?;
                let mut trials = 1u32;
                while trials < params.max_trials {
                    let dir = random_seed(y, casters, &mut rng);
                    // A trial whose seed turns otherwise than the chain found cannot solve to
                    // it (a solve keeps its seed's turns): it fails without a solve.
                    let only = Some(&found.shot.turns[..found.shot.len]);
                    let again = self.solve(dir, Turns::Random(&mut rng), only, distance, true, rays);
                    if again.is_some_and(|a| a.same_chain(&found)) {
                        break;
                    }
                    trials += 1;
                }
                Some((found, trials as f32))
            }
        }
    }

    /// The landing point's offset from `x` in the tangent frame `(s, t)` of `x`.
    fn residual(&self, shot: &Shot, (s, t): (Vec3, Vec3)) -> Vec2 {
        let d = shot.landing - self.x.p;
        Vec2::new(d.dot(s), d.dot(t))
    }

    /// The chain through `x` that Newton's method finds from the seed direction `seed` with
    /// the seed's turns `turns`; `distance` (light to `x`) sets the tolerance. With `polish`,
    /// Newton steps go on past the tolerance while they still halve the residual (at most
    /// [`POLISH_STEPS`]), so two solves that find the same chain agree in direction to far
    /// better than [`SAME_CHAIN`] even where the chain is badly conditioned (a bright caustic,
    /// where the tolerance alone leaves the direction uncertain by up to 1e-2 rad). With `only`,
    /// a seed whose chain turns otherwise is not solved. The solve gives up as [`Solver::stop`]
    /// says.
    fn solve(
        &self,
        seed: Vec3,
        turns: Turns,
        only: Option<&[Turn]>,
        distance: f32,
        polish: bool,
        rays: &mut u64,
    ) -> Option<Solution> {
        #[cfg(test)]
        let before = *rays;
        let (found, outcome) = self.solve_counted(seed, turns, only, distance, polish, rays);
        #[cfg(test)]
        tally::record(outcome, *rays - before);
        #[cfg(not(test))]
        let _ = outcome;
        found
    }

    /// [`Solver::solve`], with how it ended.
    fn solve_counted(
        &self,
        seed: Vec3,
        mut turns: Turns,
        only: Option<&[Turn]>,
        distance: f32,
        polish: bool,
        rays: &mut u64,
    ) -> (Option<Solution>, Outcome) {
        let Some(first) = self.shoot(seed, &mut turns, rays) else {
            return (None, Outcome::NoChain);
        };
        if only.is_some_and(|only| only != &first.turns[..first.len]) {
            return (None, Outcome::OtherTurns);
        }
        let fixed = first.turns;
        let fixed = &fixed[..first.len];
        let plane = self.x.n.any_orthonormal_pair();
        let tolerance = TOLERANCE * distance + 4.0 * f32::EPSILON * self.x.p.abs().max_element();
        let (mut dir, mut shot) = (seed, first);
        let mut r = self.residual(&shot, plane);
        let mut iterations = 0;
        // The residual's length after each step (the seed's first), and the steps in a row that
        // the largest step did not limit.
        let mut norms = [0.0; MAX_ITERATIONS + 1];
        norms[0] = r.length();
        let mut free = 0;
        while r.length() >= tolerance {
            if iterations == MAX_ITERATIONS {
                return (None, Outcome::Exhausted(iterations));
            }
            let Some((d, s, rc, clamped)) = self.newton_step(dir, r, fixed, plane, self.stop.halvings, rays)
            else {
                return (None, Outcome::Stuck(iterations + 1));
            };
            (dir, shot, r) = (d, s, rc);
            iterations += 1;
            norms[iterations] = r.length();
            free = if clamped { 0 } else { free + 1 };
            let window = self.stop.window;
            if window > 0
                && free >= window
                && norms[iterations] > self.stop.factor * norms[iterations - window]
            {
                return (None, Outcome::Stalled(iterations));
            }
        }
        if polish {
            for _ in 0..POLISH_STEPS {
                match self.newton_step(dir, r, fixed, plane, MAX_HALVINGS, rays) {
                    Some((d, s, rc, _)) if rc.length() <= 0.5 * r.length() => (dir, shot, r) = (d, s, rc),
                    Some((d, s, _, _)) => {
                        (dir, shot) = (d, s);
                        break;
                    }
                    None => break,
                }
            }
        }
        // The last ray's first hit must be `x` itself: nothing blocks the chain.
        if (shot.end - self.x.p).length() > 1e-3 * distance + tolerance {
            return (None, Outcome::Blocked(iterations));
        }
        (Some(Solution { dir, shot }), Outcome::Converged(iterations))
    }

    /// One Newton step from the direction `dir` whose chain (turning as `fixed`) lands at the
    /// residual `r`, the Jacobian by forward differences, the step halved until the residual
    /// decreases: the new direction, its chain and its residual; `None` where the differences
    /// leave the chain or no halving decreases the residual.
    fn newton_step(
        &self,
        dir: Vec3,
        r: Vec2,
        fixed: &[Turn],
        plane: (Vec3, Vec3),
        halvings: usize,
        rays: &mut u64,
    ) -> Option<(Vec3, Shot, Vec2, bool)> {
        let (a, b) = dir.any_orthonormal_pair();
        let moved = |e: Vec3| (dir + e * DIFFERENCE).normalize();
        let sa = self.shoot(moved(a), &mut Turns::Fixed(fixed), rays)?;
        let sb = self.shoot(moved(b), &mut Turns::Fixed(fixed), rays)?;
        let ja = (self.residual(&sa, plane) - r) / DIFFERENCE;
        let jb = (self.residual(&sb, plane) - r) / DIFFERENCE;
        let det = ja.x * jb.y - ja.y * jb.x;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        // step = −J⁻¹ r, J = [ja jb]
        let mut step = Vec2::new(-(jb.y * r.x - jb.x * r.y) / det, -(-ja.y * r.x + ja.x * r.y) / det);
        let clamped = step.length() > MAX_STEP;
        if clamped {
            step *= MAX_STEP / step.length();
        }
        for halving in 0..halvings {
            let candidate = (dir + a * step.x + b * step.y).normalize();
            if let Some(s) = self.shoot(candidate, &mut Turns::Fixed(fixed), rays) {
                let rc = self.residual(&s, plane);
                if rc.length() < r.length() {
                    return Some((candidate, s, rc, clamped && halving == 0));
                }
            }
            step *= 0.5;
        }
        None
    }

    /// `|det ∂X/∂ω|` at a solution, by central differences.
    fn determinant(&self, solution: &Solution, rays: &mut u64) -> Option<f32> {
        let fixed = &solution.shot.turns[..solution.shot.len];
        let plane = self.x.n.any_orthonormal_pair();
        let (a, b) = solution.dir.any_orthonormal_pair();
        let mut column = |e: Vec3| -> Option<Vec2> {
            let plus =
                self.shoot((solution.dir + e * DIFFERENCE).normalize(), &mut Turns::Fixed(fixed), rays)?;
            let minus =
                self.shoot((solution.dir - e * DIFFERENCE).normalize(), &mut Turns::Fixed(fixed), rays)?;
            Some((self.residual(&plus, plane) - self.residual(&minus, plane)) / (2.0 * DIFFERENCE))
        };
        let (ja, jb) = (column(a)?, column(b)?);
        Some((ja.x * jb.y - ja.y * jb.x).abs())
    }
}

/// How a solve ended, with its Newton iterations (polishing not counted; read by the tests'
/// counts alone).
#[derive(Clone, Copy, Debug)]
#[cfg_attr(not(test), allow(dead_code))]
enum Outcome {
    /// The seed's chain is no chain (it meets no glass, leaves the scene, is too long).
    NoChain,
    /// The seed's chain turns otherwise than the solve asked for, so it was not solved.
    OtherTurns,
    /// Converged, and nothing blocks the chain.
    Converged(usize),
    /// Converged, but the chain's last ray hits something before `x`.
    Blocked(usize),
    /// A Newton step found no decrease (or its differences left the chain).
    Stuck(usize),
    /// The iterations ran out.
    Exhausted(usize),
    /// The residual stopped shrinking ([`Stop::window`]).
    Stalled(usize),
}

/// Counts of the solves' outcomes on this thread, for the tests that measure the solver.
#[cfg(test)]
mod tally {
    use super::Outcome;
    use std::cell::RefCell;

    /// Per outcome (no chain, converged, blocked, stuck, exhausted, stalled, other turns): solves, iterations, rays.
    #[derive(Clone, Copy, Debug, Default)]
    pub struct Tally {
        pub solves: [u64; 7],
        pub iterations: [u64; 7],
        pub rays: [u64; 7],
    }

    thread_local! {
        static TALLY: RefCell<Tally> = RefCell::new(Tally::default());
    }

    pub fn record(outcome: Outcome, rays: u64) {
        let (i, n) = match outcome {
            Outcome::NoChain => (0, 0),
            Outcome::Converged(n) => (1, n),
            Outcome::Blocked(n) => (2, n),
            Outcome::Stuck(n) => (3, n),
            Outcome::Exhausted(n) => (4, n),
            Outcome::Stalled(n) => (5, n),
            Outcome::OtherTurns => (6, 0),
        };
        TALLY.with(|t| {
            let mut t = t.borrow_mut();
            t.solves[i] += 1;
            t.iterations[i] += n as u64;
            t.rays[i] += rays;
        });
    }

    /// The counts so far, and zero them.
    pub fn take() -> Tally {
        TALLY.with(|t| std::mem::take(&mut *t.borrow_mut()))
    }
}

/// Beer–Lambert transmittance over `length` in a medium of absorption `sigma`.
#[inline]
fn transmittance(sigma: Vec3, length: f32) -> Vec3 {
    if sigma == Vec3::ZERO {
        Vec3::ONE
    } else {
        (-sigma * length).exp()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::load_str;

    /// A glass ball of radius 0.5 on a diffuse floor, lit from the side by a small sphere light
    /// (`tests/mnee.rs`'s partition scene).
    const BALL: &str = include_str!("../tests/data/glass-ball-under-a-sphere-light.toml");

    /// The solver from the point of the light at `u` to the floor point `x`.
    fn solver<'a>(scene: &'a Scene, channels: &'a Channels, u: Vec2, x: Vec3) -> Solver<'a> {
        let light = &scene.lights[0];
        let (at, area) = light.area_point(u).unwrap();
        let source = Source { light, at, delta: false, area };
        Solver {
            scene,
            x: Receiver { p: x, n: Vec3::Y, time: 0.0 },
            source,
            channels,
            max_chain: 8,
            stop: Stop::RULE,
        }
    }

    /// A chain's irradiance over `|cos θ_x|` (red channel), as [`sample`] weights it.
    fn value(solver: &Solver, sol: &Solution) -> f64 {
        let det = solver.determinant(sol, &mut 0).unwrap_or(0.0);
        let cos_x = sol.shot.arriving.dot(solver.x.n).abs();
        if det <= 0.0 || cos_x <= 0.0 || !det.is_finite() {
            return 0.0;
        }
        (solver.source.intensity(sol.dir) * sol.shot.throughput).x as f64 / (det * cos_x) as f64
    }

    /// The ball's object id in [`BALL`].
    fn ball(scene: &Scene) -> u32 {
        let down = Ray { origin: Vec3::new(0.0, 3.0, 0.0), dir: -Vec3::Y, time: 0.0 };
        scene.object_of(scene.intersect(&down, f32::INFINITY).unwrap().primitive)
    }

    /// The stall rule must not stop a solve that converges slowly because the largest step
    /// limits it: seeds up to 0.9 rad from the chain through the ball (refracted twice) to a
    /// floor point in its caustic, each converging without the rule, converge with it to the
    /// same chain, some of them after 4 or more limited steps.
    #[test]
    fn the_stall_rule_keeps_slow_solves_that_converge() {
        let scene = load_str(BALL, "ball", None).unwrap();
        let channels = Channels::Rgb;
        let x = Vec3::new(0.9, 0.0, 0.9);
        let mut s = solver(&scene, &channels, Vec2::new(0.161, 0.937), x);
        let y = s.source.at.p;
        let distance = (x - y).length();
        let ball = ball(&scene);
        let turns = [Turn { object: ball, reflects: false }; 2];
        let axis = (scene.casters()[0].centre - y).normalize();
        let (t, b) = axis.any_orthonormal_pair();
        let (mut converging, mut slow) = (0, 0);
        for i in 0..400 {
            let phi = i as f32 * 0.2;
            let theta = 0.9 * ((i / 20) as f32 + 0.5) / 20.0;
            let seed = (axis * theta.cos() + (t * phi.cos() + b * phi.sin()) * theta.sin()).normalize();
            s.stop = Stop::NONE;
            let (free, free_outcome) =
                s.solve_counted(seed, Turns::Fixed(&turns), None, distance, false, &mut 0);
            let Some(free) = free else { continue };
            converging += 1;
            s.stop = Stop::RULE;
            let (ruled, outcome) = s.solve_counted(seed, Turns::Fixed(&turns), None, distance, false, &mut 0);
            let ruled = ruled.unwrap_or_else(|| panic!("seed {i} stopped: {outcome:?} ({free_outcome:?})"));
            assert!(ruled.same_chain(&free), "seed {i}: another chain");
            slow += usize::from(matches!(outcome, Outcome::Converged(n) if n >= 4));
        }
        eprintln!("{converging} of 400 seeds converge, {slow} after 4 or more steps");
        assert!(converging >= 100 && slow >= 10, "{converging} converging, {slow} slow");
    }

    /// Where no chain of the given turns exists, the rule stops every solve within
    /// its window plus 3 steps, and in fewer than two thirds of the steps the solver takes
    /// without it (measured 830 against 1663 over 270 solves): floor points in front of the
    /// ball (towards the light), where no light refracted twice by the ball lands.
    #[test]
    fn the_stop_rule_ends_solves_without_a_solution_early() {
        let scene = load_str(BALL, "ball", None).unwrap();
        let channels = Channels::Rgb;
        let ball = ball(&scene);
        let turns = [Turn { object: ball, reflects: false }; 2];
        let (mut free_iterations, mut ruled_iterations, mut solves) = (0, 0, 0);
        for x in [Vec3::new(-0.4, 0.0, -0.4), Vec3::new(-0.6, 0.0, -0.2), Vec3::new(-0.2, 0.0, -0.6)] {
            let mut s = solver(&scene, &channels, Vec2::new(0.161, 0.937), x);
            let y = s.source.at.p;
            let distance = (x - y).length();
            for i in 0..400 {
                let u = Vec2::new((i % 20) as f32 + 0.5, (i / 20) as f32 + 0.5) / 20.0;
                let seed = cone_seed(y, scene.casters()[0], u);
                s.stop = Stop::NONE;
                let (found, free) =
                    s.solve_counted(seed, Turns::Fixed(&turns), None, distance, false, &mut 0);
                assert!(found.is_none(), "a chain to {x} from seed {i}");
                s.stop = Stop::RULE;
                let (found, ruled) =
                    s.solve_counted(seed, Turns::Fixed(&turns), None, distance, false, &mut 0);
                assert!(found.is_none(), "a chain to {x} from seed {i}");
                let steps = |o: Outcome| match o {
                    Outcome::NoChain | Outcome::OtherTurns => 0,
                    Outcome::Converged(n)
                    | Outcome::Blocked(n)
                    | Outcome::Stuck(n)
                    | Outcome::Exhausted(n)
                    | Outcome::Stalled(n) => n,
                };
                let n = steps(ruled);
                assert!(n <= Stop::RULE.window + 3, "{x} seed {i}: {ruled:?}, without the rule {free:?}");
                if !matches!(free, Outcome::NoChain) {
                    solves += 1;
                    free_iterations += steps(free);
                    ruled_iterations += n;
                }
            }
        }
        eprintln!(
            "{solves} solves: {free_iterations} iterations without the rule, {ruled_iterations} with it"
        );
        assert!(solves >= 200, "{solves} seeds through the ball");
        assert!(3 * ruled_iterations < 2 * free_iterations, "{ruled_iterations} against {free_iterations}");
    }

    /// Shading points of `cornell-glass`: the first hits (not on glass) of a 48×48 grid of
    /// camera rays, then 2304 points uniform over the box's floor, walls and ceiling.
    fn cornell_receivers(scene: &Scene) -> Vec<Receiver> {
        let mut out = Vec::new();
        let (w, h) = (800.0, 800.0);
        for i in 0..48 * 48 {
            let film = Vec2::new(((i % 48) as f32 + 0.5) * w / 48.0, ((i / 48) as f32 + 0.5) * h / 48.0);
            let ray = scene.camera.generate_ray(film);
            if let Some(isect) = scene.intersect(&ray, f32::INFINITY) {
                if !is_caster(&scene.material_of(isect.primitive).bsdf) {
                    let n = if isect.hit.n.dot(ray.dir) > 0.0 { -isect.hit.n } else { isect.hit.n };
                    out.push(Receiver { p: isect.hit.p, n, time: 0.0 });
                }
            }
        }
        let mut rng = Pcg32::seed_from_u64(5);
        for _ in 0..48 * 48 {
            let (a, b) = (rng.random::<f32>() * 2.0 - 1.0, rng.random::<f32>() * 2.0 - 1.0);
            let (p, n) = match rng.random_range(0..6) {
                0 => (Vec3::new(a, 0.0, b), Vec3::Y),
                1 => (Vec3::new(a, 2.0, b), -Vec3::Y),
                2 => (Vec3::new(a, b + 1.0, -1.0), Vec3::Z),
                3 => (Vec3::new(-1.0, b + 1.0, a), Vec3::X),
                4 => (Vec3::new(1.0, b + 1.0, a), -Vec3::X),
                _ => (Vec3::new(a, 0.0, b), Vec3::Y),
            };
            out.push(Receiver { p, n, time: 0.0 });
        }
        out
    }

    /// Not a check: the solves' outcomes, iterations and rays on `cornell-glass` for both
    /// seedings, and the sum of the chains' radiance (`cargo test --release --lib
    /// manifold::tests::solve_statistics -- --ignored --nocapture`).
    #[test]
    #[ignore]
    fn solve_statistics() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-glass.toml");
        let scene = crate::scene::load(std::path::Path::new(path)).unwrap();
        let receivers = cornell_receivers(&scene);
        let channels = Channels::Rgb;
        let stops = [
            Stop::NONE,
            Stop::RULE,
            Stop { halvings: 6, ..Stop::RULE },
            Stop { window: 2, ..Stop::RULE },
            Stop { factor: 0.25, ..Stop::RULE },
        ];
        let runs = [Seeding::Straight, Seeding::Sms].into_iter().flat_map(|s| stops.map(|t| (s, t)));
        for (seeding, stop) in runs {
            let params = ManifoldParams { seeding, ..ManifoldParams::default() };
            let runs = if seeding == Seeding::Sms { 8 } else { 1 };
            tally::take();
            let (mut rays, mut found, mut total, mut squares) = (0u64, 0u64, 0.0f64, 0.0f64);
            let start = std::time::Instant::now();
            for (k, x) in receivers.iter().enumerate() {
                for r in 0..runs {
                    let u_seed = ((k * runs + r) as f32 + 0.5) / (receivers.len() * runs) as f32;
                    let u = Vec2::splat(0.5);
                    let m =
                        sample_stopping(&scene, x, 0, u, u_seed, &params, &channels, false, stop, &mut rays);
                    if let Some(m) = m {
                        found += 1;
                        let v = f64::from(m.radiance.element_sum()) / runs as f64;
                        total += v;
                        squares += v * v;
                    }
                }
            }
            let t = tally::take();
            let n = receivers.len() * runs;
            eprintln!(
                "{seeding:?}, {stop:?}: {n} samples, {:.2?}, {rays} rays, {found} found, radiance sum {total:.5} (sd of a term {:.5})",
                start.elapsed(),
                (squares - total * total / n as f64).max(0.0).sqrt()
            );
            for (i, name) in
                ["no chain", "converged", "blocked", "stuck", "exhausted", "stalled", "other turns"]
                    .iter()
                    .enumerate()
            {
                let s = t.solves[i].max(1) as f64;
                eprintln!(
                    "  {name:>9}: {:>7} solves, {:>5.2} iterations, {:>6.1} rays per solve, {:>9} rays",
                    t.solves[i],
                    t.iterations[i] as f64 / s,
                    t.rays[i] as f64 / s,
                    t.rays[i]
                );
            }
        }
    }

    /// Two solves that converge to the same chain must agree in direction far below
    /// [`SAME_CHAIN`], or the Bernoulli trials miss it and overcount `1/p`. In the ball's bright
    /// caustic the tolerance alone left same-turn solutions 1e-4…1e-2 rad apart (320 of the
    /// pairs below, 6 beyond `SAME_CHAIN`); polished, none (the closest distinct chains are
    /// 0.1 rad apart).
    #[test]
    fn solves_of_the_same_chain_agree_far_below_the_threshold() {
        let scene = load_str(BALL, "ball", None).unwrap();
        let channels = Channels::Rgb;
        let x = Vec3::new(0.8, 0.0, 0.8);
        let mut rng = Pcg32::seed_from_u64(11);
        let (mut ambiguous, mut pairs) = (0, 0);
        for _ in 0..3000 {
            let u = Vec2::new(rng.random::<f32>(), rng.random::<f32>());
            let solver = solver(&scene, &channels, u, x);
            let distance = (x - solver.source.at.p).length();
            let mut found: Vec<Solution> = Vec::new();
            for _ in 0..64 {
                let dir = random_seed(solver.source.at.p, scene.casters(), &mut rng);
                if let Some(s) = solver.solve(dir, Turns::Random(&mut rng), None, distance, true, &mut 0) {
                    found.push(s);
                }
            }
            for (i, a) in found.iter().enumerate() {
                for b in &found[..i] {
                    if a.shot.turns[..a.shot.len] == b.shot.turns[..b.shot.len] {
                        pairs += 1;
                        let d = (a.dir - b.dir).length();
                        ambiguous += usize::from((0.1 * SAME_CHAIN..10.0 * SAME_CHAIN).contains(&d));
                    }
                }
            }
        }
        assert!(pairs > 10_000, "{pairs} pairs of same-turn solutions");
        assert_eq!(ambiguous, 0, "same-turn solutions within 10× of SAME_CHAIN of each other");
    }

    /// At one point of the light and one floor point in the ball's caustic, SMS's estimate (the
    /// chain found times the trials' count) averages to the sum over every chain, the chains
    /// enumerated by solving from a 40×40 grid of seeds for each turn sequence a ball allows
    /// (R, T Rᵏ T), within 4 standard errors of the estimate's mean.
    #[test]
    fn sms_sums_the_chains_at_one_light_point() {
        let scene = load_str(BALL, "ball", None).unwrap();
        let channels = Channels::Rgb;
        let x = Vec3::new(0.9, 0.0, 0.9);
        // The light's point facing the ball.
        let solver = solver(&scene, &channels, Vec2::new(0.161, 0.937), x);
        let y = solver.source.at.p;
        let distance = (x - y).length();
        let down = Ray { origin: Vec3::new(0.0, 3.0, 0.0), dir: -Vec3::Y, time: 0.0 };
        let ball = scene.object_of(scene.intersect(&down, f32::INFINITY).unwrap().primitive);
        let turn = |reflects| Turn { object: ball, reflects };
        let mut sequences = vec![vec![turn(true)]];
        for k in 0..6 {
            sequences.push([vec![turn(false)], vec![turn(true); k], vec![turn(false)]].concat());
        }
        let mut chains: Vec<(Solution, f64)> = Vec::new();
        let grid = 40;
        for sequence in &sequences {
            for i in 0..grid * grid {
                let u = Vec2::new((i % grid) as f32 + 0.5, (i / grid) as f32 + 0.5) / grid as f32;
                let dir = cone_seed(y, scene.casters()[0], u);
                if let Some(s) = solver.solve(dir, Turns::Fixed(sequence), None, distance, true, &mut 0) {
                    if !chains.iter().any(|(c, _)| c.same_chain(&s)) {
                        chains.push((s, value(&solver, &s)));
                    }
                }
            }
        }
        let sum: f64 = chains.iter().map(|c| c.1).sum();
        let params = ManifoldParams { seeding: Seeding::Sms, ..ManifoldParams::default() };
        let runs = 20_000;
        let (mut total, mut squares) = (0.0, 0.0);
        for r in 0..runs {
            let u_seed = (r as f32 + 0.5) / runs as f32;
            if let Some((s, trials)) = solver.estimate(&params, u_seed, distance, &mut 0) {
                let e = value(&solver, &s) * f64::from(trials);
                total += e;
                squares += e * e;
            }
        }
        let mean = total / runs as f64;
        let error = ((squares / runs as f64 - mean * mean) / runs as f64).sqrt();
        eprintln!("SMS {mean:.4} ± {error:.4}, the {} chains' sum {sum:.4}", chains.len());
        assert!(sum > 1.0, "the caustic's chains: {sum}");
        assert!((mean - sum).abs() <= 4.0 * error, "SMS {mean} ± {error} against {sum}");
    }
}
