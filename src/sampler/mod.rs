//! Deterministic random streams: every number is a pure function of
//! (seed, pixel, sample index, dimension), so images do not depend on thread count or order,
//! any sample range can be rendered separately, and one sample can be re-run for debugging.
//! A render's sample index first goes to its replica ([`Replicas::stream`]): the seed is the
//! replica's and the index the sample's within the replica.
//!
//! Three kinds:
//! - `sobol` (the default): Owen-scrambled Sobol' points ([`sobol`]). Each request (a 1D or 2D
//!   dimension) draws from its own randomly shuffled and scrambled (0, 2)-sequence, seeded by
//!   (seed, pixel, dimension), so a pixel's first 2^m samples are a (0, m, 2)-net in every 2D
//!   request and well stratified in every 1D one, whatever the sample count: the stream does not
//!   depend on the planned count, so renders are progressive (the first k samples of an
//!   n-sample render are a k-sample render) and time budgets are stratified too.
//! - `stratified` (jittered): for each dimension of a pixel, the pixel's samples fall in distinct
//!   strata, assigned to sample indices by a pseudo-random permutation per (pixel, dimension)
//!   (Kensler 2013), so no table is stored and the value of sample *s* is still a pure function
//!   of its key. Two-dimensional requests use an m×m grid when the sample count is a perfect
//!   square and Latin-hypercube strata otherwise. It needs the sample count in advance.
//! - `independent`: uniform random numbers.
//!
//! A fourth stream serves Metropolis light transport ([`Sampler::primary`]): its numbers are
//! those of a Markov chain's primary sample vector ([`primary`]), which the chain mutates.
//!
//! Every request names its purpose ([`Dim`]); the sampler counts requests per purpose so tests
//! can prove that a scene without depth of field, motion or dispersion never draws lens, time or
//! wavelength numbers.

pub mod primary;
pub mod sobol;

use glam::Vec2;

/// What a random number is for (the order of consumption is the stream's dimension order).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dim {
    /// Position inside the pixel.
    Pixel = 0,
    /// Point on the thin lens.
    Lens = 1,
    /// Time within the shutter interval.
    Time = 2,
    /// Wavelength for spectral rendering.
    Wavelength = 3,
    /// Choice of a light and a point on it.
    Light = 4,
    /// Choice of a scattering direction.
    Bsdf = 5,
    /// Anything else (Russian roulette, …).
    Other = 6,
}

/// Number of [`Dim`] purposes.
pub const DIM_PURPOSES: usize = 7;

/// How sample values are distributed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SamplerKind {
    /// Uniform independent random numbers.
    Independent,
    /// Jittered strata per pixel and dimension.
    Stratified,
    /// Owen-scrambled Sobol' points, progressive.
    #[default]
    Sobol,
}

impl SamplerKind {
    /// Every kind, in the order the command line lists them.
    pub const ALL: [SamplerKind; 3] = [SamplerKind::Sobol, SamplerKind::Stratified, SamplerKind::Independent];

    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Independent => "independent",
            SamplerKind::Stratified => "stratified",
            SamplerKind::Sobol => "sobol",
        }
    }

    /// Parse a command-line name.
    pub fn from_name(name: &str) -> Option<SamplerKind> {
        SamplerKind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Whether the stream of a sample depends on the planned sample count (only stratified
    /// does): otherwise the first k samples of any render are a k-sample render.
    pub fn needs_count(self) -> bool {
        self == SamplerKind::Stratified
    }
}

/// How a render's sample indices split into independent randomisations (randomised quasi-Monte
/// Carlo, L'Ecuyer): sample index `s` belongs to replica `s mod R` and is sample `s div R` of it.
/// Each replica draws every stream from a seed of its own ([`Replicas::stream`]), so the replicas
/// are independent renders of `⌈n/R⌉` or `⌊n/R⌋` samples each, every one stratified by the
/// Sobol' or stratified sampler on its own. Their means give the variance of the whole render's
/// mean without assuming its samples independent: the spread of R independent estimates is an
/// unbiased estimate of their variance, stratification included (`crate::render`).
///
/// Interleaving the replicas by index keeps renders progressive (after any n samples every
/// replica has its share), time budgets and interrupts exact, and shards of any range complete
/// (a range covers all replicas). With R = 1 the mapping is the identity: the render's own seed
/// and indices, a single randomisation with no variance estimate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Replicas(u32);

/// Where a sample index of a render draws its numbers: its replica's seed, its index within the
/// replica and the replica's planned sample count (0 when unknown).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleStream {
    /// The seed of the sample's replica.
    pub seed: u64,
    /// The sample's index within its replica.
    pub index: u32,
    /// The replica's planned sample count (for the stratified sampler), 0 when unknown.
    pub count: u32,
}

impl Replicas {
    /// The default replica count: 8 gives a variance estimate of 7 degrees of freedom per pixel
    /// and costs 8 × 24 bytes per pixel of film.
    pub const DEFAULT: Replicas = Replicas(8);
    /// The largest replica count accepted.
    pub const MAX: u32 = 64;

    /// `count` replicas, `None` outside 1..=[`Replicas::MAX`].
    pub fn new(count: u32) -> Option<Replicas> {
        (1..=Replicas::MAX).contains(&count).then_some(Replicas(count))
    }

    /// The number of replicas.
    pub fn count(self) -> u32 {
        self.0
    }

    /// The replica of sample index `s`.
    #[inline(always)]
    pub fn of(self, s: u32) -> u32 {
        s % self.0
    }

    /// How many of the sample indices `0..total` replica `r` holds.
    pub fn samples_in(self, r: u32, total: u32) -> u32 {
        total / self.0 + u32::from(r < total % self.0)
    }

    /// How many of the sample indices `range` replica `r` holds.
    pub fn samples_in_range(self, r: u32, range: std::ops::Range<u32>) -> u32 {
        self.samples_in(r, range.end) - self.samples_in(r, range.start.min(range.end))
    }

    /// Where sample index `s` of a render under `seed` (of `total` planned, 0 when unknown)
    /// draws its numbers.
    #[inline(always)]
    pub fn stream(self, seed: u64, s: u32, total: u32) -> SampleStream {
        let r = self.of(s);
        // Replica 0 keeps the render's seed, so one replica is the plain render.
        let seed = if r == 0 { seed } else { mix64(seed ^ (r as u64).wrapping_mul(0x2545_f491_4f6c_dd1d)) };
        SampleStream {
            seed,
            index: s / self.0,
            count: if total == 0 { 0 } else { self.samples_in(r, total) },
        }
    }
}

impl Default for Replicas {
    fn default() -> Replicas {
        Replicas::DEFAULT
    }
}

/// A random stream for one sample of one pixel; successive calls consume successive dimensions.
#[derive(Clone, Debug)]
pub struct Sampler {
    pixel_key: u64,
    sample_key: u64,
    sample: u32,
    /// `sample.reverse_bits()`, the form the Sobol' index shuffle starts from.
    reversed_sample: u32,
    samples_per_pixel: u32,
    /// What the stream draws: stratified only with a known count above 1.
    mode: Mode,
    /// The side of the 2D stratification grid when the count is a perfect square, else 0.
    grid_side: u32,
    dimension: u32,
    requests: [u32; DIM_PURPOSES],
}

/// The stream a [`Sampler`] draws from, resolved once from its kind and sample count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    Independent,
    Stratified,
    Sobol,
    /// The numbers of this thread's Markov chain ([`primary::with_primary`]): request `d`
    /// reads the vector's dimension `d · streams + stream` (one of `streams` interleaved
    /// streams, as pbrt-v4's `MLTSampler` keeps the camera's, the light's and the
    /// connection's numbers apart).
    /// (Bytes, so that the mode stays within the sampler's padding.)
    Primary {
        stream: u8,
        streams: u8,
    },
}

/// Lowbias32 (Wellons): a fast, well-mixed 32-bit hash.
#[inline(always)]
fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// SplitMix64 finaliser: a fast, well-mixed 64-bit hash.
#[inline(always)]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A uniform number in [0, 1) from the high 24 bits of a hash.
#[inline]
fn unit(bits: u64) -> f32 {
    (bits >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

/// Kensler's hash-based permutation of [0, n): element `i` of permutation `seed`.
#[inline]
fn permute(mut i: u32, n: u32, seed: u32) -> u32 {
    let mut w = n - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    loop {
        i ^= seed;
        i = i.wrapping_mul(0xe170893d);
        i ^= seed >> 16;
        i ^= (i & w) >> 4;
        i ^= seed >> 8;
        i = i.wrapping_mul(0x0929eb3f);
        i ^= seed >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | seed >> 27);
        i = i.wrapping_mul(0x6935fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dcb303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e501cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860a3df);
        i &= w;
        i ^= i >> 5;
        if i < n {
            return (i.wrapping_add(seed)) % n;
        }
    }
}

impl Sampler {
    /// The stream of sample `sample` (of `samples_per_pixel`) of pixel `pixel` (row-major
    /// index) under `seed`. Stratification needs the sample count; with 0 (unknown, as in
    /// time-budget renders) or 1 the stream is independent.
    pub fn new(kind: SamplerKind, seed: u64, pixel: u64, sample: u32, samples_per_pixel: u32) -> Sampler {
        let pixel_key = pixel_key(seed, pixel);
        let mode = match kind {
            SamplerKind::Stratified if samples_per_pixel > 1 => Mode::Stratified,
            SamplerKind::Stratified | SamplerKind::Independent => Mode::Independent,
            SamplerKind::Sobol => Mode::Sobol,
        };
        // The jitter's key and the strata's grid serve the hashed kinds only.
        let sample_key = match mode {
            Mode::Sobol => 0,
            _ => mix64(pixel_key ^ (sample as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)),
        };
        let m = if mode == Mode::Stratified { (samples_per_pixel as f64).sqrt() as u32 } else { 0 };
        Sampler {
            pixel_key,
            sample_key,
            sample,
            reversed_sample: sample.reverse_bits(),
            samples_per_pixel,
            mode,
            grid_side: if m * m == samples_per_pixel { m } else { 0 },
            dimension: 0,
            requests: [0; DIM_PURPOSES],
        }
    }

    /// The stream of pixel (or path) `pixel` at `stream` (a sample index placed in its replica
    /// by [`Replicas::stream`]).
    #[inline]
    pub fn of_stream(kind: SamplerKind, stream: SampleStream, pixel: u64) -> Sampler {
        Sampler::new(kind, stream.seed, pixel, stream.index, stream.count)
    }

    /// The stream of a Metropolis chain's primary sample vector: request `d` (1D, or 2D at `d`
    /// and `d + 1`) reads dimension `d` of the vector that [`primary::with_primary`] installs
    /// on this thread, mutated as the chain's current proposal asks.
    pub fn primary() -> Sampler {
        Sampler::primary_stream(0, 1)
    }

    /// Stream `stream` of `streams` (> `stream`) interleaved in a Metropolis chain's primary
    /// sample vector: its request `d` reads dimension `d · streams + stream`, so the streams
    /// draw disjoint numbers and each stream's numbers do not move when another draws more
    /// (multiplexed MLT's camera, light and connection streams). `primary_stream(0, 1)` is
    /// [`Sampler::primary`].
    pub fn primary_stream(stream: u32, streams: u32) -> Sampler {
        debug_assert!(stream < streams && streams <= u8::MAX as u32, "stream {stream} of {streams}");
        Sampler {
            pixel_key: 0,
            sample_key: 0,
            sample: 0,
            reversed_sample: 0,
            samples_per_pixel: 0,
            mode: Mode::Primary { stream: stream as u8, streams: streams as u8 },
            grid_side: 0,
            dimension: 0,
            requests: [0; DIM_PURPOSES],
        }
    }

    /// An independent stream (used where no stratification applies, e.g. tests).
    pub fn independent(seed: u64, pixel: u64, sample: u32) -> Sampler {
        Sampler::new(SamplerKind::Independent, seed, pixel, sample, 0)
    }

    /// The jitter value of dimension `d` for this sample, in [0, 1).
    #[inline]
    fn jitter(&self, d: u32) -> f32 {
        unit(mix64(self.sample_key ^ (d as u64 + 1).wrapping_mul(0xd6e8_feb8_6659_fd93)))
    }

    /// This sample's stratum among `n` in dimension `d`.
    #[inline]
    fn stratum(&self, d: u32, n: u32) -> u32 {
        let seed = mix64(self.pixel_key ^ (d as u64 + 1).wrapping_mul(0xa076_1d64_78bd_642f)) as u32;
        permute(self.sample % n, n, seed)
    }

    /// The next dimension, in [0, 1), for `purpose`.
    pub fn get_1d(&mut self, purpose: Dim) -> f32 {
        self.requests[purpose as usize] += 1;
        let d = self.dimension;
        self.dimension += 1;
        match self.mode {
            Mode::Independent => self.jitter(d),
            Mode::Stratified => {
                let n = self.samples_per_pixel;
                ((self.stratum(d, n) as f32 + self.jitter(d)) / n as f32).min(ONE_MINUS_EPSILON)
            }
            Mode::Sobol => sobol_first(self.pixel_key, self.reversed_sample, d),
            Mode::Primary { stream, streams } => primary::draw(d * streams as u32 + stream as u32),
        }
    }

    /// The next two dimensions, in [0, 1)², for `purpose`.
    pub fn get_2d(&mut self, purpose: Dim) -> Vec2 {
        self.requests[purpose as usize] += 1;
        let d = self.dimension;
        self.dimension += 2;
        match self.mode {
            Mode::Independent => Vec2::new(self.jitter(d), self.jitter(d + 1)),
            Mode::Stratified => {
                let (jx, jy) = (self.jitter(d), self.jitter(d + 1));
                let n = self.samples_per_pixel;
                let m = self.grid_side;
                let (sx, sy, nx, ny) = if m > 0 {
                    let s = self.stratum(d, n);
                    (s % m, s / m, m, m)
                } else {
                    (self.stratum(d, n), self.stratum(d + 1, n), n, n)
                };
                Vec2::new(
                    ((sx as f32 + jx) / nx as f32).min(ONE_MINUS_EPSILON),
                    ((sy as f32 + jy) / ny as f32).min(ONE_MINUS_EPSILON),
                )
            }
            Mode::Sobol => {
                let (x, y) = sobol_pair(self.pixel_key, self.reversed_sample, d);
                Vec2::new(x, y)
            }
            Mode::Primary { stream, streams } => {
                let (k, n) = (stream as u32, streams as u32);
                Vec2::new(primary::draw(d * n + k), primary::draw((d + 1) * n + k))
            }
        }
    }

    /// Continues the stream after numbers drawn from its [`sobol_state`](Self::sobol_state)
    /// elsewhere (across lanes): at dimension `dimension`, with `requests` more requests per
    /// purpose.
    #[inline]
    pub fn resume(&mut self, dimension: u32, requests: &[u32; DIM_PURPOSES]) {
        debug_assert!(dimension >= self.dimension, "a stream only moves on");
        self.dimension = dimension;
        for (total, n) in self.requests.iter_mut().zip(requests) {
            *total += n;
        }
    }

    /// The next dimension the stream draws.
    #[inline]
    pub fn dimension(&self) -> u32 {
        self.dimension
    }

    /// Draws again from `dimension` on (one it has passed): the numbers it drew from there, in
    /// the same order (a branch of a path that replays the numbers of another).
    #[inline]
    pub fn replay_from(&mut self, dimension: u32) {
        self.dimension = dimension;
    }

    /// The Sobol' stream's state, what its numbers across lanes depend on
    /// ([`crate::lanes::sobol_pairs`]); `None` for the other kinds.
    pub fn sobol_state(&self) -> Option<SobolState> {
        (self.mode == Mode::Sobol).then_some(SobolState {
            pixel_key: self.pixel_key,
            reversed_sample: self.reversed_sample,
            dimension: self.dimension,
        })
    }

    /// How many requests were made for `purpose` so far.
    pub fn requests(&self, purpose: Dim) -> u32 {
        self.requests[purpose as usize]
    }
}

/// What a Sobol' stream's numbers depend on: the pixel's key, the bit-reversed sample index and
/// the next dimension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SobolState {
    /// Hash of (seed, pixel).
    pub pixel_key: u64,
    /// The sample index, bit-reversed.
    pub reversed_sample: u32,
    /// The next dimension.
    pub dimension: u32,
}

/// The key of pixel `pixel`'s streams under `seed` (what every request of its samples hashes).
#[inline(always)]
pub(crate) fn pixel_key(seed: u64, pixel: u64) -> u64 {
    mix64(mix64(seed ^ 0x5eed_5eed_5eed_5eed) ^ pixel)
}

/// The three hash seeds of the Sobol' request at dimension `d` of the pixel with key
/// `pixel_key`: the index shuffle and the scrambles of the two coordinates.
#[inline(always)]
fn sobol_seeds(pixel_key: u64, d: u32) -> (u32, u32, u32) {
    let h = mix64(pixel_key ^ (d as u64 + 1).wrapping_mul(0xa076_1d64_78bd_642f));
    (h as u32, (h >> 32) as u32, hash32(h as u32 ^ 0x2f6b_45c3))
}

/// The one-dimensional Sobol' request at dimension `d` of the stream (`pixel_key`,
/// `reversed_sample`): the first coordinate of the two-dimensional one, [`sobol_pair`].
#[inline(always)]
pub(crate) fn sobol_first(pixel_key: u64, reversed_sample: u32, d: u32) -> f32 {
    let (shuffle, x, _) = sobol_seeds(pixel_key, d);
    let index = sobol::shuffle_reversed(reversed_sample, shuffle).reverse_bits();
    sobol::to_unit(sobol::scrambled_dim0(index, x))
}

/// The two-dimensional Sobol' request at dimension `d` of the stream (`pixel_key`,
/// `reversed_sample`). Plain integer arithmetic with no branches: the lane form of the stream
/// runs it in a loop that vectorises.
#[inline(always)]
pub(crate) fn sobol_pair(pixel_key: u64, reversed_sample: u32, d: u32) -> (f32, f32) {
    let (shuffle, x, y) = sobol_seeds(pixel_key, d);
    // The shuffled index is kept bit-reversed too: the second coordinate needs only that form
    // (three bit reversals per request instead of five).
    let reversed_index = sobol::shuffle_reversed(reversed_sample, shuffle);
    (
        sobol::to_unit(sobol::scrambled_dim0(reversed_index.reverse_bits(), x)),
        sobol::to_unit(sobol::scrambled_dim1_of_reversed(reversed_index, y)),
    )
}

/// The largest f32 below 1.
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_pure_functions_of_their_key() {
        for kind in SamplerKind::ALL {
            let mut a = Sampler::new(kind, 7, 123, 4, 16);
            let mut b = Sampler::new(kind, 7, 123, 4, 16);
            for _ in 0..16 {
                assert_eq!(a.get_1d(Dim::Other), b.get_1d(Dim::Other));
                assert_eq!(a.get_2d(Dim::Bsdf), b.get_2d(Dim::Bsdf));
            }
            let first = |seed, pixel, sample| Sampler::new(kind, seed, pixel, sample, 16).get_1d(Dim::Other);
            assert_ne!(first(7, 123, 4), first(7, 124, 4));
            assert_ne!(first(7, 123, 4), first(8, 123, 4));
            assert_ne!(first(7, 123, 4), first(7, 123, 5));
        }
    }

    /// χ² statistic of counts against a uniform expectation.
    fn chi2(counts: &[u32]) -> f64 {
        let expected = counts.iter().sum::<u32>() as f64 / counts.len() as f64;
        counts.iter().map(|&c| (c as f64 - expected).powi(2) / expected).sum()
    }

    #[test]
    fn independent_values_are_uniform() {
        // 16 bins, 64,000 values; the 99.9% quantile of χ²(15) is 37.7.
        let mut bins = [0u32; 16];
        for p in 0..4000u64 {
            let mut s = Sampler::independent(1, p, 0);
            for _ in 0..16 {
                let v = s.get_1d(Dim::Other);
                assert!((0.0..1.0).contains(&v));
                bins[(v * 16.0) as usize] += 1;
            }
        }
        assert!(chi2(&bins) < 37.7, "chi2 = {}", chi2(&bins));
    }

    #[test]
    fn stratified_samples_fill_every_stratum_exactly_once() {
        for n in [4u32, 9, 16, 7, 12] {
            for pixel in 0..20u64 {
                let mut cells_1d = vec![0u32; n as usize];
                let m = (n as f64).sqrt() as u32;
                let mut cells_2d = vec![0u32; n as usize];
                let mut rows = vec![0u32; n as usize];
                for s in 0..n {
                    let mut smp = Sampler::new(SamplerKind::Stratified, 3, pixel, s, n);
                    let v = smp.get_1d(Dim::Other);
                    cells_1d[(v * n as f32) as usize] += 1;
                    let p = smp.get_2d(Dim::Pixel);
                    if m * m == n {
                        cells_2d[(p.y * m as f32) as usize * m as usize + (p.x * m as f32) as usize] += 1;
                    } else {
                        cells_2d[(p.x * n as f32) as usize] += 1;
                        rows[(p.y * n as f32) as usize] += 1;
                    }
                }
                assert!(cells_1d.iter().all(|&c| c == 1), "n {n}: {cells_1d:?}");
                assert!(cells_2d.iter().all(|&c| c == 1), "n {n}: {cells_2d:?}");
                if m * m != n {
                    assert!(rows.iter().all(|&c| c == 1), "n {n}: {rows:?}");
                }
            }
        }
    }

    #[test]
    fn stratified_values_are_uniform_over_many_pixels() {
        let mut bins = [0u32; 16];
        for p in 0..1000u64 {
            for s in 0..16 {
                let mut smp = Sampler::new(SamplerKind::Stratified, 5, p, s, 16);
                smp.get_1d(Dim::Other);
                let v = smp.get_2d(Dim::Light);
                bins[(v.x * 4.0) as usize * 4 + (v.y * 4.0) as usize] += 1;
            }
        }
        // every pixel puts exactly one sample in each 4×4 cell
        assert!(bins.iter().all(|&c| c == 1000), "{bins:?}");
    }

    #[test]
    fn stratification_reduces_the_error_of_a_smooth_integral() {
        // ∫∫ x·y = 1/4 with 16 samples per pixel: stratified error far below independent.
        let mean_sq_err = |kind| {
            let mut total = 0.0f64;
            for p in 0..500u64 {
                let mut est = 0.0f64;
                for s in 0..16 {
                    let v = Sampler::new(kind, 9, p, s, 16).get_2d(Dim::Pixel);
                    est += (v.x * v.y) as f64 / 16.0;
                }
                total += (est - 0.25).powi(2);
            }
            total / 500.0
        };
        let (ind, strat) = (mean_sq_err(SamplerKind::Independent), mean_sq_err(SamplerKind::Stratified));
        assert!(strat < ind / 4.0, "independent {ind}, stratified {strat}");
    }

    #[test]
    fn sobol_pixels_are_nets_in_every_request() {
        // For 2^m samples, every 2D request of a pixel puts exactly one point in every
        // elementary interval of area 2^-m (2^k × 2^(m-k) cells, every k): a (0, m, 2)-net; every
        // 1D request one point in each of the 2^m strata. The stream ignores the planned count.
        for m in [2u32, 4, 5] {
            let n = 1u32 << m;
            for pixel in 0..50u64 {
                let samples: Vec<(f32, Vec2, Vec2)> = (0..n)
                    .map(|s| {
                        let mut smp =
                            Sampler::new(SamplerKind::Sobol, 11, pixel, s, [0, n, 3 * n][pixel as usize % 3]);
                        (smp.get_1d(Dim::Light), smp.get_2d(Dim::Pixel), smp.get_2d(Dim::Bsdf))
                    })
                    .collect();
                let mut strata = vec![0u32; n as usize];
                for &(v, _, _) in &samples {
                    strata[(v * n as f32) as usize] += 1;
                }
                assert!(strata.iter().all(|&c| c == 1), "m {m} pixel {pixel}: {strata:?}");
                for k in 0..=m {
                    let (nx, ny) = (1u32 << k, 1u32 << (m - k));
                    for pick in [|t: &(f32, Vec2, Vec2)| t.1, |t: &(f32, Vec2, Vec2)| t.2] {
                        let mut cells = vec![0u32; n as usize];
                        for t in &samples {
                            let p = pick(t);
                            cells[(p.y * ny as f32) as usize * nx as usize + (p.x * nx as f32) as usize] += 1;
                        }
                        assert!(cells.iter().all(|&c| c == 1), "m {m} k {k} pixel {pixel}: {cells:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn sobol_values_are_uniform_and_decorrelated_across_requests() {
        // Over many pixels: the first sample's 2D values fill 8×8 cells uniformly (χ²(63), 99.9%
        // quantile 103.4), and two successive 2D requests of one sample are independent (their
        // x values fill a joint 8×8 table uniformly).
        let (mut cells, mut joint) = ([0u32; 64], [0u32; 64]);
        for pixel in 0..16_000u64 {
            let mut smp = Sampler::new(SamplerKind::Sobol, 2, pixel, 0, 0);
            let a = smp.get_2d(Dim::Pixel);
            let b = smp.get_2d(Dim::Light);
            assert!((0.0..1.0).contains(&a.x) && (0.0..1.0).contains(&a.y));
            cells[(a.y * 8.0) as usize * 8 + (a.x * 8.0) as usize] += 1;
            joint[(a.x * 8.0) as usize * 8 + (b.x * 8.0) as usize] += 1;
        }
        assert!(chi2(&cells) < 103.4, "chi2 = {}", chi2(&cells));
        assert!(chi2(&joint) < 103.4, "chi2 = {}", chi2(&joint));
    }

    #[test]
    fn sobol_lowers_the_error_of_a_smooth_integral_below_stratified() {
        // ∫∫ x·y = 1/4 with 16 samples per pixel: a (0, 4, 2)-net beats jittered 4×4 strata.
        let mean_sq_err = |kind| {
            let mut total = 0.0f64;
            for p in 0..2000u64 {
                let est: f64 = (0..16)
                    .map(|s| {
                        let v = Sampler::new(kind, 9, p, s, 16).get_2d(Dim::Pixel);
                        (v.x * v.y) as f64 / 16.0
                    })
                    .sum();
                total += (est - 0.25).powi(2);
            }
            total / 2000.0
        };
        let (strat, sobol) = (mean_sq_err(SamplerKind::Stratified), mean_sq_err(SamplerKind::Sobol));
        assert!(sobol < strat, "stratified {strat}, sobol {sobol}");
    }

    #[test]
    fn sobol_values_follow_the_plain_definition() {
        // Pins the stream: each request is the Owen-scrambled Sobol' point at the shuffled index,
        // with the seeds of its dimension (computed here by the plain, reversal-heavy forms).
        for (pixel, sample) in [(0u64, 0u32), (5, 3), (123_456, 1000), (7, u32::MAX)] {
            let mut smp = Sampler::new(SamplerKind::Sobol, 42, pixel, sample, 0);
            let reference = Sampler::new(SamplerKind::Sobol, 42, pixel, sample, 0);
            let v1 = smp.get_1d(Dim::Light);
            let v2 = smp.get_2d(Dim::Bsdf);
            let (shuffle, x, _) = sobol_seeds(reference.pixel_key, 0);
            let index = sobol::shuffle(sample, shuffle);
            assert_eq!(v1, sobol::to_unit(sobol::owen_scramble(index.reverse_bits(), x)));
            let (shuffle, x, y) = sobol_seeds(reference.pixel_key, 1);
            let index = sobol::shuffle(sample, shuffle);
            assert_eq!(v2.x, sobol::to_unit(sobol::owen_scramble(index.reverse_bits(), x)));
            assert_eq!(v2.y, sobol::to_unit(sobol::owen_scramble(sobol::sobol_dim1(index), y)));
        }
    }

    #[test]
    fn requests_are_counted_by_purpose() {
        let mut s = Sampler::new(SamplerKind::Stratified, 0, 0, 0, 4);
        s.get_2d(Dim::Pixel);
        s.get_1d(Dim::Light);
        s.get_2d(Dim::Light);
        assert_eq!(s.requests(Dim::Pixel), 1);
        assert_eq!(s.requests(Dim::Light), 2);
        assert_eq!(s.requests(Dim::Lens), 0);
        assert_eq!(s.requests(Dim::Time), 0);
        assert_eq!(s.requests(Dim::Wavelength), 0);
    }
}
