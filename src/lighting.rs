//! Direct lighting shared by the deterministic and distributed methods: dielectric interfaces,
//! shadow rays (optionally through glass) and the empirical Phong model.

use crate::geometry::{offset_origin, spawn_origin, Ray, SurfaceHit};
use crate::lanes::Vector;
use crate::light::PointIllumination;
use crate::material::{Bsdf, Material, Medium, Phong};
use crate::optics::fresnel_dielectric;
use crate::scene::Scene;
use crate::spectrum::Channels;
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
    /// Dielectrics pass light attenuated by their Fresnel transmittance at each crossing and by
    /// absorption between crossings (no refraction of the shadow ray: these methods cannot bend
    /// light towards lights; no caustics).
    ThroughGlass {
        /// Constant reflectance instead of exact Fresnel (the thesis's 0.06).
        reflectance: Option<f32>,
    },
}

/// Everything a shadow ray needs besides its end points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowRays {
    /// How dielectrics are treated.
    pub mode: ShadowMode,
    /// What the path's channels hold (for indices at the hero wavelength and absorption spectra).
    pub channels: Channels,
    /// Time of the path (moving objects).
    pub time: f32,
}

/// A ray crossing a dielectric interface: the media and indices on its two sides.
#[derive(Clone, Copy, Debug)]
pub struct Crossing<'a> {
    /// Index on the side the ray comes from.
    pub n_i: f32,
    /// Index on the side it goes to.
    pub n_t: f32,
    /// Medium the ray comes from (where a reflected ray stays).
    pub incident: &'a Medium,
    /// Medium the ray goes into if it is transmitted.
    pub transmitted: &'a Medium,
}

/// The crossing of a ray travelling along `dir` through a dielectric with outward normal `n`,
/// with indices at `lambda` (nm) or nominal in RGB mode; `None` for other materials.
#[inline]
pub fn crossing(bsdf: &Bsdf, dir: Vec3, n: Vec3, lambda: Option<f32>) -> Option<Crossing<'_>> {
    match bsdf {
        Bsdf::Dielectric { inside, outside, .. } => {
            let (incident, transmitted) =
                if dir.dot(n) < 0.0 { (outside, inside) } else { (inside, outside) };
            Some(Crossing {
                n_i: incident.ior_at(lambda),
                n_t: transmitted.ior_at(lambda),
                incident,
                transmitted,
            })
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

/// Reflectance charged to a shadow ray that crosses an interface in a straight line at incidence
/// cosine `cos`. The real light path is bent, so the crossing is evaluated from the optically
/// thinner side, where the angle is the one the straight ray makes: by reciprocity (Stokes) a
/// transmitted path has the same Fresnel factor at both ends, so a solid convex body transmits
/// T(θ)² as the refracted path does, and no spurious total internal reflection blackens the
/// rim of a glass body's shadow.
#[inline]
fn straight_crossing_reflectance(cos: f32, n_i: f32, n_t: f32, constant: Option<f32>) -> f32 {
    dielectric_reflectance(cos, n_i.min(n_t), n_i.max(n_t), constant)
}

/// Whether a shadow ray aimed at `target` on light `light` that meets `primitive` at distance
/// `t` of the `remaining` distance has reached the light itself: reaching it ends the ray;
/// meeting it well before the target does not (a point on the far side of an emissive ball is
/// hidden by its near side), unless the target is inside the light (a sphere's centre, its
/// stand-in for the deterministic methods), which the ray reaches where it meets the light's
/// surface.
#[inline]
fn reaches_light(
    scene: &Scene,
    light: Option<u32>,
    target: Vec3,
    primitive: u32,
    t: f32,
    remaining: f32,
) -> bool {
    light.is_some_and(|l| {
        scene.light_of(primitive) == Some(l)
            && (t >= remaining * (1.0 - 1e-3) || scene.lights[l as usize].encloses(target))
    })
}

/// A straight shadow ray from a surface point to a target that every surface blocks but the
/// light it aims at: the visibility query of next-event estimation ([`ShadowMode::Opaque`]),
/// asked of the scene at once ([`ShadowRay::blocked`]) or batched across lanes by the wavefront
/// engine of `path`, which tests its primitives itself ([`ShadowRay::blocks`]).
#[derive(Clone, Copy, Debug)]
pub struct ShadowRay {
    /// The ray, from the offset surface point towards the target.
    pub ray: Ray,
    /// Hits at distances in (0, `tmax`) can block it.
    pub tmax: f32,
    /// Distance from the ray's origin to the target.
    pub(crate) remaining: f32,
    /// The target.
    pub(crate) target: Vec3,
    /// The light aimed at, which does not block where the ray reaches it.
    pub(crate) light: Option<u32>,
}

/// The segment of a shadow ray (one, or one per lane): where it starts and goes, and how far.
#[derive(Clone, Copy, Debug)]
pub struct ShadowSegment<V: Vector> {
    /// The origin, offset from the surface ([`offset_origin`]).
    pub origin: V,
    /// The unit direction towards the target (no −0 components, as [`Ray::new`] makes them).
    pub dir: V,
    /// Hits at distances in (0, `tmax`) can block it.
    pub tmax: V::Real,
    /// Distance from the origin to the target.
    pub remaining: V::Real,
}

impl<V: Vector> ShadowSegment<V> {
    /// The segment from the surface point `p` (geometric normal `n`, error bound `p_error`) to
    /// `target`.
    #[inline(always)]
    pub fn toward(p: V, n: V, p_error: V::Real, target: V) -> ShadowSegment<V> {
        let dir = (target - p).normalize();
        let origin = offset_origin(p, n, p_error, dir);
        let remaining = (target - origin).dot(dir);
        ShadowSegment { origin, dir: dir + V::splat(Vec3::ZERO), tmax: remaining * (1.0 - 1e-5), remaining }
    }
}

impl ShadowRay {
    /// The shadow ray from `from` to `target` (on light `light`, if any) at time `time`; `None`
    /// when the target does not lie beyond the ray's origin (nothing can block it). Counts one
    /// shadow ray in `rays` either way.
    #[inline]
    pub fn new(
        from: &SurfaceHit,
        target: Vec3,
        light: Option<u32>,
        time: f32,
        rays: &mut RayCounts,
    ) -> Option<ShadowRay> {
        rays.shadow += 1;
        let shadow = ShadowRay::toward(from, target, light, time);
        shadow.can_be_blocked().then_some(shadow)
    }

    /// [`new`](Self::new) without a branch and without counting: the ray, whether or not
    /// anything can block it. The wavefront engine builds it across lanes.
    #[inline(always)]
    pub fn toward(from: &SurfaceHit, target: Vec3, light: Option<u32>, time: f32) -> ShadowRay {
        let ShadowSegment { origin, dir, tmax, remaining } =
            ShadowSegment::toward(from.p, from.n, from.p_error, target);
        let mut ray = Ray::new(origin, dir);
        ray.time = time;
        ShadowRay { ray, tmax, remaining, target, light }
    }

    /// Whether the target lies beyond the ray's origin, where something can block it.
    #[inline(always)]
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // a NaN distance is blockable, as it always was
    pub fn can_be_blocked(&self) -> bool {
        !(self.remaining <= 0.0)
    }

    /// The light aimed at, if any.
    pub fn light(&self) -> Option<u32> {
        self.light
    }

    /// The distance from which a hit on the light aimed at no longer blocks the ray (−∞ where
    /// the target lies inside the light): a hit on a primitive of [`light`](Self::light) at a
    /// distance `t >= reach` does not block, any other hit does. What the lanes' occlusion test
    /// ([`crate::lanes::LaneScene::occluded`]) takes instead of [`blocks`](Self::blocks).
    pub fn reach(&self, scene: &Scene) -> f32 {
        shadow_reach(scene, self.light, self.target, self.remaining)
    }

    /// Whether a hit on `primitive` at distance `t` (below [`tmax`](Self::tmax)) blocks the ray.
    #[inline]
    pub fn blocks(&self, scene: &Scene, primitive: u32, t: f32) -> bool {
        // The rule of [`reach`](Self::reach), which the lanes apply too.
        !(self.light.is_some_and(|l| scene.light_of(primitive) == Some(l)) && t >= self.reach(scene))
    }

    /// Whether any primitive of `scene` blocks the ray (an occlusion query that stops at the
    /// first blocker).
    #[inline]
    pub fn blocked(&self, scene: &Scene) -> bool {
        scene.occluded(&self.ray, self.tmax, |primitive, t| self.blocks(scene, primitive, t))
    }
}

/// [`ShadowRay::reach`] of a ray aimed at `target` on light `light` from `remaining` away: the
/// distance from which a hit on that light no longer blocks it (−∞ where the target lies inside
/// the light).
#[inline]
pub(crate) fn shadow_reach(scene: &Scene, light: Option<u32>, target: Vec3, remaining: f32) -> f32 {
    match light {
        Some(l) if scene.lights[l as usize].encloses(target) => f32::NEG_INFINITY,
        _ => remaining * (1.0 - 1e-3),
    }
}

/// Fraction of the light at `target` that reaches the surface point `from` (0 if blocked).
/// `light` is the emitter's light index: the ray ends on reaching it, but its surface blocks
/// targets behind it (the far side of an emissive ball).
pub fn transmittance(
    scene: &Scene,
    from: &SurfaceHit,
    target: Vec3,
    light: Option<u32>,
    shadow: ShadowRays,
    rays: &mut RayCounts,
) -> Vec3 {
    let ShadowMode::ThroughGlass { reflectance } = shadow.mode else {
        // Opaque: pure visibility.
        let visible =
            ShadowRay::new(from, target, light, shadow.time, rays).is_none_or(|s| !s.blocked(scene));
        return if visible { Vec3::ONE } else { Vec3::ZERO };
    };
    let dir = (target - from.p).normalize();
    let mut origin = spawn_origin(from, dir);
    let reaches_light =
        |primitive: u32, t: f32, remaining: f32| reaches_light(scene, light, target, primitive, t, remaining);
    let mut t = Vec3::ONE;
    // The medium around the starting point is unknown unless we entered it through glass.
    let mut medium: Option<&Medium> = None;
    for _ in 0..MAX_SHADOW_CROSSINGS {
        rays.shadow += 1;
        let remaining = (target - origin).dot(dir);
        if remaining <= 0.0 {
            return t;
        }
        let mut ray = Ray::new(origin, dir);
        ray.time = shadow.time;
        let hit = scene.intersect(&ray, remaining * (1.0 - 1e-5));
        let travelled = hit.as_ref().map_or(remaining, |h| h.hit.t);
        if let Some(m) = medium {
            t *= m.transmittance(travelled, &shadow.channels);
        }
        let Some(hit) = hit else {
            return t;
        };
        if reaches_light(hit.primitive, hit.hit.t, remaining) {
            return t;
        }
        let bsdf = &scene.material_of(hit.primitive).bsdf;
        if let Bsdf::ThinDielectric { ior, ior_outside } = bsdf {
            // A thin slab lets the straight ray through with its transmittance, medium unchanged.
            let slab = crate::bsdf::ThinDielectric { eta: ior / ior_outside };
            t *= 1.0 - slab.reflectance(dir.dot(hit.hit.n));
            origin = spawn_origin(&hit.hit, dir);
            continue;
        }
        let Some(c) = crossing(bsdf, dir, hit.hit.n, shadow.channels.hero()) else {
            return Vec3::ZERO;
        };
        t *= 1.0 - straight_crossing_reflectance(dir.dot(hit.hit.n).abs(), c.n_i, c.n_t, reflectance);
        if t == Vec3::ZERO {
            return t;
        }
        medium = Some(c.transmitted);
        origin = spawn_origin(&hit.hit, dir);
    }
    Vec3::ZERO
}

/// Phong local illumination at `hit` seen from direction `wo` (pointing away from the surface)
/// with every light taken as the point source `illumination(light)` gives for it (its centre
/// for the deterministic methods, a random point for distributed ray tracing): ambient plus,
/// per light, diffuse and normalised specular terms weighted by irradiance and shadow
/// transmittance (see [`crate::material::Phong`]), with the coefficients `ph` (normally the
/// material's own).
#[allow(clippy::too_many_arguments)]
pub fn phong_local(
    scene: &Scene,
    material: &Material,
    ph: Phong,
    hit: &SurfaceHit,
    wo: Vec3,
    shadow: ShadowRays,
    rays: &mut RayCounts,
    mut illumination: impl FnMut(&crate::light::Light, Vec3) -> PointIllumination,
) -> Vec3 {
    let channels = &shadow.channels;
    // Two-sided shading: the (shading) normal facing the viewer.
    let ns = crate::bsdf::ShadingFrame::normal(hit, wo);
    // A one-sided diffuse surface seen from behind has no colour (Mitsuba's black back).
    let behind = material.is_one_sided() && ns.dot(wo) <= 0.0;
    let color = if behind { Vec3::ZERO } else { channels.colour(material.phong_color(hit.p, hit.uv)) };
    let mut l = ph.ambient * color * channels.colour(scene.settings.ambient);
    if behind {
        // Black, the highlight of a one-sided plastic's coating included.
        return l;
    }
    // A mirror or glass already sees an area light's surface through its reflected ray: its
    // highlight stands in only for point lights, which have no surface to be seen.
    let specular_surface = !matches!(material.bsdf, Bsdf::Diffuse { .. });
    if ph.diffuse == 0.0 && ph.specular == 0.0 {
        return l;
    }
    let n = if ns.dot(wo) >= 0.0 { ns } else { -ns };
    let smooth = ns != hit.n;
    for (index, light) in scene.lights.iter().enumerate() {
        let source = illumination(light, hit.p);
        let to_light = source.position - hit.p;
        let dist2 = to_light.length_squared();
        let wi = to_light / dist2.sqrt();
        let cos = n.dot(wi);
        if cos <= 0.0 || source.intensity == Vec3::ZERO {
            continue;
        }
        // A light below the geometric surface does not shine through it.
        if smooth && wi.dot(hit.n) * wo.dot(hit.n) <= 0.0 {
            continue;
        }
        let vis = transmittance(scene, hit, source.position, Some(index as u32), shadow, rays);
        if vis == Vec3::ZERO {
            continue;
        }
        let irradiance = channels.colour(source.intensity) * vis * (cos / dist2);
        let mut f = ph.diffuse * color / PI;
        if ph.specular > 0.0 && !(specular_surface && light.is_area()) {
            let r = crate::optics::reflect(wi, n);
            let rv = r.dot(wo).max(0.0);
            f += Vec3::splat(ph.specular * (ph.shininess + 2.0) / (2.0 * PI) * rv.powf(ph.shininess));
        }
        l += f * irradiance;
    }
    l
}

/// Radiance emitted by the primitive of `hit` towards `wo`, if it is a light's emitting side (RGB).
pub fn emitted(scene: &Scene, primitive: u32, hit: &SurfaceHit, wo: Vec3) -> Vec3 {
    match scene.light_of(primitive) {
        Some(i) => scene.lights[i as usize].emitted(hit, wo),
        None => Vec3::ZERO,
    }
}
