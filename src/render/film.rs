//! The [`Film`]: per-pixel f64 sums of the per-sample estimates and of their squares, by sample index.

use super::*;
use crate::image::Image;
use crate::stats::RayCounts;
use glam::DVec3;
use std::ops::Range;

/// The running sums of a render: what a progressive render carries from pass to pass.
#[derive(Clone, Debug)]
pub struct Film {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Per pixel, the sum over sample indices of the per-sample estimates (before `norm`).
    pub sum: Vec<DVec3>,
    /// Per pixel, the sum of their squares.
    pub sum_sq: Vec<DVec3>,
    /// The first sample index of the film (0 but for a part of a larger render: a shard).
    pub first: u32,
    /// Sample indices added so far, `first..first + samples` (the driver advances it after
    /// each addition).
    pub samples: u32,
    /// A pixel's estimate is `sum / (samples · norm)`: 1 for the camera pass, the film area for
    /// light tracing.
    pub norm: f64,
    /// Rays traced, by kind.
    pub rays: RayCounts,
    /// Samples (or light paths' splats) that were NaN or infinite.
    pub non_finite: u64,
    /// Sampler requests per purpose (camera pass only).
    pub requests: DimensionRequests,
    /// How full the wavefront engine's lanes were, by stage (camera pass with it only).
    pub occupancy: crate::integrators::StageOccupancy,
    /// Whether wavelengths are traced.
    pub spectral: bool,
    /// Seconds spent adding samples.
    pub seconds: f64,
}

/// `x` clamped below at 0 per channel, NaN kept (a NaN must never turn into a clean 0).
pub(super) fn non_negative(v: DVec3) -> DVec3 {
    let f = |x: f64| if x < 0.0 { 0.0 } else { x };
    DVec3::new(f(v.x), f(v.y), f(v.z))
}

impl Film {
    /// An empty film of `width × height` pixels.
    pub fn new(width: usize, height: usize, norm: f64, spectral: bool) -> Film {
        Film {
            width,
            height,
            sum: vec![DVec3::ZERO; width * height],
            sum_sq: vec![DVec3::ZERO; width * height],
            first: 0,
            samples: 0,
            norm,
            rays: RayCounts::default(),
            non_finite: 0,
            requests: DimensionRequests::default(),
            occupancy: Default::default(),
            spectral,
            seconds: 0.0,
        }
    }

    /// The sample index the next addition starts at.
    pub fn next_sample(&self) -> u32 {
        self.first + self.samples
    }

    /// The sample indices added so far.
    pub fn sample_range(&self) -> Range<u32> {
        self.first..self.next_sample()
    }

    /// The mean per pixel (black before the first sample).
    pub fn image(&self) -> Image {
        let scale = 1.0 / (self.samples.max(1) as f64 * self.norm);
        let pixels = self.sum.iter().map(|s| (*s * scale).as_vec3()).collect();
        Image { width: self.width, height: self.height, pixels }
    }

    /// The variance of each pixel's mean, s²/n; `None` below two samples.
    pub fn variance(&self) -> Option<Image> {
        if self.samples < 2 {
            return None;
        }
        let n = self.samples as f64;
        let scale = 1.0 / (self.norm * self.norm * n * (n - 1.0));
        let pixels = self
            .sum
            .iter()
            .zip(&self.sum_sq)
            .map(|(s, q)| (non_negative(*q - *s * *s / n) * scale).as_vec3())
            .collect();
        Some(Image { width: self.width, height: self.height, pixels })
    }

    /// The render so far.
    pub fn output(&self) -> RenderOutput {
        RenderOutput {
            image: self.image(),
            spp: self.samples,
            seconds: self.seconds,
            rays: self.rays,
            non_finite_samples: self.non_finite,
            spectral: self.spectral,
            samples_per_pixel: None,
            variance: self.variance(),
        }
    }
}
