//! The microfacet distributions a rough conductor or dielectric can use, behind one type: GGX
//! ([`TrowbridgeReitz`]) or [`Beckmann`], each with its own Smith Λ and visible-normal sampler
//! (from above the surface, and for rough glass's random walk from below it too).

use super::{Beckmann, TrowbridgeReitz};
use glam::{Vec2, Vec3};

/// A distribution of microfacet normals with its masking term and visible-normal sampling.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MicrofacetDistribution {
    /// Trowbridge–Reitz (GGX).
    Ggx(TrowbridgeReitz),
    /// Beckmann.
    Beckmann(Beckmann),
}

impl From<TrowbridgeReitz> for MicrofacetDistribution {
    fn from(d: TrowbridgeReitz) -> Self {
        MicrofacetDistribution::Ggx(d)
    }
}

impl From<Beckmann> for MicrofacetDistribution {
    fn from(d: Beckmann) -> Self {
        MicrofacetDistribution::Beckmann(d)
    }
}

impl MicrofacetDistribution {
    /// Whether the lobe is narrow enough for the delta (perfectly smooth) form.
    pub fn effectively_smooth(&self) -> bool {
        match self {
            MicrofacetDistribution::Ggx(d) => d.effectively_smooth(),
            MicrofacetDistribution::Beckmann(d) => d.effectively_smooth(),
        }
    }

    /// Normal distribution D(wm) per unit solid angle.
    pub fn d(&self, wm: Vec3) -> f32 {
        match self {
            MicrofacetDistribution::Ggx(d) => d.d(wm),
            MicrofacetDistribution::Beckmann(d) => d.d(wm),
        }
    }

    /// Smith's Λ(w) (infinite at the horizon).
    pub fn lambda(&self, w: Vec3) -> f32 {
        match self {
            MicrofacetDistribution::Ggx(d) => d.lambda(w),
            MicrofacetDistribution::Beckmann(d) => d.lambda(w),
        }
    }

    /// Smith masking G1(w) = 1 / (1 + Λ(w)).
    pub fn g1(&self, w: Vec3) -> f32 {
        match self {
            MicrofacetDistribution::Ggx(d) => d.g1(w),
            MicrofacetDistribution::Beckmann(d) => d.g1(w),
        }
    }

    /// Height-correlated Smith masking-shadowing G(wo, wi).
    pub fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            MicrofacetDistribution::Ggx(d) => d.g(wo, wi),
            MicrofacetDistribution::Beckmann(d) => d.g(wo, wi),
        }
    }

    /// Density of the normals visible from `w` (flipped above the surface).
    pub fn d_visible(&self, w: Vec3, wm: Vec3) -> f32 {
        match self {
            MicrofacetDistribution::Ggx(d) => d.d_visible(w, wm),
            MicrofacetDistribution::Beckmann(d) => d.d_visible(w, wm),
        }
    }

    /// Density of the upward-facing normals visible from any `w`, also from below the mean
    /// surface (inside a microsurface).
    pub fn d_visible_any(&self, w: Vec3, wm: Vec3) -> f32 {
        match self {
            MicrofacetDistribution::Ggx(d) => d.d_visible_any(w, wm),
            MicrofacetDistribution::Beckmann(d) => d.d_visible_any(w, wm),
        }
    }

    /// A normal drawn from [`d_visible_any`](Self::d_visible_any)(w, ·).
    pub fn sample_visible_any(&self, w: Vec3, u: Vec2) -> Vec3 {
        match self {
            MicrofacetDistribution::Ggx(d) => d.sample_visible_any(w, u),
            MicrofacetDistribution::Beckmann(d) => d.sample_visible_any(w, u),
        }
    }

    /// A normal drawn from [`d_visible`](Self::d_visible)(w, ·).
    pub fn sample_visible(&self, w: Vec3, u: Vec2) -> Vec3 {
        match self {
            MicrofacetDistribution::Ggx(d) => d.sample_visible(w, u),
            MicrofacetDistribution::Beckmann(d) => d.sample_visible(w, u),
        }
    }
}
