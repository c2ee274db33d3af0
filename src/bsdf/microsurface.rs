//! Light scattering inside a rough dielectric interface, followed facet by facet: the random walk
//! on a Smith microsurface of Heitz, Hanika, d'Eon and Dachsbacher 2016, "Multiple-scattering
//! microfacet BSDFs with the Smith model".
//!
//! A single-scattering microfacet BSDF discards light that a facet sends into a neighbouring facet
//! (up to 4% at roughness 0.3 for glass), so a rough glass sphere in a white furnace comes out
//! grey. The walk instead follows the ray: it draws the height at which the ray meets the
//! microsurface from the Smith model (uniform heights in [−1, 1], uncorrelated with slopes), a
//! visible facet there, reflection or refraction by that facet's Fresnel term, and repeats until
//! the ray leaves above or below. Every step conserves energy, so the walk scatters all the light
//! that enters (up to [`MAX_ORDER`] facets). Its first scattering event is exactly the
//! single-scattering BSDF with the height-correlated Smith term, which for refraction is the Beta
//! function B(1 + Λo, 1 + Λi) (see [`RoughDielectric`](super::RoughDielectric)).
//!
//! Inside the walk, the side of the interface a ray travels in is tracked by `outside`; seen from
//! below, the microsurface is the mirror image of itself (heights and normals negated), which is
//! how the lower side reuses the upper side's formulas.
//!
//! Directions follow the flow of light (the importance convention): the walk starts from `wo`,
//! the direction light arrives from, and returns where it leaves.

use super::MicrofacetDistribution;
use crate::optics::{fresnel_dielectric, reflect, refract};
use glam::{Vec2, Vec3};
use rand::{Rng, RngExt};

/// Longest walk followed; the light still on the microsurface after this many facets is dropped
/// (on the order of 1e-6 of it for glass at roughness 1).
pub const MAX_ORDER: u32 = 100;

/// Height above which a ray has left the microsurface (heights are uniform in [−1, 1]).
const START_HEIGHT: f32 = 2.0;

/// Where a walk left the microsurface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exit {
    /// Direction of the light leaving, away from the surface.
    pub w: Vec3,
    /// Number of facets the light scattered from (1 for single scattering).
    pub order: u32,
}

/// The microsurface of a dielectric interface with relative index `eta` = n_below / n_above.
#[derive(Clone, Copy, Debug)]
pub struct Microsurface {
    /// Distribution of facet normals.
    pub distribution: MicrofacetDistribution,
    /// n_below / n_above.
    pub eta: f32,
}

/// Smith's uniform height distribution: the fraction of the microsurface below height `h`.
#[inline]
fn c1(h: f32) -> f32 {
    (0.5 * (h + 1.0)).clamp(0.0, 1.0)
}

/// Inverse of [`c1`].
#[inline]
fn inv_c1(u: f32) -> f32 {
    (2.0 * u - 1.0).clamp(-1.0, 1.0)
}

impl Microsurface {
    /// Smith's Λ for a ray travelling along `wr` (not away from the surface): Λ(wr) for a rising
    /// ray and −1 − Λ(−wr) for a falling one (Heitz 2016, eq. 12).
    fn lambda_along(&self, wr: Vec3) -> f32 {
        let lambda = self.distribution.lambda(wr);
        if wr.z >= 0.0 {
            lambda
        } else {
            -1.0 - lambda
        }
    }

    /// The probability that a ray rising along `w` from height `h` above the upper microsurface
    /// leaves without meeting it again.
    fn escape(&self, w: Vec3, h: f32) -> f32 {
        if w.z <= 0.0 {
            return 0.0;
        }
        c1(h).powf(self.distribution.lambda(w))
    }

    /// The next height at which a ray along `wr` from height `h` meets the upper microsurface, or
    /// `None` when it leaves (Heitz 2016, Algorithm 2).
    fn next_height(&self, wr: Vec3, h: f32, u: f32) -> Option<f32> {
        if wr.z > 0.9999 {
            return None;
        }
        if wr.z < -0.9999 {
            return Some(inv_c1(u * c1(h)));
        }
        if wr.z.abs() < 1e-4 {
            return Some(h);
        }
        if u > 1.0 - self.escape(wr, h) {
            return None;
        }
        Some(inv_c1(c1(h) / (1.0 - u).powf(1.0 / self.lambda_along(wr))))
    }

    /// The same for a ray on either side: below, the mirror image of the surface.
    fn next_height_on(&self, outside: bool, wr: Vec3, h: f32, u: f32) -> Option<f32> {
        if outside {
            self.next_height(wr, h, u)
        } else {
            self.next_height(-wr, -h, u).map(|h| -h)
        }
    }

    /// The escape probability of [`escape`](Self::escape) for a ray leaving along `w` on either
    /// side (`w` above the surface leaves upwards, below downwards).
    fn escape_towards(&self, w: Vec3, h: f32) -> f32 {
        if w.z > 0.0 {
            self.escape(w, h)
        } else {
            self.escape(-w, -h)
        }
    }

    /// Scatters light arriving from `wi` (away from the facet) off a visible facet on the side
    /// `outside`: reflection with the facet's Fresnel probability, refraction otherwise. Returns
    /// the new direction and the side it travels on.
    fn scatter(&self, wi: Vec3, outside: bool, u: Vec2, uc: f32) -> Option<(Vec3, bool)> {
        let (eta, wm) = if outside {
            (self.eta, self.distribution.sample_visible_any(wi, u))
        } else {
            (1.0 / self.eta, -self.distribution.sample_visible_any(-wi, u))
        };
        let cos = wi.dot(wm);
        if cos <= 0.0 {
            return None;
        }
        if uc < fresnel_dielectric(cos, eta) {
            Some((reflect(wi, wm), outside))
        } else {
            refract(wi, wm, eta).map(|w| (w, !outside))
        }
    }

    /// Density of scattering from `wi` (light arriving from it, on side `wi_outside`) into `wo`
    /// (on the side `wo_outside`) at one facet: visible-normal density × Fresnel × Jacobian. It
    /// integrates to one over `wo`.
    fn phase(&self, wi: Vec3, wi_outside: bool, wo: Vec3, wo_outside: bool) -> f32 {
        // Work on the upper side: below, mirror both directions.
        let (wi, wo, eta) = if wi_outside { (wi, wo, self.eta) } else { (-wi, -wo, 1.0 / self.eta) };
        let dist = &self.distribution;
        if wi_outside == wo_outside {
            let Some(wm) = (wi + wo).try_normalize() else { return 0.0 };
            let cos = wi.dot(wm);
            if cos <= 0.0 {
                return 0.0;
            }
            dist.d_visible_any(wi, wm) * fresnel_dielectric(cos, eta) / (4.0 * cos)
        } else {
            let Some(wm) = (wi + wo * eta).try_normalize() else { return 0.0 };
            let wm = if wm.z < 0.0 { -wm } else { wm };
            let (cos_i, cos_o) = (wi.dot(wm), wo.dot(wm));
            if cos_i <= 0.0 || cos_o >= 0.0 {
                return 0.0;
            }
            let denom = cos_i + eta * cos_o;
            let jacobian = eta * eta * -cos_o / (denom * denom);
            dist.d_visible_any(wi, wm) * (1.0 - fresnel_dielectric(cos_i, eta)) * jacobian
        }
    }

    /// Follows light arriving from `wo` (above the surface) through the microsurface. The first
    /// facet is drawn with `uc` (reflect or refract) and `u` (the facet), everything else from
    /// `rng`. `None` when the walk is still on the surface after [`MAX_ORDER`] facets.
    pub fn walk<R: Rng>(&self, wo: Vec3, uc: f32, u: Vec2, rng: &mut R) -> Option<Exit> {
        let mut wr = -wo;
        let mut h = START_HEIGHT;
        let mut outside = true;
        for order in 0..=MAX_ORDER {
            match self.next_height_on(outside, wr, h, rng.random()) {
                None => return (order > 0).then_some(Exit { w: wr, order }),
                Some(next) => h = next,
            }
            if order == MAX_ORDER {
                break;
            }
            let (u, uc) =
                if order == 0 { (u, uc) } else { (Vec2::new(rng.random(), rng.random()), rng.random()) };
            (wr, outside) = self.scatter(-wr, outside, u, uc)?;
        }
        None
    }

    /// An unbiased estimate of the multiply scattered part (second facet onwards) of
    /// f(wo → wi)·|cos θi| for light arriving from `wo` (above) and leaving towards `wi`:
    /// next-event estimation at every facet of one walk from `wo` (Heitz 2016, §5.2).
    pub fn eval_multiple<R: Rng>(&self, wo: Vec3, wi: Vec3, rng: &mut R) -> f32 {
        let wi_outside = wi.z > 0.0;
        let mut wr = -wo;
        let mut h = START_HEIGHT;
        let mut outside = true;
        let mut sum = 0.0;
        for order in 1..=MAX_ORDER {
            match self.next_height_on(outside, wr, h, rng.random()) {
                None => break,
                Some(next) => h = next,
            }
            if order > 1 {
                let value = self.phase(-wr, outside, wi, wi_outside) * self.escape_towards(wi, h);
                if value.is_finite() {
                    sum += value;
                }
            }
            let u = Vec2::new(rng.random(), rng.random());
            match self.scatter(-wr, outside, u, rng.random()) {
                Some(next) => (wr, outside) = next,
                None => break,
            }
        }
        sum
    }
}
