//! Mitsuba 3's RGB reading of a `<spectrum>` (what its RGB variants render): a spectrum of
//! `wavelength:value` pairs is interpolated linearly between its wavelengths (zero outside them)
//! and integrated against the CIE 1931 colour-matching functions from 360 to 830 nm at 1 nm, then
//! taken to linear sRGB. Inside an emitter it is light (normalised by `∫ȳ`, so a constant
//! spectrum of 1 is the colour of the equal-energy illuminant E); elsewhere a reflectance, seen
//! under illuminant D65 (normalised by `∫D65·ȳ`, so a constant 1 is white) and clamped to
//! [0, 1]. Negative channels (colours outside sRGB's gamut) become 0.
//!
//! vitrum's colour-matching functions are the Wyman–Sloan–Shirley fit (`crate::spectrum`), not
//! the CIE tables Mitsuba integrates: the colours agree with Mitsuba 3's to about 1% (tested).

use crate::spectrum::{cie_xyz, xyz_to_linear_srgb};
use glam::Vec3;

/// CIE standard illuminant D65, relative spectral power at 5 nm steps from 360 to 830 nm (any
/// scale: only ratios matter).
const D65: [f64; 95] = [
    0.4711, 0.4986, 0.5262, 0.5155, 0.5048, 0.5284, 0.5520, 0.6940, 0.8359, 0.8800, 0.9241, 0.9340, 0.9438,
    0.9097, 0.8756, 0.9674, 1.0593, 1.1206, 1.1819, 1.1860, 1.1901, 1.1751, 1.1602, 1.1656, 1.1710, 1.1350,
    1.0991, 1.1019, 1.1046, 1.0968, 1.0889, 1.0737, 1.0585, 1.0731, 1.0878, 1.0712, 1.0546, 1.0528, 1.0510,
    1.0306, 1.0101, 0.9916, 0.9731, 0.9703, 0.9676, 0.9317, 0.8958, 0.9025, 0.9092, 0.9071, 0.9051, 0.8955,
    0.8859, 0.8636, 0.8413, 0.8434, 0.8455, 0.8269, 0.8084, 0.8093, 0.8103, 0.8207, 0.8311, 0.8109, 0.7908,
    0.7475, 0.7043, 0.7138, 0.7233, 0.7372, 0.7510, 0.6866, 0.6223, 0.6641, 0.7059, 0.7322, 0.7585, 0.7004,
    0.6424, 0.5556, 0.4689, 0.5719, 0.6748, 0.6575, 0.6402, 0.6449, 0.6496, 0.6250, 0.6005, 0.5627, 0.5249,
    0.5525, 0.5802, 0.5947, 0.6092,
];

/// The first and last wavelength of the integration (nm).
const RANGE: (u32, u32) = (360, 830);

/// D65 at `lambda` nm, linear between its 5 nm samples.
fn d65(lambda: f64) -> f64 {
    let x = ((lambda - RANGE.0 as f64) / 5.0).clamp(0.0, (D65.len() - 1) as f64);
    let i = (x as usize).min(D65.len() - 2);
    let f = x - i as f64;
    D65[i] * (1.0 - f) + D65[i + 1] * f
}

/// The spectrum of `pairs` (sorted by wavelength) at `lambda`: linear between them, 0 outside.
fn interpolate(pairs: &[(f64, f64)], lambda: f64) -> f64 {
    let (first, last) = (pairs[0], pairs[pairs.len() - 1]);
    if lambda < first.0 || lambda > last.0 {
        return 0.0;
    }
    let k = pairs.partition_point(|&(w, _)| w <= lambda);
    if k == 0 || k >= pairs.len() {
        return if lambda == last.0 { last.1 } else { first.1 };
    }
    let ((w0, v0), (w1, v1)) = (pairs[k - 1], pairs[k]);
    if w1 == w0 {
        v1
    } else {
        v0 + (v1 - v0) * (lambda - w0) / (w1 - w0)
    }
}

/// The linear-sRGB colour of `spectrum` (a function of the wavelength in nm), read as light
/// (`emitter`) or as a reflectance, before clamping.
fn colour_of(spectrum: impl Fn(f64) -> f64, emitter: bool) -> Vec3 {
    let (mut xyz, mut norm) = (glam::DVec3::ZERO, 0.0);
    for lambda in RANGE.0..=RANGE.1 {
        let lambda = lambda as f64;
        let cmf = cie_xyz(lambda as f32).as_dvec3();
        let light = if emitter { 1.0 } else { d65(lambda) };
        xyz += cmf * (light * spectrum(lambda));
        norm += cmf.y * light;
    }
    xyz_to_linear_srgb((xyz / norm).as_vec3())
}

/// Mitsuba 3's RGB of a spectrum of `wavelength:value` pairs (sorted by wavelength, at least
/// one), inside an emitter or not, with whether a channel was clamped.
pub fn sampled(pairs: &[(f64, f64)], emitter: bool) -> ([f64; 3], bool) {
    clamp(colour_of(|l| interpolate(pairs, l), emitter), emitter)
}

/// Mitsuba 3's RGB of a constant spectrum `value`: grey for a reflectance, `value` times the
/// colour of the equal-energy illuminant E inside an emitter.
pub fn constant(value: f64, emitter: bool) -> [f64; 3] {
    if emitter {
        let e = colour_of(|_| 1.0, true).as_dvec3();
        (e * value).to_array()
    } else {
        [value; 3]
    }
}

/// Negative channels to 0, and a reflectance's channels to at most 1.
fn clamp(c: Vec3, emitter: bool) -> ([f64; 3], bool) {
    let high = if emitter { f32::INFINITY } else { 1.0 };
    let clamped = c.clamp(Vec3::ZERO, Vec3::splat(high));
    (clamped.as_dvec3().to_array(), clamped != c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Colours Mitsuba 3.9.1 (`scalar_rgb`) made of the same spectra, read back with
    /// `mi.traverse` (and `mi.spectrum_list_to_srgb`).
    #[test]
    fn spectra_read_as_mitsuba_3_reads_them() {
        let close = |a: [f64; 3], b: [f64; 3], what: &str| {
            for k in 0..3 {
                assert!(
                    (a[k] - b[k]).abs() <= 0.01 * b[k].abs().max(0.1),
                    "{what}: {a:?} vs Mitsuba's {b:?}"
                );
            }
        };
        let pairs = [(400.0, 0.2), (500.0, 0.5), (600.0, 0.8), (700.0, 0.3)];
        let (reflectance, clamped) = sampled(&pairs, false);
        assert!(!clamped);
        close(reflectance, [0.75503, 0.641415, 0.323239], "reflectance");
        let light = [(400.0, 1.0), (500.0, 2.0), (600.0, 3.0), (700.0, 4.0)];
        close(sampled(&light, true).0, [4.02061, 2.31368, 1.24453], "radiance");
        close(constant(5.0, true), [6.02397, 4.74146, 4.54458], "constant radiance");
        assert_eq!(constant(0.4, false), [0.4; 3]);
        // A constant reflectance spectrum given as pairs over the whole range is white.
        close(sampled(&[(360.0, 1.0), (830.0, 1.0)], false).0, [0.998983, 0.998872, 0.998802], "white");
        // Green light between 500 and 600 nm only is outside sRGB's gamut: blue is clamped.
        let (green, clamped) = sampled(&[(500.0, 1.0), (600.0, 1.0)], true);
        assert!(clamped && green[2] == 0.0, "{green:?}");
    }
}
