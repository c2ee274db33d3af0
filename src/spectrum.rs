//! Spectral sampling for an RGB renderer: CIE 1931 colour matching, wavelength sampling, and the
//! RGB weight that turns a single-wavelength path back into an unbiased RGB estimate.
//!
//! The renderer stays RGB everywhere (albedos, emission, radiance). In spectral mode each camera
//! sample draws one wavelength λ with [`sample_wavelength`], traces its path with refractive
//! indices evaluated at λ (so refraction separates the colours), and multiplies the path's RGB
//! radiance `L` component-wise by [`WavelengthSample::weight`] = w(λ) / p(λ):
//!
//! - w(λ) ([`rgb_weight`]) is the linear-sRGB colour of monochromatic light of wavelength λ
//!   (CIE 1931 2° colour-matching functions → XYZ → linear sRGB with the D65 matrix), scaled per
//!   channel so that ∫ w(λ) dλ over [[`LAMBDA_MIN`], [`LAMBDA_MAX`]] = (1, 1, 1) exactly for the
//!   colour-matching approximation used here. Hence E_λ[w(λ)/p(λ)] = (1, 1, 1): a path whose
//!   radiance does not depend on λ has the same expected RGB as in RGB mode (non-dispersive scenes
//!   render the same image within noise; white stays white), and an equal-energy spectrum maps to
//!   RGB (1, 1, 1), the renderer's white. The per-channel scaling is a white balance on the
//!   equal-energy illuminant, not a colorimetric transform of the spectrum.
//! - w(λ) has **negative lobes**: monochromatic light lies outside the sRGB gamut, so every channel
//!   is negative somewhere (red between about 460 and 553 nm, green below 467 nm and between 608
//!   and 681 nm, blue above 515 nm; the values there are small). Individual samples can therefore
//!   carry negative channels; they average out in the pixel estimate. Film and any sample clamping
//!   must not clip per-sample values to zero, or spectral mode becomes biased.
//! - p(λ) ([`wavelength_pdf`]) is pbrt-v4's visible-wavelength density, ∝ 1 / cosh²(0.0072 (λ − 538)),
//!   renormalised to [[`LAMBDA_MIN`], [`LAMBDA_MAX`]] and sampled through its closed-form inverse
//!   CDF; it roughly follows the luminance curve ȳ, which keeps the weights' variance low.

use glam::{DMat3, DVec3, Vec3};
use std::sync::OnceLock;

/// Shortest sampled wavelength, in nanometres.
pub const LAMBDA_MIN: f32 = 380.0;
/// Longest sampled wavelength, in nanometres.
pub const LAMBDA_MAX: f32 = 780.0;

/// Rate of pbrt-v4's visible-wavelength density 1 / cosh²(K (λ − C)), per nanometre.
const PDF_K: f64 = 0.0072;
/// Centre of that density, in nanometres.
const PDF_C: f64 = 538.0;

/// One asymmetric ("piecewise") Gaussian lobe with reciprocal widths below and above its centre.
#[inline]
fn lobe(lambda: f64, mu: f64, inv_sigma_below: f64, inv_sigma_above: f64) -> f64 {
    let t = (lambda - mu) * if lambda < mu { inv_sigma_below } else { inv_sigma_above };
    (-0.5 * t * t).exp()
}

/// The Wyman–Sloan–Shirley (2013) multi-lobe fit of the CIE 1931 2° colour-matching functions,
/// in f64 (constants as in the paper's listing; the widths are reciprocals of its σ).
fn cie_xyz_f64(lambda: f64) -> DVec3 {
    let x = 1.056 * lobe(lambda, 599.8, 0.0264, 0.0323) + 0.362 * lobe(lambda, 442.0, 0.0624, 0.0374)
        - 0.065 * lobe(lambda, 501.1, 0.0490, 0.0382);
    let y = 0.821 * lobe(lambda, 568.8, 0.0213, 0.0247) + 0.286 * lobe(lambda, 530.9, 0.0613, 0.0322);
    let z = 1.217 * lobe(lambda, 437.0, 0.0845, 0.0278) + 0.681 * lobe(lambda, 459.0, 0.0385, 0.0725);
    DVec3::new(x, y, z)
}

/// The lobe centres: the fit is smooth between them, so quadrature splits its range there.
const LOBE_CENTRES: [f64; 7] = [437.0, 442.0, 459.0, 501.1, 530.9, 568.8, 599.8];

/// XYZ → linear sRGB (IEC 61966-2-1 primaries, D65 white), rows are R, G, B.
const XYZ_TO_SRGB: [[f64; 3]; 3] = [
    [3.240_454_2, -1.537_138_5, -0.498_531_4],
    [-0.969_266_0, 1.876_010_8, 0.041_556_0],
    [0.055_643_4, -0.204_025_9, 1.057_225_2],
];

/// [`XYZ_TO_SRGB`] as a glam matrix (glam is column-major, so the rows are transposed in).
fn xyz_to_srgb_matrix() -> DMat3 {
    DMat3::from_cols_array_2d(&XYZ_TO_SRGB).transpose()
}

/// Constants derived once from the colour-matching fit and the wavelength density.
struct Derived {
    /// Per-channel factors making ∫ w(λ) dλ = (1, 1, 1): 1 / ∫ srgb(xyz(λ)) dλ.
    rgb_scale: DVec3,
    /// tanh(K (LAMBDA_MIN − C)): the unnormalised CDF of the density at LAMBDA_MIN.
    tanh_min: f64,
    /// tanh(K (LAMBDA_MAX − C)) − tanh(K (LAMBDA_MIN − C)): the density's normaliser.
    tanh_range: f64,
}

/// Composite Simpson integration of `f` over [a, b], split at the lobe centres (where the fit's
/// second derivative jumps) so every piece is smooth; accurate to ~1e-12 relative.
fn integrate_piecewise(a: f64, b: f64, f: impl Fn(f64) -> DVec3) -> DVec3 {
    let mut knots = vec![a];
    knots.extend(LOBE_CENTRES.iter().copied().filter(|&c| c > a && c < b));
    knots.push(b);
    let mut total = DVec3::ZERO;
    for piece in knots.windows(2) {
        let (lo, hi) = (piece[0], piece[1]);
        let n = 2 * ((hi - lo).ceil() as usize * 50).max(1); // even; ≤ 0.01 nm steps
        let h = (hi - lo) / n as f64;
        let mut sum = f(lo) + f(hi);
        for i in 1..n {
            sum += f(lo + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        total += sum * (h / 3.0);
    }
    total
}

fn derived() -> &'static Derived {
    static DERIVED: OnceLock<Derived> = OnceLock::new();
    DERIVED.get_or_init(|| {
        let (a, b) = (LAMBDA_MIN as f64, LAMBDA_MAX as f64);
        let xyz_integral = integrate_piecewise(a, b, cie_xyz_f64);
        let rgb_integral = xyz_to_srgb_matrix() * xyz_integral;
        let tanh_min = (PDF_K * (a - PDF_C)).tanh();
        let tanh_max = (PDF_K * (b - PDF_C)).tanh();
        Derived { rgb_scale: DVec3::ONE / rgb_integral, tanh_min, tanh_range: tanh_max - tanh_min }
    })
}

/// CIE 1931 2° colour-matching functions (x̄, ȳ, z̄) at `lambda_nm`: Wyman–Sloan–Shirley multi-lobe fit.
pub fn cie_xyz(lambda_nm: f32) -> Vec3 {
    cie_xyz_f64(lambda_nm as f64).as_vec3()
}

/// CIE XYZ to linear sRGB (Rec. 709 primaries, D65 white); out-of-gamut colours get negative channels.
pub fn xyz_to_linear_srgb(xyz: Vec3) -> Vec3 {
    (xyz_to_srgb_matrix() * xyz.as_dvec3()).as_vec3()
}

/// A sampled wavelength and the RGB weight to multiply the path radiance by (w(λ)/p(λ)).
#[derive(Clone, Copy, Debug)]
pub struct WavelengthSample {
    /// The wavelength in nanometres, in [`LAMBDA_MIN`, `LAMBDA_MAX`].
    pub lambda: f32,
    /// w(λ)/p(λ): per-channel RGB factor for the path's radiance; may have negative channels.
    pub weight: Vec3,
}

/// Draws λ from [`wavelength_pdf`] by its inverse CDF at `u` ∈ [0, 1] (clamped; NaN counts as 0).
pub fn sample_wavelength(u: f32) -> WavelengthSample {
    let d = derived();
    // `u > 0.0` is false for NaN, so a NaN input maps to the first wavelength, never to NaN.
    let u = if u > 0.0 { u.min(1.0) as f64 } else { 0.0 };
    let t = (d.tanh_min + u * d.tanh_range).clamp(-1.0, 1.0);
    let lambda = ((PDF_C + t.atanh() / PDF_K) as f32).clamp(LAMBDA_MIN, LAMBDA_MAX);
    let weight = rgb_weight(lambda) / wavelength_pdf(lambda);
    WavelengthSample { lambda, weight }
}

/// w(λ): linear sRGB of monochromatic light at `lambda` nm, scaled so ∫ w dλ = (1, 1, 1); 0 outside.
pub fn rgb_weight(lambda: f32) -> Vec3 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return Vec3::ZERO;
    }
    let rgb = xyz_to_srgb_matrix() * cie_xyz_f64(lambda as f64);
    (rgb * derived().rgb_scale).as_vec3()
}

/// p(λ) per nm of [`sample_wavelength`]: ∝ 1/cosh²(0.0072 (λ − 538)) on the sampled range, 0 outside.
pub fn wavelength_pdf(lambda: f32) -> f32 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return 0.0;
    }
    let c = (PDF_K * (lambda as f64 - PDF_C)).cosh();
    (PDF_K / (c * c) / derived().tanh_range) as f32
}

/// The CDF of [`wavelength_pdf`] (for tests: [`sample_wavelength`] is its inverse).
#[cfg(test)]
fn wavelength_cdf(lambda: f32) -> f64 {
    let d = derived();
    let l = (lambda as f64).clamp(LAMBDA_MIN as f64, LAMBDA_MAX as f64);
    (((PDF_K * (l - PDF_C)).tanh() - d.tanh_min) / d.tanh_range).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The `i`-th value of an independent uniform stream in [0, 1) (a SplitMix64 hash of
    /// (`seed`, `i`)); self-contained so these tests do not depend on the renderer's samplers.
    fn uniform(seed: u64, i: u64) -> f64 {
        let mut z = (seed << 40 ^ i).wrapping_add(0x9e37_79b9_7f4a_7c15).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Midpoint rule over the sampled range with `n` cells, in f64 (independent of Simpson above).
    fn midpoint(n: usize, f: impl Fn(f32) -> DVec3) -> DVec3 {
        let (a, b) = (LAMBDA_MIN as f64, LAMBDA_MAX as f64);
        let h = (b - a) / n as f64;
        (0..n).map(|i| f((a + (i as f64 + 0.5) * h) as f32)).sum::<DVec3>() * h
    }

    #[test]
    fn weight_integrates_to_one_per_channel() {
        let integral = midpoint(400_000, |l| rgb_weight(l).as_dvec3());
        assert!((integral - DVec3::ONE).abs().max_element() < 1e-4, "∫w = {integral}");
        // The pdf is normalised the same way.
        let p = midpoint(400_000, |l| DVec3::splat(wavelength_pdf(l) as f64)).x;
        assert!((p - 1.0).abs() < 1e-5, "∫p = {p}");
    }

    #[test]
    fn flat_spectrum_is_white() {
        // An equal-energy spectrum maps to equal channels after the normalisation...
        let white = midpoint(40_000, |l| rgb_weight(l).as_dvec3());
        assert!(white.max_element() - white.min_element() < 1e-3, "{white}");
        // ...whereas in plain linear sRGB it is pinkish (sRGB white is D65, not equal energy),
        // which is why the per-channel scaling exists.
        let raw = midpoint(40_000, |l| xyz_to_linear_srgb(cie_xyz(l)).as_dvec3());
        assert!(raw.x > 1.1 * raw.z, "{raw}");
        // The matrix maps the D65 white point to RGB white.
        let d65 = xyz_to_linear_srgb(Vec3::new(0.95047, 1.0, 1.08883));
        assert!(d65.abs_diff_eq(Vec3::ONE, 1e-4), "{d65}");
    }

    #[test]
    fn monte_carlo_weight_has_unit_mean() {
        // 200k stratified (jittered) u. The standard error is the ordinary i.i.d. one, s/√N,
        // which is conservative for stratified sampling (stratification only lowers variance).
        let n = 200_000u64;
        let (mut sum, mut sum2) = (DVec3::ZERO, DVec3::ZERO);
        for i in 0..n {
            let jitter = uniform(11, i);
            let u = ((i as f64 + jitter) / n as f64) as f32;
            let s = sample_wavelength(u);
            assert!((LAMBDA_MIN..=LAMBDA_MAX).contains(&s.lambda));
            let w = s.weight.as_dvec3();
            sum += w;
            sum2 += w * w;
        }
        let mean = sum / n as f64;
        let var = (sum2 / n as f64 - mean * mean) * (n as f64 / (n - 1) as f64);
        let std_err = (var / n as f64).map(f64::sqrt);
        let err = (mean - DVec3::ONE).abs();
        assert!(err.cmplt(3.0 * std_err).all(), "mean {mean}, standard error {std_err}");
        // Stratification of a smooth integrand is far more accurate than that bound.
        assert!(err.max_element() < 1e-4, "mean {mean}");
    }

    #[test]
    fn sampling_follows_the_pdf_chi_square() {
        // Independent u; 20 equal-width bins whose probabilities come from integrating
        // `wavelength_pdf` numerically (not from the closed-form CDF the sampler inverts).
        const BINS: usize = 20;
        let n = 200_000u64;
        let mut counts = [0u64; BINS];
        let thresholds = [400.0f32, 450.0, 500.0, 538.0, 600.0, 650.0, 700.0, 760.0];
        let mut below = [0u64; 8];
        for i in 0..n {
            let l = sample_wavelength(uniform(5, i) as f32).lambda;
            assert!((LAMBDA_MIN..=LAMBDA_MAX).contains(&l));
            let bin = ((l - LAMBDA_MIN) / (LAMBDA_MAX - LAMBDA_MIN) * BINS as f32) as usize;
            counts[bin.min(BINS - 1)] += 1;
            for (t, c) in thresholds.iter().zip(below.iter_mut()) {
                *c += (l < *t) as u64;
            }
        }
        let prob = |lo: f32, hi: f32| -> f64 {
            let m = 2000;
            let h = (hi - lo) as f64 / m as f64;
            (0..m).map(|k| wavelength_pdf((lo as f64 + (k as f64 + 0.5) * h) as f32) as f64).sum::<f64>() * h
        };
        let width = (LAMBDA_MAX - LAMBDA_MIN) / BINS as f32;
        let chi2: f64 = (0..BINS)
            .map(|k| {
                let lo = LAMBDA_MIN + k as f32 * width;
                let expected = prob(lo, lo + width) * n as f64;
                (counts[k] as f64 - expected).powi(2) / expected
            })
            .sum();
        // 99% quantile of χ² with 19 degrees of freedom (p-value threshold 0.01).
        assert!(chi2 < 36.191, "chi2 = {chi2}, counts {counts:?}");
        for (t, c) in thresholds.iter().zip(below) {
            let p = prob(LAMBDA_MIN, *t);
            let frac = c as f64 / n as f64;
            let std_err = (p * (1.0 - p) / n as f64).sqrt();
            assert!((frac - p).abs() < 3.0 * std_err, "below {t}: {frac} vs {p}");
        }
    }

    #[test]
    fn sampling_inverts_the_cdf() {
        for k in 0..=400 {
            let l = LAMBDA_MIN + k as f32;
            let back = sample_wavelength(wavelength_cdf(l) as f32).lambda;
            assert!((back - l).abs() < 2e-3, "{l} -> {back}");
        }
        for k in 1..100 {
            let u = k as f32 / 100.0;
            let l = sample_wavelength(u).lambda;
            assert!((wavelength_cdf(l) - u as f64).abs() < 1e-6, "{u} -> {l}");
        }
    }

    #[test]
    fn sample_weight_is_w_over_p() {
        for k in 0..50 {
            let s = sample_wavelength((k as f32 + 0.5) / 50.0);
            let expected = rgb_weight(s.lambda) / wavelength_pdf(s.lambda);
            assert!(s.weight.abs_diff_eq(expected, 1e-6 * expected.abs().max_element()));
        }
    }

    #[test]
    fn wavelengths_stay_in_range() {
        let edge = [0.0f32, f32::MIN_POSITIVE, 1e-7, 0.5, 1.0 - f32::EPSILON, 1.0, -0.5, 1.5, f32::NAN];
        for u in edge {
            let s = sample_wavelength(u);
            assert!((LAMBDA_MIN..=LAMBDA_MAX).contains(&s.lambda), "u {u} -> {}", s.lambda);
            assert!(s.weight.is_finite(), "u {u}");
        }
        assert!((sample_wavelength(0.0).lambda - LAMBDA_MIN).abs() < 1e-3);
        assert!((sample_wavelength(1.0).lambda - LAMBDA_MAX).abs() < 1e-3);
        for i in 0..10_000 {
            let l = sample_wavelength(uniform(3, i) as f32).lambda;
            assert!((LAMBDA_MIN..=LAMBDA_MAX).contains(&l));
        }
        assert_eq!(rgb_weight(LAMBDA_MIN - 1.0), Vec3::ZERO);
        assert_eq!(wavelength_pdf(LAMBDA_MAX + 1.0), 0.0);
    }

    #[test]
    fn fit_matches_cie_1931_table() {
        // CIE 1931 2° table values (λ, x̄, ȳ, z̄). The multi-lobe fit's deviations from the table
        // are of order 1% of the peak, so the tolerance is 0.02 absolute.
        let table = [
            (450.0f32, 0.33620f32, 0.03800f32, 1.77211f32),
            (500.0, 0.00490, 0.32300, 0.27200),
            (555.0, 0.51205, 1.00000, 0.00575),
            (600.0, 1.06220, 0.63100, 0.00080),
            (650.0, 0.28350, 0.10700, 0.00002),
            (700.0, 0.01136, 0.00410, 0.00000),
        ];
        for (l, x, y, z) in table {
            let fit = cie_xyz(l);
            assert!(fit.abs_diff_eq(Vec3::new(x, y, z), 0.02), "{l} nm: {fit} vs ({x}, {y}, {z})");
        }
        assert!((cie_xyz(555.0).y - 1.0).abs() < 0.01);
        assert!((cie_xyz(600.0).x - 1.062).abs() < 0.01);
        assert!((cie_xyz(450.0).z - 1.772).abs() < 0.015);
    }

    #[test]
    fn monochromatic_colours_have_the_right_hue() {
        let argmax = |v: Vec3| (0..3).max_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap();
        for (l, channel) in [(450.0f32, 2usize), (550.0, 1), (650.0, 0)] {
            assert_eq!(argmax(rgb_weight(l)), channel, "{l} nm: {}", rgb_weight(l));
            assert_eq!(argmax(xyz_to_linear_srgb(cie_xyz(l))), channel, "{l} nm");
        }
        // The red channel's negative lobe (monochromatic cyan-green is out of the sRGB gamut).
        assert!(rgb_weight(500.0).x < 0.0);
    }
}
