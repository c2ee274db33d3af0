//! Owen-scrambled Sobol' numbers across lanes: the scalar stream's own function
//! ([`crate::sampler::Sampler::get_2d`]'s) in a loop over [`WIDTH`] lanes, each lane with its
//! own pixel, sample and dimension. Integer arithmetic only, so every lane's pair is the scalar
//! stream's to the bit.

// Lane loops index several arrays by the lane, as the kernels they vectorise into do.
#![allow(clippy::needless_range_loop)]

use super::{dispatch, Lanes, WIDTH};
use crate::sampler::{sobol_first, sobol_pair};

/// The kernel: lane `k` draws dimension `dims[k]` of the stream (`keys[k]`, `reversed[k]`).
#[inline(always)]
fn sobol_kernel(keys: &[u64; WIDTH], reversed: &[u32; WIDTH], dims: &[u32; WIDTH]) -> (Lanes, Lanes) {
    let (mut x, mut y) = ([0.0; WIDTH], [0.0; WIDTH]);
    for k in 0..WIDTH {
        (x[k], y[k]) = sobol_pair(keys[k], reversed[k], dims[k]);
    }
    (x, y)
}

dispatch! {
    /// The two-dimensional Sobol' request at dimension `dims[k]` of the stream of pixel key
    /// `keys[k]` and bit-reversed sample index `reversed[k]`, for every lane `k` (see
    /// [`crate::sampler::SobolState`]); a one-dimensional request's number is the first.
    pub fn sobol_pairs(keys: &[u64; WIDTH], reversed: &[u32; WIDTH], dims: &[u32; WIDTH]) -> (Lanes, Lanes) => sobol_kernel
}

/// The one-dimensional kernel: lane `k` draws dimension `dims[k]`.
#[inline(always)]
fn sobol_first_kernel(keys: &[u64; WIDTH], reversed: &[u32; WIDTH], dims: &[u32; WIDTH]) -> Lanes {
    let mut x = [0.0; WIDTH];
    for k in 0..WIDTH {
        x[k] = sobol_first(keys[k], reversed[k], dims[k]);
    }
    x
}

dispatch! {
    /// The one-dimensional Sobol' request at dimension `dims[k]` of every lane's stream (the
    /// first number of [`sobol_pairs`], without the second).
    pub fn sobol_firsts(keys: &[u64; WIDTH], reversed: &[u32; WIDTH], dims: &[u32; WIDTH]) -> Lanes => sobol_first_kernel
}

#[cfg(test)]
mod tests {
    use super::super::Isa;
    use super::*;
    use crate::sampler::{Dim, Sampler, SamplerKind};

    #[test]
    fn every_lane_draws_the_scalar_streams_numbers() {
        for isa in Isa::available() {
            for batch in 0..64u32 {
                let samplers: Vec<Sampler> = (0..WIDTH as u32)
                    .map(|k| {
                        Sampler::new(SamplerKind::Sobol, 7, (batch * 977 + k * 131) as u64, batch * 3 + k, 0)
                    })
                    .collect();
                let states: Vec<_> = samplers.iter().map(|s| s.sobol_state().unwrap()).collect();
                let keys = std::array::from_fn(|k| states[k].pixel_key);
                let reversed = std::array::from_fn(|k| states[k].reversed_sample);
                let dims: [u32; WIDTH] = std::array::from_fn(|k| (batch + k as u32 * 5) % 40);
                let (x, y) = sobol_pairs(isa, &keys, &reversed, &dims);
                let first = sobol_firsts(isa, &keys, &reversed, &dims);
                for k in 0..WIDTH {
                    // The scalar stream at dimension dims[k]: skip that many 1-D requests.
                    let mut s = samplers[k].clone();
                    for _ in 0..dims[k] {
                        s.get_1d(Dim::Other);
                    }
                    let mut one = s.clone();
                    let want = s.get_2d(Dim::Bsdf);
                    assert_eq!(
                        (x[k].to_bits(), y[k].to_bits()),
                        (want.x.to_bits(), want.y.to_bits()),
                        "{isa:?}"
                    );
                    let one = one.get_1d(Dim::Other).to_bits();
                    assert_eq!((x[k].to_bits(), first[k].to_bits()), (one, one), "{isa:?}: 1D is the first");
                }
            }
        }
    }

    #[test]
    fn other_kinds_have_no_lane_form() {
        for kind in [SamplerKind::Stratified, SamplerKind::Independent] {
            assert!(Sampler::new(kind, 1, 2, 3, 16).sobol_state().is_none());
        }
    }
}
