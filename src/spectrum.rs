//! Spectral transport for an RGB scene: colour matching, hero-wavelength sampling and the
//! upsampling of RGB colours to spectra.
//!
//! Scenes are written in RGB. In spectral mode every camera (or light) sample carries
//! [`HERO_WAVELENGTHS`] = 3 wavelengths along its whole path (hero-wavelength sampling, Wilkie
//! et al. 2014), and the three channels of every radiance and throughput the integrators
//! compute hold the spectrum at those three wavelengths instead of red, green and blue
//! ([`Channels`]). Refractive indices are taken at the first, the *hero* wavelength.
//!
//! - **Sampling** ([`Wavelengths::sample`]): one number u gives u, u + ⅓ and u + ⅔ (mod 1),
//!   each mapped through the inverse CDF of [`wavelength_pdf`], so the three are stratified over
//!   the visible range and each alone is distributed by the density. The density is
//!   piecewise constant in 1 nm bins, ∝ ‖w(λ)‖^0.7 (Euclidean norm of the colour weights w
//!   below): it follows the visual response of all three channels (the blue one too, which
//!   pbrt-v4's luminance-like density 1/cosh² starves); ‖w‖ itself would minimise the summed
//!   channel variance of a flat spectrum, and the exponent 0.7 flattens it, a hedge for the
//!   colours whose spectra are not flat. Measured on the white spectrum, the
//!   per-channel variance of the three-wavelength estimate is 0.033 (averaged over R, G, B)
//!   against 0.31 with pbrt-v4's density, 3.0 for the hero alone and 4.2 for the single
//!   wavelength of vitrum's first spectral mode (‖w‖^0.5 gives 0.035, (Σ|w_c|)^0.7 0.049). On
//!   `path` over `soft-shadows` the three wavelengths cost 1.06× the variance of RGB mode at equal
//!   samples, the light seen directly added in RGB (docs/performance.md, "Spectral rendering").
//! - **Back to RGB** ([`Wavelengths::to_rgb`]): a spectral radiance L at λ₁, λ₂, λ₃ becomes
//!   RGB = Σᵢ L(λᵢ) w(λᵢ) / (3 p(λᵢ)), an unbiased estimate of ∫ L(λ) w(λ) dλ.
//!   w(λ) ([`rgb_weight`]) is the linear-sRGB colour of monochromatic light (CIE 1931 2°
//!   colour-matching functions → XYZ → linear sRGB with the D65 matrix), scaled per channel so
//!   that ∫ w dλ = (1, 1, 1): an equal-energy spectrum is the renderer's white (a white balance
//!   on the equal-energy illuminant). w has negative lobes (monochromatic light is outside the
//!   sRGB gamut), so single samples can carry negative channels; they average out, and the
//!   film never clips them.
//! - **RGB to spectrum** ([`Wavelengths::colour`]): every colour of the scene (albedos, mirror
//!   tints, emission, the background, absorption coefficients) becomes the smooth spectrum
//!   S(λ) = r B_r(λ) + g B_g(λ) + b B_b(λ), a linear *spectral primary decomposition* (after
//!   Mallett and Yuksel 2019) with basis spectra of our own: the softmax of two cubic
//!   polynomials ([`basis`]). By construction B_r + B_g + B_b = 1 and 0 < B_c < 1, so white and
//!   every grey stay flat spectra, a reflectance in [0, 1]³ stays in [0, 1] at every
//!   wavelength (no energy is created), and emission and absorption stay non-negative. The
//!   cubics' coefficients were fitted (by `scripts/spectral/fit_basis.py`) so that
//!   ∫ B_c w_c' dλ = δ_cc': under a white light every colour reflects exactly its RGB.
//!   Jakob and Hanika's (2019) sigmoid spectra are smoother for saturated colours but need a
//!   precomputed coefficient table per colour and are not linear; linearity lets a path
//!   project each colour with one 3×3 product at its wavelengths.
//! - **Dispersion**: where a path refracts through a dispersive interface, the directions of
//!   the three wavelengths part. `path` and `light` split it there (smooth glass, one decision:
//!   `PathContext::part_wavelengths` in `integrators/mod.rs`): each wavelength chooses
//!   reflection or refraction by its own Fresnel reflectance with the same random number and
//!   follows its own direction; if all three reflect they go on together, otherwise each goes on
//!   as a branch of its own, carrying its channel alone with weight 1, its indices taken at its
//!   wavelength ([`Wavelengths::led_by`]). The branches set aside run after the one in flight
//!   and replay its random numbers from the split, so the three paths stay close and their
//!   colours correlated; every channel is its own unbiased estimate and [`Wavelengths::to_rgb`]
//!   is unchanged. Hero-wavelength MIS (Wilkie et al. 2014) would not help there: at a smooth
//!   interface the other wavelengths' densities of the hero's direction are zero, so it reduces
//!   to ending them. At rough dispersive glass `path` uses it: a wavelength chosen uniformly
//!   samples the direction and, after one facet, all three go on weighted by the balance
//!   heuristic over their densities (where the microsurface scatters several times, without a
//!   density, it splits as at smooth glass; `integrators/wavelengths.rs`), and so does `light`.
//!   `light` and the bidirectional engine (`bpt`, `ppm`, `bpm`, `vcm`: camera and light
//!   sub-paths) split at smooth dispersive glass as `path` does. Elsewhere a path ends the two secondary
//!   wavelengths and carries the hero alone with weight 3 ([`HERO_ONLY`], as pbrt-v4's
//!   `TerminateSecondary`): the bidirectional engine at rough dispersive glass, `mmlt` also where smooth glass refracts (where it reflects it keeps all three, each
//!   weighted by its Fresnel reflectance over the hero's; its sample is one path), and the
//!   deterministic recursions (`whitted`, `distributed`), which follow both branches at once. On `glass-of-water` the
//!   variance at equal samples is 1.19× RGB mode's (docs/performance.md, "Spectral cost of
//!   `path`").
//! - **Light seen directly**: what a camera ray itself meets (an emitter, the background) is
//!   added in RGB (`PathContext::seen_rgb`), because the expectation of its spectral estimate
//!   over the wavelengths is its RGB exactly (the basis keeps every RGB under the colour
//!   weights): its colour noise, the larger part of spectral mode's cost where a light is in
//!   view, is gone and nothing else changes (`glass-of-water` 1.89× → 1.19×, `soft-shadows`
//!   1.39× → 1.06×). The bidirectional engine's camera sub-paths do the same
//!   (`glass-of-water`: `bpt` 2.18× → 1.06×, `vcm` 1.98× → 1.02×).

use glam::{DMat3, DVec3, Vec3};
use std::sync::OnceLock;

/// Shortest sampled wavelength, in nanometres.
pub const LAMBDA_MIN: f32 = 380.0;
/// Longest sampled wavelength, in nanometres.
pub const LAMBDA_MAX: f32 = 780.0;

/// Wavelengths carried by one spectral sample: the hero and two secondaries, one per channel.
pub const HERO_WAVELENGTHS: usize = 3;

/// The factor that ends a path's secondary wavelengths: the hero alone, weighted by their count.
pub const HERO_ONLY: Vec3 = Vec3::new(HERO_WAVELENGTHS as f32, 0.0, 0.0);

/// Bins of the tabulated wavelength density, 1 nm each.
const DENSITY_BINS: usize = (LAMBDA_MAX - LAMBDA_MIN) as usize;

/// Exponent of the norm of the colour weights in the wavelength density (chosen by measurement, see
/// the module documentation).
const DENSITY_EXPONENT: f64 = 0.7;

/// Coefficients (constant term first) of the cubics in x = (λ − 580 nm)/200 nm whose softmax
/// with 0 (green) gives the red and blue basis spectra; fitted by `scripts/spectral/fit_basis.py`.
const BASIS_RED: [f32; 4] = [-1.815_745_6, 38.094_308, 59.811_833, -7.819_125_6];
/// See [`BASIS_RED`].
const BASIS_BLUE: [f32; 4] = [-3.733_315, 3.170_743, 16.617_997, -15.724_476];

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

/// Constants derived once from the colour-matching fit.
struct Derived {
    /// Per-channel factors making ∫ w(λ) dλ = (1, 1, 1): 1 / ∫ srgb(xyz(λ)) dλ.
    rgb_scale: DVec3,
    /// The wavelength density in each 1 nm bin (per nm; they sum to 1).
    density: Vec<f64>,
    /// Its cumulative distribution at the bin edges: `cdf[0] = 0`, `cdf[DENSITY_BINS] = 1`.
    cdf: Vec<f64>,
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
        let xyz_integral = integrate_piecewise(LAMBDA_MIN as f64, LAMBDA_MAX as f64, cie_xyz_f64);
        let rgb_scale = DVec3::ONE / (xyz_to_srgb_matrix() * xyz_integral);
        let mut density: Vec<f64> = (0..DENSITY_BINS)
            .map(|k| {
                let centre = LAMBDA_MIN as f64 + k as f64 + 0.5;
                let w = xyz_to_srgb_matrix() * cie_xyz_f64(centre) * rgb_scale;
                w.length().powf(DENSITY_EXPONENT)
            })
            .collect();
        let total: f64 = density.iter().sum();
        density.iter_mut().for_each(|d| *d /= total);
        let mut cdf = Vec::with_capacity(DENSITY_BINS + 1);
        cdf.push(0.0);
        for d in &density {
            cdf.push(cdf.last().unwrap() + d);
        }
        *cdf.last_mut().unwrap() = 1.0;
        Derived { rgb_scale, density, cdf }
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

/// w(λ): linear sRGB of monochromatic light at `lambda` nm, scaled so ∫ w dλ = (1, 1, 1); 0 outside.
pub fn rgb_weight(lambda: f32) -> Vec3 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return Vec3::ZERO;
    }
    let rgb = xyz_to_srgb_matrix() * cie_xyz_f64(lambda as f64);
    (rgb * derived().rgb_scale).as_vec3()
}

/// The bin of the density that holds `lambda` (clamped to the range).
fn density_bin(lambda: f32) -> usize {
    ((lambda - LAMBDA_MIN) as usize).min(DENSITY_BINS - 1)
}

/// p(λ) per nm of one sampled wavelength (every one of a sample's three has it): piecewise
/// constant in 1 nm bins, ∝ ‖w(λ)‖^0.7 at the bin's centre; 0 outside the range.
pub fn wavelength_pdf(lambda: f32) -> f32 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return 0.0;
    }
    derived().density[density_bin(lambda)] as f32
}

/// The wavelength at cumulative probability `u` ∈ [0, 1] of [`wavelength_pdf`] (clamped; NaN
/// counts as 0), by its inverse CDF: linear within a bin.
pub fn wavelength_at(u: f32) -> f32 {
    let d = derived();
    // `u > 0.0` is false for NaN, so a NaN input maps to the first wavelength, never to NaN.
    let u = if u > 0.0 { u.min(1.0) as f64 } else { 0.0 };
    let k = (d.cdf.partition_point(|&c| c <= u) - 1).min(DENSITY_BINS - 1);
    let t = ((u - d.cdf[k]) / d.density[k]).clamp(0.0, 1.0);
    (LAMBDA_MIN + (k as f64 + t) as f32).clamp(LAMBDA_MIN, LAMBDA_MAX)
}

/// The basis spectra (B_r, B_g, B_b) at `lambda` nm: softmax of the red and blue cubics and 0.
/// Each lies in (0, 1) and the three sum to 1.
pub fn basis(lambda: f32) -> Vec3 {
    let x = (lambda - 580.0) / 200.0;
    let cubic = |c: [f32; 4]| c[0] + x * (c[1] + x * (c[2] + x * c[3]));
    let (r, b) = (cubic(BASIS_RED), cubic(BASIS_BLUE));
    // Shift by the largest exponent so that no exponential overflows.
    let m = r.max(b).max(0.0);
    let e = Vec3::new((r - m).exp(), (-m).exp(), (b - m).exp());
    e / e.element_sum()
}

/// The wavelengths one spectral sample carries, with what its path needs of them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wavelengths {
    /// The wavelengths in nm; the first is the hero.
    pub lambda: [f32; HERO_WAVELENGTHS],
    /// The channel whose wavelength refractive indices are taken at: 0 (the hero), but in a
    /// branch of a path split at dispersive glass the one wavelength the branch carries.
    lead: u8,
    /// Row i: the basis spectra at wavelength i (a colour's spectral value there is its dot product).
    basis: [Vec3; HERO_WAVELENGTHS],
    /// w(λᵢ) / (3 p(λᵢ)): the RGB that wavelength i's radiance stands for.
    weights: [Vec3; HERO_WAVELENGTHS],
}

impl Wavelengths {
    /// The three stratified wavelengths of `u` ∈ [0, 1]: at cumulative probabilities u, u + ⅓
    /// and u + ⅔ (mod 1) of [`wavelength_pdf`].
    pub fn sample(u: f32) -> Wavelengths {
        let lambda: [f32; HERO_WAVELENGTHS] = std::array::from_fn(|i| {
            let v = u + i as f32 / HERO_WAVELENGTHS as f32;
            wavelength_at(if v >= 1.0 { v - 1.0 } else { v })
        });
        Wavelengths {
            lambda,
            basis: lambda.map(basis),
            weights: lambda.map(|l| {
                rgb_weight(l) / (HERO_WAVELENGTHS as f32 * wavelength_pdf(l).max(f32::MIN_POSITIVE))
            }),
            lead: 0,
        }
    }

    /// The wavelength refractive indices are taken at: the hero, or in a branch of a split path
    /// the branch's own ([`led_by`](Self::led_by)).
    #[inline]
    pub fn hero(&self) -> f32 {
        self.lambda[self.lead as usize]
    }

    /// The same wavelengths with indices taken at channel `channel`'s (below
    /// [`HERO_WAVELENGTHS`]); the channels, their colours and [`to_rgb`](Self::to_rgb) unchanged.
    #[inline]
    pub fn led_by(self, channel: usize) -> Wavelengths {
        debug_assert!(channel < HERO_WAVELENGTHS);
        Wavelengths { lead: channel as u8, ..self }
    }

    /// The channel whose wavelength [`hero`](Self::hero) is.
    #[inline]
    pub fn lead(&self) -> usize {
        self.lead as usize
    }

    /// The spectrum of the RGB colour `rgb` at the three wavelengths.
    #[inline]
    pub fn colour(&self, rgb: Vec3) -> Vec3 {
        Vec3::new(self.basis[0].dot(rgb), self.basis[1].dot(rgb), self.basis[2].dot(rgb))
    }

    /// The RGB estimate of a spectral radiance `l` (one value per wavelength).
    #[inline]
    pub fn to_rgb(&self, l: Vec3) -> Vec3 {
        self.weights[0] * l.x + self.weights[1] * l.y + self.weights[2] * l.z
    }
}

/// What the three channels of the radiances and throughputs of a path hold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Channels {
    /// Red, green and blue (indices at their nominal n_d).
    Rgb,
    /// The spectrum at the sample's three wavelengths.
    Spectral(Wavelengths),
}

impl Channels {
    /// The hero wavelength in spectral mode (for refractive indices); `None` in RGB.
    #[inline]
    pub fn hero(&self) -> Option<f32> {
        match self {
            Channels::Rgb => None,
            Channels::Spectral(w) => Some(w.hero()),
        }
    }

    /// Whether the channels are wavelengths.
    #[inline]
    pub fn is_spectral(&self) -> bool {
        matches!(self, Channels::Spectral(_))
    }

    /// A scene colour in these channels: itself, or its spectrum at the wavelengths.
    #[inline]
    pub fn colour(&self, rgb: Vec3) -> Vec3 {
        match self {
            Channels::Rgb => rgb,
            Channels::Spectral(w) => w.colour(rgb),
        }
    }

    /// A radiance in these channels as RGB.
    #[inline]
    pub fn to_rgb(&self, l: Vec3) -> Vec3 {
        match self {
            Channels::Rgb => l,
            Channels::Spectral(w) => w.to_rgb(l),
        }
    }
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

    /// Mean and standard error per channel of `f` over `n` independent uniform numbers.
    fn estimate(seed: u64, n: u64, f: impl Fn(f32) -> Vec3) -> (DVec3, DVec3) {
        let (mut sum, mut sum2) = (DVec3::ZERO, DVec3::ZERO);
        for i in 0..n {
            let v = f(uniform(seed, i) as f32).as_dvec3();
            sum += v;
            sum2 += v * v;
        }
        let mean = sum / n as f64;
        let var = (sum2 / n as f64 - mean * mean) * (n as f64 / (n - 1) as f64);
        (mean, (var / n as f64).map(f64::sqrt))
    }

    #[test]
    fn weight_and_density_integrate_to_one() {
        let integral = midpoint(400_000, |l| rgb_weight(l).as_dvec3());
        assert!((integral - DVec3::ONE).abs().max_element() < 1e-4, "∫w = {integral}");
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
    fn basis_spectra_partition_unity_and_keep_their_colour() {
        for k in 0..=4000 {
            let l = LAMBDA_MIN + k as f32 * 0.1;
            let b = basis(l);
            assert!(b.is_finite() && b.cmpge(Vec3::ZERO).all() && b.cmple(Vec3::ONE).all(), "{l}: {b}");
            assert!((b.element_sum() - 1.0).abs() < 1e-6, "{l}: {b}");
        }
        // ∫ B_c w_c' dλ = δ_cc': under the equal-energy white every primary reflects itself.
        for c in 0..3 {
            let rgb = midpoint(400_000, |l| (rgb_weight(l) * basis(l)[c]).as_dvec3());
            let expected = DVec3::from_array(std::array::from_fn(|k| (k == c) as u8 as f64));
            assert!((rgb - expected).abs().max_element() < 2e-5, "primary {c}: {rgb}");
        }
        // The basis is smooth: no jump between neighbouring 0.1 nm samples.
        for k in 0..4000 {
            let l = LAMBDA_MIN + k as f32 * 0.1;
            assert!((basis(l + 0.1) - basis(l)).abs().max_element() < 0.01, "{l}");
        }
    }

    #[test]
    fn colours_keep_their_rgb_and_white_stays_flat() {
        let colours = [
            Vec3::ONE,
            Vec3::splat(0.18),
            Vec3::new(0.63, 0.065, 0.05),
            Vec3::new(0.14, 0.45, 0.091),
            Vec3::new(0.05, 0.1, 0.8),
            Vec3::new(12.0, 9.0, 4.0),
        ];
        for rgb in colours {
            // The upsampled spectrum integrates back to its RGB (quadrature, exact up to 2e-5).
            let back = midpoint(400_000, |l| (rgb_weight(l) * basis(l).dot(rgb)).as_dvec3());
            let err = (back - rgb.as_dvec3()).abs().max_element();
            assert!(err < 2e-5 * rgb.max_element() as f64, "{rgb}: {back}");
            // A grey is the same value at every wavelength.
            if rgb.x == rgb.y && rgb.y == rgb.z {
                for k in 0..=40 {
                    let s = Wavelengths::sample(k as f32 / 40.0).colour(rgb);
                    assert!(s.abs_diff_eq(Vec3::splat(rgb.x), 1e-6 * rgb.x), "{rgb}: {s}");
                }
            }
            // A reflectance stays a reflectance.
            if rgb.max_element() <= 1.0 {
                for k in 0..=400 {
                    let s = basis(LAMBDA_MIN + k as f32).dot(rgb);
                    assert!((0.0..=rgb.max_element() + 1e-6).contains(&s), "{rgb} at {k}: {s}");
                }
            }
        }
    }

    #[test]
    fn three_wavelength_estimate_is_unbiased_for_every_colour() {
        // E[to_rgb(colour(rgb))] = rgb, within 4 standard errors of 200k independent samples.
        for rgb in [Vec3::ONE, Vec3::new(0.63, 0.065, 0.05), Vec3::new(0.05, 0.1, 0.8)] {
            let (mean, se) = estimate(7, 200_000, |u| {
                let w = Wavelengths::sample(u);
                w.to_rgb(w.colour(rgb))
            });
            let err = (mean - rgb.as_dvec3()).abs();
            assert!(err.cmplt(4.0 * se + 1e-6).all(), "{rgb}: mean {mean}, standard error {se}");
        }
    }

    #[test]
    fn three_wavelengths_are_far_less_noisy_than_one() {
        // The variance of the white spectrum's estimate (what colour noise a grey scene gets):
        // three stratified wavelengths against the hero alone (weight 3, as after dispersion).
        let n = 100_000;
        let (_, se3) = estimate(3, n, |u| Wavelengths::sample(u).to_rgb(Vec3::ONE));
        let (_, se1) = estimate(3, n, |u| Wavelengths::sample(u).to_rgb(HERO_ONLY));
        let (var3, var1) =
            ((se3 * se3).element_sum() * n as f64 / 3.0, (se1 * se1).element_sum() * n as f64 / 3.0);
        // Measured: 0.033 and 3.0 (the module documentation's figures).
        assert!(var3 < 0.04, "three wavelengths: {var3}");
        assert!(var1 > 20.0 * var3, "one {var1}, three {var3}");
    }

    #[test]
    fn every_wavelength_follows_the_density_chi_square() {
        // Independent u; 20 equal-width bins whose probabilities come from integrating
        // `wavelength_pdf` numerically (not from the CDF the sampler inverts). Each of the three
        // wavelengths is checked: the rotation by ⅓ keeps each marginal the same.
        const BINS: usize = 20;
        let n = 200_000u64;
        let prob = |lo: f32, hi: f32| -> f64 {
            let m = 4000;
            let h = (hi - lo) as f64 / m as f64;
            (0..m).map(|k| wavelength_pdf((lo as f64 + (k as f64 + 0.5) * h) as f32) as f64).sum::<f64>() * h
        };
        let width = (LAMBDA_MAX - LAMBDA_MIN) / BINS as f32;
        for i in 0..HERO_WAVELENGTHS {
            let mut counts = [0u64; BINS];
            for j in 0..n {
                let l = Wavelengths::sample(uniform(5, j) as f32).lambda[i];
                assert!((LAMBDA_MIN..=LAMBDA_MAX).contains(&l));
                let bin = ((l - LAMBDA_MIN) / width) as usize;
                counts[bin.min(BINS - 1)] += 1;
            }
            let chi2: f64 = (0..BINS)
                .map(|k| {
                    let lo = LAMBDA_MIN + k as f32 * width;
                    let expected = prob(lo, lo + width) * n as f64;
                    (counts[k] as f64 - expected).powi(2) / expected
                })
                .sum();
            // 99.9% quantile of χ² with 19 degrees of freedom (three tests at p = 0.001 each).
            assert!(chi2 < 43.82, "wavelength {i}: chi2 = {chi2}, counts {counts:?}");
        }
    }

    #[test]
    fn wavelengths_are_stratified_thirds() {
        let d = derived();
        let cdf_at = |l: f32| {
            let k = density_bin(l);
            d.cdf[k] + d.density[k] * (l - LAMBDA_MIN - k as f32) as f64
        };
        for k in 0..300 {
            let u = (k as f32 + 0.5) / 300.0;
            let w = Wavelengths::sample(u);
            for i in 0..HERO_WAVELENGTHS {
                let expected = (u as f64 + i as f64 / 3.0).fract();
                assert!((cdf_at(w.lambda[i]) - expected).abs() < 2e-6, "u {u}, wavelength {i}");
            }
        }
    }

    #[test]
    fn sampling_inverts_the_cdf() {
        let d = derived();
        for k in 0..DENSITY_BINS {
            let u = (d.cdf[k] + 0.5 * d.density[k]) as f32;
            // u is rounded to f32 (half an ulp, ≤ 2⁻²⁵ below 1), which moves the wavelength by
            // that over the bin's density (per nm); beyond it, 1e-3 nm of arithmetic.
            let tolerance = 1e-3 + f32::EPSILON as f64 / 4.0 / d.density[k];
            let l = wavelength_at(u);
            assert!(((l - (LAMBDA_MIN + k as f32 + 0.5)) as f64).abs() < tolerance, "bin {k}: {l}");
        }
    }

    #[test]
    fn wavelengths_stay_in_range() {
        let edge = [0.0f32, f32::MIN_POSITIVE, 1e-7, 0.5, 1.0 - f32::EPSILON, 1.0, -0.5, 1.5, f32::NAN];
        for u in edge {
            let w = Wavelengths::sample(u);
            for l in w.lambda {
                assert!((LAMBDA_MIN..=LAMBDA_MAX).contains(&l), "u {u} -> {l}");
            }
            assert!(w.to_rgb(Vec3::ONE).is_finite(), "u {u}");
        }
        assert!((wavelength_at(0.0) - LAMBDA_MIN).abs() < 1e-3);
        assert!((wavelength_at(1.0) - LAMBDA_MAX).abs() < 1e-3);
        assert_eq!(rgb_weight(LAMBDA_MIN - 1.0), Vec3::ZERO);
        assert_eq!(wavelength_pdf(LAMBDA_MAX + 1.0), 0.0);
        assert!(wavelength_pdf(LAMBDA_MIN) > 0.0 && wavelength_pdf(LAMBDA_MAX) > 0.0);
    }

    #[test]
    fn rgb_channels_pass_colours_through() {
        let c = Vec3::new(0.3, 0.2, 0.1);
        assert_eq!(Channels::Rgb.colour(c), c);
        assert_eq!(Channels::Rgb.to_rgb(c), c);
        assert_eq!(Channels::Rgb.hero(), None);
        let w = Wavelengths::sample(0.25);
        assert_eq!(Channels::Spectral(w).hero(), Some(w.lambda[0]));
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
