//! Mitsuba 3's smooth `plastic`: a diffuse base under a smooth dielectric coating.
//!
//! Light meeting the coating is reflected specularly with the Fresnel reflectance R(cos θo)
//! (times `specular`), the rest enters, scatters diffusely in the base and leaves with the
//! transmittance of the way out. The light the coating reflects back into the base is summed in
//! closed form: f = ρ' T(θo) T(θi) / (η² π) with ρ' = ρ / (1 − F_dr,int) (Mitsuba's default) or,
//! when `nonlinear`, ρ / (1 − ρ F_dr,int) (the colour shift of repeated bounces), F_dr,int the
//! diffuse Fresnel reflectance seen from inside ([`fresnel_diffuse_reflectance`] of 1/η).
//! One-sided as Mitsuba's: black seen from behind and blind to light from behind; or two-sided
//! as Mitsuba's `twosided` wrapper makes it (the same plastic on the back).
//!
//! Sampling chooses the coating's mirror with probability R·w / (R·w + T·(1 − w)), w the
//! specular sampling weight mean(specular) / (mean(diffuse) + mean(specular)), the cosine-
//! distributed base otherwise; `eval` and `pdf` hold the base alone (the mirror is a delta).

use super::{lambert::cosine_hemisphere, BsdfSample};
use crate::optics::fresnel_dielectric;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// The hemispherical average of the Fresnel reflectance of a dielectric interface of relative
/// index `eta` for light arriving uniformly (cosine-weighted) from the side `eta` is seen from,
/// as Mitsuba 3's `fresnel_diffuse_reflectance` fits it: Egan and Hilgeman's polynomial for
/// η < 1, d'Eon and Irving's for η ≥ 1.
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    let inv = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        let c = [0.919317f32, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881];
        c.iter().rev().fold(0.0, |acc, &x| acc * inv + x)
    }
}

/// A smooth plastic: diffuse base `diffuse`, coating of relative index `eta` (inside / outside)
/// whose specular reflection is scaled by `specular`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plastic {
    /// The base's diffuse reflectance ρ, per channel.
    pub diffuse: Vec3,
    /// Scale of the coating's specular reflection, per channel.
    pub specular: Vec3,
    /// The coating's index over the outside medium's.
    pub eta: f32,
    /// Whether internal scattering shifts the colour (ρ / (1 − ρ F_dr,int)).
    pub nonlinear: bool,
    /// Probability weight w of the specular lobe before the Fresnel factors.
    pub specular_weight: f32,
    /// Whether the back is the same plastic (Mitsuba's `twosided`); otherwise it is black.
    pub two_sided: bool,
}

/// `v` mirrored through the surface when `flip`.
#[inline]
pub(crate) fn mirrored(v: Vec3, flip: bool) -> Vec3 {
    if flip {
        Vec3::new(v.x, v.y, -v.z)
    } else {
        v
    }
}

/// Whether a coated surface evaluates `wo` mirrored to its front: seen on the back of a
/// two-sided one (Mitsuba's `twosided` wrapper). A one-sided one stays as it is, black behind.
#[inline]
pub(crate) fn flips(two_sided: bool, wo: Vec3) -> bool {
    two_sided && wo.z < 0.0
}

/// The diffuse reflectance after the internal bounces, ρ' = ρ / (1 − F_int) or, when
/// `nonlinear`, ρ / (1 − ρ F_int), for a coating that reflects the fraction `internal` of the
/// base's light back into it (Mitsuba's smooth and rough plastics alike).
#[inline]
pub fn effective_diffuse(diffuse: Vec3, internal: f32, nonlinear: bool) -> Vec3 {
    if nonlinear {
        diffuse / (Vec3::ONE - diffuse * internal)
    } else {
        diffuse / (1.0 - internal)
    }
}

/// The probability of choosing a coating's specular lobe when it reflects the fraction
/// `reflected` of the light from `wo`: R·w / (R·w + (1 − R)(1 − w)) with the specular sampling
/// weight w (Mitsuba's choice for both plastics); 0 when neither lobe carries weight.
#[inline]
pub fn specular_probability(reflected: f32, weight: f32) -> f32 {
    let (ps, pd) = (reflected * weight, (1.0 - reflected) * (1.0 - weight));
    if ps + pd > 0.0 {
        ps / (ps + pd)
    } else {
        0.0
    }
}

impl Plastic {
    /// Mitsuba's specular sampling weight from the RGB reflectances: the specular mean over the
    /// sum of both means.
    pub fn sampling_weight(diffuse: Vec3, specular: Vec3) -> f32 {
        let (d, s) = (diffuse.element_sum() / 3.0, specular.element_sum() / 3.0);
        if d + s > 0.0 {
            s / (d + s)
        } else {
            0.5
        }
    }

    /// The diffuse reflectance after the internal bounces, ρ'.
    #[inline]
    pub fn effective_diffuse(&self) -> Vec3 {
        effective_diffuse(self.diffuse, fresnel_diffuse_reflectance(1.0 / self.eta), self.nonlinear)
    }

    /// The coating's Fresnel reflectance for the incidence cosine `cos` (from outside).
    #[inline]
    fn reflectance(&self, cos: f32) -> f32 {
        fresnel_dielectric(cos, self.eta)
    }

    /// The probability of choosing the mirror for `wo` (cos θo > 0).
    #[inline]
    pub fn specular_probability(&self, cos_o: f32) -> f32 {
        specular_probability(self.reflectance(cos_o), self.specular_weight)
    }

    /// Whether `wo` is seen on the back of a two-sided plastic (evaluated mirrored to the front).
    #[inline]
    fn flips(&self, wo: Vec3) -> bool {
        flips(self.two_sided, wo)
    }

    /// The base's BSDF value: ρ' T(θo) T(θi) / (η² π), 0 unless both directions are in front
    /// (or, two-sided, both behind).
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let flip = self.flips(wo);
        let (wo, wi) = (mirrored(wo, flip), mirrored(wi, flip));
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let (t_o, t_i) = (1.0 - self.reflectance(wo.z), 1.0 - self.reflectance(wi.z));
        self.effective_diffuse() * (t_o * t_i * FRAC_1_PI / (self.eta * self.eta))
    }

    /// The density of the base's samples: (1 − P_specular(θo)) cos θi / π.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let flip = self.flips(wo);
        let (wo, wi) = (mirrored(wo, flip), mirrored(wi, flip));
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        (1.0 - self.specular_probability(wo.z)) * wi.z * FRAC_1_PI
    }

    /// The coating's mirror (chosen by `uc`) or a cosine-distributed direction of the base
    /// (from `u`); none seen from behind (one-sided).
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        let flip = self.flips(wo);
        self.sample_front(mirrored(wo, flip), uc, u).map(|s| BsdfSample { wi: mirrored(s.wi, flip), ..s })
    }

    /// [`sample`](Self::sample) of the front.
    fn sample_front(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let p_specular = self.specular_probability(wo.z);
        if uc < p_specular {
            // Weight f·cos/pdf = specular·R/P_specular.
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            let r = self.reflectance(wo.z);
            return Some(BsdfSample {
                wi,
                f: self.specular * (r / wi.z),
                pdf: p_specular,
                is_specular: true,
                is_multiple: false,
                is_transmission: false,
                eta: 1.0,
            });
        }
        let wi = cosine_hemisphere(u);
        if wi.z <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            f: self.eval(wo, wi),
            pdf: self.pdf(wo, wi),
            is_specular: false,
            is_multiple: false,
            is_transmission: false,
            eta: 1.0,
        })
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::chi2::{self, direction};
    use rand::{RngExt, SeedableRng};

    const THETAS: [f32; 3] = [0.0, 45.0, 80.0];
    /// Chi-square cases this module adds to the suite (for the Šidák correction).
    pub(crate) const CHI2_CASES: usize = THETAS.len();

    fn plastic(diffuse: Vec3, eta: f32) -> Plastic {
        Plastic {
            diffuse,
            specular: Vec3::ONE,
            eta,
            nonlinear: false,
            specular_weight: Plastic::sampling_weight(diffuse, Vec3::ONE),
            two_sided: false,
        }
    }

    #[test]
    fn diffuse_fresnel_reflectance_is_mitsubas_fit() {
        // Mitsuba 3.x `mi.fresnel_diffuse_reflectance` (scalar_rgb) for 1/1.49 and 1.49.
        assert!((fresnel_diffuse_reflectance(1.0 / 1.49) - 0.590_732_5).abs() < 1e-6);
        assert!((fresnel_diffuse_reflectance(1.49) - 0.090_299_96).abs() < 1e-6);
        // Against the exact hemispherical average 2∫ F(cos) cos dcos (midpoint rule) within the fits' error.
        for eta in [1.0 / 1.5, 1.33, 1.5, 2.0] {
            let n = 20_000;
            let exact: f64 = (0..n)
                .map(|i| {
                    let c = (i as f64 + 0.5) / n as f64;
                    2.0 * fresnel_dielectric(c as f32, eta) as f64 * c / n as f64
                })
                .sum();
            let fit = fresnel_diffuse_reflectance(eta) as f64;
            assert!((fit - exact).abs() < 0.01, "η {eta}: fit {fit} vs {exact}");
        }
    }

    #[test]
    fn chi2_plastic_sampling_matches_pdf() {
        let m = plastic(Vec3::new(0.2, 0.4, 0.8), 1.5);
        let mut results = Vec::new();
        for (k, theta) in THETAS.into_iter().enumerate() {
            let wo = direction(theta, 0.3);
            let test = chi2::ChiSquare::default().seed(1700 + k as u64);
            // The mirror's samples are the pdf's missing mass (the "failed" cell).
            let outcome = test.run(
                |uc, u| m.sample(wo, uc, u).filter(|s| !s.is_specular).map(|s| s.wi),
                |wi| m.pdf(wo, wi),
            );
            results.push((format!("plastic θo={theta}°"), outcome));
        }
        assert_eq!(results.len(), CHI2_CASES);
        chi2::assert_all_pass(&results);
    }

    #[test]
    fn samples_agree_with_eval_and_pdf_and_the_model_is_reciprocal_and_one_sided() {
        let mut m = plastic(Vec3::new(0.2, 0.4, 0.8), 1.49);
        for nonlinear in [false, true] {
            m.nonlinear = nonlinear;
            let mut rng = rand_pcg::Pcg32::seed_from_u64(3);
            for theta in [5.0f32, 40.0, 75.0] {
                let wo = direction(theta, 0.7);
                for _ in 0..2000 {
                    let (uc, u) = (rng.random::<f32>(), Vec2::new(rng.random(), rng.random()));
                    let s = m.sample(wo, uc, u).unwrap();
                    if s.is_specular {
                        assert_eq!(s.wi, Vec3::new(-wo.x, -wo.y, wo.z));
                        let r = fresnel_dielectric(wo.z, m.eta);
                        let w = r / m.specular_probability(wo.z);
                        assert!((s.weight() - Vec3::splat(w)).abs().max_element() < 1e-5);
                    } else {
                        assert_eq!(s.f, m.eval(wo, s.wi));
                        assert_eq!(s.pdf, m.pdf(wo, s.wi));
                        assert_eq!(m.eval(wo, s.wi), m.eval(s.wi, wo), "reciprocity");
                    }
                }
                // Behind: nothing.
                assert!(m.sample(-wo, 0.9, Vec2::new(0.3, 0.3)).is_none());
                let wi = direction(30.0, 2.0);
                assert_eq!(m.eval(-wo, wi), Vec3::ZERO);
                assert_eq!(m.eval(wo, -wi), Vec3::ZERO);
                assert_eq!(m.pdf(-wo, -wi), 0.0);
            }
        }
        // Two-sided: the back is the front mirrored, nothing across.
        let two = Plastic { two_sided: true, ..m };
        let (wo, wi) = (direction(40.0, 1.0), direction(70.0, 2.0));
        let back = |v: Vec3| Vec3::new(v.x, v.y, -v.z);
        assert_eq!(two.eval(back(wo), back(wi)), m.eval(wo, wi));
        assert_eq!(two.pdf(back(wo), back(wi)), m.pdf(wo, wi));
        assert_eq!(two.eval(wo, back(wi)), Vec3::ZERO);
        assert_eq!(two.eval(back(wo), wi), Vec3::ZERO);
        for uc in [0.01, 0.99] {
            let (s, t) = (
                two.sample(back(wo), uc, Vec2::new(0.3, 0.6)).unwrap(),
                m.sample(wo, uc, Vec2::new(0.3, 0.6)).unwrap(),
            );
            assert_eq!((s.wi, s.f, s.pdf, s.is_specular), (back(t.wi), t.f, t.pdf, t.is_specular));
        }
        // Nonlinear: ρ/(1 − ρF) differs from ρ/(1 − F) unless ρ is 0 or 1.
        let fdr = fresnel_diffuse_reflectance(1.0 / 1.49);
        let expected = m.diffuse / (Vec3::ONE - m.diffuse * fdr);
        assert!((m.effective_diffuse() - expected).abs().max_element() < 1e-6);
    }

    /// The directional albedo R(θo) + T(θo)(1 − F_dr,ext)/(η²(1 − F_dr,int)) of a white base
    /// (F_dr,ext the exact average of the Fresnel reflectance from outside, by quadrature).
    fn white_albedo(eta: f32, cos_o: f32) -> f64 {
        let n = 20_000;
        let transmitted: f64 = (0..n)
            .map(|i| {
                let c = (i as f64 + 0.5) / n as f64;
                2.0 * (1.0 - fresnel_dielectric(c as f32, eta) as f64) * c / n as f64
            })
            .sum();
        let r = fresnel_dielectric(cos_o, eta) as f64;
        let fdr_int = fresnel_diffuse_reflectance(1.0 / eta) as f64;
        r + (1.0 - r) * transmitted / ((eta * eta) as f64 * (1.0 - fdr_int))
    }

    #[test]
    fn white_furnace_gives_mitsubas_albedo() {
        let mut rng = rand_pcg::Pcg32::seed_from_u64(17);
        for eta in [1.33f32, 1.5] {
            let m = plastic(Vec3::ONE, eta);
            for theta in [0.0f32, 50.0, 85.0] {
                let wo = direction(theta, 0.2);
                let n = 400_000;
                let (mut sum, mut sum2) = (0.0f64, 0.0f64);
                for _ in 0..n {
                    let s = m.sample(wo, rng.random(), Vec2::new(rng.random(), rng.random()));
                    let w = s.map_or(0.0, |s| s.weight().x as f64);
                    sum += w;
                    sum2 += w * w;
                }
                let mean = sum / n as f64;
                let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
                let expected = white_albedo(eta, wo.z);
                assert!(
                    (mean - expected).abs() < 4.0 * se + 1e-6,
                    "η {eta} θ {theta}: {mean} vs {expected} ± {se}"
                );
                // Mitsuba's fitted F_dr,int makes a lossless white plastic 1 only up to the fit's
                // error: 1.0011 at η = 1.5 and normal incidence, 1.0004 at 85°, 1.0009 at η = 1.33.
                assert!(expected > 1.0 && expected < 1.002, "η {eta} θ {theta}: albedo {expected}");
            }
        }
        // A grey base keeps the albedo below 1.
        let grey = plastic(Vec3::splat(0.5), 1.5);
        let wo = direction(30.0, 0.0);
        let n = 200_000;
        let mean: f64 = (0..n)
            .map(|_| grey.sample(wo, rng.random(), Vec2::new(rng.random(), rng.random())))
            .map(|s| s.map_or(0.0, |s| s.weight().x as f64))
            .sum::<f64>()
            / n as f64;
        assert!(mean < 0.8, "{mean}");
    }
}
