//! Mitsuba 3's `thindielectric`: an infinitely thin slab of a dielectric, such as a window pane.
//!
//! Light meets two parallel interfaces and bounces between them; the directions never change, so
//! the slab reflects specularly with R' = R + T²R/(1 − R²) = 2R/(1 + R) (R the Fresnel
//! reflectance of one interface at the incidence angle, T = 1 − R, summed over every internal
//! bounce) and lets the rest, T' = 1 − R', pass straight through (no refraction, no change of
//! medium, no radiance scaling). The same from either side.

use super::BsdfSample;
use crate::optics::fresnel_dielectric;
use glam::Vec3;

/// A thin slab of relative index `eta` = n_slab / n_around.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinDielectric {
    /// The slab's index over the surrounding medium's.
    pub eta: f32,
}

impl ThinDielectric {
    /// The slab's reflectance R' = 2R/(1 + R) for the incidence cosine `cos` (either side).
    pub fn reflectance(&self, cos: f32) -> f32 {
        let r = fresnel_dielectric(cos.abs(), self.eta);
        // R + T²R/(1 − R²) with T = 1 − R; 1 stays 1 (no total reflection happens from outside).
        if r < 1.0 {
            2.0 * r / (1.0 + r)
        } else {
            1.0
        }
    }

    /// Mirror reflection with probability R', straight transmission otherwise, chosen by `uc`:
    /// every sample has the weight f·|cos θi|/pdf = 1.
    pub fn sample(&self, wo: Vec3, uc: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let r = self.reflectance(wo.z);
        let reflects = uc < r;
        let (wi, p) = if reflects { (Vec3::new(-wo.x, -wo.y, wo.z), r) } else { (-wo, 1.0 - r) };
        Some(BsdfSample {
            wi,
            f: Vec3::splat(p / wi.z.abs()),
            pdf: p,
            is_specular: true,
            is_multiple: false,
            is_transmission: !reflects,
            eta: 1.0,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::chi2::direction;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn reflectance_is_the_sum_over_internal_bounces() {
        let pane = ThinDielectric { eta: 1.5 };
        // Normal incidence: R = ((η − 1)/(η + 1))² = 0.04, R' = 0.08/1.04.
        assert!((pane.reflectance(1.0) - 0.08 / 1.04).abs() < 1e-6);
        for theta in [0.0f32, 30.0, 60.0, 80.0, 89.0] {
            let cos = theta.to_radians().cos();
            let r = fresnel_dielectric(cos, 1.5);
            // The series R + T²R Σ R^(2k), summed term by term.
            let (mut series, mut term) = (r, (1.0 - r) * (1.0 - r) * r);
            for _ in 0..200 {
                series += term;
                term *= r * r;
            }
            assert!(
                (pane.reflectance(cos) - series).abs() < 1e-5,
                "θ {theta}: {} vs {series}",
                pane.reflectance(cos)
            );
            assert_eq!(pane.reflectance(cos), pane.reflectance(-cos), "the same from behind");
        }
        // Grazing: everything is reflected.
        assert_eq!(pane.reflectance(0.0), 1.0);
    }

    #[test]
    fn samples_conserve_energy_and_reflect_with_the_slab_reflectance() {
        let pane = ThinDielectric { eta: 1.5 };
        let mut rng = rand_pcg::Pcg32::seed_from_u64(5);
        for theta in [10.0f32, 70.0, 110.0] {
            let wo = direction(theta, 0.4);
            let n = 200_000;
            let mut reflected = 0.0f64;
            for _ in 0..n {
                let s = pane.sample(wo, rng.random()).unwrap();
                assert!(s.is_specular && (s.weight().x - 1.0).abs() < 1e-5, "{s:?}");
                if s.is_transmission {
                    assert_eq!(s.wi, -wo, "straight through");
                } else {
                    assert_eq!(s.wi, Vec3::new(-wo.x, -wo.y, wo.z));
                    reflected += 1.0;
                }
            }
            let r = pane.reflectance(wo.z) as f64;
            let se = (r * (1.0 - r) / n as f64).sqrt();
            let f = reflected / n as f64;
            assert!((f - r).abs() < 4.0 * se, "θ {theta}: {f} vs {r} ± {se}");
        }
    }
}
