//! The split of a render's error into the part its noise explains and the rest, its bias, with
//! standard errors from the replicas and a verdict a thesis can cite.
//!
//! With x̄ the render's mean and v_x the variance of that mean, r̄ and v_r the reference's, for
//! independent renders E[(x̄ − r̄)²] = bias² + v_x + v_r, so over the compared pixels and channels
//!
//! - the error E = mean(w·(x̄ − r̄)²), the variance part V = mean(w·v_x), the reference part
//!   V_r = mean(w·v_r) and the bias part B = E − V − V_r, an unbiased estimate of the mean
//!   weighted squared bias. v_x and v_r come from the replicas
//!   ([`crate::render::ReplicaMeans`]): unbiased for the estimator actually used, so B is
//!   neither pushed negative by an over-estimated variance (as the spread of Sobol' samples
//!   was) nor positive by an under-estimated one.
//! - **The weights** w = 1/(r̃² + 0.01) make the parts relative, as the relMSE is, so that a
//!   bias in the dark (a missing caustic on a dim floor) weighs as much as one in the light. r̃
//!   is the mean of the reference over the pixel's 3×3 neighbourhood *without the pixel
//!   itself*: weights from the pixel's own reference value would correlate with its error
//!   (where the noisy reference happens to be low the weight is high and the error large),
//!   which biases E upwards by a term of order (σ_r/r)²·E. On `glass-of-water` against a
//!   512-spp `path` reference that term made an unbiased `vcm` render "biased" at 4.9 standard
//!   errors; with neighbour weights the pixel's own noise is independent of its weight. (The
//!   relMSE with the pixel's own weights, the figure the tables show, gets its own standard
//!   error for the efficiency's interval.)
//! - **Standard errors** by the delete-one jackknife over the replicas: B and the relMSE are
//!   recomputed without each of the render's replicas in turn (the reference fixed), and
//!   without each of the reference's (the render fixed); the two variances add. The replicas
//!   are independent whatever the method shares between pixels (light paths, photons), so the
//!   errors hold for the bidirectional methods too. Where a noisy side has fewer than three
//!   replicas (a render of 2 samples, a file with only a variance), the standard error of B
//!   falls back to the spread of its per-pixel terms over the pixels (right only for pixels
//!   estimated independently).
//! - **Verdict** ([`Verdict`]), in this order:
//!   - `biased`: B > [`BIAS_SIGNIFICANCE`] standard errors, and B > V_r (a bias larger than
//!     the reference's whole variance, which an under-estimate of that variance, as fireflies
//!     make it, cannot explain). With the jackknife's R − 1 = 7 degrees of freedom (R = 8) a
//!     render with no bias crosses 3 standard errors with a probability of about 1% (Student's
//!     t), fewer in practice (the jackknife errs large); the false-alarm and miss rates
//!     measured on renders of known bias are in docs/accuracy.md ("Verdicts: false alarms and misses").
//!   - `reference too noisy`: the reference's variance V_r is more than
//!     [`REFERENCE_SHARE_LIMIT`] (a tenth) of the render's error E: the reference's own noise is
//!     too large a part of what is measured to judge a bias; render a longer reference.
//!   - `inconclusive`: a bias of [`INCONCLUSIVE_FRACTION`] (half) of the error would still hide
//!     within 3 standard errors: the budget is too small to tell.
//!   - `no bias detected`: otherwise. Never "unbiased": a bias below the detection limit
//!     (3·SE, reported) may remain.
//!
//! A deterministic render (no variance: `ssaa`'s fixed pattern) has V = 0; its standard error is
//! then the reference's alone.

use super::{check_sizes, resolve_region, Crop, MetricsError, Region, REL_EPSILON};
use crate::image::Image;
use crate::render::{t95, RenderOutput, ReplicaMeans};
use glam::DVec3;
use rayon::prelude::*;

/// A render as the split judges it: its mean and what says how noisy it is.
#[derive(Clone, Copy, Debug)]
pub struct Estimate<'a> {
    /// The mean per pixel.
    pub image: &'a Image,
    /// Its replicas' means, when it has them: the variance and the standard errors come from
    /// them.
    pub replicas: Option<&'a ReplicaMeans>,
    /// The variance of each pixel's mean, used only without replicas (a file of another tool);
    /// neither: the image is taken as exact.
    pub variance: Option<&'a Image>,
}

impl<'a> Estimate<'a> {
    /// An image taken as exact (no variance).
    pub fn exact(image: &'a Image) -> Estimate<'a> {
        Estimate { image, replicas: None, variance: None }
    }

    /// A render with its replicas (or, without them, its variance).
    pub fn of(out: &'a RenderOutput) -> Estimate<'a> {
        Estimate { image: &out.image, replicas: out.replicas.as_ref(), variance: out.variance.as_ref() }
    }

    /// Whether the estimate says anything about its noise.
    pub fn has_noise(&self) -> bool {
        self.replicas.is_some() || self.variance.is_some()
    }

    /// The variance of pixel `i`'s mean (zero when taken as exact).
    fn variance_at(&self, i: usize) -> DVec3 {
        match (self.replicas, self.variance) {
            (Some(r), _) => r.variance_at(i),
            (None, Some(v)) => v.pixels[i].as_dvec3(),
            (None, None) => DVec3::ZERO,
        }
    }

    /// The replicas, when there are enough (three) for a jackknife that also re-estimates the
    /// variance.
    fn jackknife(&self) -> Option<&'a ReplicaMeans> {
        self.replicas.filter(|r| r.count() >= 3)
    }

    /// An error unless every image of the estimate has the size of `reference`.
    fn check(&self, which: &'static str, reference: &Image) -> Result<(), MetricsError> {
        let sizes = self.variance.into_iter().chain(self.replicas.into_iter().flat_map(|r| r.means.iter()));
        for v in sizes {
            if check_sizes(v, reference).is_err() {
                return Err(MetricsError::VarianceSize { which, width: v.width, height: v.height });
            }
        }
        Ok(())
    }
}

/// Where the standard errors of a split come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorSource {
    /// The jackknife over the replicas of the render (`test`) and of the reference
    /// (`reference`; 0 where a side has fewer than three).
    Replicas {
        /// The render's replicas used.
        test: usize,
        /// The reference's replicas used.
        reference: usize,
    },
    /// The spread of the per-pixel terms over the pixels (no replicas).
    Pixels,
}

/// The bias and variance parts of a render's relMSE (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Split {
    /// E, the weighted mean squared error the split divides, over the pixels of the split (those
    /// finite in both images and variances).
    pub error: f64,
    /// The relMSE over the same pixels.
    pub rel_mse: f64,
    /// Standard error of the relMSE (NaN without replicas).
    pub rel_mse_se: f64,
    /// V = mean of the render's weighted per-pixel variance (0 for a deterministic render).
    pub variance: f64,
    /// V_r = mean of the reference's weighted per-pixel variance (0 when taken as exact).
    pub reference_variance: f64,
    /// B = E − V − V_r, the estimate of the mean weighted squared bias; can be negative by
    /// noise.
    pub bias: f64,
    /// Standard error of B.
    pub bias_se: f64,
    /// The degrees of freedom of the standard errors.
    pub dof: usize,
    /// Where the standard errors come from.
    pub errors: ErrorSource,
    /// Pixels in the split.
    pub pixels: usize,
    /// Pixels left out because a variance (of the render or of the reference) is not finite.
    pub non_finite_variance: usize,
}

/// B must exceed this many standard errors to call a render biased.
pub const BIAS_SIGNIFICANCE: f64 = 3.0;

/// A reference whose variance part exceeds this fraction of a render's error E is too noisy to
/// judge it.
pub const REFERENCE_SHARE_LIMIT: f64 = 0.1;

/// A verdict is inconclusive when a bias of this fraction of the error E could hide within
/// [`BIAS_SIGNIFICANCE`] standard errors.
pub const INCONCLUSIVE_FRACTION: f64 = 0.5;

/// What the split says of a render's bias.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// B is significant.
    Biased,
    /// The reference's own variance is too large a part of the error to judge it.
    ReferenceTooNoisy,
    /// The noise would hide a bias of half the error: the budget is too small to tell.
    Inconclusive,
    /// No bias above the detection limit.
    NoBiasDetected,
}

impl Verdict {
    /// The verdict's name in tables, CSV and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Verdict::Biased => "biased",
            Verdict::ReferenceTooNoisy => "reference too noisy",
            Verdict::Inconclusive => "inconclusive",
            Verdict::NoBiasDetected => "no bias detected",
        }
    }
}

impl Split {
    /// The verdict (module documentation).
    pub fn verdict(&self) -> Verdict {
        if self.biased() {
            Verdict::Biased
        } else if self.reference_too_noisy() {
            Verdict::ReferenceTooNoisy
        } else if !self.bias_se.is_finite() || self.detection_limit() > INCONCLUSIVE_FRACTION * self.error {
            Verdict::Inconclusive
        } else {
            Verdict::NoBiasDetected
        }
    }

    /// Whether B is significant: more than [`BIAS_SIGNIFICANCE`] standard errors above 0, and
    /// larger than the reference's whole variance V_r (which an under-estimated V_r could not
    /// explain).
    pub fn biased(&self) -> bool {
        self.bias > BIAS_SIGNIFICANCE * self.bias_se && self.bias > self.reference_variance && self.bias > 0.0
    }

    /// The smallest bias part the split would call significant: [`BIAS_SIGNIFICANCE`] standard
    /// errors.
    pub fn detection_limit(&self) -> f64 {
        BIAS_SIGNIFICANCE * self.bias_se
    }

    /// The reference's variance part as a fraction of the error E.
    pub fn reference_share(&self) -> f64 {
        self.reference_variance / self.error
    }

    /// Whether the reference's variance is more than [`REFERENCE_SHARE_LIMIT`] of the error E.
    pub fn reference_too_noisy(&self) -> bool {
        self.reference_share() > REFERENCE_SHARE_LIMIT
    }

    /// The 95% confidence interval of the relMSE (Student's t with [`Split::dof`] degrees of
    /// freedom); NaN bounds without a standard error.
    pub fn rel_mse_interval(&self) -> (f64, f64) {
        let half = t95(self.dof) * self.rel_mse_se;
        if half.is_nan() {
            return (f64::NAN, f64::NAN);
        }
        ((self.rel_mse - half).max(0.0), self.rel_mse + half)
    }

    /// √max(B, 0), the root-mean-square bias.
    pub fn rms_bias(&self) -> f64 {
        self.bias.max(0.0).sqrt()
    }
}

/// An efficiency with its 95% confidence interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Efficiency {
    /// 1 / (relMSE · seconds).
    pub value: f64,
    /// The interval's lower bound.
    pub low: f64,
    /// The interval's upper bound (infinite when the relMSE's interval reaches 0).
    pub high: f64,
}

impl Efficiency {
    /// The efficiency of a render of relMSE `rel_mse` (interval `interval`) in `seconds`.
    pub fn of(rel_mse: f64, (low, high): (f64, f64), seconds: f64) -> Efficiency {
        let s = seconds.max(1e-9);
        let inverse = |e: f64| if e > 0.0 { 1.0 / (e * s) } else { f64::INFINITY };
        Efficiency { value: inverse(rel_mse), low: inverse(high), high: inverse(low) }
    }
}

/// The one efficiency (tables, HTML, CSV, plots): 1 / (relMSE · seconds), for a render whose
/// verdict is `no bias detected` only; `Err` with the reason otherwise (the efficiency of a
/// biased render would reward its bias, an inconclusive one could be).
pub fn efficiency(split: Option<&Split>, seconds: f64) -> Result<Efficiency, &'static str> {
    let Some(s) = split else {
        return Err("no replicas to judge its bias");
    };
    match s.verdict() {
        Verdict::NoBiasDetected => Ok(Efficiency::of(s.rel_mse, s.rel_mse_interval(), seconds)),
        Verdict::Biased => Err("biased: its error does not fall with time alone"),
        Verdict::ReferenceTooNoisy => Err("the reference is too noisy to judge its bias"),
        Verdict::Inconclusive => Err("too noisy to tell whether it is biased"),
    }
}

/// A pixel of the split: its index, its weights (the relMSE's from its own reference value, the
/// split's from its neighbours'), the render's and the reference's values and the variances of
/// both.
type Used = (usize, (DVec3, DVec3), DVec3, DVec3, DVec3, DVec3);

/// The split's weights 1/(r̃² + 0.01) at pixel `i` of `reference`, r̃ the mean of the finite
/// values of its 3×3 neighbourhood without the pixel itself (the pixel's own value when it has
/// no finite neighbour).
fn neighbour_weight(reference: &Image, i: usize) -> DVec3 {
    let (w, h) = (reference.width, reference.height);
    let (x, y) = (i % w, i / w);
    let (mut sum, mut n) = (DVec3::ZERO, 0.0);
    for ny in y.saturating_sub(1)..(y + 2).min(h) {
        for nx in x.saturating_sub(1)..(x + 2).min(w) {
            let v = reference.pixels[ny * w + nx].as_dvec3();
            if (nx, ny) != (x, y) && v.is_finite() {
                (sum, n) = (sum + v, n + 1.0);
            }
        }
    }
    weight(if n > 0.0 { sum / n } else { reference.pixels[i].as_dvec3() })
}

/// The per-pixel-channel weights 1/(r² + 0.01) of the relMSE (for its standard error only).
#[inline]
fn weight(r: DVec3) -> DVec3 {
    DVec3::ONE / (r * r + REL_EPSILON)
}

/// The mean over a pixel's channels of `v` weighted by `w`.
#[inline]
fn weighted(w: DVec3, v: DVec3) -> f64 {
    (w * v).element_sum() / 3.0
}

/// The bias and variance parts of the relMSE of `test` against `reference` over `crop` (or the
/// whole image), with their standard errors (module documentation).
pub fn split(test: Estimate, reference: Estimate, crop: Option<Crop>) -> Result<Split, MetricsError> {
    split_over(test, reference, crop.map(Region::rect).as_ref())
}

/// The split of [`split`] over `region` (or the whole image).
pub fn split_over(
    test: Estimate,
    reference: Estimate,
    region: Option<&Region>,
) -> Result<Split, MetricsError> {
    check_sizes(test.image, reference.image)?;
    test.check("test", reference.image)?;
    reference.check("reference", reference.image)?;
    let region = resolve_region(test.image, region)?;
    // The pixels of the split, with their weights, errors and variances.
    let mut used: Vec<Used> = Vec::new();
    let mut non_finite_variance = 0;
    for i in region.indices(test.image.width) {
        let (x, r) = (test.image.pixels[i].as_dvec3(), reference.image.pixels[i].as_dvec3());
        if !(x.is_finite() && r.is_finite()) {
            continue;
        }
        let (vx, vr) = (test.variance_at(i), reference.variance_at(i));
        if !(vx.is_finite() && vr.is_finite()) {
            non_finite_variance += 1;
            continue;
        }
        used.push((i, (weight(r), neighbour_weight(reference.image, i)), x, r, vx, vr));
    }
    let n = used.len() as f64;
    let mean = |f: &dyn Fn(&Used) -> f64| used.iter().map(f).sum::<f64>() / n;
    let error = mean(&|&(_, (_, w), x, r, _, _)| weighted(w, (x - r) * (x - r)));
    let rel_mse = mean(&|&(_, (w, _), x, r, _, _)| weighted(w, (x - r) * (x - r)));
    let variance = mean(&|&(_, (_, w), _, _, vx, _)| weighted(w, vx));
    let reference_variance = mean(&|&(_, (_, w), _, _, _, vr)| weighted(w, vr));
    let bias = error - variance - reference_variance;

    // The jackknife: (relMSE, B) without replica j of one side (`test_side`: the render's, else
    // the reference's), the other side fixed.
    let leave_out = |j: usize, reps: &ReplicaMeans, test_side: bool| {
        let (mut e, mut b) = (0.0, 0.0);
        for &(i, (w, wn), x, r, vx, vr) in &used {
            let (m, v) = reps.leave_one_out_at(i, j);
            let (x, r, vx, vr) = if test_side { (m, r, v, vr) } else { (x, m, vx, v) };
            let d2 = (x - r) * (x - r);
            e += weighted(w, d2);
            b += weighted(wn, d2 - vx - vr);
        }
        (e / n, b / n)
    };
    let test_loo = |j: usize, reps: &ReplicaMeans| leave_out(j, reps, true);
    let reference_loo = |j: usize, reps: &ReplicaMeans| leave_out(j, reps, false);
    let jackknife = |reps: &ReplicaMeans, loo: &(dyn Fn(usize, &ReplicaMeans) -> (f64, f64) + Sync)| {
        let values: Vec<(f64, f64)> = (0..reps.count()).into_par_iter().map(|j| loo(j, reps)).collect();
        let se = |pick: fn(&(f64, f64)) -> f64| {
            crate::render::jackknife_se(&values.iter().map(pick).collect::<Vec<_>>())
        };
        (se(|v| v.0), se(|v| v.1))
    };
    let (mut e_var, mut b_var, mut dof) = (0.0, 0.0, usize::MAX);
    let (mut test_replicas, mut reference_replicas) = (0, 0);
    // The jackknife needs every noisy side's replicas (three or more each): a side whose noise
    // it could not see would be taken as exact.
    let jackknifed = |e: &Estimate| !e.has_noise() || e.jackknife().is_some();
    let replicas_suffice = jackknifed(&test) && jackknifed(&reference);
    if let (true, Some(reps)) = (replicas_suffice, test.jackknife()) {
        let (e, b) = jackknife(reps, &test_loo);
        (e_var, b_var, dof, test_replicas) = (e * e, b * b, reps.count() - 1, reps.count());
    }
    if let (true, Some(reps)) = (replicas_suffice, reference.jackknife()) {
        let (e, b) = jackknife(reps, &reference_loo);
        (e_var, b_var) = (e_var + e * e, b_var + b * b);
        (dof, reference_replicas) = (dof.min(reps.count() - 1), reps.count());
    }
    let (rel_mse_se, bias_se, errors) = if test_replicas + reference_replicas > 0 {
        let errors = ErrorSource::Replicas { test: test_replicas, reference: reference_replicas };
        (e_var.sqrt(), b_var.sqrt(), errors)
    } else {
        // No replicas: the spread of the per-pixel terms over the pixels.
        let terms: Vec<f64> =
            used.iter().map(|&(_, (_, w), x, r, vx, vr)| weighted(w, (x - r) * (x - r) - vx - vr)).collect();
        dof = used.len().saturating_sub(1);
        (f64::NAN, super::mean_and_se(&terms).1, ErrorSource::Pixels)
    };
    Ok(Split {
        error,
        rel_mse,
        rel_mse_se,
        variance,
        reference_variance,
        bias,
        bias_se,
        dof,
        errors,
        pixels: used.len(),
        non_finite_variance,
    })
}

/// The CSV columns of a split, as [`split_csv`] fills them.
pub const SPLIT_CSV_COLUMNS: &str =
    "rel_mse_se,variance,reference_variance,reference_share,bias,bias_se,detection_limit,verdict";

/// The CSV fields of `split` under [`SPLIT_CSV_COLUMNS`] (full precision); empty fields and
/// "unknown" without a split.
pub fn split_csv(split: Option<&Split>) -> String {
    match split {
        Some(s) => format!(
            "{},{},{},{},{},{},{},{}",
            s.rel_mse_se,
            s.variance,
            s.reference_variance,
            s.reference_share(),
            s.bias,
            s.bias_se,
            s.detection_limit(),
            s.verdict().name()
        ),
        None => ",,,,,,,unknown".to_string(),
    }
}

/// The split of a render `out` by a method against `reference` (see [`split`]). A render of one
/// fixed, deterministic pattern (`deterministic`: `ssaa`) is exact, its error all bias; `None`
/// (unknown) for any other render without replicas or variance (a single sample, a file that
/// kept none).
pub fn render_split(
    deterministic: bool,
    out: &RenderOutput,
    reference: Estimate,
    region: Option<&Region>,
) -> Result<Option<Split>, MetricsError> {
    let test = Estimate::of(out);
    if !test.has_noise() && !deterministic {
        return Ok(None);
    }
    split_over(test, reference, region).map(Some)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use rand::{RngExt, SeedableRng};

    /// `replicas` replica means of a `width`×`height` image whose pixel `i` has the true value
    /// `truth(i)` plus `bias`, each replica adding noise of standard deviation `sigma` (uniform,
    /// scaled), from `seed`; with the full mean (equal counts).
    fn synthetic(truth: &[f32], bias: f32, sigma: f32, replicas: usize, seed: u64) -> (Image, ReplicaMeans) {
        let mut rng = rand_pcg::Pcg32::seed_from_u64(seed);
        // A uniform variable on [−√3, √3] has unit variance.
        let mut noise = || (rng.random::<f32>() * 2.0 - 1.0) * 3f32.sqrt() * sigma;
        let (w, h) = (truth.len(), 1);
        let means: Vec<Image> = (0..replicas)
            .map(|_| {
                let pixels =
                    truth.iter().map(|&t| Vec3::splat(t + bias) + Vec3::new(noise(), noise(), noise()));
                Image { width: w, height: h, pixels: pixels.collect() }
            })
            .collect();
        let mean = Image {
            width: w,
            height: h,
            pixels: (0..w)
                .map(|p| means.iter().map(|m| m.pixels[p]).sum::<Vec3>() / replicas as f32)
                .collect(),
        };
        (mean, ReplicaMeans { means, samples: vec![4; replicas] })
    }

    /// The verdicts of `trials` independent renders with a planted `bias` against a reference
    /// of noise `sigma_r` (each trial its own reference too).
    fn verdicts(bias: f32, sigma: f32, sigma_r: f32, trials: u64) -> Vec<Verdict> {
        let truth: Vec<f32> = (0..1024).map(|i| 0.2 + (i % 37) as f32 / 37.0).collect();
        (0..trials)
            .map(|t| {
                let (x, xr) = synthetic(&truth, bias, sigma, 8, 2 * t + 1);
                let (r, rr) = synthetic(&truth, 0.0, sigma_r, 8, 2 * t + 2);
                let test = Estimate { image: &x, replicas: Some(&xr), variance: None };
                let reference = Estimate { image: &r, replicas: Some(&rr), variance: None };
                split(test, reference, None).unwrap().verdict()
            })
            .collect()
    }

    #[test]
    fn planted_biases_are_found_and_none_is_invented() {
        // No bias, a reference 4 times less noisy (variance 1/16): 200 trials. The test at 3
        // jackknife standard errors with 7 degrees of freedom should cross by chance in about 1%;
        // the documented bound (docs/workflow.md, "Verdicts") is 5%.
        let none = verdicts(0.0, 0.1, 0.025, 200);
        let false_alarms = none.iter().filter(|v| **v == Verdict::Biased).count();
        assert!(false_alarms <= 10, "{false_alarms} of 200 renders without bias called biased");
        assert!(none.iter().filter(|v| **v == Verdict::NoBiasDetected).count() >= 180, "{none:?}");
        // A bias as large as the noise of the mean (σ/√8 ≈ 0.035): found every time.
        let planted = verdicts(0.035, 0.1, 0.025, 100);
        assert!(planted.iter().all(|v| *v == Verdict::Biased), "{planted:?}");
        // A reference as noisy as the render: its variance is half the MSE, "reference too noisy".
        let noisy = verdicts(0.0, 0.1, 0.1, 20);
        assert!(noisy.iter().all(|v| *v == Verdict::ReferenceTooNoisy), "{noisy:?}");
    }

    #[test]
    fn a_small_budget_is_inconclusive() {
        // 16 pixels: the detection limit exceeds half the MSE.
        let truth = [0.5f32; 16];
        let (x, xr) = synthetic(&truth, 0.0, 0.1, 8, 1);
        let exact = Image { width: 16, height: 1, pixels: vec![Vec3::splat(0.5); 16] };
        let s =
            split(Estimate { image: &x, replicas: Some(&xr), variance: None }, Estimate::exact(&exact), None)
                .unwrap();
        assert_eq!(s.verdict(), Verdict::Inconclusive, "{s:?}");
        assert_eq!(s.errors, ErrorSource::Replicas { test: 8, reference: 0 });
        assert!(efficiency(Some(&s), 1.0).is_err());
    }

    #[test]
    fn the_split_adds_up_and_the_efficiency_interval_holds_the_value() {
        let truth: Vec<f32> = (0..4096).map(|i| 0.1 + (i % 61) as f32 / 30.0).collect();
        let (x, xr) = synthetic(&truth, 0.0, 0.05, 8, 9);
        let (r, rr) = synthetic(&truth, 0.0, 0.005, 8, 10);
        let s = split(
            Estimate { image: &x, replicas: Some(&xr), variance: None },
            Estimate { image: &r, replicas: Some(&rr), variance: None },
            None,
        )
        .unwrap();
        assert!(
            (s.error - (s.bias + s.variance + s.reference_variance)).abs() < 1e-12 * s.error.max(1.0),
            "{s:?}"
        );
        assert_eq!(s.verdict(), Verdict::NoBiasDetected, "{s:?}");
        let e = efficiency(Some(&s), 2.0).unwrap();
        assert!(
            e.low < e.value && e.value < e.high && (e.value - 1.0 / (s.rel_mse * 2.0)).abs() < 1e-12,
            "{e:?}"
        );
    }
}
