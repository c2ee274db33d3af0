//! Deterministic random streams: every number is a pure function of
//! (seed, pixel, sample index, dimension), so images do not depend on thread count or order.

use glam::Vec2;

/// A random stream for one sample of one pixel; successive calls consume successive dimensions.
#[derive(Clone, Debug)]
pub struct Sampler {
    key: u64,
    dimension: u32,
}

/// SplitMix64 finaliser: a fast, well-mixed 64-bit hash.
#[inline]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl Sampler {
    /// The stream of sample `sample` of pixel `pixel` (row-major index) under `seed`.
    pub fn new(seed: u64, pixel: u64, sample: u64) -> Sampler {
        let key = mix64(
            mix64(mix64(seed ^ 0x5eed_5eed_5eed_5eed) ^ pixel) ^ sample.wrapping_mul(0x9e37_79b9_7f4a_7c15),
        );
        Sampler { key, dimension: 0 }
    }

    /// The value of dimension `dimension` of this stream, in [0, 1).
    pub fn value_at(&self, dimension: u32) -> f32 {
        let bits = mix64(self.key ^ (dimension as u64 + 1).wrapping_mul(0xd6e8_feb8_6659_fd93));
        // 24 high bits give every representable multiple of 2^-24 below 1.
        (bits >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

    /// The next dimension, in [0, 1).
    pub fn next_1d(&mut self) -> f32 {
        let v = self.value_at(self.dimension);
        self.dimension += 1;
        v
    }

    /// The next two dimensions, in [0, 1)².
    pub fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next_1d(), self.next_1d())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_pure_functions_of_their_key() {
        let mut a = Sampler::new(7, 123, 4);
        let mut b = Sampler::new(7, 123, 4);
        for _ in 0..16 {
            assert_eq!(a.next_1d(), b.next_1d());
        }
        assert_ne!(Sampler::new(7, 123, 4).next_1d(), Sampler::new(7, 124, 4).next_1d());
        assert_ne!(Sampler::new(7, 123, 4).next_1d(), Sampler::new(8, 123, 4).next_1d());
        assert_ne!(Sampler::new(7, 123, 4).next_1d(), Sampler::new(7, 123, 5).next_1d());
    }

    #[test]
    fn values_are_uniform_in_the_unit_interval() {
        // Chi-square over 16 equal bins, 16,000 values; the 99.9% quantile of χ²(15) is 37.7.
        let mut bins = [0u32; 16];
        for p in 0..1000u64 {
            let mut s = Sampler::new(1, p, 0);
            for _ in 0..16 {
                let v = s.next_1d();
                assert!((0.0..1.0).contains(&v));
                bins[(v * 16.0) as usize] += 1;
            }
        }
        let expected = 1000.0;
        let chi2: f64 = bins.iter().map(|&c| (c as f64 - expected).powi(2) / expected).sum();
        assert!(chi2 < 37.7, "chi2 = {chi2}");
    }
}
