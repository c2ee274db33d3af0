//! Physically based scattering functions (BSDFs) evaluated in a local shading frame.
//!
//! Conventions shared by every BSDF here:
//! - Directions are unit vectors in the local frame of [`Frame`], where the shading normal is +Z.
//! - `wo` and `wi` both point *away* from the surface: `wo` towards the viewer (or the previous
//!   path vertex), `wi` towards the light (or the next vertex).
//! - `eta` is n_inside / n_outside, where "outside" is the +Z hemisphere. A direction below the
//!   surface (z < 0) is inside, so seen from there the relative index is 1 / `eta`.
//! - Colours are linear RGB in `glam::Vec3`; random numbers arrive as uniforms in [0, 1) from the
//!   caller's sampler.
//! - `eval` returns the BSDF value f (not multiplied by the cosine); `pdf` is the solid-angle
//!   density of `sample`. Both are 0 for delta (perfectly smooth) lobes, which only `sample`
//!   produces.

pub mod beckmann;
pub mod distribution;
pub mod lambert;
pub mod microfacet;
pub mod microsurface;
pub mod model;
pub mod plastic;
pub mod rough_conductor;
pub mod rough_dielectric;
pub mod rough_plastic;
pub mod thin_dielectric;

#[cfg(test)]
pub(crate) mod chi2;

pub use beckmann::Beckmann;
pub use distribution::MicrofacetDistribution;
pub use lambert::Lambert;
pub use microfacet::TrowbridgeReitz;
pub use model::Scattering;
pub use plastic::Plastic;
pub use rough_conductor::{ConductorFresnel, RoughConductor};
pub use rough_dielectric::{RoughDielectric, TransportMode};
pub use rough_plastic::{RoughCoating, RoughPlastic};
pub use thin_dielectric::ThinDielectric;

use crate::lanes::{Mask3, Real, Vector};
use glam::Vec3;

/// An orthonormal, right-handed shading frame: `s` and `t` span the tangent plane, `n` is +Z.
/// One frame (`Frame`, of glam's `Vec3`) or one per lane (`Frame<Vec3x>`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame<V = Vec3> {
    /// First tangent (local +X).
    pub s: V,
    /// Second tangent (local +Y), `n × s`.
    pub t: V,
    /// Normal (local +Z).
    pub n: V,
}

impl<V: Vector> Frame<V> {
    /// A frame around the unit normal `n`; the tangents are arbitrary but deterministic.
    #[inline(always)]
    pub fn from_normal(n: V) -> Frame<V> {
        // Duff et al. 2017, "Building an orthonormal basis, revisited", as glam's
        // `any_orthonormal_pair` computes it: branch-free and accurate for every n; the tangents
        // jump where n.z changes sign.
        let (x, y, z) = (n.x(), n.y(), n.z());
        let sign = z.signum();
        let one = V::Real::splat(1.0);
        let a = V::Real::splat(-1.0) / (sign + z);
        let b = x * y * a;
        let s = V::new(one + sign * x * x * a, sign * b, -sign * x);
        let t = V::new(b, sign + y * y * a, -y);
        Frame { s, t, n }
    }

    /// World-space `v` expressed in this frame (normal along +Z).
    #[inline(always)]
    pub fn to_local(&self, v: V) -> V {
        V::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local-frame `v` expressed in world space.
    #[inline(always)]
    pub fn to_world(&self, v: V) -> V {
        self.s * v.x() + self.t * v.y() + self.n * v.z()
    }
}

/// The frame a BSDF is evaluated in at a surface hit: around the shading normal, with the
/// geometric normal kept for the side tests (pbrt-v4's treatment; `docs/architecture.md`,
/// "Shading normals"). For analytic shapes and flat triangles both normals are the same and
/// every factor is exactly 1. One frame (`ShadingFrame`), or one per lane
/// (`ShadingFrame<Vec3x>`), written once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingFrame<V: Vector = Vec3> {
    /// The local frame: around the shading normal, or the geometric one where `wo` lies on
    /// different sides of the two.
    pub frame: Frame<V>,
    /// The geometric normal.
    pub ng: V,
    /// Whether the frame's normal differs from the geometric one.
    smooth: Mask3<V>,
}

impl ShadingFrame {
    /// The frame at `hit` for the direction `wo` back along the path (world space).
    #[inline]
    pub fn at(hit: &crate::geometry::SurfaceHit, wo: Vec3) -> ShadingFrame {
        ShadingFrame::around(hit.n, hit.shading_n, wo)
    }

    /// The normal of [`ShadingFrame::at`] without the frame: the shading normal, or the
    /// geometric one where `wo` lies on different sides of the two (seen from below its shading
    /// surface but above its geometric one, near a smooth mesh's silhouette, the flat face is
    /// all there is).
    #[inline]
    pub fn normal(hit: &crate::geometry::SurfaceHit, wo: Vec3) -> Vec3 {
        ShadingFrame::chosen_normal(hit.n, hit.shading_n, wo)
    }
}

impl<V: Vector> ShadingFrame<V> {
    /// The frame at a hit of geometric normal `ng` and shading normal `ns` for the direction
    /// `wo` back along the path (world space): [`ShadingFrame::at`] of one hit or of 16.
    #[inline(always)]
    pub fn around(ng: V, ns: V, wo: V) -> ShadingFrame<V> {
        let n = ShadingFrame::chosen_normal(ng, ns, wo);
        ShadingFrame { frame: Frame::from_normal(n), ng, smooth: !(n - ng).is_zero() }
    }

    /// The frame at a flat hit (shading normal = geometric normal `n`, an analytic shape's):
    /// [`ShadingFrame::around`]`(n, n, wo)` without the choice.
    #[inline(always)]
    pub fn flat(n: V) -> ShadingFrame<V> {
        ShadingFrame { frame: Frame::from_normal(n), ng: n, smooth: V::Real::mask(false) }
    }

    /// [`ShadingFrame::normal`] from the two normals.
    #[inline(always)]
    pub fn chosen_normal(ng: V, ns: V, wo: V) -> V {
        let zero = V::Real::splat(0.0);
        let (above_s, above_g) = (wo.dot(ns).gt(zero), wo.dot(ng).gt(zero));
        let sides_differ = (above_s & !above_g) | (above_g & !above_s);
        V::select((ns - ng).is_zero() | sides_differ, ng, ns)
    }

    /// World-space `v` in the local frame.
    #[inline(always)]
    pub fn to_local(&self, v: V) -> V {
        self.frame.to_local(v)
    }

    /// Local-frame `v` in world space.
    #[inline(always)]
    pub fn to_world(&self, v: V) -> V {
        self.frame.to_world(v)
    }

    /// The factor that multiplies f(wo, wi)·|cos θi| (cosine in the shading frame) for the
    /// world directions `wo` (back along the path) and `wi` (on along it): 0 when `wi` lies on
    /// different sides of the shading and the geometric surface (it would leak through the
    /// surface, or reflect where the geometry transmits); for importance transport (light
    /// paths), Veach's adjoint correction |wo·ns|·|wi·ng| / (|wo·ng|·|wi·ns|), which keeps light
    /// tracing consistent with the radiance of camera paths; 1 otherwise and always 1 at a flat
    /// hit. (`wo` is read for importance transport only.)
    #[inline(always)]
    pub fn factor(&self, wo: V, wi: V, mode: TransportMode) -> V::Real {
        let (zero, one) = (V::Real::splat(0.0), V::Real::splat(1.0));
        if !V::Real::any(self.smooth) {
            return one;
        }
        let (ns, ng) = (self.frame.n, self.ng);
        let (si, gi) = (wi.dot(ns), wi.dot(ng));
        let adjoint = match mode {
            TransportMode::Radiance => one,
            TransportMode::Importance => {
                let denominator = (wo.dot(ng) * si).abs();
                V::Real::select(denominator.eq(zero), zero, (wo.dot(ns) * gi).abs() / denominator)
            }
        };
        V::Real::select(self.smooth, V::Real::select((si * gi).le(zero), zero, adjoint), one)
    }
}

/// One sampled scattering direction (`BsdfSample`), or one per lane (`BsdfSample<Vec3x>`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample<V: Vector = Vec3> {
    /// The sampled direction, away from the surface, in the local frame.
    pub wi: V,
    /// The BSDF value f(wo, wi) (not divided by the pdf, not multiplied by the cosine).
    pub f: V,
    /// Solid-angle density of `wi`, or for a specular sample the discrete probability of its lobe.
    pub pdf: V::Real,
    /// True for a delta lobe (perfect mirror or perfect refraction): `eval`/`pdf` cannot reproduce it.
    pub is_specular: Mask3<V>,
    /// True for light that a rough dielectric scattered between several facets: like a delta
    /// sample, `eval`/`pdf` do not include it, so only its weight f·|cos θi|/pdf is meaningful.
    pub is_multiple: Mask3<V>,
    /// True when `wi` lies on the other side of the surface from `wo`.
    pub is_transmission: Mask3<V>,
    /// Relative index crossed, n(side of `wi`) / n(side of `wo`); 1 for reflection.
    pub eta: V::Real,
}

impl<V: Vector> BsdfSample<V> {
    /// The Monte Carlo weight f·|cos θi| / pdf that multiplies the path throughput.
    #[inline]
    pub fn weight(&self) -> V {
        self.f * (self.wi.z().abs() / self.pdf)
    }

    /// Whether `eval` and `pdf` reproduce this sample, so that it can take part in multiple
    /// importance sampling (false for delta and multiply scattered samples).
    #[inline]
    pub fn is_evaluable(&self) -> Mask3<V> {
        !self.is_specular & !self.is_multiple
    }

    /// `if m { a } else { b }`, field by field (per lane).
    #[inline(always)]
    pub fn select(m: Mask3<V>, a: &BsdfSample<V>, b: &BsdfSample<V>) -> BsdfSample<V> {
        let pick = |x: Mask3<V>, y: Mask3<V>| (m & x) | (!m & y);
        BsdfSample {
            wi: V::select(m, a.wi, b.wi),
            f: V::select(m, a.f, b.f),
            pdf: V::Real::select(m, a.pdf, b.pdf),
            is_specular: pick(a.is_specular, b.is_specular),
            is_multiple: pick(a.is_multiple, b.is_multiple),
            is_transmission: pick(a.is_transmission, b.is_transmission),
            eta: V::Real::select(m, a.eta, b.eta),
        }
    }
}

/// A BSDF evaluated for a pair of directions, with the two densities multiple importance
/// sampling between light and camera sub-paths needs ([`Scattering::evaluate`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfEval {
    /// The BSDF value f(wo, wi) (single scattering for rough glass).
    pub f: Vec3,
    /// Solid-angle density with which sampling from `wo` produces `wi`.
    pub pdf: f32,
    /// Solid-angle density with which sampling from `wi` produces `wo` (the reverse direction).
    pub pdf_rev: f32,
}

/// Whether two local directions lie strictly on the same side of the surface.
#[inline]
pub(crate) fn same_hemisphere(a: Vec3, b: Vec3) -> bool {
    a.z * b.z > 0.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg32;

    #[test]
    fn shading_frame_factor_is_one_flat_zero_across_and_adjoint_for_importance() {
        use crate::geometry::SurfaceHit;
        let hit = |shading_n: Vec3| SurfaceHit {
            t: 1.0,
            p: Vec3::ZERO,
            n: Vec3::Z,
            shading_n,
            uv: glam::Vec2::ZERO,
            p_error: 0.0,
        };
        let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
        let wi = Vec3::new(-0.5, 0.2, 0.4).normalize();
        // A flat hit: the frame of the geometric normal and factor 1 for any pair.
        let flat = ShadingFrame::at(&hit(Vec3::Z), wo);
        assert_eq!(flat.frame, Frame::from_normal(Vec3::Z));
        for mode in [TransportMode::Radiance, TransportMode::Importance] {
            assert_eq!(flat.factor(wo, wi, mode), 1.0);
            assert_eq!(flat.factor(wo, -wi, mode), 1.0);
        }
        // Tilted shading normal: wi below the shading surface but above the geometric one → 0.
        let ns = Vec3::new(0.5, 0.0, 1.0).normalize();
        let smooth = ShadingFrame::at(&hit(ns), wo);
        assert_eq!(smooth.frame.n, ns);
        let across = Vec3::new(-1.0, 0.0, 0.3).normalize();
        assert!(across.dot(ns) < 0.0 && across.dot(Vec3::Z) > 0.0);
        assert_eq!(smooth.factor(wo, across, TransportMode::Radiance), 0.0);
        assert_eq!(smooth.factor(wo, across, TransportMode::Importance), 0.0);
        assert_eq!(smooth.factor(wo, wi, TransportMode::Radiance), 1.0);
        let adjoint = (wo.dot(ns) * wi.dot(Vec3::Z)).abs() / (wo.dot(Vec3::Z) * wi.dot(ns)).abs();
        assert!((smooth.factor(wo, wi, TransportMode::Importance) - adjoint).abs() < 1e-6);
        assert!((adjoint - 1.0).abs() > 0.05, "the example must test something: {adjoint}");
        // wo on different sides of the two surfaces: the flat face.
        let grazing = Vec3::new(-1.0, 0.0, 0.2).normalize();
        assert_eq!(ShadingFrame::at(&hit(ns), grazing).frame.n, Vec3::Z);
    }

    #[test]
    fn frame_is_orthonormal_right_handed_and_invertible() {
        let mut rng = Pcg32::seed_from_u64(7);
        let mut normals = vec![Vec3::Z, -Vec3::Z, Vec3::X, -Vec3::Y, Vec3::new(1e-8, 0.0, -1.0).normalize()];
        for _ in 0..1000 {
            let v = Vec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0;
            if v.length_squared() > 1e-4 {
                normals.push(v.normalize());
            }
        }
        for n in normals {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5, "{n}");
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(n).abs() < 1e-5 && f.t.dot(n).abs() < 1e-5);
            assert!(f.s.cross(f.t).abs_diff_eq(n, 1e-5), "left-handed frame for {n}");
            assert!(f.to_local(n).abs_diff_eq(Vec3::Z, 1e-5));
            let v = Vec3::new(0.3, -0.5, 0.8);
            assert!(f.to_local(f.to_world(v)).abs_diff_eq(v, 1e-5));
            assert!(f.to_world(f.to_local(v)).abs_diff_eq(v, 1e-5));
        }
    }
}
