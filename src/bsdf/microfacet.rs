//! The Trowbridge–Reitz (GGX) microfacet distribution with the height-correlated Smith
//! masking-shadowing term and sampling of visible normals.
//!
//! The microsurface is a height field above the local +Z plane: its normals `wm` all have
//! wm.z > 0 and the projected areas of the microfacets sum to one, ∫ D(wm) cos θm dωm = 1
//! (Walter et al. 2007). Roughness is the slope spread `alpha` (≈ tan of a typical facet tilt),
//! possibly different along X and Y.
//!
//! Functions of a direction `w` (Λ, G1, the visible-normal density and its sampling) are even in
//! `w`: a direction below the surface is treated as its negation `-w`, which looks at the same
//! microsurface from the other side. This is what lets the BSDFs work from both sides.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Smallest slope spread kept by the constructors, so that D stays finite (every distribution).
pub(crate) const MIN_ALPHA: f32 = 1e-4;
/// Below this slope spread a surface is treated as a perfect specular interface (every
/// distribution).
pub(crate) const SMOOTH_ALPHA: f32 = 1e-3;

/// The Trowbridge–Reitz (GGX) distribution of microfacet normals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrowbridgeReitz {
    alpha_x: f32,
    alpha_y: f32,
}

impl TrowbridgeReitz {
    /// An isotropic distribution with slope spread `alpha` (clamped to ≥ 1e-4).
    pub fn new(alpha: f32) -> Self {
        Self::new_anisotropic(alpha, alpha)
    }

    /// An anisotropic distribution with slope spreads along local X and Y (each clamped to ≥ 1e-4).
    pub fn new_anisotropic(alpha_x: f32, alpha_y: f32) -> Self {
        Self { alpha_x: alpha_x.max(MIN_ALPHA), alpha_y: alpha_y.max(MIN_ALPHA) }
    }

    /// An isotropic distribution from a perceptual roughness r in [0, 1]: alpha = r² (≥ 1e-4).
    ///
    /// Squaring makes equal steps of r look like roughly equal steps of blur (Burley 2012).
    pub fn from_roughness(roughness: f32) -> Self {
        Self::new(roughness * roughness)
    }

    /// Slope spread along local X.
    pub fn alpha_x(&self) -> f32 {
        self.alpha_x
    }

    /// Slope spread along local Y.
    pub fn alpha_y(&self) -> f32 {
        self.alpha_y
    }

    /// True when alpha < 1e-3 in both directions: the lobe is narrower than anything a renderer
    /// could resolve by sampling, so the BSDFs switch to their delta (perfectly smooth) form.
    pub fn effectively_smooth(&self) -> bool {
        self.alpha_x.max(self.alpha_y) < SMOOTH_ALPHA
    }

    /// Normal distribution D(wm) per unit solid angle; 0 for normals at or below the horizon.
    pub fn d(&self, wm: Vec3) -> f32 {
        if wm.z <= 0.0 {
            return 0.0;
        }
        // 1 / (π αx αy cos⁴θ (1 + tan²θ (cos²φ/αx² + sin²φ/αy²))²), with cos⁴θ folded in so that
        // neither the pole (tan θ = 0) nor a near-horizon normal divides by zero.
        let (sx, sy) = (wm.x / self.alpha_x, wm.y / self.alpha_y);
        let e = sx * sx + sy * sy + wm.z * wm.z;
        1.0 / (PI * self.alpha_x * self.alpha_y * e * e)
    }

    /// (αx·wx)² + (αy·wy)², i.e. α(φ)² sin²θ: the squared stretched tangential length of `w`.
    #[inline]
    fn stretched_sin2(&self, w: Vec3) -> f32 {
        let (x, y) = (self.alpha_x * w.x, self.alpha_y * w.y);
        x * x + y * y
    }

    /// Smith's auxiliary function Λ(w) (infinite at the horizon).
    pub fn lambda(&self, w: Vec3) -> f32 {
        let z = w.z.abs();
        if z == 0.0 {
            return f32::INFINITY;
        }
        // (√(1 + α² tan²θ) − 1) / 2, rewritten without the cancellation for small α tan θ.
        let s2 = self.stretched_sin2(w);
        s2 / (2.0 * z * (z + (z * z + s2).sqrt()))
    }

    /// Smith masking G1(w) = 1 / (1 + Λ(w)): the fraction of the microsurface visible from `w`
    /// among the facets facing it.
    pub fn g1(&self, w: Vec3) -> f32 {
        let z = w.z.abs();
        2.0 * z / (z + (z * z + self.stretched_sin2(w)).sqrt())
    }

    /// Height-correlated Smith masking-shadowing G(wo, wi) = 1 / (1 + Λ(wo) + Λ(wi)).
    pub fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// G1(w) / |cos θ|, finite even at the horizon.
    #[inline]
    fn g1_over_cos(&self, w: Vec3) -> f32 {
        let z = w.z.abs();
        2.0 / (z + (z * z + self.stretched_sin2(w)).sqrt())
    }

    /// Density of the normals visible from `w`: D_w(wm) = G1(w) max(0, w·wm) D(wm) / |cos θw|
    /// (Heitz 2014). It integrates to one over `wm`; `w` below the surface is flipped to `-w`.
    pub fn d_visible(&self, w: Vec3, wm: Vec3) -> f32 {
        let w = if w.z < 0.0 { -w } else { w };
        let cos_wm = w.dot(wm);
        if cos_wm <= 0.0 {
            return 0.0;
        }
        self.g1_over_cos(w) * cos_wm * self.d(wm)
    }

    /// Density of the upward-facing normals (wm.z > 0) visible from any `w`, including from below
    /// the mean surface as inside a microsurface: max(0, w·wm) D(wm) / A(w), with the projected
    /// visible area A(w) = cos θw (1 + Λ) for w above and |cos θw| Λ(w) below (Heitz 2016, §4).
    /// Zero where no facet is visible (w straight down, or horizontal).
    pub fn d_visible_any(&self, w: Vec3, wm: Vec3) -> f32 {
        let cos_wm = w.dot(wm);
        if cos_wm <= 0.0 || w.z == 0.0 {
            return 0.0;
        }
        let lambda = self.lambda(w);
        let area = if w.z > 0.0 { w.z * (1.0 + lambda) } else { -w.z * lambda };
        if area > 0.0 && area.is_finite() {
            cos_wm * self.d(wm) / area
        } else {
            0.0
        }
    }

    /// A normal drawn from [`d_visible`](Self::d_visible)(w, ·) (Heitz 2018, "Sampling the GGX
    /// distribution of visible normals"); `w` below the surface is flipped to `-w` first, so the
    /// result always has wm.z > 0 and faces the flipped `w`.
    pub fn sample_visible(&self, w: Vec3, u: Vec2) -> Vec3 {
        self.sample_visible_any(if w.z < 0.0 { -w } else { w }, u)
    }

    /// A normal drawn from [`d_visible_any`](Self::d_visible_any)(w, ·) for any `w`, also from
    /// below the mean surface: Heitz's projection of the hemisphere holds for every direction
    /// (with cos θw < 0 the warp keeps the part of the disk between the equator's ellipse and the
    /// rim, which is what a ray travelling upwards sees).
    pub fn sample_visible_any(&self, w: Vec3, u: Vec2) -> Vec3 {
        let v = Vec3::new(self.alpha_x * w.x, self.alpha_y * w.y, w.z).normalize();
        let tangent_len2 = v.x * v.x + v.y * v.y;
        let t1 = if tangent_len2 > 0.0 { Vec3::new(-v.y, v.x, 0.0) / tangent_len2.sqrt() } else { Vec3::X };
        let t2 = v.cross(t1);
        // A uniform point on the unit disk...
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let p1 = r * phi.cos();
        let p2 = r * phi.sin();
        // ...with its upper half squeezed onto the visible part of the projected hemisphere: the
        // projection of the half sphere is a disk half of which is foreshortened by cos θ.
        let half_chord = (1.0 - p1 * p1).max(0.0).sqrt();
        let s = 0.5 * (1.0 + v.z);
        let p2 = (1.0 - s) * half_chord + s * p2;
        // Lift onto the hemisphere around v and unstretch (the normal transforms with the
        // inverse transpose, i.e. by the alphas again).
        let pz = (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        let nh = p1 * t1 + p2 * t2 + pz * v;
        Vec3::new(self.alpha_x * nh.x, self.alpha_y * nh.y, nh.z.max(1e-6)).normalize()
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::chi2::{self, direction};

    /// (alpha_x, alpha_y) for the visible-normal chi-square test.
    const VNDF_ALPHAS: [(f32, f32); 4] = [(0.1, 0.1), (0.3, 0.3), (0.7, 0.7), (0.1, 0.5)];
    /// Polar angles of `w` in degrees; 135° is below the surface (the flipped case).
    const VNDF_THETAS: [f32; 4] = [0.0, 45.0, 89.0, 135.0];
    /// Number of chi-square cases run here (counted in the Šidák correction).
    /// Directions below the mean surface for [`TrowbridgeReitz::sample_visible_any`].
    const BELOW_THETAS: [f32; 2] = [100.0, 150.0];
    pub(crate) const CHI2_CASES: usize = VNDF_ALPHAS.len() * (VNDF_THETAS.len() + BELOW_THETAS.len());

    /// Distributions wide enough for the quadrature of [`chi2::integrate_sphere`] to resolve.
    fn distributions() -> Vec<TrowbridgeReitz> {
        let mut ds: Vec<_> = [0.05f32, 0.1, 0.3, 0.7, 1.0].iter().map(|&a| TrowbridgeReitz::new(a)).collect();
        ds.push(TrowbridgeReitz::new_anisotropic(0.1, 0.5));
        ds.push(TrowbridgeReitz::new_anisotropic(0.8, 0.05));
        ds
    }

    #[test]
    fn roughness_mapping_and_smooth_threshold() {
        let d = TrowbridgeReitz::from_roughness(0.5);
        assert_eq!((d.alpha_x(), d.alpha_y()), (0.25, 0.25));
        assert_eq!(TrowbridgeReitz::from_roughness(0.0).alpha_x(), 1e-4);
        assert!(TrowbridgeReitz::from_roughness(0.0).effectively_smooth());
        assert!(TrowbridgeReitz::from_roughness(0.03).effectively_smooth()); // alpha 9e-4
        assert!(!TrowbridgeReitz::from_roughness(0.04).effectively_smooth()); // alpha 1.6e-3
        assert!(!TrowbridgeReitz::new_anisotropic(1e-4, 0.2).effectively_smooth());
    }

    #[test]
    fn projected_microfacet_area_is_one() {
        // ∫ D(wm) cos θm dωm = 1, integrated numerically over the upper hemisphere.
        for dist in distributions() {
            let area = chi2::integrate_sphere(|wm| dist.d(wm) * wm.z);
            assert!((area - 1.0).abs() < 1e-3, "{dist:?}: {area}");
        }
    }

    #[test]
    fn visible_normal_density_is_normalised_for_every_direction() {
        // ∫ D_w(wm) dωm = 1 is the Smith relation cos θ / G1 = ∫ D max(0, w·m) dωm.
        for dist in distributions() {
            for theta in [0.0f32, 30.0, 60.0, 85.0, 89.9, 90.0, 120.0] {
                let w = direction(theta, 0.7);
                let mass = chi2::integrate_sphere(|wm| dist.d_visible(w, wm));
                assert!((mass - 1.0).abs() < 2e-3, "{dist:?} θ {theta}: {mass}");
            }
        }
    }

    #[test]
    fn visible_normal_density_from_below_is_normalised() {
        for dist in distributions() {
            for theta in [90.5f32, 100.0, 135.0, 170.0, 179.0] {
                let w = direction(theta, 0.7);
                let mass = chi2::integrate_sphere(|wm| dist.d_visible_any(w, wm));
                assert!((mass - 1.0).abs() < 2e-3, "{dist:?} θ {theta}: {mass}");
                // Above the surface it is the ordinary visible-normal density.
                let up = direction(180.0 - theta, 0.7);
                let wm = Vec3::new(0.1, -0.2, 1.0).normalize();
                assert!(
                    (dist.d_visible_any(up, wm) - dist.d_visible(up, wm)).abs()
                        <= 1e-4 * dist.d_visible(up, wm)
                );
            }
        }
    }

    #[test]
    fn smith_terms_are_bounded_even_and_exact_at_the_pole() {
        for dist in distributions() {
            assert_eq!(dist.lambda(Vec3::Z), 0.0);
            assert_eq!(dist.g1(Vec3::Z), 1.0);
            assert_eq!(dist.g1(Vec3::X), 0.0);
            assert_eq!(dist.lambda(Vec3::X), f32::INFINITY);
            for theta in (0..=180).step_by(5) {
                let w = direction(theta as f32, 2.0);
                let g1 = dist.g1(w);
                assert!((0.0..=1.0).contains(&g1));
                assert!((g1 - 1.0 / (1.0 + dist.lambda(w))).abs() < 1e-6);
                assert_eq!(dist.lambda(w), dist.lambda(-w));
                let v = direction(40.0, -1.0);
                let g = dist.g(w, v);
                assert!(g <= g1.min(dist.g1(v)) + 1e-6 && g >= 0.0);
                assert!(dist.g1_over_cos(w).is_finite());
            }
        }
    }

    #[test]
    fn sampled_visible_normals_are_valid_for_extreme_inputs() {
        let grazing = [Vec3::X, Vec3::new(0.0, -1.0, 0.0), direction(89.999, 0.3), -Vec3::Z];
        for dist in [TrowbridgeReitz::new(1e-4), TrowbridgeReitz::new(1.0), TrowbridgeReitz::new(0.3)] {
            for w in grazing {
                for u in [Vec2::ZERO, Vec2::new(0.999_999, 0.999_999), Vec2::new(0.5, 0.25), Vec2::X] {
                    let wm = dist.sample_visible(w, u);
                    assert!(wm.is_finite() && (wm.length() - 1.0).abs() < 1e-5, "{w} {u}: {wm}");
                    assert!(wm.z > 0.0);
                    let flipped = if w.z < 0.0 { -w } else { w };
                    assert!(flipped.dot(wm) >= -1e-5, "a hidden normal was sampled");
                }
            }
        }
    }

    #[test]
    fn chi2_visible_normal_sampling() {
        let mut results = Vec::new();
        for (k, (ax, ay)) in VNDF_ALPHAS.into_iter().enumerate() {
            let dist = TrowbridgeReitz::new_anisotropic(ax, ay);
            for (l, theta) in VNDF_THETAS.into_iter().enumerate() {
                let w = direction(theta, 0.6);
                let outcome = chi2::ChiSquare::default()
                    .seed((k * VNDF_THETAS.len() + l) as u64)
                    .run(|_, u| Some(dist.sample_visible(w, u)), |wm| dist.d_visible(w, wm));
                results.push((format!("vndf α=({ax},{ay}) θ={theta}°"), outcome));
            }
            for (l, theta) in BELOW_THETAS.into_iter().enumerate() {
                let w = direction(theta, 0.6);
                let outcome = chi2::ChiSquare::default()
                    .seed(1000 + (k * BELOW_THETAS.len() + l) as u64)
                    .run(|_, u| Some(dist.sample_visible_any(w, u)), |wm| dist.d_visible_any(w, wm));
                results.push((format!("vndf from below α=({ax},{ay}) θ={theta}°"), outcome));
            }
        }
        assert_eq!(results.len(), CHI2_CASES);
        chi2::assert_all_pass(&results);
    }
}
