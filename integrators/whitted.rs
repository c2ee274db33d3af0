//! Whitted ray tracing: Phong local shading plus recursive mirror reflection and refraction.
//!
//! At a dielectric the reflected and refracted rays are weighted by the exact Fresnel
//! reflectance (or a constant, as in the thesis), with total internal reflection sending all
//! light back; light travelling inside an absorbing medium is attenuated by Beer–Lambert's law.
//! Shadow rays pass straight through glass, attenuated by its Fresnel transmittance. Light is
//! never bent *towards* a light source, so there are no caustics: that is the method's design,
//! not a bug.
//!
//! The recursion here is shared with distributed ray tracing (Cook et al. 1984), which is
//! Whitted's algorithm with the rays *distributed*: light points, glossy directions, lens
//! positions and times are sampled instead of fixed ([`Sampling::Distributed`]).

use super::{ends_secondaries, CameraEstimator, Integrator, Method, PathContext, Progression, RenderParams};
use crate::bsdf::rough_dielectric::{RoughDielectric, TransportMode};
use crate::bsdf::{Frame, Scattering, ShadingFrame, ThinDielectric};
use crate::geometry::{spawn_origin, Ray, SurfaceHit};
use crate::lighting::{crossing, dielectric_reflectance, emitted, phong_local, ShadowMode, ShadowRays};
use crate::material::{Bsdf, Material, Phong};
use crate::optics::{reflect, refract};
use crate::sampler::Dim;
use crate::scene::effects::Support;
use crate::scene::{Effect, Scene};
use crate::spectrum::HERO_ONLY;
use glam::Vec3;

/// Recursive reflection and refraction with Fresnel weights.
pub struct Whitted;

impl Integrator for Whitted {
    fn method(&self) -> Method {
        Method::Whitted
    }

    fn support(&self, effect: Effect) -> Support {
        deterministic_support(effect)
    }

    fn progression(&self) -> Progression<'_> {
        Progression::Camera(self)
    }
}

impl CameraEstimator for Whitted {
    fn radiance(&self, scene: &Scene, params: &RenderParams, ray: &Ray, ctx: &mut PathContext) -> Vec3 {
        trace(scene, params, ray, Segment::camera(), Sampling::Fixed, ctx)
    }
}

/// What the deterministic recursive methods (`whitted`, `ssaa`) do with each effect.
pub(super) fn deterministic_support(effect: Effect) -> Support {
    match effect {
        Effect::Absorption | Effect::Textures | Effect::Meshes => Support::Simulates,
        Effect::SoftShadows => Support::Approximates("an area light acts as a point light at its centre"),
        Effect::Environment => Support::Approximates(
            "the environment is seen only where rays leave the scene: it casts no light",
        ),
        Effect::Glossy => Support::Approximates("rough surfaces are traced as smooth ones"),
        Effect::Dispersion => Support::Approximates(
            "refracts at the nominal index n_d unless --spectral on (three wavelengths per sample, the hero alone past dispersive glass)",
        ),
        Effect::DepthOfField => Support::Ignores("renders through a pinhole"),
        Effect::MotionBlur => Support::Ignores("renders the scene at the shutter's opening time"),
    }
}

/// How the recursion chooses its rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Sampling {
    /// Whitted: lights at their centres, rough surfaces traced as smooth.
    Fixed,
    /// Cook: random points on area lights, glossy directions sampled from the GGX lobe.
    Distributed,
}

/// The segment a ray travels: its depth and the medium around it.
#[derive(Clone, Copy, Debug)]
pub(super) struct Segment {
    /// Bounces since the camera.
    depth: u32,
    /// Absorption coefficient of the medium the ray travels through.
    absorption: Vec3,
    /// Whether emission seen by this ray counts (false after a glossy bounce, whose direct
    /// light was already gathered by light sampling).
    count_emission: bool,
    /// Largest channel of the product of the weights since the camera.
    weight: f32,
    /// Whether the path has ended its secondary wavelengths (spectral mode, after dispersion).
    hero_only: bool,
}

/// Rays whose weight since the camera falls below this are not traced (adaptive depth control,
/// Hall and Greenberg 1983): they could change a pixel by at most this fraction of the radiance
/// they would see, and the binary tree of a Whitted ray otherwise grows as 2^depth.
pub(super) const MIN_PATH_WEIGHT: f32 = 1e-4;

impl Segment {
    /// A camera ray (in a clear medium).
    pub(super) fn camera() -> Segment {
        Segment { depth: 0, absorption: Vec3::ZERO, count_emission: true, weight: 1.0, hero_only: false }
    }

    /// The segment after a bounce with weight `weight` into a medium of `absorption` (in the
    /// path's channels), or `None` if it is not worth tracing.
    fn next(self, weight: Vec3, absorption: Vec3, count_emission: bool) -> Option<Segment> {
        let weight = self.weight * weight.max_element();
        (weight >= MIN_PATH_WEIGHT).then_some(Segment {
            depth: self.depth + 1,
            absorption,
            count_emission,
            weight,
            hero_only: self.hero_only,
        })
    }
}

/// Radiance along `ray`.
pub(super) fn trace(
    scene: &Scene,
    params: &RenderParams,
    ray: &Ray,
    seg: Segment,
    sampling: Sampling,
    ctx: &mut PathContext,
) -> Vec3 {
    let Some(isect) = scene.intersect(ray, f32::INFINITY) else {
        let survives = seg.absorption == Vec3::ZERO;
        return if survives { ctx.channels.colour(scene.background(ray.dir)) } else { Vec3::ZERO };
    };
    let hit = &isect.hit;
    let attenuation = if seg.absorption == Vec3::ZERO { Vec3::ONE } else { (-seg.absorption * hit.t).exp() };
    let wo = -ray.dir;
    let material = scene.material_of(isect.primitive);
    // A dispersive interface parts the wavelengths: from here on the hero goes alone.
    let hero_only = ends_secondaries(&ctx.channels, seg.hero_only, &material.bsdf);
    let seg = Segment { hero_only: seg.hero_only || hero_only, ..seg };
    let attenuation = if hero_only { attenuation * HERO_ONLY } else { attenuation };
    let channels = ctx.channels;
    let shadow = ShadowRays {
        mode: ShadowMode::ThroughGlass { reflectance: params.reflectance },
        channels,
        time: ray.time,
    };
    let glossy = sampling == Sampling::Distributed && material.bsdf.is_rough();

    let mut l = if seg.count_emission {
        channels.colour(emitted(scene, isect.primitive, hit, wo))
    } else {
        Vec3::ZERO
    };
    l += local(scene, material, hit, wo, shadow, sampling, glossy, ctx);
    if seg.depth >= params.max_depth {
        return attenuation * l;
    }
    // The (shading) normal on the side the ray came from.
    let ns = ShadingFrame::normal(hit, wo);
    let n = if ns.dot(wo) >= 0.0 { ns } else { -ns };
    let smooth = ns != hit.n;
    // Weighted radiance along a secondary ray (nothing when its weight is negligible, or when a
    // direction from a shading normal lies on the other side of the geometric surface than
    // `transmitted` says).
    let follow = |dir: Vec3,
                  transmitted: bool,
                  weight: Vec3,
                  absorption: Vec3,
                  count_emission: bool,
                  ctx: &mut PathContext| {
        if smooth && (dir.dot(hit.n) * wo.dot(hit.n) > 0.0) == transmitted {
            return Vec3::ZERO;
        }
        let Some(next_seg) = seg.next(weight, absorption, count_emission) else { return Vec3::ZERO };
        if dir.dot(hit.n) * wo.dot(hit.n) > 0.0 {
            ctx.rays.reflected += 1;
        } else {
            ctx.rays.refracted += 1;
        }
        let next = ray.spawn(spawn_origin(hit, dir), dir);
        weight * trace(scene, params, &next, next_seg, sampling, ctx)
    };
    match &material.bsdf {
        Bsdf::Diffuse { .. } => {}
        Bsdf::Mirror { .. } | Bsdf::Conductor(_) if glossy => {
            let frame = Frame::from_normal(n);
            let lobe = Scattering::at(material, hit.p, hit.uv, &channels);
            let u = ctx.sampler.get_2d(Dim::Bsdf);
            if let Some(s) =
                lobe.sample(frame.to_local(wo), 0.0, u, TransportMode::Radiance).filter(|s| s.pdf > 0.0)
            {
                let wi = frame.to_world(s.wi);
                l += follow(wi, false, s.f * (s.wi.z.abs() / s.pdf), seg.absorption, !s.is_evaluable(), ctx);
            }
        }
        Bsdf::Mirror { color, .. } => {
            l += follow(
                reflect(wo, n),
                false,
                channels.colour(color.eval(hit.p, hit.uv)),
                seg.absorption,
                true,
                ctx,
            );
        }
        Bsdf::Conductor(c) => {
            let reflectance = c.fresnel(&channels).at(wo.dot(n));
            l += follow(reflect(wo, n), false, reflectance, seg.absorption, true, ctx);
        }
        Bsdf::Plastic { specular, ior, ior_outside, two_sided, .. }
        | Bsdf::RoughPlastic { specular, ior, ior_outside, two_sided, .. } => {
            // The coating's mirror, seen from the front only unless two-sided (the Phong terms
            // stand in for the base, and for a rough coating's blur): the Fresnel reflectance
            // times the specular factor.
            if *two_sided || wo.dot(hit.n) > 0.0 {
                let r = crate::optics::fresnel_dielectric(wo.dot(n), ior / ior_outside);
                let weight = channels.colour(*specular) * r;
                l += follow(reflect(wo, n), false, weight, seg.absorption, true, ctx);
            }
        }
        Bsdf::ThinDielectric { ior, ior_outside } => {
            // Both branches, weighted by the slab's reflectance and transmittance.
            let r = ThinDielectric { eta: ior / ior_outside }.reflectance(wo.dot(n));
            l += follow(reflect(wo, n), false, Vec3::splat(r), seg.absorption, true, ctx);
            l += follow(-wo, true, Vec3::splat(1.0 - r), seg.absorption, true, ctx);
        }
        Bsdf::Dielectric { roughness, distribution, .. } => {
            let c = crossing(&material.bsdf, ray.dir, hit.n, channels.hero())
                .expect("a dielectric has two sides");
            if glossy {
                // Local frame on the outward (shading) normal: eta = n_inside / n_outside.
                let frame = Frame::from_normal(ns);
                let (n_in, n_out) = if ray.dir.dot(hit.n) < 0.0 { (c.n_t, c.n_i) } else { (c.n_i, c.n_t) };
                let lobe = RoughDielectric::new(n_in / n_out, distribution.with_alpha(roughness * roughness));
                let (uc, u) = (ctx.sampler.get_1d(Dim::Bsdf), ctx.sampler.get_2d(Dim::Bsdf));
                if let Some(s) =
                    lobe.sample(frame.to_local(wo), uc, u, TransportMode::Radiance).filter(|s| s.pdf > 0.0)
                {
                    let wi = frame.to_world(s.wi);
                    let medium = if s.is_transmission { c.transmitted } else { c.incident };
                    let absorption = channels.colour(medium.absorption);
                    let weight = s.f * (s.wi.z.abs() / s.pdf);
                    l += follow(wi, s.is_transmission, weight, absorption, !s.is_evaluable(), ctx);
                }
            } else {
                let transmitted = refract(wo, n, c.n_t / c.n_i);
                let r = match transmitted {
                    Some(_) => dielectric_reflectance(wo.dot(n), c.n_i, c.n_t, params.reflectance),
                    None => 1.0,
                };
                let absorption = channels.colour(c.incident.absorption);
                l += follow(reflect(wo, n), false, Vec3::splat(r), absorption, true, ctx);
                if let Some(wt) = transmitted {
                    let absorption = channels.colour(c.transmitted.absorption);
                    l += follow(wt, true, Vec3::splat(1.0 - r), absorption, true, ctx);
                }
            }
        }
    }
    attenuation * l
}

/// Local shading at a hit: the Phong model with every light as a point (its centre, or a
/// random point on it when distributed); on a glossy surface under distributed sampling the
/// Phong highlight is replaced by the GGX lobe evaluated towards each light.
#[allow(clippy::too_many_arguments)]
fn local(
    scene: &Scene,
    material: &Material,
    hit: &SurfaceHit,
    wo: Vec3,
    shadow: ShadowRays,
    sampling: Sampling,
    glossy: bool,
    ctx: &mut PathContext,
) -> Vec3 {
    let PathContext { sampler, rays, .. } = ctx;
    match sampling {
        Sampling::Fixed => {
            phong_local(scene, material, material.phong, hit, wo, shadow, rays, |l, p| l.as_point_from(p))
        }
        Sampling::Distributed if !glossy => {
            phong_local(scene, material, material.phong, hit, wo, shadow, rays, |l, p| {
                l.sample_point(p, sampler.get_2d(Dim::Light))
            })
        }
        Sampling::Distributed => {
            let without_highlight = Phong { specular: 0.0, ..material.phong };
            phong_local(scene, material, without_highlight, hit, wo, shadow, rays, |l, p| {
                l.sample_point(p, sampler.get_2d(Dim::Light))
            }) + glossy_direct(scene, material, hit, wo, shadow, ctx)
        }
    }
}

/// Direct light reflected or transmitted by a rough surface: Σ f(wo, wi)·|cos θi|·E·V with
/// one random point on every light, counting only lights in plain view: the shadow ray is
/// opaque here. Light behind glass reaches a rough surface through its sampled continuation,
/// which refracts through the glass and counts the emission it meets there (after a smooth
/// surface) or gathers it at the next rough one; a straight shadow ray through the glass would
/// count that light a second time (a rough glass ball in a white furnace rendered 1.44).
fn glossy_direct(
    scene: &Scene,
    material: &Material,
    hit: &SurfaceHit,
    wo: Vec3,
    shadow: ShadowRays,
    ctx: &mut PathContext,
) -> Vec3 {
    let shadow = ShadowRays { mode: ShadowMode::Opaque, ..shadow };
    let frame = ShadingFrame::at(hit, wo);
    let wo_local = frame.to_local(wo);
    let mut l = Vec3::ZERO;
    for (index, light) in scene.lights.iter().enumerate() {
        let source = light.sample_point(hit.p, ctx.sampler.get_2d(Dim::Light));
        let to_light = source.position - hit.p;
        let dist2 = to_light.length_squared();
        let wi = to_light / dist2.sqrt();
        if source.intensity == Vec3::ZERO {
            continue;
        }
        let wi_local = frame.to_local(wi);
        let f = match &material.bsdf {
            Bsdf::Mirror { .. } | Bsdf::Conductor(_) => {
                Scattering::at(material, hit.p, hit.uv, &shadow.channels).eval(
                    wo_local,
                    wi_local,
                    TransportMode::Radiance,
                )
            }
            Bsdf::Dielectric { inside, outside, roughness, distribution } => RoughDielectric::new(
                inside.ior_at(shadow.channels.hero()) / outside.ior_at(shadow.channels.hero()),
                distribution.with_alpha(roughness * roughness),
            )
            .eval(wo_local, wi_local, TransportMode::Radiance),
            Bsdf::Diffuse { .. }
            | Bsdf::ThinDielectric { .. }
            | Bsdf::Plastic { .. }
            | Bsdf::RoughPlastic { .. } => Vec3::ZERO,
        };
        if f == Vec3::ZERO || frame.factor(wo, wi, TransportMode::Radiance) == 0.0 {
            continue;
        }
        let vis = crate::lighting::transmittance(
            scene,
            hit,
            source.position,
            Some(index as u32),
            shadow,
            &mut ctx.rays,
        );
        l += f * vis * shadow.channels.colour(source.intensity) * (wi_local.z.abs() / dist2);
    }
    l
}
