//! Reflection, refraction (Snell's law) and dielectric Fresnel reflectance.
//!
//! Conventions: `wi` points *away* from the surface (towards where the light or viewer is), `n` is
//! a unit normal on the same side as `wi`, and `eta` is the ratio n_transmitted / n_incident.

use crate::lanes::{Mask3, Real, Vector};
use glam::Vec3;

/// Mirror reflection of the away-pointing direction `wi` about the unit normal `n`.
#[inline]
pub fn reflect(wi: Vec3, n: Vec3) -> Vec3 {
    2.0 * wi.dot(n) * n - wi
}

/// Refracted direction for `wi` (away-pointing, on the side of `n`), with `eta` = n_t / n_i.
/// Returns `None` on total internal reflection instead of a NaN direction.
#[inline]
pub fn refract(wi: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let (refracts, t) = refraction(wi, n, eta);
    refracts.then_some(t)
}

/// [`refract`] without a branch, for one ray or across lanes: whether the ray refracts (no
/// total internal reflection; a NaN refracts, to a NaN direction), and the direction (NaN where
/// it does not).
#[inline(always)]
pub fn refraction<V: Vector>(wi: V, n: V, eta: V::Real) -> (Mask3<V>, V) {
    let (zero, one) = (V::Real::splat(0.0), V::Real::splat(1.0));
    let cos_i = wi.dot(n).clamp(-1.0, 1.0);
    let sin2_i = (one - cos_i * cos_i).max(zero);
    let sin2_t = sin2_i / (eta * eta);
    let cos_t = (one - sin2_t).sqrt();
    (!sin2_t.ge(one), (-wi / eta + n * (cos_i / eta - cos_t)).normalize())
}

/// Unpolarised Fresnel reflectance of a dielectric interface for incidence cosine `cos_i`
/// (measured on the incident side, clamped to [0,1]) and `eta` = n_t / n_i; 1 under total
/// internal reflection. For one ray or across lanes.
#[inline(always)]
pub fn fresnel_dielectric<R: Real>(cos_i: R, eta: R) -> R {
    let (zero, one) = (R::splat(0.0), R::splat(1.0));
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (one - cos_i * cos_i).max(zero) / (eta * eta);
    let cos_t = (one - sin2_t).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r = R::splat(0.5) * (r_parl * r_parl + r_perp * r_perp);
    R::select(sin2_t.ge(one), one, r)
}

/// Unpolarised Fresnel reflectance of a conductor per channel, for incidence cosine `cos_i`
/// (its absolute value is used, clamped to 1) and the complex index η + ik relative to the
/// outside medium (η and k divided by the outside's index). The exact formula for an absorbing
/// medium (pbrt-v3 `FrConductor`, Mitsuba's `fresnel_conductor`); at normal incidence it is
/// ((η−1)² + k²)/((η+1)² + k²), with k = 0 it is [`fresnel_dielectric`], and η = 0, k = 1
/// (Mitsuba's `material = "none"`) reflects everything at every angle.
pub fn fresnel_conductor(cos_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    let cos2 = cos_i.abs().min(1.0).powi(2);
    let cos = cos2.sqrt();
    let sin2 = 1.0 - cos2;
    let (eta2, k2) = (eta * eta, k * k);
    let t0 = eta2 - k2 - Vec3::splat(sin2);
    let a2b2 = sqrt3(t0 * t0 + 4.0 * eta2 * k2);
    let t1 = a2b2 + Vec3::splat(cos2);
    let a = sqrt3(0.5 * (a2b2 + t0));
    let t2 = 2.0 * cos * a;
    let t3 = cos2 * a2b2 + Vec3::splat(sin2 * sin2);
    let t4 = t2 * sin2;
    // The denominators vanish only at grazing incidence on an index-matched surface (η = 1,
    // k = 0), whose limit is total reflection.
    let ratio = |num: Vec3, den: Vec3| {
        Vec3::select(den.cmpgt(Vec3::ZERO), num / den.max(Vec3::splat(f32::MIN_POSITIVE)), Vec3::ONE)
    };
    let rs = ratio(t1 - t2, t1 + t2);
    let rp = rs * ratio(t3 - t4, t3 + t4);
    (0.5 * (rs + rp)).clamp(Vec3::ZERO, Vec3::ONE)
}

/// The square root of each channel, negative ones (round-off) read as 0.
fn sqrt3(v: Vec3) -> Vec3 {
    let v = v.max(Vec3::ZERO);
    Vec3::new(v.x.sqrt(), v.y.sqrt(), v.z.sqrt())
}

/// Critical angle (radians) for light going from index `n_i` into the lower index `n_t`;
/// `None` when `n_t >= n_i` (no total internal reflection).
pub fn critical_angle(n_i: f32, n_t: f32) -> Option<f32> {
    (n_t < n_i).then(|| (n_t / n_i).asin())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir_at(theta: f32) -> Vec3 {
        Vec3::new(theta.sin(), theta.cos(), 0.0)
    }

    #[test]
    fn reflection_mirrors_about_the_normal() {
        let r = reflect(Vec3::new(1.0, 1.0, 0.0).normalize(), Vec3::Y);
        assert!((r - Vec3::new(-1.0, 1.0, 0.0).normalize()).length() < 1e-6);
    }

    #[test]
    fn snell_law_holds_for_many_angles() {
        for eta in [1.5f32, 1.0 / 1.5, 1.33, 2.4] {
            for k in 0..89 {
                let theta_i = (k as f32).to_radians();
                let wi = dir_at(theta_i);
                match refract(wi, Vec3::Y, eta) {
                    Some(wt) => {
                        assert!((wt.length() - 1.0).abs() < 1e-5);
                        assert!(wt.y < 0.0, "transmitted ray must cross the surface");
                        let sin_t = (wt.x * wt.x + wt.z * wt.z).sqrt();
                        // n_i sin(theta_i) = n_t sin(theta_t)  <=>  sin_i = eta sin_t
                        assert!((theta_i.sin() - eta * sin_t).abs() < 1e-5, "eta {eta} theta {k}");
                        // the refracted ray lies in the plane of incidence, on the other side
                        assert!(wt.x <= 1e-6 && wt.z.abs() < 1e-6);
                    }
                    None => {
                        assert!(eta < 1.0 && theta_i.sin() / eta >= 1.0 - 1e-6, "spurious TIR");
                    }
                }
            }
        }
    }

    #[test]
    fn total_internal_reflection_exactly_beyond_the_critical_angle() {
        let (n_glass, n_air) = (1.5f32, 1.0f32);
        let crit = critical_angle(n_glass, n_air).unwrap();
        assert!((crit - (1.0f32 / 1.5).asin()).abs() < 1e-7);
        let eta = n_air / n_glass;
        let below = dir_at(crit * (1.0 - 1e-4));
        let above = dir_at(crit * (1.0 + 1e-4));
        assert!(refract(below, Vec3::Y, eta).is_some());
        assert!(refract(above, Vec3::Y, eta).is_none());
        assert_eq!(fresnel_dielectric(above.y, eta), 1.0);
        assert!(fresnel_dielectric(below.y, eta) < 1.0);
        assert!(critical_angle(1.0, 1.5).is_none());
    }

    #[test]
    fn fresnel_at_normal_incidence_matches_the_closed_form() {
        for (n1, n2) in [(1.0f32, 1.5f32), (1.5, 1.0), (1.0, 1.33), (1.33, 1.52), (1.0, 3.0)] {
            let expected = ((n1 - n2) / (n1 + n2)).powi(2);
            let r = fresnel_dielectric(1.0, n2 / n1);
            assert!((r - expected).abs() < 1e-6, "{n1}->{n2}: {r} vs {expected}");
        }
    }

    #[test]
    fn fresnel_is_symmetric_and_energy_is_conserved() {
        // R is the same from both sides for corresponding angles (Stokes), so R + T = 1 with T = 1 - R
        // equal to the transmittance computed from the other side.
        let eta = 1.5f32;
        for k in 0..90 {
            let theta_i = (k as f32).to_radians();
            let r = fresnel_dielectric(theta_i.cos(), eta);
            assert!((0.0..=1.0).contains(&r));
            let wt = refract(dir_at(theta_i), Vec3::Y, eta).unwrap();
            let r_back = fresnel_dielectric(-wt.y, 1.0 / eta);
            // dR/dθ grows like 1/cos θ towards grazing, amplifying f32 roundoff of the direction.
            let tolerance = 1e-5 / theta_i.cos().max(0.05);
            assert!((r - r_back).abs() < tolerance, "theta {k}: {r} vs {r_back}");
            // Brewster: the parallel term vanishes at tan(theta) = eta
        }
        let brewster = eta.atan();
        let r = fresnel_dielectric(brewster.cos(), eta);
        let cos_t = (1.0 - brewster.sin().powi(2) / (eta * eta)).sqrt();
        let r_perp = ((brewster.cos() - eta * cos_t) / (brewster.cos() + eta * cos_t)).powi(2);
        assert!((r - 0.5 * r_perp).abs() < 1e-6);
    }

    #[test]
    fn reflectance_plus_transmittance_from_the_amplitudes_is_one() {
        // T computed independently of R: from the Fresnel transmission amplitudes and the
        // ratio of beam cross-sections, T = (n_t cos θt)/(n_i cos θi) · t².
        for (n_i, n_t) in [(1.0f32, 1.5f32), (1.5, 1.0), (1.0, 2.4), (1.33, 1.52)] {
            for k in 0..90 {
                let cos_i = (k as f32).to_radians().cos();
                let sin_t = (n_i / n_t) * (1.0 - cos_i * cos_i).sqrt();
                if sin_t >= 1.0 {
                    assert_eq!(fresnel_dielectric(cos_i, n_t / n_i), 1.0);
                    continue;
                }
                let cos_t = (1.0 - sin_t * sin_t).sqrt();
                let t_s = 2.0 * n_i * cos_i / (n_i * cos_i + n_t * cos_t);
                let t_p = 2.0 * n_i * cos_i / (n_t * cos_i + n_i * cos_t);
                let beam = (n_t * cos_t) / (n_i * cos_i);
                let t = 0.5 * beam * (t_s * t_s + t_p * t_p);
                let r = fresnel_dielectric(cos_i, n_t / n_i);
                assert!((r + t - 1.0).abs() < 1e-5, "{n_i}->{n_t} at {k}°: R {r} + T {t}");
            }
        }
    }

    #[test]
    fn conductor_fresnel_matches_closed_forms() {
        // Normal incidence: ((η−1)² + k²)/((η+1)² + k²).
        for (eta, k) in [(0.2f32, 3.9f32), (1.5, 0.0), (0.05, 4.2), (1.2, 2.6), (2.9, 3.1)] {
            let expected = ((eta - 1.0).powi(2) + k * k) / ((eta + 1.0).powi(2) + k * k);
            let r = fresnel_conductor(1.0, Vec3::splat(eta), Vec3::splat(k)).x;
            assert!((r - expected).abs() < 1e-6, "η {eta} k {k}: {r} vs {expected}");
        }
        // k = 0 is the dielectric, above and below the critical angle (η < 1).
        for eta in [1.5f32, 1.33, 2.4, 1.0 / 1.5] {
            for deg in 0..=90 {
                let cos = (deg as f32).to_radians().cos();
                let r = fresnel_conductor(cos, Vec3::splat(eta), Vec3::ZERO).x;
                let d = fresnel_dielectric(cos, eta);
                assert!((r - d).abs() < 2e-5, "η {eta} at {deg}°: {r} vs {d}");
            }
        }
        // η = 0, k = 1 is a perfect mirror; gold (Mitsuba's RGB) is reddish and reflects more
        // towards grazing; every value is finite and in [0, 1], from either side.
        let gold = (Vec3::new(0.143, 0.375, 1.442), Vec3::new(3.983, 2.386, 1.603));
        for deg in 0..=90 {
            let cos = (deg as f32).to_radians().cos();
            let mirror = fresnel_conductor(cos, Vec3::ZERO, Vec3::ONE);
            assert!(mirror.abs_diff_eq(Vec3::ONE, 1e-6), "{deg}°: {mirror}");
            let r = fresnel_conductor(cos, gold.0, gold.1);
            assert_eq!(r, fresnel_conductor(-cos, gold.0, gold.1));
            assert!(r.cmpge(Vec3::ZERO).all() && r.cmple(Vec3::ONE).all() && r.x > r.z, "{deg}°: {r}");
        }
        assert!(fresnel_conductor(0.0, gold.0, gold.1).abs_diff_eq(Vec3::ONE, 1e-6));
        assert!(fresnel_conductor(0.0, Vec3::ONE, Vec3::ZERO).is_finite());
    }

    #[test]
    fn grazing_and_out_of_range_cosines_stay_finite() {
        for cos in [-0.5f32, 0.0, 1e-30, 1.0, 1.0000001] {
            for eta in [1.5f32, 1.0 / 1.5, 1.0] {
                let r = fresnel_dielectric(cos, eta);
                assert!(r.is_finite() && (0.0..=1.0).contains(&r));
            }
        }
        assert_eq!(fresnel_dielectric(0.0, 1.5), 1.0);
        let wt = refract(Vec3::X, Vec3::Y, 1.5).unwrap();
        assert!(wt.is_finite());
        assert!(refract(Vec3::Y, Vec3::Y, 1.0).unwrap().abs_diff_eq(-Vec3::Y, 1e-6));
    }
}
