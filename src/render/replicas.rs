//! The means of a render's independent replicas ([`crate::sampler::Replicas`]) and what they
//! estimate without assuming the samples independent: the variance of each pixel's mean, and
//! the standard error of any statistic of the image by the delete-one jackknife.
//!
//! With R replicas of n₁ … n_R samples and means m₁ … m_R, the render's mean is
//! x̄ = Σ n_r·m_r / Σ n_r. The replicas are independent, each an unbiased estimate of the same
//! pixel value (for an unbiased method), so
//!
//! - **the variance of the mean** is estimated by V = Σ (m_r − m̃)² / (R (R − 1)), with m̃ the
//!   plain mean of the m_r: unbiased for the variance of m̃, which is x̄ when the counts are
//!   equal (spp a multiple of R). With counts that differ by one (a render stopped between
//!   two multiples) the difference is of order 1/n. Stratification within a replica (Sobol',
//!   stratified) is seen, not assumed away: V is the variance of the estimator actually used.
//! - **the standard error of a statistic** θ(x̄) (the relMSE, the bias part, …) is the jackknife's
//!   √((R−1)/R · Σ (θ₍₋ⱼ₎ − θ̄)²), with θ₍₋ⱼ₎ the statistic of the render without replica j
//!   ([`ReplicaMeans::leave_one_out`]). Pixels need not be independent: the replicas are, which
//!   is what the light paths and photons that the bidirectional methods share between pixels
//!   need.

use crate::image::Image;
use glam::DVec3;

/// The means of the replicas of a render that hold samples (at least two), and their sample
/// counts.
#[derive(Clone, Debug, PartialEq)]
pub struct ReplicaMeans {
    /// The replicas' mean images, all of one size.
    pub means: Vec<Image>,
    /// The sample indices each replica holds.
    pub samples: Vec<u32>,
}

impl ReplicaMeans {
    /// The number of replicas.
    pub fn count(&self) -> usize {
        self.means.len()
    }

    /// Image width.
    pub fn width(&self) -> usize {
        self.means[0].width
    }

    /// Image height.
    pub fn height(&self) -> usize {
        self.means[0].height
    }

    /// Pixel `p`'s replica means, in f64.
    #[inline]
    pub fn at(&self, p: usize) -> impl Iterator<Item = DVec3> + Clone + '_ {
        self.means.iter().map(move |m| m.pixels[p].as_dvec3())
    }

    /// The variance of the replicas' plain mean at pixel `p`: Σ (m_r − m̃)² / (R (R − 1)).
    pub fn variance_at(&self, p: usize) -> DVec3 {
        spread(self.at(p), self.count())
    }

    /// The per-pixel variance of the render's mean (module documentation).
    pub fn variance(&self) -> Image {
        let pixels = (0..self.width() * self.height()).map(|p| self.variance_at(p).as_vec3()).collect();
        Image { width: self.width(), height: self.height(), pixels }
    }

    /// Pixel `p` of the render without replica `j`: its mean and the variance of that mean from
    /// the other replicas (zero with fewer than two of them).
    pub fn leave_one_out_at(&self, p: usize, j: usize) -> (DVec3, DVec3) {
        let (mut sum, mut n) = (DVec3::ZERO, 0.0f64);
        for (r, m) in self.at(p).enumerate() {
            if r != j {
                sum += m * self.samples[r] as f64;
                n += self.samples[r] as f64;
            }
        }
        let others = self.at(p).enumerate().filter(|&(r, _)| r != j).map(|(_, m)| m);
        let variance = if self.count() > 2 { spread(others, self.count() - 1) } else { DVec3::ZERO };
        (sum / n.max(1.0), variance)
    }
}

/// Σ (m − m̃)² / (k (k − 1)) over the `k` values `m` (0 for k < 2).
fn spread(values: impl Iterator<Item = DVec3> + Clone, k: usize) -> DVec3 {
    if k < 2 {
        return DVec3::ZERO;
    }
    let mean = values.clone().sum::<DVec3>() / k as f64;
    values.map(|m| (m - mean) * (m - mean)).sum::<DVec3>() / (k * (k - 1)) as f64
}

/// The delete-one jackknife's standard error from a statistic's values without each replica in
/// turn: √((R−1)/R · Σ (θⱼ − θ̄)²); NaN below two values or when one is not finite.
pub fn jackknife_se(leave_one_out: &[f64]) -> f64 {
    let r = leave_one_out.len() as f64;
    if leave_one_out.len() < 2 || leave_one_out.iter().any(|v| !v.is_finite()) {
        return f64::NAN;
    }
    let mean = leave_one_out.iter().sum::<f64>() / r;
    ((r - 1.0) / r * leave_one_out.iter().map(|v| (v - mean).powi(2)).sum::<f64>()).sqrt()
}

/// The two-sided 95% quantile of Student's t distribution with `dof` degrees of freedom (the
/// half-width of a 95% confidence interval in standard errors); the normal 1.96 above 30.
pub fn t95(dof: usize) -> f64 {
    const TABLE: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145,
        2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048,
        2.045, 2.042,
    ];
    match dof {
        0 => f64::NAN,
        d if d <= 30 => TABLE[d - 1],
        _ => 1.96,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn replicas(values: &[f32], samples: &[u32]) -> ReplicaMeans {
        ReplicaMeans {
            means: values
                .iter()
                .map(|&v| Image { width: 1, height: 1, pixels: vec![Vec3::splat(v)] })
                .collect(),
            samples: samples.to_vec(),
        }
    }

    #[test]
    fn the_variance_of_the_mean_by_hand() {
        // Means 1, 2, 3, 6: mean 3, squared deviations 4 + 1 + 0 + 9 = 14, / (4·3) = 7/6.
        let m = replicas(&[1.0, 2.0, 3.0, 6.0], &[2, 2, 2, 2]);
        assert!((m.variance_at(0).x - 14.0 / 12.0).abs() < 1e-12);
        // Without the last: mean of 1, 2, 3 (equal counts), variance 2 / (3·2).
        let (mean, var) = m.leave_one_out_at(0, 3);
        assert!((mean.x - 2.0).abs() < 1e-12 && (var.x - 2.0 / 6.0).abs() < 1e-12);
        // Unequal counts weight the leave-one-out mean by samples: (1·3 + 2·1) / 4.
        let m = replicas(&[1.0, 2.0, 9.0], &[3, 1, 1]);
        assert!((m.leave_one_out_at(0, 2).0.x - 1.25).abs() < 1e-12);
    }

    #[test]
    fn the_jackknife_of_the_mean_is_the_usual_standard_error() {
        // For θ = the mean, the jackknife gives sd/√R exactly.
        let x = [0.3, 1.7, 2.2, 0.9, 4.1, 3.3];
        let r = x.len() as f64;
        let mean = x.iter().sum::<f64>() / r;
        let sd = (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (r - 1.0)).sqrt();
        let loo: Vec<f64> = (0..x.len()).map(|j| (r * mean - x[j]) / (r - 1.0)).collect();
        assert!((jackknife_se(&loo) - sd / r.sqrt()).abs() < 1e-12);
        assert!(jackknife_se(&[1.0]).is_nan() && jackknife_se(&[1.0, f64::NAN]).is_nan());
    }

    #[test]
    fn the_variance_estimate_is_unbiased_for_independent_replicas() {
        // 4000 trials of 8 replicas of a uniform mean of 4 values: Var = 1/12 / 4 per replica,
        // 1/(12·4·8) for the mean of the replicas. The estimate's mean must match within 5
        // standard errors (its sd over trials / √trials).
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg32::seed_from_u64(7);
        let trials = 4000;
        let estimates: Vec<f64> = (0..trials)
            .map(|_| {
                let values: Vec<f32> =
                    (0..8).map(|_| (0..4).map(|_| rng.random::<f32>()).sum::<f32>() / 4.0).collect();
                replicas(&values, &[4; 8]).variance_at(0).x
            })
            .collect();
        let mean = estimates.iter().sum::<f64>() / trials as f64;
        let sd = (estimates.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (trials - 1) as f64).sqrt();
        let expected = 1.0 / (12.0 * 4.0 * 8.0);
        assert!((mean - expected).abs() < 5.0 * sd / (trials as f64).sqrt(), "{mean} vs {expected}");
    }

    #[test]
    fn t_quantiles() {
        assert_eq!(t95(7), 2.365);
        assert_eq!(t95(100), 1.96);
        assert!(t95(0).is_nan());
    }
}
