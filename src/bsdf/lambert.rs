//! Lambertian (ideal diffuse) reflection, two-sided (light arriving on either side is scattered
//! back to that side with the same albedo) or one-sided as Mitsuba 3's `diffuse` (only the +Z
//! side, the one the surface normal points to, reflects: f = 0 unless cos θo > 0 and cos θi > 0).

use super::BsdfSample;
use crate::lanes::{Mask3, Real, Vector};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// Ideal diffuse reflection with albedo `albedo`: one surface (`Lambert`), or one per lane
/// (`Lambert<Vec3x>`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambert<V: Vector = Vec3> {
    /// Fraction of light reflected, per channel.
    pub albedo: V,
    /// Whether only the +Z side reflects (black from behind, blind to light from behind).
    pub one_sided: Mask3<V>,
}

/// A cosine-distributed direction in the +Z hemisphere (Malley's method on a concentric disk).
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = crate::camera::concentric_disk(u);
    hemisphere_above(d.x, d.y)
}

/// The point of the unit +Z hemisphere above the point (`dx`, `dy`) of the unit disk (Malley's
/// method), for one point or across lanes.
#[inline(always)]
pub fn hemisphere_above<V: Vector>(dx: V::Real, dy: V::Real) -> V {
    let zero = V::Real::splat(0.0);
    V::new(dx, dy, (V::Real::splat(1.0) - (dx * dx + dy * dy)).max(zero).sqrt())
}

impl Lambert {
    /// A surface that reflects on both sides with albedo `albedo`.
    pub fn two_sided(albedo: Vec3) -> Lambert {
        Lambert { albedo, one_sided: false }
    }

    /// A cosine-distributed direction on the side of `wo` (none seen from behind when one-sided).
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        let d = crate::camera::concentric_disk(u);
        let (valid, sample) = self.disk_sample(wo, d.x, d.y);
        valid.then_some(sample)
    }
}

impl<V: Vector> Lambert<V> {
    /// Whether `wo` and `wi` lie on a side that reflects: the same side, and the +Z one when
    /// one-sided.
    #[inline(always)]
    fn reflects(&self, wo: V, wi: V) -> Mask3<V> {
        let zero = V::Real::splat(0.0);
        (wo.z() * wi.z()).gt(zero) & (wo.z().gt(zero) | !self.one_sided)
    }

    /// `albedo / π` when `wo` and `wi` are on the same (reflecting) side, 0 otherwise.
    #[inline(always)]
    pub fn eval(&self, wo: V, wi: V) -> V {
        V::select(self.reflects(wo, wi), self.albedo * FRAC_1_PI, V::splat(Vec3::ZERO))
    }

    /// Cosine density `|cos θi| / π` on the side of `wo` (0 seen from behind when one-sided).
    #[inline(always)]
    pub fn pdf(&self, wo: V, wi: V) -> V::Real {
        V::Real::select(self.reflects(wo, wi), wi.z().abs() * FRAC_1_PI, V::Real::splat(0.0))
    }

    /// [`sample`](Lambert::sample) from the point (`dx`, `dy`) of the unit disk that its
    /// uniforms map to ([`crate::camera::concentric_disk`]), without a branch: whether there is a
    /// sample (neither direction in the surface, and `wo` in front when one-sided) and the sample.
    #[inline(always)]
    pub fn disk_sample(&self, wo: V, dx: V::Real, dy: V::Real) -> (Mask3<V>, BsdfSample<V>) {
        let (zero, one) = (V::Real::splat(0.0), V::Real::splat(1.0));
        let z = hemisphere_above::<V>(dx, dy).z();
        let wi = V::new(dx, dy, V::Real::select(wo.z().lt(zero), -z, z));
        let no = V::Real::mask(false);
        let sample = BsdfSample {
            wi,
            f: self.albedo * FRAC_1_PI,
            pdf: wi.z().abs() / PI,
            is_specular: no,
            is_multiple: no,
            is_transmission: no,
            eta: one,
        };
        let behind = self.one_sided & wo.z().lt(zero);
        (!(wi.z().eq(zero) | wo.z().eq(zero) | behind), sample)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::chi2::{self, direction};

    const THETAS: [f32; 3] = [0.0, 60.0, 120.0];
    /// Chi-square cases this module adds to the suite (for the Šidák correction).
    pub(crate) const CHI2_CASES: usize = THETAS.len();

    #[test]
    fn chi2_cosine_sampling_matches_pdf() {
        let m = Lambert::two_sided(Vec3::splat(0.7));
        let mut results = Vec::new();
        for (k, theta) in THETAS.into_iter().enumerate() {
            let wo = direction(theta, 0.3);
            let test = chi2::ChiSquare::default().seed(900 + k as u64);
            let outcome = test.run(|_, u| m.sample(wo, u).map(|s| s.wi), |wi| m.pdf(wo, wi));
            results.push((format!("lambert θo={theta}°"), outcome));
        }
        assert_eq!(results.len(), CHI2_CASES);
        chi2::assert_all_pass(&results);
    }

    #[test]
    fn sample_eval_and_pdf_agree_and_albedo_is_exact() {
        let m = Lambert::two_sided(Vec3::new(0.2, 0.5, 0.9));
        let wo = direction(40.0, 1.0);
        let n = 64;
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let s = m.sample(wo, u).unwrap();
                assert_eq!(m.eval(wo, s.wi), s.f);
                assert!((m.pdf(wo, s.wi) - s.pdf).abs() < 1e-6);
                assert!(s.wi.z > 0.0 && (s.wi.length() - 1.0).abs() < 1e-5);
                // f·cos/pdf = albedo for every sample: the albedo estimator has no variance.
                assert!((s.f * s.wi.z.abs() / s.pdf - m.albedo).abs().max_element() < 1e-6);
            }
        }
        // reciprocity and the other side
        let wi = direction(70.0, 2.0);
        assert_eq!(m.eval(wo, wi), m.eval(wi, wo));
        assert!(m.sample(-wo, Vec2::new(0.3, 0.6)).unwrap().wi.z < 0.0);
    }

    #[test]
    fn one_sided_reflects_only_in_front_and_stays_reciprocal() {
        let albedo = Vec3::new(0.2, 0.5, 0.9);
        let (one, two) = (Lambert { albedo, one_sided: true }, Lambert::two_sided(albedo));
        let (front_o, front_i) = (direction(40.0, 1.0), direction(70.0, 2.0));
        let (back_o, back_i) = (-front_o, -front_i);
        // In front: the two-sided values to the bit, sample included.
        assert_eq!(one.eval(front_o, front_i), two.eval(front_o, front_i));
        assert_eq!(one.pdf(front_o, front_i).to_bits(), two.pdf(front_o, front_i).to_bits());
        let u = Vec2::new(0.3, 0.6);
        assert_eq!(one.sample(front_o, u), two.sample(front_o, u));
        // Behind: black, no density, no sample; the two-sided one reflects there.
        assert_eq!(one.eval(back_o, back_i), Vec3::ZERO);
        assert_eq!(one.pdf(back_o, back_i), 0.0);
        assert!(one.sample(back_o, u).is_none());
        assert_ne!(two.eval(back_o, back_i), Vec3::ZERO);
        assert!(two.sample(back_o, u).is_some());
        // Across the surface: nothing either way. Reciprocity for every pair of sides.
        for (a, b) in [(front_o, front_i), (back_o, back_i), (front_o, back_i), (back_o, front_i)] {
            assert_eq!(one.eval(a, b), one.eval(b, a));
            assert_eq!(one.pdf(a, b) > 0.0, one.pdf(b, a) > 0.0);
        }
    }
}
