//! Confidence intervals from repeated runs (`vitrum compare --repeat K`).
//!
//! A method renders the scene K times, run k with seed `seed + k` (run 0 is the plain render), so
//! the runs are independent estimates; under a time budget their seconds and sample counts
//! differ too, since a shared machine is noisy. From the K runs' (relMSE, seconds):
//!
//! - relMSE and seconds: the mean over the runs, with the 95% interval mean ± t₉₅(K−1)·s/√K
//!   (s the runs' sample standard deviation, t Student's quantile, [`t95`]);
//! - efficiency: 1 / (mean relMSE · mean seconds), the efficiency of the method rather than of
//!   one lucky or unlucky run, with the interval value ± t₉₅(K−1)·SE, SE the delete-one jackknife
//!   over the runs ([`jackknife_se`]).
//!
//! The intervals cover the whole spread a researcher would see rerunning the comparison: the
//! noise of the estimate, the reference's error being the same in every run (it is shared), and
//! the machine's timing. They need K ≥ 2.

use crate::render::{jackknife_se, t95};

/// A mean over runs with its 95% confidence interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spread {
    /// The mean.
    pub mean: f64,
    /// The interval's lower bound.
    pub low: f64,
    /// The interval's upper bound.
    pub high: f64,
}

impl Spread {
    /// The mean of `values` with its t interval; `None` below two values or when one is not
    /// finite.
    pub fn of(values: &[f64]) -> Option<Spread> {
        let k = values.len();
        if k < 2 || values.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let mean = values.iter().sum::<f64>() / k as f64;
        let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (k - 1) as f64;
        let half = t95(k - 1) * (variance / k as f64).sqrt();
        Some(Spread { mean, low: mean - half, high: mean + half })
    }
}

/// One run of a repeated comparison: its seed and what it measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Run {
    /// The run's seed.
    pub seed: u64,
    /// Samples per pixel it took.
    pub spp: f64,
    /// Its render seconds.
    pub seconds: f64,
    /// Its relMSE against the reference.
    pub rel_mse: f64,
}

/// The K runs' relMSE, seconds and efficiency with their intervals (the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunSpread {
    /// The number of runs K.
    pub runs: usize,
    /// relMSE over the runs.
    pub rel_mse: Spread,
    /// Seconds over the runs.
    pub seconds: Spread,
    /// 1 / (mean relMSE · mean seconds) (in `mean`) with its jackknife interval.
    pub efficiency: Spread,
}

impl RunSpread {
    /// The spread of `runs`; `None` below two runs or when one's numbers are not finite.
    pub fn of(runs: &[Run]) -> Option<RunSpread> {
        let rel: Vec<f64> = runs.iter().map(|r| r.rel_mse).collect();
        let seconds: Vec<f64> = runs.iter().map(|r| r.seconds).collect();
        let (rel_mse, seconds_spread) = (Spread::of(&rel)?, Spread::of(&seconds)?);
        let k = runs.len();
        let efficiency = |skip: Option<usize>| {
            let kept = |v: &[f64]| {
                let sum: f64 = v.iter().enumerate().filter(|(i, _)| Some(*i) != skip).map(|(_, x)| x).sum();
                sum / (k - usize::from(skip.is_some())) as f64
            };
            1.0 / (kept(&rel) * kept(&seconds).max(1e-9))
        };
        let value = efficiency(None);
        let leave_one_out: Vec<f64> = (0..k).map(|i| efficiency(Some(i))).collect();
        let half = t95(k - 1) * jackknife_se(&leave_one_out);
        let efficiency = Spread { mean: value, low: (value - half).max(0.0), high: value + half };
        Some(RunSpread { runs: k, rel_mse, seconds: seconds_spread, efficiency })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(rel_mse: f64, seconds: f64) -> Run {
        Run { seed: 0, spp: 1.0, seconds, rel_mse }
    }

    #[test]
    fn a_spread_is_the_t_interval_of_the_mean() {
        let s = Spread::of(&[1.0, 2.0, 3.0]).unwrap();
        // Mean 2, sample standard deviation 1, t₉₅(2) = 4.303.
        assert_eq!(s.mean, 2.0);
        assert!((s.high - 2.0 - 4.303 / 3f64.sqrt()).abs() < 1e-12);
        assert!((2.0 - s.low - 4.303 / 3f64.sqrt()).abs() < 1e-12);
        assert_eq!(Spread::of(&[1.0]), None);
        assert_eq!(Spread::of(&[1.0, f64::NAN]), None);
    }

    #[test]
    fn equal_runs_have_a_point_interval_and_efficiency_is_of_the_means() {
        let s = RunSpread::of(&[run(0.5, 2.0), run(0.5, 2.0), run(0.5, 2.0)]).unwrap();
        assert_eq!(s.runs, 3);
        assert_eq!((s.rel_mse.low, s.rel_mse.high), (0.5, 0.5));
        assert_eq!(s.efficiency, Spread { mean: 1.0, low: 1.0, high: 1.0 });
        let s = RunSpread::of(&[run(0.25, 2.0), run(0.75, 2.0)]).unwrap();
        assert_eq!(s.efficiency.mean, 1.0, "1/(mean relMSE · mean seconds), not a mean of ratios");
        assert!(s.efficiency.low < 1.0 && s.efficiency.high > 1.0);
    }

    #[test]
    fn the_interval_covers_the_true_mean_about_95_percent_of_the_time() {
        // 2000 repeated experiments of 5 runs with normal relMSE (mean 1, sd 0.2), by a
        // deterministic generator: coverage must be 95% within 3 binomial standard errors (1.5%).
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        let normal = |rng: &mut rand_pcg::Pcg64| {
            let (u, v): (f64, f64) = (rng.random(), rng.random());
            (-2.0 * (1.0 - u).ln()).sqrt() * (std::f64::consts::TAU * v).cos()
        };
        let trials = 2000;
        let covered = (0..trials)
            .filter(|_| {
                let values: Vec<f64> = (0..5).map(|_| 1.0 + 0.2 * normal(&mut rng)).collect();
                let s = Spread::of(&values).unwrap();
                s.low <= 1.0 && 1.0 <= s.high
            })
            .count();
        let rate = covered as f64 / trials as f64;
        let se = (0.95 * 0.05 / trials as f64).sqrt();
        assert!((rate - 0.95).abs() < 3.0 * se, "coverage {rate}");
    }
}
