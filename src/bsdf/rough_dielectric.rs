//! A rough dielectric interface (frosted glass): microfacet reflection and refraction after
//! Walter et al. 2007, "Microfacet models for refraction through rough surfaces", with GGX or
//! Beckmann normals ([`MicrofacetDistribution`]), the height-correlated Smith term, the exact dielectric Fresnel term and sampling of
//! visible normals (Heitz 2018), plus the light that scatters between facets, followed by the
//! random walk of Heitz et al. 2016 ([`super::microsurface`]).
//!
//! With wm the (generalised) half vector, facing +Z, and η' = n(side of wi) / n(side of wo), the
//! single-scattering part that `eval` and `pdf` give is
//! - reflection:   f = F D G / (4 |cos θo| |cos θi|), wm ∝ wo + wi, G = 1 / (1 + Λo + Λi);
//! - transmission: f = (1 − F) D G |wi·wm| |wo·wm| / (|cos θo| |cos θi| (wi·wm + wo·wm/η')²) · s,
//!   wm ∝ wo + η' wi, G = B(1 + Λo, 1 + Λi) (the Beta function), with s = 1/η'² for radiance and 1
//!   for importance ([`TransportMode`]).
//!
//! Both G are the height-correlated Smith masking–shadowing of uniform microsurface heights
//! (Heitz 2014, §6): a reflected ray and the incident one share the same height, a refracted ray
//! leaves the other way. (The common 1/(1 + Λo + Λi) for refraction is an approximation of the
//! Beta form; the exact one makes `eval` the first scattering event of the random walk.)
//!
//! F is the Fresnel reflectance of the facet, the same seen from either side of a refracting pair
//! (Stokes). Hence the two modes are adjoint, f_importance(wo, wi) = f_radiance(wi, wo), and the
//! radiance BTDF obeys the generalised reciprocity
//! f_radiance(wo, wi) / n(wo side)² = f_radiance(wi, wo) / n(wi side)².
//! For a refracting pair F is computed from the direction in the optically thinner medium, where it
//! is well conditioned (see `refraction_fresnel`).
//!
//! `sample` follows the light through the microsurface, so it is lossless: every sample leaves
//! with weight exactly 1 (importance) or 1/η'² (radiance, refracted), and the white furnace stays
//! white at any roughness. A sample that left after one facet has the density
//! `pdf` = f_importance(wo, wi) |cos θi| and its `eval` value; one that met several facets is
//! marked [`BsdfSample::is_multiple`]: `eval` and `pdf` do not cover it, so integrators weight it
//! like a delta sample (no MIS). [`RoughDielectric::eval_multiple`] estimates that remainder
//! without bias where an integrator needs the full value in a given direction (light tracing's
//! connection to the camera).
//!
//! An index-matched interface (`eta` = 1) is invisible whatever its roughness: `sample` passes
//! straight through as a specular event.

use super::microsurface::Microsurface;
use super::{BsdfSample, MicrofacetDistribution};
use crate::lanes::{Mask3, Real, Vector};
use crate::optics::{fresnel_dielectric, refraction};
use glam::{Vec2, Vec3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

/// Whether light or importance is being transported; matters only for refraction.
///
/// Along a refracted ray L/n² is conserved, so radiance is multiplied by (n_t / n_i)² on crossing
/// into the medium of index n_t. The BTDF used with radiance (paths traced from the camera) carries
/// that factor, 1/η'² with η' = n(side of wi) / n(side of wo), and the BTDF used with importance
/// (paths traced from lights) does not, so the BTDF is not symmetric (Veach 1997, §5.2).
/// Reflection is the same in both modes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TransportMode {
    /// Camera paths: `wo` leads towards the camera and `wi` towards the light.
    #[default]
    Radiance,
    /// Light paths: `wo` leads towards the light and `wi` towards the camera.
    Importance,
}

/// A rough dielectric interface with relative index `eta` = n_inside / n_outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughDielectric {
    /// n_inside / n_outside, "inside" being the −Z side.
    pub eta: f32,
    /// Distribution of microfacet normals; effectively smooth means a perfect specular interface.
    pub distribution: MicrofacetDistribution,
}

/// Fresnel reflectance for the signed cosine between a direction and a normal facing +Z: a
/// negative cosine means the direction is inside, where the relative index is 1/`eta`.
#[inline]
fn fresnel(cos: f32, eta: f32) -> f32 {
    if cos >= 0.0 {
        fresnel_dielectric(cos, eta)
    } else {
        fresnel_dielectric(-cos, 1.0 / eta)
    }
}

/// Everything eval and pdf share for one pair of directions.
struct Pair {
    /// Generalised half vector, facing +Z.
    wm: Vec3,
    /// η' = n(side of wi) / n(side of wo); 1 for reflection.
    etap: f32,
    reflect: bool,
}

impl RoughDielectric {
    /// A rough dielectric with the given relative index and distribution.
    pub fn new(eta: f32, distribution: impl Into<MicrofacetDistribution>) -> Self {
        RoughDielectric { eta, distribution: distribution.into() }
    }

    /// True when the interface scatters only into delta lobes (smooth, or index-matched).
    pub fn is_specular(&self) -> bool {
        self.eta == 1.0 || self.distribution.effectively_smooth()
    }

    /// The microfacet normal that takes `wo` to `wi`, or `None` when no visible facet does.
    fn pair(&self, wo: Vec3, wi: Vec3) -> Option<Pair> {
        let (cos_o, cos_i) = (wo.z, wi.z);
        if cos_o == 0.0 || cos_i == 0.0 {
            return None;
        }
        let reflect = cos_o * cos_i > 0.0;
        let etap = match (reflect, cos_o > 0.0) {
            (true, _) => 1.0,
            (false, true) => self.eta,
            (false, false) => 1.0 / self.eta,
        };
        let wm = (wi * etap + wo).try_normalize()?;
        let wm = if wm.z < 0.0 { -wm } else { wm };
        // Both directions must see the facet from their own side of the macrosurface.
        if wm.dot(wo) * cos_o <= 0.0 || wm.dot(wi) * cos_i <= 0.0 {
            return None;
        }
        Some(Pair { wm, etap, reflect })
    }

    /// Fresnel reflectance of the facet `wm` for a refracting pair, evaluated from whichever of
    /// `wo`, `wi` lies in the optically thinner medium. Both sides give the same value in exact
    /// arithmetic (Stokes), but from the denser side F has an infinite slope at the critical angle
    /// and f32 rounding of the cosine there costs percent-level errors in 1 − F; the thinner side
    /// is well conditioned, and using one side makes `eval` reciprocal to rounding.
    fn refraction_fresnel(&self, wo: Vec3, wi: Vec3, wm: Vec3) -> f32 {
        let outside_is_thinner = self.eta > 1.0;
        let w = if (wo.z > 0.0) == outside_is_thinner { wo } else { wi };
        fresnel(w.dot(wm), self.eta)
    }

    /// Single-scattering BSDF value f(wo, wi) for light arriving from `wi` and leaving towards
    /// `wo` (or the reverse flow of importance); zero when the interface is effectively smooth.
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        if self.is_specular() {
            return Vec3::ZERO;
        }
        let Some(Pair { wm, etap, reflect }) = self.pair(wo, wi) else { return Vec3::ZERO };
        let dist = &self.distribution;
        let (cos_om, cos_im) = (wo.dot(wm), wi.dot(wm));
        let value = if reflect {
            fresnel(cos_om, self.eta) * dist.d(wm) * dist.g(wo, wi) / (4.0 * (wo.z * wi.z).abs())
        } else {
            let t = 1.0 - self.refraction_fresnel(wo, wi, wm);
            let dg = dist.d(wm) * smith_refraction(dist, wo, wi);
            transmission_value(t, dg, wo, wi, cos_om, cos_im, etap, mode)
        };
        Vec3::splat(value)
    }

    /// Solid-angle density with which [`sample`](Self::sample) returns `wi` after a single
    /// facet: the importance-mode single-scattering f(wo, wi)·|cos θi|. It integrates to less
    /// than one; the rest is the multiply scattered samples.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval(wo, wi, TransportMode::Importance).x * wi.z.abs()
    }

    /// [`eval`](Self::eval) in `mode` and [`pdf`](Self::pdf) from one evaluation (the same bits
    /// as the two calls): the density is the importance-mode value times |cos θi|, and the
    /// radiance-mode value of a refraction is that value over η'².
    pub fn eval_with_pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> (Vec3, f32) {
        let importance = self.eval(wo, wi, TransportMode::Importance).x;
        let refracted_radiance = mode == TransportMode::Radiance && wo.z * wi.z < 0.0;
        let f = if refracted_radiance {
            let etap = if wo.z > 0.0 { self.eta } else { 1.0 / self.eta };
            importance / (etap * etap)
        } else {
            importance
        };
        (Vec3::splat(f), importance * wi.z.abs())
    }

    /// An unbiased estimate of the multiply scattered remainder of f(wo, wi), which `eval` leaves
    /// out, from one random walk drawn with `rng`.
    pub fn eval_multiple<R: Rng>(&self, wo: Vec3, wi: Vec3, mode: TransportMode, rng: &mut R) -> Vec3 {
        if self.is_specular() || wo.z == 0.0 || wi.z == 0.0 {
            return Vec3::ZERO;
        }
        // The walk follows the light: from wo in importance mode, from wi in radiance mode.
        let (from, to) = match mode {
            TransportMode::Importance => (wo, wi),
            TransportMode::Radiance => (wi, wo),
        };
        let (surface, flip) = self.microsurface_facing(from);
        let value = surface.eval_multiple(from * flip, to * flip, rng) / to.z.abs();
        Vec3::splat(if value.is_finite() { value } else { 0.0 })
    }

    /// The microsurface seen from the side of `w`, and the sign that takes directions into it.
    fn microsurface_facing(&self, w: Vec3) -> (Microsurface, f32) {
        if w.z > 0.0 {
            (Microsurface { distribution: self.distribution, eta: self.eta }, 1.0)
        } else {
            (Microsurface { distribution: self.distribution, eta: 1.0 / self.eta }, -1.0)
        }
    }

    /// Follows the light arriving from `wo` through the microsurface (random walk, see the module
    /// documentation) and returns where it leaves; `uc` and `u` choose the first facet's event and
    /// normal, the later facets are drawn from a generator seeded by them. `None` only when the
    /// walk is cut at [`MAX_ORDER`](super::microsurface::MAX_ORDER) facets.
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        if self.is_specular() {
            return self.sample_specular(wo, uc, mode);
        }
        let (surface, flip) = self.microsurface_facing(wo);
        let mut rng = Pcg32::seed_from_u64(seed_from_uniforms(uc, u));
        let exit = surface.walk(wo * flip, uc, u, &mut rng)?;
        let wi = exit.w * flip;
        if wi.z == 0.0 || !wi.is_finite() {
            return None;
        }
        let is_transmission = wi.z * wo.z < 0.0;
        let etap = match (is_transmission, wo.z > 0.0) {
            (false, _) => 1.0,
            (true, true) => self.eta,
            (true, false) => 1.0 / self.eta,
        };
        // The exact weight f·|cos θi|/pdf of every walk: lossless, radiance scaled on refraction.
        let weight = match mode {
            TransportMode::Radiance => 1.0 / (etap * etap),
            TransportMode::Importance => 1.0,
        };
        // After one facet: f and pdf from `eval` (importance-mode f·|cos θi| is the density, and
        // the radiance-mode f differs from it by the same factor as the weight).
        let f_importance = if exit.order == 1 { self.eval(wo, wi, TransportMode::Importance).x } else { 0.0 };
        let (f, pdf, is_multiple) = if f_importance > 0.0 {
            (Vec3::splat(f_importance * weight), f_importance * wi.z.abs(), false)
        } else {
            // Several facets (or a single one at the limit of rounding): only the weight is known.
            (Vec3::splat(weight / wi.z.abs()), 1.0, true)
        };
        Some(BsdfSample { wi, f, pdf, is_specular: false, is_multiple, is_transmission, eta: etap })
    }

    /// The smooth interface: mirror reflection with probability R, refraction otherwise.
    #[inline(always)]
    fn sample_specular(&self, wo: Vec3, uc: f32, mode: TransportMode) -> Option<BsdfSample> {
        let (valid, sample) = self.specular_sample(wo, uc, mode);
        valid.then_some(sample)
    }

    /// [`sample`](Self::sample) of a smooth interface without a branch: whether there is a
    /// sample (`wo` not in the surface, no refraction lost to rounding) and the sample (garbage
    /// where there is none). The wavefront engine runs it across lanes.
    #[inline(always)]
    pub fn specular_sample(&self, wo: Vec3, uc: f32, mode: TransportMode) -> (bool, BsdfSample) {
        smooth_dielectric_sample(self.eta, wo, uc, mode)
    }
}

/// [`RoughDielectric::specular_sample`] of a smooth interface of relative index `eta`, for one
/// ray or across lanes.
#[inline(always)]
pub fn smooth_dielectric_sample<V: Vector>(
    eta: V::Real,
    wo: V,
    uc: V::Real,
    mode: TransportMode,
) -> (Mask3<V>, BsdfSample<V>) {
    let (zero, one) = (V::Real::splat(0.0), V::Real::splat(1.0));
    let cos_o = wo.z();
    let etap = V::Real::select(cos_o.gt(zero), eta, one / eta);
    let r = fresnel_dielectric(cos_o.abs(), etap);
    let reflects = uc.lt(r);
    let mirrored = V::new(-wo.x(), -wo.y(), cos_o);
    let (refracts, refracted) = refraction(wo, V::splat(Vec3::Z) * cos_o.signum(), etap);
    let t = one - r;
    let scale = match mode {
        TransportMode::Radiance => one / (etap * etap),
        TransportMode::Importance => one,
    };
    let f = V::Real::select(reflects, r / mirrored.z().abs(), t * scale / refracted.z().abs());
    let sample = BsdfSample {
        wi: V::select(reflects, mirrored, refracted),
        f: V::new(f, f, f),
        pdf: V::Real::select(reflects, r, t),
        is_specular: V::Real::mask(true),
        is_multiple: V::Real::mask(false),
        is_transmission: !reflects,
        eta: V::Real::select(reflects, one, etap),
    };
    (cos_o.ne(zero) & (reflects | refracts), sample)
}

/// Height-correlated Smith masking–shadowing for a refracting pair: B(1 + Λo, 1 + Λi), the
/// probability that a ray meeting a facet at a uniformly distributed height and one leaving it on
/// the other side are both unblocked (Heitz 2014, eq. 99 for uniform heights).
fn smith_refraction(dist: &MicrofacetDistribution, wo: Vec3, wi: Vec3) -> f32 {
    let (a, b) = (1.0 + dist.lambda(wo) as f64, 1.0 + dist.lambda(wi) as f64);
    if !(a.is_finite() && b.is_finite()) {
        return 0.0;
    }
    (libm::lgamma(a) + libm::lgamma(b) - libm::lgamma(a + b)).exp() as f32
}

/// A 64-bit seed that depends on every bit of the three uniforms of a BSDF sample.
fn seed_from_uniforms(uc: f32, u: Vec2) -> u64 {
    let bits = (u64::from(uc.to_bits()) << 32) | u64::from(u.x.to_bits());
    bits ^ u64::from(u.y.to_bits()).wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

/// The microfacet BTDF given the transmittance `t` = 1 − F and `dg` = D·G.
#[allow(clippy::too_many_arguments)]
#[inline]
fn transmission_value(
    t: f32,
    dg: f32,
    wo: Vec3,
    wi: Vec3,
    cos_om: f32,
    cos_im: f32,
    etap: f32,
    mode: TransportMode,
) -> f32 {
    let denom = cos_im + cos_om / etap;
    let value = t * dg * (cos_im * cos_om / (wi.z * wo.z * denom * denom)).abs();
    match mode {
        TransportMode::Radiance => value / (etap * etap),
        TransportMode::Importance => value,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::chi2::{self, direction};
    use crate::bsdf::rough_conductor::tests::albedo;
    use crate::bsdf::{Beckmann, TrowbridgeReitz};
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg32;

    const ETAS: [f32; 2] = [1.5, 1.0 / 1.5];
    const ALPHAS: [f32; 3] = [0.1, 0.3, 0.7];
    /// Polar angles of `wo` in degrees, each used from above (θ) and from below (180° − θ).
    const THETAS: [f32; 3] = [0.0, 45.0, 89.0];
    /// Number of chi-square cases run here (counted in the Šidák correction).
    /// GGX and Beckmann each run the whole grid.
    pub(crate) const CHI2_CASES: usize = 2 * ETAS.len() * ALPHAS.len() * THETAS.len() * 2;

    /// Every (eta, alpha, wo) combination of the chi-square grid for GGX, with a label.
    fn grid() -> Vec<(String, RoughDielectric, Vec3)> {
        grid_of("dielectric", |alpha| TrowbridgeReitz::new(alpha).into())
    }

    /// The grid for the distribution `of` each alpha, labelled `name`.
    fn grid_of(
        name: &str,
        of: impl Fn(f32) -> MicrofacetDistribution,
    ) -> Vec<(String, RoughDielectric, Vec3)> {
        let mut cases = Vec::new();
        for eta in ETAS {
            for alpha in ALPHAS {
                for theta in THETAS {
                    for below in [false, true] {
                        let theta_o = if below { 180.0 - theta } else { theta };
                        let label = format!("{name} η={eta:.3} α={alpha} θo={theta_o}°");
                        cases.push((label, RoughDielectric::new(eta, of(alpha)), direction(theta_o, 2.2)));
                    }
                }
            }
        }
        cases
    }

    /// A direction uniformly distributed on the sphere.
    fn random_direction(rng: &mut Pcg32) -> Vec3 {
        let z: f32 = rng.random_range(-1.0..1.0);
        let phi: f32 = rng.random_range(0.0..std::f32::consts::TAU);
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    /// The direction of a sample that left after a single facet, which is what `pdf` describes.
    fn single_scattering_sample(d: &RoughDielectric, wo: Vec3, uc: f32, u: Vec2) -> Option<Vec3> {
        d.sample(wo, uc, u, TransportMode::Radiance).filter(BsdfSample::is_evaluable).map(|s| s.wi)
    }

    fn chi2_for_eta(eta: f32, seed: u64) {
        let mut results = Vec::new();
        for (k, (label, d, wo)) in grid().into_iter().filter(|(_, d, _)| d.eta == eta).enumerate() {
            let test = chi2::ChiSquare::default().seed(seed + k as u64);
            let outcome = test.run(|uc, u| single_scattering_sample(&d, wo, uc, u), |wi| d.pdf(wo, wi));
            results.push((label, outcome));
        }
        assert_eq!(results.len(), CHI2_CASES / ETAS.len() / 2);
        chi2::assert_all_pass(&results);
    }

    #[test]
    fn chi2_beckmann_sampling_matches_pdf() {
        // Mitsuba's default distribution for `roughdielectric`: the same grid, both sides.
        let mut results = Vec::new();
        for (k, (label, d, wo)) in
            grid_of("beckmann dielectric", |a| Beckmann::new(a).into()).into_iter().enumerate()
        {
            let test = chi2::ChiSquare::default().seed(3000 + k as u64);
            let outcome = test.run(|uc, u| single_scattering_sample(&d, wo, uc, u), |wi| d.pdf(wo, wi));
            results.push((label, outcome));
        }
        assert_eq!(results.len(), CHI2_CASES / 2);
        chi2::assert_all_pass(&results);
    }

    #[test]
    fn chi2_sampling_matches_pdf_glass_outside() {
        chi2_for_eta(ETAS[0], 1000);
    }

    #[test]
    fn chi2_sampling_matches_pdf_glass_inside() {
        chi2_for_eta(ETAS[1], 2000);
    }

    #[test]
    fn sampled_values_agree_with_eval_and_pdf() {
        let mut rng = Pcg32::seed_from_u64(17);
        let mut worst = 0.0f32;
        for (label, d, wo) in grid() {
            for mode in [TransportMode::Radiance, TransportMode::Importance] {
                for _ in 0..5_000 {
                    let uc: f32 = rng.random();
                    let u = Vec2::new(rng.random(), rng.random());
                    let Some(s) = d.sample(wo, uc, u, mode) else { continue };
                    assert!(!s.is_specular && s.f.is_finite() && s.pdf.is_finite());
                    if s.is_multiple {
                        continue;
                    }
                    assert_eq!(s.is_transmission, s.wi.z * wo.z < 0.0);
                    let (f, pdf) = (d.eval(wo, s.wi, mode).x, d.pdf(wo, s.wi));
                    let (ef, ep) = ((f - s.f.x).abs() / s.f.x, (pdf - s.pdf).abs() / s.pdf);
                    worst = worst.max(ef).max(ep);
                    assert!(
                        ef <= 1e-3 && ep <= 1e-3,
                        "{label} {mode:?} wi {}: f {f} vs {}, pdf {pdf} vs {}",
                        s.wi,
                        s.f.x,
                        s.pdf
                    );
                }
            }
        }
        println!("largest relative eval/pdf mismatch {worst:.2e}");
    }

    #[test]
    fn eval_with_pdf_gives_the_bits_of_eval_and_pdf() {
        let mut rng = Pcg32::seed_from_u64(35);
        for (label, d, wo) in grid() {
            for _ in 0..2_000 {
                let wi = random_direction(&mut rng);
                for mode in [TransportMode::Radiance, TransportMode::Importance] {
                    let both = (d.eval(wo, wi, mode), d.pdf(wo, wi));
                    assert_eq!(d.eval_with_pdf(wo, wi, mode), both, "{label} {mode:?} wi {wi}");
                }
            }
        }
    }

    #[test]
    fn btdf_obeys_generalised_reciprocity() {
        // f_rad(wo, wi) / n_o² = f_rad(wi, wo) / n_i² with n_o, n_i the indices on the sides of
        // wo and wi (1 outside, eta inside), and f_imp(wo, wi) = f_rad(wi, wo) (adjointness).
        let mut rng = Pcg32::seed_from_u64(23);
        let mut worst = 0.0f32;
        for eta in ETAS {
            for alpha in [0.05f32, 0.3, 0.7] {
                let d = RoughDielectric::new(eta, TrowbridgeReitz::new(alpha));
                let index = |w: Vec3| if w.z > 0.0 { 1.0 } else { eta };
                for _ in 0..20_000 {
                    let (wo, wi) = (random_direction(&mut rng), random_direction(&mut rng));
                    let forward = d.eval(wo, wi, TransportMode::Radiance).x / index(wo).powi(2);
                    let backward = d.eval(wi, wo, TransportMode::Radiance).x / index(wi).powi(2);
                    let adjoint = d.eval(wo, wi, TransportMode::Importance).x;
                    let reverse = d.eval(wi, wo, TransportMode::Radiance).x;
                    let scale = forward.max(backward).max(1e-6);
                    let err = ((forward - backward).abs() / scale)
                        .max((adjoint - reverse).abs() / reverse.max(1e-6));
                    worst = worst.max(err);
                    assert!(
                        err <= 1e-3,
                        "η {eta} α {alpha} {wo} {wi}: {forward} vs {backward}, {adjoint} vs {reverse}"
                    );
                }
            }
        }
        println!("largest relative reciprocity error {worst:.2e}");
    }

    #[test]
    fn rough_glass_scatters_all_the_energy_it_receives() {
        // The importance-mode albedo ∫ f_imp(wo, wi) |cos θi| dωi is the fraction of the power
        // arriving from wo that the interface scatters: exactly 1 for lossless glass, which the
        // random walk achieves sample by sample (every sample weighs 1; only walks cut at
        // MAX_ORDER facets are lost). Its single-scattering part alone (the samples that left
        // after one facet, whose density `sampled_albedo_matches_quadrature_of_eval` ties to
        // `eval`) is what a single-scattering model would keep; the lowest is printed.
        let mut lowest_single = 1.0f64;
        let distributions = [0.01f32, 0.1, 0.3, 0.7, 1.0].into_iter().flat_map(|alpha| {
            [MicrofacetDistribution::from(TrowbridgeReitz::new(alpha)), Beckmann::new(alpha).into()]
        });
        for eta in ETAS {
            for distribution in distributions.clone() {
                let d = RoughDielectric::new(eta, distribution);
                let alpha = format!("{distribution:?}");
                for theta in [0.0, 30.0, 60.0, 75.0, 85.0, 89.0, 91.0, 95.0, 105.0, 120.0, 150.0, 180.0] {
                    let wo = direction(theta, 0.9);
                    let mut rng = Pcg32::seed_from_u64(29);
                    let n = 20_000;
                    let (mut total, mut single) = (0.0f64, 0.0f64);
                    for _ in 0..n {
                        let u = Vec2::new(rng.random(), rng.random());
                        if let Some(s) = d.sample(wo, rng.random(), u, TransportMode::Importance) {
                            assert!((s.weight().x - 1.0).abs() < 1e-3, "η {eta} α {alpha} θ {theta}: {s:?}");
                            total += 1.0;
                            single += f64::from(s.is_evaluable());
                        }
                    }
                    let lost = n as f64 - total;
                    assert!(lost <= 1e-4 * n as f64, "η {eta} α {alpha} θ {theta}: {lost} of {n} lost");
                    lowest_single = lowest_single.min(single / n as f64);
                }
            }
        }
        println!("lowest single-scattering albedo {lowest_single:.4}");
    }

    /// Counts of walks by (incident cos bin, exit cos bin) for `wo` drawn cosine-weighted on one
    /// side, separately for exits on the same side and on the other; `multiple_only` keeps only
    /// walks that met two facets or more.
    fn exit_histogram(d: &RoughDielectric, from_above: bool, n: usize, multiple_only: bool) -> [Vec<f64>; 2] {
        const BINS: usize = 6;
        let mut rng = Pcg32::seed_from_u64(if from_above { 71 } else { 72 });
        let mut counts = [vec![0.0; BINS * BINS], vec![0.0; BINS * BINS]];
        let bin = |w: Vec3| ((w.z.abs() * BINS as f32) as usize).min(BINS - 1);
        for _ in 0..n {
            let local = crate::bsdf::lambert::cosine_hemisphere(Vec2::new(rng.random(), rng.random()));
            let wo = if from_above { local } else { -local };
            let u = Vec2::new(rng.random(), rng.random());
            let Some(s) = d.sample(wo, rng.random(), u, TransportMode::Importance) else { continue };
            if multiple_only && !s.is_multiple {
                continue;
            }
            counts[s.is_transmission as usize][bin(wo) * BINS + bin(s.wi)] += 1.0;
        }
        counts
    }

    /// χ² of `a` against `b` scaled by `k`, cell by cell, over cells with at least 20 counts each,
    /// with its p-value: independent Poisson counts a ≈ k·b.
    fn two_sample_chi2(a: &[f64], b: &[f64], k: f64) -> (f64, usize, f64) {
        let (mut chi2, mut dof) = (0.0, 0);
        for (&x, &y) in a.iter().zip(b) {
            if x >= 20.0 && y >= 20.0 {
                chi2 += (x - k * y).powi(2) / (x + k * k * y);
                dof += 1;
            }
        }
        (chi2, dof, chi2::gamma_q(dof as f64 / 2.0, chi2 / 2.0))
    }

    #[test]
    fn random_walk_is_reciprocal() {
        // Light from a cosine-weighted direction has the joint density f(a → b) |cos a| |cos b| / π
        // of entering along a and leaving along b. Physical reciprocity, f(a → b) / n_b² =
        // f(b → a) / n_a², makes reflection symmetric and transmission from outside η² times the
        // transmission back: counts[a][b] = η² counts_back[b][a] for every pair of bins. This ties
        // the multiply scattered light, which nothing else can evaluate, to physics, for all
        // orders together and for the second facet onwards alone.
        let n = 1 << 20;
        let beckmann = |alpha| MicrofacetDistribution::from(Beckmann::new(alpha));
        let ggx = |alpha| MicrofacetDistribution::from(TrowbridgeReitz::new(alpha));
        for (eta, alpha, d) in [
            (1.5f32, 0.5f32, ggx(0.5)),
            (1.5, 1.0, ggx(1.0)),
            (1.0 / 1.33, 0.7, ggx(0.7)),
            (1.5, 0.7, beckmann(0.7)),
        ] {
            let d = RoughDielectric::new(eta, d);
            for multiple_only in [false, true] {
                let above = exit_histogram(&d, true, n, multiple_only);
                let below = exit_histogram(&d, false, n, multiple_only);
                let transpose = |m: &[f64]| {
                    let b = (m.len() as f64).sqrt() as usize;
                    (0..m.len()).map(|k| m[(k % b) * b + k / b]).collect::<Vec<_>>()
                };
                let label =
                    format!("η {eta:.3} α {alpha} {:?} multiple only {multiple_only}", d.distribution);
                for (name, (a, b, k)) in [
                    ("reflection above", (&above[0], transpose(&above[0]), 1.0)),
                    ("reflection below", (&below[0], transpose(&below[0]), 1.0)),
                    ("transmission", (&above[1], transpose(&below[1]), (eta * eta) as f64)),
                ] {
                    let (chi2, dof, p) = two_sample_chi2(a, &b, k);
                    println!("{label} {name}: χ² {chi2:.1} over {dof} cells, p = {p:.3}");
                    assert!(dof >= 10 && p > 1e-3, "{label} {name}: χ² {chi2} over {dof}, p = {p}");
                }
            }
        }
    }

    #[test]
    fn multiple_scattering_estimate_agrees_with_the_walk() {
        // ∫ eval_multiple(wo, wi) |cos θi| dωi over each side must equal the fraction of walks that
        // leave there after two facets or more: the estimator and the sampler are independent
        // code paths over the same microsurface.
        let mut rng = Pcg32::seed_from_u64(83);
        let ggx = |alpha| MicrofacetDistribution::from(TrowbridgeReitz::new(alpha));
        let beckmann = |alpha| MicrofacetDistribution::from(Beckmann::new(alpha));
        for (eta, alpha, theta, distribution) in [
            (1.5f32, 0.7f32, 30.0f32, ggx(0.7)),
            (1.5, 0.3, 80.0, ggx(0.3)),
            (1.5, 1.0, 150.0, ggx(1.0)),
            (1.0 / 1.5, 0.5, 20.0, ggx(0.5)),
            (1.5, 0.7, 30.0, beckmann(0.7)),
            (1.0 / 1.5, 0.5, 150.0, beckmann(0.5)),
        ] {
            let d = RoughDielectric::new(eta, distribution);
            let wo = direction(theta, 0.4);
            let n = 400_000;
            let mut walked = [0.0f64; 2];
            for _ in 0..n {
                let u = Vec2::new(rng.random(), rng.random());
                if let Some(s) = d.sample(wo, rng.random(), u, TransportMode::Importance) {
                    if s.is_multiple {
                        walked[s.is_transmission as usize] += 1.0;
                    }
                }
            }
            let mut sums = [(0.0f64, 0.0f64); 2];
            for _ in 0..n {
                let wi = random_direction(&mut rng);
                let estimate = d.eval_multiple(wo, wi, TransportMode::Importance, &mut rng).x as f64
                    * wi.z.abs() as f64
                    * 4.0
                    * std::f64::consts::PI;
                let side = &mut sums[(wi.z * wo.z < 0.0) as usize];
                side.0 += estimate;
                side.1 += estimate * estimate;
            }
            for side in 0..2 {
                let p = walked[side] / n as f64;
                let mean = sums[side].0 / n as f64;
                let se = ((sums[side].1 / n as f64 - mean * mean) / n as f64).sqrt();
                let se_walk = (p * (1.0 - p) / n as f64).sqrt();
                println!(
                    "η {eta:.3} α {alpha} θ {theta} side {side}: walk {p:.4} vs estimate {mean:.4} ± {se:.4}"
                );
                assert!(
                    (mean - p).abs() <= 4.0 * (se * se + se_walk * se_walk).sqrt(),
                    "η {eta} α {alpha} θ {theta} side {side}: walk {p} vs estimate {mean} ± {se}"
                );
            }
        }
    }

    #[test]
    fn sampled_albedo_matches_quadrature_of_eval() {
        // The importance-sampled albedo (mean of f·|cos θi|/pdf) against ∫ f |cos θi| dωi by
        // quadrature of `eval`: ties the sampling weights, including lost samples, to `eval`.
        for (eta, alpha, theta) in
            [(1.5f32, 0.3f32, 30.0f32), (1.5, 0.7, 120.0), (1.0 / 1.5, 0.1, 89.0), (1.5, 1.0, 160.0)]
        {
            let d = RoughDielectric::new(eta, TrowbridgeReitz::new(alpha));
            let wo = direction(theta, 0.5);
            for mode in [TransportMode::Radiance, TransportMode::Importance] {
                let weight = |uc, u| {
                    d.sample(wo, uc, u, mode).filter(BsdfSample::is_evaluable).map_or(0.0, |s| s.weight().x)
                };
                let (mean, se) = albedo(weight, 100_000, 41);
                let quadrature = chi2::integrate_sphere(|wi| d.eval(wo, wi, mode).x * wi.z.abs());
                assert!(
                    (mean - quadrature).abs() <= 4.0 * se + 1e-3,
                    "η {eta} α {alpha} θ {theta} {mode:?}: {mean} ± {se} vs {quadrature}"
                );
            }
        }
    }

    #[test]
    fn smooth_limit_weights_are_exact_fresnel() {
        for eta in [1.5f32, 1.0 / 1.5, 1.33] {
            let d = RoughDielectric::new(eta, TrowbridgeReitz::from_roughness(0.0));
            for theta in (0..180).step_by(7).filter(|&t| t != 90) {
                let wo = direction(theta as f32, 0.3);
                let etap = if wo.z > 0.0 { eta } else { 1.0 / eta };
                let r = fresnel_dielectric(wo.z.abs(), etap);
                let refl = d.sample(wo, r * 0.5, Vec2::splat(0.5), TransportMode::Importance).unwrap();
                assert!(refl.is_specular && !refl.is_transmission && refl.eta == 1.0);
                assert!((refl.pdf - r).abs() < 1e-6 && (refl.f.x * refl.wi.z.abs() - r).abs() < 1e-6);
                assert!((refl.weight().x - 1.0).abs() < 1e-5);
                assert!(refl.wi.abs_diff_eq(Vec3::new(-wo.x, -wo.y, wo.z), 1e-6));
                assert_eq!(
                    (d.eval(wo, refl.wi, TransportMode::Radiance), d.pdf(wo, refl.wi)),
                    (Vec3::ZERO, 0.0)
                );
                if r >= 1.0 {
                    // Total internal reflection: every sample reflects.
                    assert!(d.sample(wo, 0.999_999, Vec2::ZERO, TransportMode::Radiance).unwrap().pdf == 1.0);
                    continue;
                }
                let uc = r + 0.5 * (1.0 - r);
                for mode in [TransportMode::Importance, TransportMode::Radiance] {
                    let s = d.sample(wo, uc, Vec2::splat(0.5), mode).unwrap();
                    assert!(s.is_specular && s.is_transmission && s.eta == etap);
                    assert!(s.wi.z * wo.z < 0.0 && (s.wi.length() - 1.0).abs() < 1e-5);
                    let scale = if mode == TransportMode::Radiance { etap * etap } else { 1.0 };
                    assert!((s.pdf - (1.0 - r)).abs() < 1e-6);
                    assert!((s.f.x * s.wi.z.abs() * scale - (1.0 - r)).abs() < 1e-5, "η {eta} θ {theta}");
                    // Reflected plus transmitted energy is exactly one (importance weights).
                    assert!((s.weight().x * scale - 1.0).abs() < 1e-5);
                }
            }
        }
        // Index-matched: the interface is invisible.
        let d = RoughDielectric::new(1.0, TrowbridgeReitz::new(0.5));
        let wo = direction(40.0, 1.0);
        let s = d.sample(wo, 0.0, Vec2::splat(0.5), TransportMode::Radiance).unwrap();
        assert!(s.is_specular && s.wi.abs_diff_eq(-wo, 1e-6) && (s.weight().x - 1.0).abs() < 1e-6);
    }

    #[test]
    fn reflection_frequency_matches_fresnel_when_smooth() {
        let d = RoughDielectric::new(1.5, TrowbridgeReitz::new(0.0));
        let wo = direction(70.0, 0.0);
        let r = fresnel_dielectric(wo.z, 1.5) as f64;
        let n = 200_000;
        let mut rng = Pcg32::seed_from_u64(31);
        let reflected = (0..n)
            .filter(|_| {
                !d.sample(wo, rng.random(), Vec2::ZERO, TransportMode::Radiance).unwrap().is_transmission
            })
            .count() as f64;
        let se = (r * (1.0 - r) / n as f64).sqrt();
        assert!((reflected / n as f64 - r).abs() < 4.0 * se, "{} vs {r}", reflected / n as f64);
    }

    #[test]
    fn no_nan_anywhere_including_total_internal_reflection() {
        let mut rng = Pcg32::seed_from_u64(37);
        let specials = [Vec3::Z, -Vec3::Z, Vec3::X, direction(89.999, 0.1), direction(90.001, 0.1)];
        for eta in [1.5f32, 1.0 / 1.5, 2.4] {
            for alpha in [1e-4f32, 2e-3, 0.1, 1.0] {
                let d = RoughDielectric::new(eta, TrowbridgeReitz::new(alpha));
                for k in 0..20_000 {
                    let wo = if k < specials.len() { specials[k] } else { random_direction(&mut rng) };
                    let wi =
                        if k % 7 < specials.len() { specials[k % 7] } else { random_direction(&mut rng) };
                    for mode in [TransportMode::Radiance, TransportMode::Importance] {
                        let f = d.eval(wo, wi, mode);
                        let pdf = d.pdf(wo, wi);
                        assert!(f.is_finite() && f.min_element() >= 0.0 && pdf.is_finite() && pdf >= 0.0);
                        let u = Vec2::new(rng.random(), rng.random());
                        if let Some(s) = d.sample(wo, rng.random(), u, mode) {
                            assert!(s.wi.is_finite() && s.f.is_finite() && s.pdf > 0.0 && s.pdf.is_finite());
                            assert!(s.weight().is_finite(), "η {eta} α {alpha} {wo}: {s:?}");
                        }
                    }
                }
            }
        }
    }
}
