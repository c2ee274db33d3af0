//! Test support: a chi-square goodness-of-fit test for direction samplers against their pdf.
//!
//! The sphere is cut into rings of equal polar angle and equal azimuth sectors. Directions drawn
//! by the sampler are counted per cell; the expected counts come from integrating the sampler's
//! claimed pdf over each cell (nested adaptive Simpson in θ and φ). A sampler may fail (return
//! `None`, e.g. a reflection below the horizon); failures form one more cell whose expected count
//! is N·(1 − ∫ pdf). Cells expecting fewer than 5 samples are pooled, and the χ² statistic gives a
//! p-value through the regularised upper incomplete gamma function. Every case must exceed the
//! Šidák-corrected level 1 − (1 − 0.01)^(1/N_cases), so that the whole suite rejects a correct
//! sampler with probability 0.01.
//!
//! Rings are equal in θ rather than in cos θ so that a narrow lobe around the normal (α = 0.1
//! puts nearly all of it at cos θ > 0.98) spreads over several rings instead of one.

use glam::{Vec2, Vec3};
use rand::RngExt;
use rand_pcg::Pcg32;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Family-wise significance level of the whole chi-square suite.
pub(crate) const FAMILY_ALPHA: f64 = 0.01;
/// Number of chi-square cases in the suite, the N of the Šidák correction.
pub(crate) const TOTAL_CASES: usize = super::lambert::tests::CHI2_CASES
    + super::beckmann::tests::CHI2_CASES
    + super::microfacet::tests::CHI2_CASES
    + super::rough_conductor::tests::CHI2_CASES
    + super::rough_dielectric::tests::CHI2_CASES
    + super::plastic::tests::CHI2_CASES
    + super::rough_plastic::tests::CHI2_CASES
    + crate::light::tests::CHI2_CASES
    + crate::light::environment_map::tests::CHI2_CASES
    + crate::light::spot::tests::CHI2_CASES;
/// Cells expecting fewer samples than this are pooled into one.
const MIN_EXPECTED: f64 = 5.0;
/// Samples drawn per parallel chunk (each chunk has its own random stream).
const CHUNK: usize = 1 << 15;

/// The per-case significance level that keeps the family-wise level at [`FAMILY_ALPHA`].
pub(crate) fn sidak_level() -> f64 {
    1.0 - (1.0 - FAMILY_ALPHA).powf(1.0 / TOTAL_CASES as f64)
}

/// The unit direction with polar angle `theta_deg` (degrees from +Z) and azimuth `phi` (radians).
pub(crate) fn direction(theta_deg: f32, phi: f32) -> Vec3 {
    let theta = theta_deg.to_radians();
    Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
}

/// One chi-square experiment: binning resolution, sample count and random seed.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ChiSquare {
    pub theta_bins: usize,
    pub phi_bins: usize,
    pub samples: usize,
    pub seed: u64,
}

impl Default for ChiSquare {
    fn default() -> Self {
        ChiSquare { theta_bins: 40, phi_bins: 40, samples: 1 << 20, seed: 1 }
    }
}

/// What one experiment found.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Outcome {
    pub chi2: f64,
    pub dof: usize,
    pub p_value: f64,
    /// ∫ pdf over the sphere.
    pub pdf_mass: f64,
    /// Fraction of sampler calls that returned a direction.
    pub sampled_fraction: f64,
    pub samples: usize,
    /// Samples that were not unit vectors (always a failure).
    pub invalid: u64,
}

impl ChiSquare {
    /// The same experiment with another seed.
    pub fn seed(self, seed: u64) -> Self {
        ChiSquare { seed, ..self }
    }

    /// Draws `samples` directions with `sample(uc, u)` and tests them against `pdf`.
    pub fn run<S, P>(&self, sample: S, pdf: P) -> Outcome
    where
        S: Fn(f32, Vec2) -> Option<Vec3> + Sync,
        P: Fn(Vec3) -> f32 + Sync,
    {
        let cells = self.theta_bins * self.phi_bins;
        let chunks = self.samples.div_ceil(CHUNK);
        // Histogram: one slot per cell, then failures, then invalid directions.
        let histogram = (0..chunks)
            .into_par_iter()
            .map(|chunk| {
                let mut rng = Pcg32::new(self.seed, chunk as u64);
                let mut counts = vec![0u64; cells + 2];
                let n = CHUNK.min(self.samples - chunk * CHUNK);
                for _ in 0..n {
                    let uc: f32 = rng.random();
                    let u = Vec2::new(rng.random(), rng.random());
                    let slot = match sample(uc, u) {
                        None => cells,
                        Some(w) if !w.is_finite() || (w.length() - 1.0).abs() > 1e-3 => cells + 1,
                        Some(w) => self.cell_of(w),
                    };
                    counts[slot] += 1;
                }
                counts
            })
            .reduce(
                || vec![0u64; cells + 2],
                |mut a, b| {
                    a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
                    a
                },
            );
        let masses = self.cell_masses(&pdf);
        let pdf_mass: f64 = masses.iter().sum();
        let n = self.samples as f64;
        let mut expected: Vec<f64> = masses.iter().map(|m| m * n).collect();
        expected.push((1.0 - pdf_mass).max(0.0) * n);
        let (chi2, dof) = pooled_chi2(&expected, &histogram[..=cells]);
        let p_value = if chi2.is_finite() { gamma_q(0.5 * dof as f64, 0.5 * chi2) } else { 0.0 };
        Outcome {
            chi2,
            dof,
            p_value,
            pdf_mass,
            sampled_fraction: 1.0 - histogram[cells] as f64 / n,
            samples: self.samples,
            invalid: histogram[cells + 1],
        }
    }

    /// Index of the cell containing the unit direction `w`.
    fn cell_of(&self, w: Vec3) -> usize {
        let theta = (w.z as f64).clamp(-1.0, 1.0).acos();
        let mut phi = (w.y as f64).atan2(w.x as f64);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let i = ((theta / PI * self.theta_bins as f64) as usize).min(self.theta_bins - 1);
        let j = ((phi / (2.0 * PI) * self.phi_bins as f64) as usize).min(self.phi_bins - 1);
        i * self.phi_bins + j
    }

    /// ∫ pdf dω over every cell, ring by ring in parallel.
    fn cell_masses<P: Fn(Vec3) -> f32 + Sync>(&self, pdf: &P) -> Vec<f64> {
        let d_theta = PI / self.theta_bins as f64;
        let d_phi = 2.0 * PI / self.phi_bins as f64;
        (0..self.theta_bins)
            .into_par_iter()
            .flat_map_iter(|i| {
                (0..self.phi_bins).map(move |j| {
                    // Shrink the ring by a hair so that the equator is evaluated on the correct
                    // side (cos(π/2) is not exactly 0 in floating point); the pdf may jump there.
                    let t0 = i as f64 * d_theta + 1e-9;
                    let t1 = (i + 1) as f64 * d_theta - 1e-9;
                    cell_integral(pdf, (t0, t1), (j as f64 * d_phi, (j + 1) as f64 * d_phi))
                })
            })
            .collect()
    }
}

/// ∫∫ f(θ, φ) sin θ dθ dφ over one cell.
fn cell_integral<P: Fn(Vec3) -> f32>(pdf: &P, (t0, t1): (f64, f64), (p0, p1): (f64, f64)) -> f64 {
    // Absolute tolerance of the cell's mass; ~1e-5 over all cells, far below the statistical
    // resolution of 10⁶ samples.
    const EPS: f64 = 1e-8;
    let inner_eps = EPS / (t1 - t0);
    let ring = |theta: f64| {
        let (sin_t, cos_t) = theta.sin_cos();
        let along_phi = |phi: f64| {
            let (sin_p, cos_p) = phi.sin_cos();
            pdf(Vec3::new((sin_t * cos_p) as f32, (sin_t * sin_p) as f32, cos_t as f32)) as f64
        };
        sin_t * adaptive_simpson(&along_phi, p0, p1, inner_eps)
    };
    adaptive_simpson(&ring, t0, t1, EPS)
}

/// ∫ pdf dω over the whole sphere, with the same cells and quadrature as the chi-square test.
pub(crate) fn integrate_sphere<P: Fn(Vec3) -> f32 + Sync>(pdf: P) -> f64 {
    ChiSquare::default().cell_masses(&pdf).iter().sum()
}

/// Adaptive Simpson quadrature of `f` on [a, b] to absolute tolerance `eps` (two starting panels,
/// Richardson-corrected, depth-limited).
fn adaptive_simpson(f: &dyn Fn(f64) -> f64, a: f64, b: f64, eps: f64) -> f64 {
    const MAX_DEPTH: u32 = 12;
    fn refine(
        f: &dyn Fn(f64) -> f64,
        a: f64,
        b: f64,
        fab: [f64; 3],
        whole: f64,
        eps: f64,
        depth: u32,
    ) -> f64 {
        let [fa, fm, fb] = fab;
        let m = 0.5 * (a + b);
        let (flm, frm) = (f(0.5 * (a + m)), f(0.5 * (m + b)));
        let left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
        let right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
        let delta = left + right - whole;
        if depth == 0 || delta.abs() <= 15.0 * eps {
            left + right + delta / 15.0
        } else {
            refine(f, a, m, [fa, flm, fm], left, 0.5 * eps, depth - 1)
                + refine(f, m, b, [fm, frm, fb], right, 0.5 * eps, depth - 1)
        }
    }
    let m = 0.5 * (a + b);
    let (fa, fm, fb) = (f(a), f(m), f(b));
    let panel = |lo: f64, hi: f64, flo: f64, fhi: f64| {
        let mid = 0.5 * (lo + hi);
        let fmid = f(mid);
        let whole = (hi - lo) / 6.0 * (flo + 4.0 * fmid + fhi);
        refine(f, lo, hi, [flo, fmid, fhi], whole, 0.5 * eps, MAX_DEPTH)
    };
    panel(a, m, fa, fm) + panel(m, b, fm, fb)
}

/// The outcome of a sampler that always returns a sample, from its `observed` counts in cells
/// whose `expected` counts (summing to the sample count) are known exactly.
pub(crate) fn outcome_of_counts(expected: &[f64], observed: &[u64]) -> Outcome {
    let (chi2, dof) = pooled_chi2(expected, observed);
    let p_value = if chi2.is_finite() { gamma_q(0.5 * dof as f64, 0.5 * chi2) } else { 0.0 };
    let samples = observed.iter().sum::<u64>() as usize;
    Outcome { chi2, dof, p_value, pdf_mass: 1.0, sampled_fraction: 1.0, samples, invalid: 0 }
}

/// χ² and degrees of freedom after pooling the cells that expect fewer than [`MIN_EXPECTED`].
fn pooled_chi2(expected: &[f64], observed: &[u64]) -> (f64, usize) {
    let mut cells: Vec<(f64, u64)> = expected.iter().copied().zip(observed.iter().copied()).collect();
    cells.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (mut pool_e, mut pool_o) = (0.0, 0u64);
    let mut bins = Vec::with_capacity(cells.len());
    for (e, o) in cells {
        if e < MIN_EXPECTED {
            pool_e += e;
            pool_o += o;
        } else {
            bins.push((e, o));
        }
    }
    if pool_e > 0.0 || pool_o > 0 {
        if pool_e >= MIN_EXPECTED || bins.is_empty() {
            bins.push((pool_e, pool_o));
        } else {
            // Too small on its own: merge it into the smallest regular cell.
            bins[0].0 += pool_e;
            bins[0].1 += pool_o;
        }
    }
    let mut chi2 = 0.0;
    for &(e, o) in &bins {
        let diff = o as f64 - e;
        chi2 += if e > 0.0 {
            diff * diff / e
        } else if o > 0 {
            f64::INFINITY
        } else {
            0.0
        };
    }
    (chi2, bins.len().saturating_sub(1))
}

/// ln Γ(x) for x > 0: Stirling's series after shifting the argument above 10 (error < 1e-12).
pub(crate) fn ln_gamma(x: f64) -> f64 {
    let (mut x, mut shift) = (x, 0.0);
    while x < 10.0 {
        // Γ(x) = Γ(x + 1) / x
        shift -= x.ln();
        x += 1.0;
    }
    let inv = 1.0 / x;
    let inv2 = inv * inv;
    let series = inv * (1.0 / 12.0 - inv2 * (1.0 / 360.0 - inv2 * (1.0 / 1260.0 - inv2 / 1680.0)));
    shift + (x - 0.5) * x.ln() - x + 0.5 * (2.0 * PI).ln() + series
}

/// The regularised upper incomplete gamma function Q(a, x) = Γ(a, x) / Γ(a); the p-value of a χ²
/// statistic c with k degrees of freedom is Q(k/2, c/2).
pub(crate) fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let prefactor = (a * x.ln() - x - ln_gamma(a)).exp();
    if x < a + 1.0 {
        // P(a, x) = x^a e^−x / Γ(a) · Σ_n x^n / (a (a+1) … (a+n)), which converges fast here.
        let (mut term, mut sum) = (1.0 / a, 1.0 / a);
        for n in 1..100_000 {
            term *= x / (a + n as f64);
            sum += term;
            if term < sum * 1e-16 {
                break;
            }
        }
        (1.0 - prefactor * sum).max(0.0)
    } else {
        // Q(a, x) = x^a e^−x / Γ(a) · 1/(x+1−a− 1·(1−a)/(x+3−a− 2·(2−a)/(x+5−a− …))), evaluated by
        // the modified Lentz method.
        const TINY: f64 = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / TINY;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..100_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < TINY {
                d = TINY;
            }
            c = b + an / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            let step = d * c;
            h *= step;
            if (step - 1.0).abs() < 1e-15 {
                break;
            }
        }
        prefactor * h
    }
}

/// Prints every case and asserts that each passes the Šidák-corrected level and that the share
/// of successful samples matches the pdf's mass.
pub(crate) fn assert_all_pass(results: &[(String, Outcome)]) {
    let level = sidak_level();
    let mut failures = Vec::new();
    for (name, o) in results {
        let n = o.samples as f64;
        let m = o.pdf_mass.min(1.0);
        // Binomial spread of the success count, plus the quadrature tolerance.
        let mass_tolerance = 4.0 * (m * (1.0 - m) / n).sqrt() + 1e-4;
        let mass_ok = (o.sampled_fraction - o.pdf_mass).abs() <= mass_tolerance && o.pdf_mass <= 1.0 + 1e-4;
        let line = format!(
            "{name}: χ² = {:.1}, dof = {}, p = {:.4}, ∫pdf = {:.5}, sampled = {:.5}, invalid = {}",
            o.chi2, o.dof, o.p_value, o.pdf_mass, o.sampled_fraction, o.invalid
        );
        println!("{line}");
        if o.p_value <= level || !mass_ok || o.invalid > 0 {
            failures.push(line);
        }
    }
    let p_min = results.iter().map(|(_, o)| o.p_value).fold(1.0, f64::min);
    println!("{} cases, smallest p = {p_min:.4}, Šidák level = {level:.2e}", results.len());
    assert!(failures.is_empty(), "chi-square failures (level {level:.2e}):\n{}", failures.join("\n"));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ln_gamma_matches_known_values() {
        assert!(ln_gamma(1.0).abs() < 1e-12);
        assert!(ln_gamma(2.0).abs() < 1e-12);
        assert!((ln_gamma(0.5) - 0.5 * PI.ln()).abs() < 1e-12);
        assert!((ln_gamma(10.0) - 362_880f64.ln()).abs() < 1e-11);
        assert!((ln_gamma(3.5) - (3.323_350_970_447_842_6f64).ln()).abs() < 1e-12);
    }

    #[test]
    fn gamma_q_matches_closed_forms_and_chi2_tables() {
        for x in [0.01, 0.5, 1.0, 2.0, 7.5, 30.0] {
            // Q(1, x) = e^−x; Q(2, x) = (1 + x) e^−x.
            assert!((gamma_q(1.0, x) - (-x).exp()).abs() < 1e-12, "{x}");
            assert!((gamma_q(2.0, x) - (1.0 + x) * (-x).exp()).abs() < 1e-12, "{x}");
        }
        // Q(1/2, 1) = erfc(1).
        assert!((gamma_q(0.5, 1.0) - 0.157_299_207_050_285_1).abs() < 1e-12);
        // Upper 5% points of the χ² distribution with 10 and 100 degrees of freedom, and the 1%
        // point with 1000.
        assert!((gamma_q(5.0, 0.5 * 18.307_038) - 0.05).abs() < 1e-7);
        assert!((gamma_q(50.0, 0.5 * 124.342_113) - 0.05).abs() < 1e-7);
        assert!((gamma_q(500.0, 0.5 * 1106.969) - 0.01).abs() < 1e-5);
        assert_eq!(gamma_q(3.0, 0.0), 1.0);
    }

    #[test]
    fn pooling_merges_small_cells_and_flags_impossible_samples() {
        let (chi2, dof) = pooled_chi2(&[100.0, 100.0, 1.0, 2.0, 3.0], &[100, 100, 1, 2, 3]);
        assert_eq!((chi2, dof), (0.0, 2));
        // 3 expected in the pool: merged into a regular cell.
        let (_, dof) = pooled_chi2(&[100.0, 100.0, 1.0, 2.0], &[100, 100, 1, 2]);
        assert_eq!(dof, 1);
        // A stray sample in an impossible cell is pooled with the smallest regular cell...
        let (chi2, dof) = pooled_chi2(&[100.0, 0.0], &[99, 1]);
        assert_eq!((chi2, dof), (0.0, 0));
        // ...but with a pool of its own (the usual case: ≥ 5 expected there), they are noticed.
        let (chi2, dof) = pooled_chi2(&[100.0, 100.0, 3.0, 3.0, 0.0], &[100, 100, 3, 3, 20]);
        assert!(dof == 2 && (chi2 - 400.0 / 6.0).abs() < 1e-9, "{chi2}");
        let (chi2, _) = pooled_chi2(&[0.0], &[1]);
        assert!(chi2.is_infinite());
    }

    #[test]
    fn a_correct_sampler_passes_and_a_wrong_one_fails() {
        // Cosine-weighted hemisphere sampling against its pdf, and against the uniform pdf.
        let cosine = |_: f32, u: Vec2| {
            let r = u.x.sqrt();
            let phi = 2.0 * std::f32::consts::PI * u.y;
            Some(Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x).max(0.0).sqrt()))
        };
        let test = ChiSquare { samples: 1 << 18, ..ChiSquare::default() };
        let good = test.run(cosine, |w| w.z.max(0.0) / std::f32::consts::PI);
        assert!(good.p_value > 0.01, "{good:?}");
        assert!((good.pdf_mass - 1.0).abs() < 1e-5);
        let bad = test.run(cosine, |w| if w.z > 0.0 { 0.5 / std::f32::consts::PI } else { 0.0 });
        assert!(bad.p_value < 1e-12, "{bad:?}");
        // A sampler that loses a tenth of its samples against a pdf that knows it.
        let lossy = |uc: f32, u: Vec2| if uc < 0.1 { None } else { cosine(uc, u) };
        let o = test.run(lossy, |w| 0.9 * w.z.max(0.0) / std::f32::consts::PI);
        assert!(o.p_value > 0.01 && (o.sampled_fraction - 0.9).abs() < 3e-3, "{o:?}");
    }
}
