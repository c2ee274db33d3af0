//! The [`Film`]: per-pixel f64 sums of the per-sample estimates, overall and per replica, by
//! sample index.

use super::*;
use crate::image::Image;
use crate::sampler::Replicas;
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
    /// How the sample indices split into independent replicas.
    pub replicas: Replicas,
    /// Per pixel and replica (pixel-major: pixel `p`'s replica `r` at `p·R + r`), the sum of the
    /// estimates of the replica's sample indices: the replicas' means give the variance.
    pub replica_sums: Vec<DVec3>,
    /// Per replica, the sample indices added to it.
    pub replica_samples: Vec<u32>,
    /// The first sample index of the film (0 but for a part of a larger render: a shard).
    pub first: u32,
    /// Sample indices added so far, `first..first + samples` (the driver advances it after
    /// each addition, [`Film::advance`]).
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
    /// Whether wavelengths are traced.
    pub spectral: bool,
    /// Seconds spent adding samples.
    pub seconds: f64,
}

impl Film {
    /// An empty film of the size of `camera`'s crop window ([`Film::new`]'s other arguments).
    pub fn of_crop(camera: &crate::camera::Camera, norm: f64, spectral: bool, replicas: Replicas) -> Film {
        Film::new(camera.crop.width as usize, camera.crop.height as usize, norm, spectral, replicas)
    }

    /// An empty film of `width × height` pixels whose sample indices split into `replicas`.
    pub fn new(width: usize, height: usize, norm: f64, spectral: bool, replicas: Replicas) -> Film {
        let r = replicas.count() as usize;
        Film {
            width,
            height,
            sum: vec![DVec3::ZERO; width * height],
            replicas,
            replica_sums: vec![DVec3::ZERO; width * height * r],
            replica_samples: vec![0; r],
            first: 0,
            samples: 0,
            norm,
            rays: RayCounts::default(),
            non_finite: 0,
            requests: DimensionRequests::default(),
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

    /// Adds the estimate `v` of sample index `s` to pixel `pixel`'s sums.
    #[inline]
    pub fn add(&mut self, pixel: usize, s: u32, v: DVec3) {
        let r = self.replicas.count() as usize;
        self.sum[pixel] += v;
        self.replica_sums[pixel * r + self.replicas.of(s) as usize] += v;
    }

    /// Counts the `n` sample indices from [`Film::next_sample`] on as added (to the film and to
    /// their replicas), once their estimates are in the sums.
    pub fn advance(&mut self, n: u32) {
        for s in self.next_sample()..self.next_sample() + n {
            self.replica_samples[self.replicas.of(s) as usize] += 1;
        }
        self.samples += n;
    }

    /// The mean per pixel (black before the first sample).
    pub fn image(&self) -> Image {
        let scale = 1.0 / (self.samples.max(1) as f64 * self.norm);
        let pixels = self.sum.iter().map(|s| (*s * scale).as_vec3()).collect();
        Image { width: self.width, height: self.height, pixels }
    }

    /// The means of the replicas that hold samples, `None` below two such replicas.
    pub fn replica_means(&self) -> Option<ReplicaMeans> {
        let r = self.replicas.count() as usize;
        let held: Vec<usize> = (0..r).filter(|&i| self.replica_samples[i] > 0).collect();
        if held.len() < 2 {
            return None;
        }
        let means = held
            .iter()
            .map(|&i| {
                let scale = 1.0 / (self.replica_samples[i] as f64 * self.norm);
                let pixels = (0..self.width * self.height)
                    .map(|p| (self.replica_sums[p * r + i] * scale).as_vec3())
                    .collect();
                Image { width: self.width, height: self.height, pixels }
            })
            .collect();
        Some(ReplicaMeans { means, samples: held.iter().map(|&i| self.replica_samples[i]).collect() })
    }

    /// The variance of each pixel's mean, from the spread of the replicas' means
    /// ([`ReplicaMeans::variance`]); `None` below two replicas with samples.
    pub fn variance(&self) -> Option<Image> {
        self.replica_means().map(|m| m.variance())
    }

    /// The render so far.
    pub fn output(&self) -> RenderOutput {
        let replicas = self.replica_means();
        RenderOutput {
            image: self.image(),
            spp: self.samples,
            seconds: self.seconds,
            rays: self.rays,
            non_finite_samples: self.non_finite,
            spectral: self.spectral,
            samples_per_pixel: None,
            variance: replicas.as_ref().map(ReplicaMeans::variance),
            replicas,
        }
    }
}
