#![allow(dead_code)] // each reference test uses a subset
//! A render against a reference at the noise level, for the reference tests
//! (`tests/mitsuba_reference.rs`, `tests/standard_scenes.rs`): the image means, and the relMSE of
//! the images averaged over square blocks of pixels, each judged in standard errors computed
//! from both images' per-pixel variances.
//!
//! With test image x and reference r, each pixel's mean and the variance of that mean (a
//! vitrum render's from its replicas, a Mitsuba reference's from the spread of its renders, an
//! image without one taken as exact):
//! - **Means.** m_x, m_r over the compared pixels and channels; the standard error of their
//!   difference is √(Σ v_x + Σ v_r) / n (pixels estimated independently, as they are with the
//!   independent sampler and with path tracing).
//! - **Block relMSE.** X and R are x and r averaged over b×b blocks (whole blocks only: pixels
//!   past the last whole block are left out; a block with a non-finite reference pixel is left
//!   out and counted); V = (Σ v_x + Σ v_r) / b⁴ is the variance of X − R. The relMSE is
//!   mean((X − R)² / (R² + 0.01)) over blocks and channels. Without a bias its expectation is
//!   the noise part N = mean(V / (R² + 0.01)), and its standard error √(Σ 2V² / (R² + 0.01)²) / n
//!   (each (X − R)² a scaled χ² of one degree of freedom). The excess (relMSE − N) in those
//!   standard errors is what the tests bound.

use glam::DVec3;
use std::path::Path;
use vitrum::render::RenderOutput;

/// An image with the variance of each pixel's mean.
#[derive(Clone, Debug)]
pub struct Noisy {
    /// Pixels across.
    pub width: usize,
    /// Pixels down.
    pub height: usize,
    /// Each pixel's mean, row by row from the top.
    pub pixels: Vec<DVec3>,
    /// The variance of each pixel's mean (zero: taken as exact).
    pub variance: Vec<DVec3>,
}

impl Noisy {
    /// A vitrum render with its replicas' variance.
    pub fn of(out: &RenderOutput) -> Noisy {
        let image = &out.image;
        let variance = out.variance.as_ref().expect("the render has replicas: a variance");
        Noisy {
            width: image.width,
            height: image.height,
            pixels: image.pixels.iter().map(|p| p.as_dvec3()).collect(),
            variance: variance.pixels.iter().map(|v| v.as_dvec3()).collect(),
        }
    }

    /// An EXR file's R, G, B and, when it has them, its `variance.R/G/B` channels (else exact).
    pub fn read(path: &Path) -> Noisy {
        let (image, _) =
            vitrum::output::exr::read_exr(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let variance = vitrum::output::exr::read_variance(path).unwrap();
        let n = image.pixels.len();
        Noisy {
            width: image.width,
            height: image.height,
            pixels: image.pixels.iter().map(|p| p.as_dvec3()).collect(),
            variance: variance
                .map_or(vec![DVec3::ZERO; n], |v| v.pixels.iter().map(|v| v.as_dvec3()).collect()),
        }
    }

    /// The image averaged over f×f pixel boxes (its size must be a multiple of f): the means
    /// averaged, the variances summed and divided by f⁴.
    pub fn downsample(&self, f: usize) -> Noisy {
        assert!(
            self.width.is_multiple_of(f) && self.height.is_multiple_of(f),
            "{}x{} by {f}",
            self.width,
            self.height
        );
        let (w, h) = (self.width / f, self.height / f);
        let mut pixels = vec![DVec3::ZERO; w * h];
        let mut variance = vec![DVec3::ZERO; w * h];
        for y in 0..self.height {
            for x in 0..self.width {
                let (i, o) = (y * self.width + x, (y / f) * w + x / f);
                pixels[o] += self.pixels[i];
                variance[o] += self.variance[i];
            }
        }
        let n = (f * f) as f64;
        pixels.iter_mut().for_each(|p| *p /= n);
        variance.iter_mut().for_each(|v| *v /= n * n);
        Noisy { width: w, height: h, pixels, variance }
    }

    /// [`downsample`](Self::downsample) of an image without a noise estimate (a published
    /// reference): each averaged pixel's variance is the spread of its `f`×`f` pixels around
    /// their mean over `f²` (the sample variance of a mean). The spread includes the image's own
    /// variation inside the block, so this bounds the noise from above: comparisons against it
    /// are no stricter than the reference's noise allows.
    pub fn downsample_with_spread(&self, f: usize) -> Noisy {
        let mut averaged = self.downsample(f);
        let w = averaged.width;
        let mut spread = vec![DVec3::ZERO; averaged.pixels.len()];
        for y in 0..self.height {
            for x in 0..self.width {
                let o = (y / f) * w + x / f;
                let d = self.pixels[y * self.width + x] - averaged.pixels[o];
                spread[o] += d * d;
            }
        }
        let n = (f * f) as f64;
        for (v, s) in averaged.variance.iter_mut().zip(spread) {
            *v += s / (n - 1.0) / n;
        }
        averaged
    }
}

/// What [`compare`] measured.
#[derive(Clone, Copy, Debug)]
pub struct Agreement {
    /// The test image's mean over the compared pixels and channels.
    pub mean_test: f64,
    /// The reference's.
    pub mean_reference: f64,
    /// The standard error of their difference.
    pub mean_se: f64,
    /// The block relMSE.
    pub rel_mse: f64,
    /// Its expectation from the noise alone.
    pub noise_rel_mse: f64,
    /// Its standard error under no bias.
    pub rel_mse_se: f64,
    /// Blocks compared.
    pub blocks: usize,
    /// Blocks left out for a non-finite reference pixel.
    pub non_finite_blocks: usize,
    /// The block side in pixels.
    pub block: usize,
}

impl Agreement {
    /// The difference of the means in standard errors.
    pub fn mean_z(&self) -> f64 {
        (self.mean_test - self.mean_reference) / self.mean_se.max(1e-300)
    }

    /// The excess of the block relMSE over its noise part, in standard errors.
    pub fn rel_mse_z(&self) -> f64 {
        (self.rel_mse - self.noise_rel_mse) / self.rel_mse_se.max(1e-300)
    }

    /// Whether both are within `z` standard errors (the relMSE only above: a relMSE below its
    /// noise part is no disagreement).
    pub fn within(&self, z: f64) -> bool {
        self.mean_z().abs() <= z && self.rel_mse_z() <= z
    }
}

impl std::fmt::Display for Agreement {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "mean {:.5} vs {:.5} (ratio {:.4}, {:+.1} SE of {:.2e}); {b}x{b}-block relMSE {:.3e}, noise part {:.3e}, {:+.1} SE of {:.2e} ({} blocks, {} left out: non-finite reference)",
            self.mean_test,
            self.mean_reference,
            self.mean_test / self.mean_reference,
            self.mean_z(),
            self.mean_se,
            self.rel_mse,
            self.noise_rel_mse,
            self.rel_mse_z(),
            self.rel_mse_se,
            self.blocks,
            self.non_finite_blocks,
            b = self.block
        )
    }
}

/// `test` against `reference` (the same size) over `block`×`block` blocks.
pub fn compare(test: &Noisy, reference: &Noisy, block: usize) -> Agreement {
    assert_eq!((test.width, test.height), (reference.width, reference.height), "image sizes");
    let (bw, bh) = (test.width / block, test.height / block);
    let (mut sum_t, mut sum_r, mut var_sum, mut pixels) = (0.0, 0.0, 0.0, 0usize);
    let (mut rel, mut noise, mut noise_var, mut terms) = (0.0, 0.0, 0.0, 0usize);
    let (mut blocks, mut non_finite_blocks) = (0, 0);
    let b4 = (block * block * block * block) as f64;
    for by in 0..bh {
        for bx in 0..bw {
            let (mut t, mut r, mut v) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
            let mut finite = true;
            for y in by * block..(by + 1) * block {
                for x in bx * block..(bx + 1) * block {
                    let i = y * test.width + x;
                    finite &= reference.pixels[i].is_finite() && reference.variance[i].is_finite();
                    t += test.pixels[i];
                    r += reference.pixels[i];
                    v += test.variance[i] + reference.variance[i];
                }
            }
            if !finite {
                non_finite_blocks += 1;
                continue;
            }
            assert!(t.is_finite() && v.is_finite(), "a non-finite test pixel in block ({bx}, {by})");
            blocks += 1;
            sum_t += t.element_sum();
            sum_r += r.element_sum();
            var_sum += v.element_sum();
            pixels += block * block;
            let n = (block * block) as f64;
            let (t, r, v) = (t / n, r / n, v / b4);
            for c in 0..3 {
                let d = r[c] * r[c] + 0.01;
                rel += (t[c] - r[c]).powi(2) / d;
                noise += v[c] / d;
                noise_var += 2.0 * (v[c] / d).powi(2);
                terms += 1;
            }
        }
    }
    let n = (3 * pixels) as f64;
    let terms_f = terms as f64;
    Agreement {
        mean_test: sum_t / n,
        mean_reference: sum_r / n,
        mean_se: var_sum.sqrt() / n,
        rel_mse: rel / terms_f,
        noise_rel_mse: noise / terms_f,
        rel_mse_se: noise_var.sqrt() / terms_f,
        blocks,
        non_finite_blocks,
        block,
    }
}
