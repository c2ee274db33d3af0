//! The Beckmann microfacet distribution with its exact Smith masking term and sampling of
//! visible normals (Heitz and d'Eon 2014, as pbrt-v3's `BeckmannSample`).
//!
//! Conventions as in [`super::microfacet`]: normals `wm` have wm.z > 0, ∫ D(wm) cos θm dωm = 1,
//! functions of a direction `w` are even in `w`. `alpha` is Mitsuba's: √2 times the RMS slope
//! along each axis, D(wm) = exp(−tan²θm (cos²φ/αx² + sin²φ/αy²)) / (π αx αy cos⁴θm).
//! Λ uses the error function (libm, in f64), not a rational fit.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;
use std::f64::consts::PI as PI64;

use super::microfacet::{MIN_ALPHA, SMOOTH_ALPHA};

/// The Beckmann distribution of microfacet normals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Beckmann {
    alpha_x: f32,
    alpha_y: f32,
}

impl Beckmann {
    /// An isotropic distribution with width `alpha` (clamped to ≥ 1e-4).
    pub fn new(alpha: f32) -> Self {
        Self::new_anisotropic(alpha, alpha)
    }

    /// An anisotropic distribution with widths along local X and Y (each clamped to ≥ 1e-4).
    pub fn new_anisotropic(alpha_x: f32, alpha_y: f32) -> Self {
        Self { alpha_x: alpha_x.max(MIN_ALPHA), alpha_y: alpha_y.max(MIN_ALPHA) }
    }

    /// Width along local X.
    pub fn alpha_x(&self) -> f32 {
        self.alpha_x
    }

    /// Width along local Y.
    pub fn alpha_y(&self) -> f32 {
        self.alpha_y
    }

    /// True when alpha < 1e-3 in both directions (the BSDFs switch to their delta form).
    pub fn effectively_smooth(&self) -> bool {
        self.alpha_x.max(self.alpha_y) < SMOOTH_ALPHA
    }

    /// Normal distribution D(wm) per unit solid angle; 0 for normals at or below the horizon.
    pub fn d(&self, wm: Vec3) -> f32 {
        if wm.z <= 0.0 {
            return 0.0;
        }
        let z2 = wm.z * wm.z;
        let (sx, sy) = (wm.x / self.alpha_x, wm.y / self.alpha_y);
        let exponent = (sx * sx + sy * sy) / z2;
        let d = (-exponent).exp() / (PI * self.alpha_x * self.alpha_y * z2 * z2);
        if d.is_finite() {
            d
        } else {
            0.0
        }
    }

    /// α(φ) sin θ of `w`: the length of its tangential part stretched by the widths.
    #[inline]
    fn stretched_sin(&self, w: Vec3) -> f64 {
        let (x, y) = ((self.alpha_x * w.x) as f64, (self.alpha_y * w.y) as f64);
        (x * x + y * y).sqrt()
    }

    /// The projected area of the microsurface seen from `w`, |cos θ|·(1 + Λ(w)) =
    /// |cos θ| + (σ e^(−a²)/√π − |cos θ| erfc(a))/2 with σ = α(φ) sin θ and a = |cos θ|/σ; finite
    /// (σ/(2√π)) at the horizon.
    fn projected_area(&self, w: Vec3) -> f64 {
        let z = (w.z as f64).abs();
        let sigma = self.stretched_sin(w);
        if sigma == 0.0 {
            return z;
        }
        let a = z / sigma;
        z + 0.5 * (sigma * (-a * a).exp() / PI64.sqrt() - z * libm::erfc(a))
    }

    /// Smith's Λ(w) for the Beckmann distribution (infinite at the horizon).
    pub fn lambda(&self, w: Vec3) -> f32 {
        let z = (w.z as f64).abs();
        if z == 0.0 {
            return f32::INFINITY;
        }
        (self.projected_area(w) / z - 1.0).max(0.0) as f32
    }

    /// Smith masking G1(w) = 1 / (1 + Λ(w)).
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated Smith masking-shadowing G(wo, wi) = 1 / (1 + Λ(wo) + Λ(wi)).
    pub fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Density of the normals visible from `w`: D_w(wm) = max(0, w·wm) D(wm) / (|cos θw| (1 + Λ(w)))
    /// (Heitz 2014); `w` below the surface is flipped to `-w`.
    pub fn d_visible(&self, w: Vec3, wm: Vec3) -> f32 {
        let w = if w.z < 0.0 { -w } else { w };
        let cos_wm = w.dot(wm);
        if cos_wm <= 0.0 {
            return 0.0;
        }
        let area = self.projected_area(w);
        if area > 0.0 {
            (cos_wm as f64 * self.d(wm) as f64 / area) as f32
        } else {
            0.0
        }
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
        let area = if w.z > 0.0 { self.projected_area(w) } else { self.area_below(w) };
        if area > 0.0 && area.is_finite() {
            (cos_wm as f64 * self.d(wm) as f64 / area) as f32
        } else {
            0.0
        }
    }

    /// |cos θ|·Λ(w) = (σ e^(−a²)/√π − |cos θ| erfc(a))/2 (σ = α(φ) sin θ, a = |cos θ|/σ): the
    /// area of upward facets a direction below the mean surface sees; 0 straight down.
    fn area_below(&self, w: Vec3) -> f64 {
        let z = (w.z as f64).abs();
        let sigma = self.stretched_sin(w);
        if sigma == 0.0 {
            return 0.0;
        }
        let a = z / sigma;
        (0.5 * (sigma * (-a * a).exp() * FRAC_1_SQRT_PI - z * libm::erfc(a))).max(0.0)
    }

    /// A normal drawn from [`d_visible`](Self::d_visible)(w, ·): stretch `w` to the unit-width
    /// distribution, draw the visible slopes there (the slope along `w`'s azimuth by inverting
    /// its CDF, the other a Gaussian), rotate back and unstretch (Heitz and d'Eon 2014).
    pub fn sample_visible(&self, w: Vec3, u: Vec2) -> Vec3 {
        let w = if w.z < 0.0 { -w } else { w };
        let stretched = Vec3::new(self.alpha_x * w.x, self.alpha_y * w.y, w.z).normalize();
        let (slope_x, slope_y) = unit_visible_slopes(stretched.z as f64, u.x as f64, u.y as f64);
        self.normal_from_unit_slopes(stretched, slope_x, slope_y)
    }

    /// A normal drawn from [`d_visible_any`](Self::d_visible_any)(w, ·) for any `w`: above the
    /// surface [`sample_visible`](Self::sample_visible); below it the same construction with the
    /// slope density of a direction from below ([`unit_visible_slopes_below`]).
    pub fn sample_visible_any(&self, w: Vec3, u: Vec2) -> Vec3 {
        if w.z >= 0.0 {
            return self.sample_visible(w, u);
        }
        let stretched = Vec3::new(self.alpha_x * w.x, self.alpha_y * w.y, w.z).normalize();
        let (slope_x, slope_y) = unit_visible_slopes_below(stretched.z as f64, u.x as f64, u.y as f64);
        self.normal_from_unit_slopes(stretched, slope_x, slope_y)
    }

    /// The normal of the unit-width slopes (`slope_x` along the azimuth of `stretched`, the
    /// stretched direction), rotated to that azimuth and unstretched.
    fn normal_from_unit_slopes(&self, stretched: Vec3, slope_x: f64, slope_y: f64) -> Vec3 {
        let tangent = (stretched.x as f64).hypot(stretched.y as f64);
        let (cos_phi, sin_phi) = if tangent > 0.0 {
            (stretched.x as f64 / tangent, stretched.y as f64 / tangent)
        } else {
            (1.0, 0.0)
        };
        let sx = cos_phi * slope_x - sin_phi * slope_y;
        let sy = sin_phi * slope_x + cos_phi * slope_y;
        let (sx, sy) = (self.alpha_x as f64 * sx, self.alpha_y as f64 * sy);
        Vec3::new(-sx as f32, -sy as f32, 1.0).normalize()
    }
}

/// 1/√π.
const FRAC_1_SQRT_PI: f64 = 0.564_189_583_547_756_3;

/// The slopes (x̃ along the incidence plane, ỹ across it) of a normal visible from a direction
/// with cosine `cos_theta` > 0 at azimuth 0 on the unit-width (α = 1) Beckmann surface, from two
/// uniforms. x̃ < cot θ has the density ∝ (1 − x̃ tan θ) e^(−x̃²), whose CDF
/// (erfc(−x̃) + tan θ e^(−x̃²)/√π) / (erfc(−cot θ) + tan θ e^(−cot² θ)/√π) is inverted by safeguarded
/// Newton steps; ỹ is a Gaussian of variance ½ (erfc(−ỹ)/2 = u₂ inverted the same way).
fn unit_visible_slopes(cos_theta: f64, u1: f64, u2: f64) -> (f64, f64) {
    let gaussian_cdf = |y: f64| 0.5 * libm::erfc(-y);
    let gaussian_pdf = |y: f64| FRAC_1_SQRT_PI * (-y * y).exp();
    let slope_y =
        invert_cdf(gaussian_cdf, gaussian_pdf, u2.clamp(1e-12, 1.0 - 1e-12), -SLOPE_RANGE, SLOPE_RANGE);
    let cos = cos_theta.clamp(1e-9, 1.0);
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    if sin < 1e-7 {
        // Seen from the normal every facet is visible: both slopes are Gaussian.
        let slope_x =
            invert_cdf(gaussian_cdf, gaussian_pdf, u1.clamp(1e-12, 1.0 - 1e-12), -SLOPE_RANGE, SLOPE_RANGE);
        return (slope_x, slope_y);
    }
    let (tan, cot) = (sin / cos, cos / sin);
    let cdf = |x: f64| libm::erfc(-x) + tan * FRAC_1_SQRT_PI * (-x * x).exp();
    let pdf = |x: f64| 2.0 * FRAC_1_SQRT_PI * (-x * x).exp() * (1.0 - x * tan).max(0.0);
    let total = cdf(cot);
    let hi = cot.min(SLOPE_RANGE);
    let slope_x = invert_cdf(cdf, pdf, u1.clamp(1e-12, 1.0 - 1e-12) * total, -SLOPE_RANGE, hi);
    (slope_x, slope_y)
}

/// The slopes of a normal visible from a direction **below** the mean surface (`cos_theta` < 0,
/// azimuth 0) on the unit-width surface, as [`unit_visible_slopes`]: the facets it sees have
/// x̃ < cot θ (< 0) with the density ∝ (cot θ − x̃) e^(−x̃²), whose CDF ∝ cot θ erfc(−x̃) + e^(−x̃²)/√π
/// is inverted by the same safeguarded Newton steps. Straight down, where no facet is visible,
/// the steepest slope of the range is returned (the caller finds it invisible).
fn unit_visible_slopes_below(cos_theta: f64, u1: f64, u2: f64) -> (f64, f64) {
    let gaussian_cdf = |y: f64| 0.5 * libm::erfc(-y);
    let gaussian_pdf = |y: f64| FRAC_1_SQRT_PI * (-y * y).exp();
    let slope_y =
        invert_cdf(gaussian_cdf, gaussian_pdf, u2.clamp(1e-12, 1.0 - 1e-12), -SLOPE_RANGE, SLOPE_RANGE);
    let cos = cos_theta.clamp(-1.0, 0.0);
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    if sin < 1e-7 {
        return (-SLOPE_RANGE, slope_y);
    }
    let cot = cos / sin;
    let cdf = |x: f64| cot * libm::erfc(-x) + FRAC_1_SQRT_PI * (-x * x).exp();
    let pdf = |x: f64| 2.0 * FRAC_1_SQRT_PI * (-x * x).exp() * (cot - x).max(0.0);
    let total = cdf(cot);
    if total.is_nan() || total <= 0.0 {
        return (cot, slope_y);
    }
    // The density falls like e^(−x̃²) below cot θ: one unit of slope further holds nothing.
    let lo = (cot - 1.0).min(-SLOPE_RANGE);
    let slope_x = invert_cdf(cdf, pdf, u1.clamp(1e-12, 1.0 - 1e-12) * total, lo, cot);
    (slope_x, slope_y)
}

/// Slopes beyond ±this (in units of the width) carry less than erfc(8) ≈ 1e-29 of the mass.
const SLOPE_RANGE: f64 = 8.0;

/// The x in [lo, hi] with cdf(x) = target for an increasing `cdf` with derivative `pdf`:
/// Newton steps kept inside a shrinking bracket (bisection where a step would leave it).
fn invert_cdf(cdf: impl Fn(f64) -> f64, pdf: impl Fn(f64) -> f64, target: f64, lo: f64, hi: f64) -> f64 {
    let (mut lo, mut hi) = (lo, hi);
    let mut x = 0.0f64.clamp(lo, hi);
    for _ in 0..100 {
        let value = cdf(x) - target;
        if value.abs() <= 1e-14 * target.abs().max(1e-300) {
            break;
        }
        if value > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let slope = pdf(x);
        let newton = x - value / slope;
        x = if slope > 0.0 && newton > lo && newton < hi { newton } else { 0.5 * (lo + hi) };
        if hi - lo < 1e-13 {
            break;
        }
    }
    x
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::chi2::{self, direction};

    /// (alpha_x, alpha_y) for the visible-normal chi-square test.
    const VNDF_ALPHAS: [(f32, f32); 4] = [(0.05, 0.05), (0.2, 0.2), (0.6, 0.6), (0.1, 0.5)];
    /// Polar angles of `w` in degrees; 135° is below the surface (the flipped case).
    const VNDF_THETAS: [f32; 5] = [0.0, 45.0, 80.0, 89.0, 135.0];
    /// Number of chi-square cases run here (counted in the Šidák correction).
    /// Directions below the surface, seen by [`Beckmann::sample_visible_any`] as a ray inside a
    /// microsurface sees the upward facets, by k = −cot θ / α(φ), the slope at which the facets it
    /// sees begin in units of the width: beyond k ≈ 3 hardly any are visible (at k = 20 a
    /// fraction e^(−400): D underflows in f32 and neither the density nor a ray can meet them).
    const BELOW_SLOPES: [f32; 3] = [0.3, 1.0, 2.0];

    /// The direction at azimuth `phi` below the surface with k = −cot θ / α(φ) = `k`.
    fn below(dist: &Beckmann, k: f32, phi: f32) -> (f32, Vec3) {
        let alpha = (dist.alpha_x() * phi.cos()).hypot(dist.alpha_y() * phi.sin());
        let theta = 90.0 + (k * alpha).atan().to_degrees();
        (theta, direction(theta, phi))
    }
    /// Number of chi-square cases run here (counted in the Šidák correction).
    pub(crate) const CHI2_CASES: usize = VNDF_ALPHAS.len() * (VNDF_THETAS.len() + BELOW_SLOPES.len());

    /// Distributions wide enough for the quadrature of [`chi2::integrate_sphere`] to resolve.
    fn distributions() -> Vec<Beckmann> {
        let mut ds: Vec<_> = [0.05f32, 0.1, 0.25, 0.5, 1.0].iter().map(|&a| Beckmann::new(a)).collect();
        ds.push(Beckmann::new_anisotropic(0.1, 0.5));
        ds
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
        // ∫ D_w(wm) dωm = 1 holds only with the exact Λ of this D (the Smith relation).
        for dist in distributions() {
            for theta in [0.0f32, 30.0, 60.0, 85.0, 89.9, 150.0] {
                let w = direction(theta, 0.7);
                let mass = chi2::integrate_sphere(|wm| dist.d_visible(w, wm));
                assert!((mass - 1.0).abs() < 2e-3, "{dist:?} θ {theta}: {mass}");
            }
        }
    }

    #[test]
    fn smith_terms_are_bounded_even_and_exact_at_the_pole() {
        for dist in distributions() {
            assert_eq!(dist.lambda(Vec3::Z), 0.0);
            assert_eq!(dist.g1(Vec3::Z), 1.0);
            assert_eq!(dist.lambda(Vec3::X), f32::INFINITY);
            for theta in (0..=180).step_by(5) {
                let w = direction(theta as f32, 2.0);
                let g1 = dist.g1(w);
                assert!((0.0..=1.0).contains(&g1), "{g1}");
                assert_eq!(dist.lambda(w), dist.lambda(-w));
            }
        }
        // Λ against the closed form (erf(a) − 1)/2 + e^(−a²)/(2a√π) at a = 1/(α tan θ).
        let dist = Beckmann::new(0.3);
        let w = direction(60.0, 0.0);
        let a = 1.0 / (0.3 * 60f64.to_radians().tan());
        let expected = 0.5 * (libm::erf(a) - 1.0) + (-a * a).exp() / (2.0 * a * PI64.sqrt());
        assert!((dist.lambda(w) as f64 - expected).abs() < 1e-6);
    }

    #[test]
    fn sampled_visible_normals_are_valid_for_extreme_inputs() {
        for dist in [Beckmann::new(1e-4), Beckmann::new(1.0), Beckmann::new(0.3)] {
            for w in [Vec3::X, direction(89.999, 0.3), -Vec3::Z, Vec3::Z] {
                for u in [Vec2::ZERO, Vec2::new(0.999_999, 0.999_999), Vec2::new(0.5, 0.25), Vec2::X] {
                    let wm = dist.sample_visible(w, u);
                    assert!(wm.is_finite() && (wm.length() - 1.0).abs() < 1e-5, "{w} {u}: {wm}");
                    assert!(wm.z > 0.0);
                    let flipped = if w.z < 0.0 { -w } else { w };
                    assert!(flipped.dot(wm) >= -1e-4, "a hidden normal was sampled");
                }
            }
        }
    }

    #[test]
    fn chi2_visible_normal_sampling() {
        let mut results = Vec::new();
        for (k, (ax, ay)) in VNDF_ALPHAS.into_iter().enumerate() {
            let dist = Beckmann::new_anisotropic(ax, ay);
            for (l, theta) in VNDF_THETAS.into_iter().enumerate() {
                let w = direction(theta, 0.6);
                let outcome = chi2::ChiSquare::default()
                    .seed(2000 + (k * VNDF_THETAS.len() + l) as u64)
                    .run(|_, u| Some(dist.sample_visible(w, u)), |wm| dist.d_visible(w, wm));
                results.push((format!("beckmann vndf α=({ax},{ay}) θ={theta}°"), outcome));
            }
        }
        for (k, (ax, ay)) in VNDF_ALPHAS.into_iter().enumerate() {
            let dist = Beckmann::new_anisotropic(ax, ay);
            for (l, slope) in BELOW_SLOPES.into_iter().enumerate() {
                let (theta, w) = below(&dist, slope, 0.6);
                let outcome = chi2::ChiSquare::default()
                    .seed(2100 + (k * BELOW_SLOPES.len() + l) as u64)
                    .run(|_, u| Some(dist.sample_visible_any(w, u)), |wm| dist.d_visible_any(w, wm));
                results.push((format!("beckmann vndf from below α=({ax},{ay}) θ={theta}°"), outcome));
            }
        }
        assert_eq!(results.len(), CHI2_CASES);
        chi2::assert_all_pass(&results);
    }

    #[test]
    fn visible_normals_from_below_are_normalised_and_match_the_flipped_view_above() {
        for dist in distributions() {
            for slope in BELOW_SLOPES {
                let (theta, w) = below(&dist, slope, 0.7);
                // ∫ D_w(wm) dωm = 1 over the upward facets w sees (the area |cos θ| Λ).
                let total = chi2::integrate_sphere(|wm| dist.d_visible_any(w, wm));
                assert!((total - 1.0).abs() < 2e-3, "{dist:?} θ {theta}: {total}");
                for k in 0..64 {
                    let u = Vec2::new((k % 8) as f32 / 8.0 + 0.06, (k / 8) as f32 / 8.0 + 0.06);
                    let wm = dist.sample_visible_any(w, u);
                    assert!(wm.is_finite() && wm.z > 0.0 && w.dot(wm) > 0.0, "{dist:?} θ {theta}: {wm}");
                }
            }
            // Above the surface the "any" forms are the ordinary ones, bit for bit.
            let w = direction(40.0, 0.3);
            let wm = dist.sample_visible(w, Vec2::new(0.3, 0.7));
            assert_eq!(dist.sample_visible_any(w, Vec2::new(0.3, 0.7)), wm);
            assert_eq!(dist.d_visible_any(w, wm).to_bits(), dist.d_visible(w, wm).to_bits());
        }
    }
}
