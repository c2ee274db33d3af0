//! Owen-scrambled Sobol' points in two dimensions, after Burley, "Practical Hash-based Owen
//! Scrambling" (JCGT 2020).
//!
//! The first two Sobol' dimensions form a (0, 2)-sequence: every aligned block of 2^m
//! consecutive points has exactly one point in each elementary interval of area 2^−m (each
//! m×… grid cell, whatever its aspect). Owen scrambling (a random permutation of the digits at
//! every level of the base-2 tree, here computed by a hash) keeps that property and makes the
//! points uniformly random in distribution, so estimates stay unbiased. Shuffling the index
//! with the same kind of nested scramble picks a random aligned block and a random order within
//! it, such that every power-of-two prefix of the shuffled order is itself one block: the first
//! k samples are well stratified whatever the final count, which makes renders progressive.
//!
//! Numbers are 32-bit fixed point in [0, 1) until [`to_unit`] keeps the top 24 bits.

/// A hash permutation of `x` in which bit `j` of the result depends only on bits `0..=j` of `x`
/// (Laine and Karras's construction with Burley's constants): applied to bit-reversed values,
/// a nested uniform (Owen) scramble.
#[inline(always)]
fn lk_permute(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Owen scramble of the fixed-point number `x` (most significant bit first).
#[inline(always)]
pub fn owen_scramble(x: u32, seed: u32) -> u32 {
    lk_permute(x.reverse_bits(), seed).reverse_bits()
}

/// The sample index `index` shuffled by `seed`: a nested scramble of its bits from the most
/// significant down, so that indices below 2^m go to one aligned block of 2^m indices. (The
/// sampler uses [`shuffle_reversed`]; this plain form is the definition the tests check.)
#[inline(always)]
pub fn shuffle(index: u32, seed: u32) -> u32 {
    owen_scramble(index, seed)
}

/// [`shuffle`] in bit-reversed form: `shuffle(index, seed).reverse_bits()` from
/// `index.reverse_bits()`, without reversing (a sampler reverses its fixed index once).
#[inline(always)]
pub fn shuffle_reversed(reversed_index: u32, seed: u32) -> u32 {
    lk_permute(reversed_index, seed)
}

/// Direction numbers of the second Sobol' dimension (primitive polynomial x + 1):
/// v₀ = 2³¹, v_{b+1} = v_b ⊕ (v_b ≫ 1), bit-reversed and stored by bit 31 − b, so that the XOR
/// over the set bits of each byte of a *reversed* index is the *reversed* coordinate.
const SOBOL_DIM1_REVERSED_BYTES: [[u32; 256]; 4] = dim1_reversed_byte_tables();

const fn dim1_reversed_byte_tables() -> [[u32; 256]; 4] {
    let mut v = [0u32; 32];
    let mut d = 1u32 << 31;
    let mut b = 0;
    while b < 32 {
        // Bit b of the index is bit 31 − b of the reversed index.
        v[31 - b] = d.reverse_bits();
        d ^= d >> 1;
        b += 1;
    }
    let mut tables = [[0u32; 256]; 4];
    let mut byte = 0;
    while byte < 4 {
        let mut x = 0;
        while x < 256 {
            let mut acc = 0;
            let mut k = 0;
            while k < 8 {
                if (x >> k) & 1 == 1 {
                    acc ^= v[byte * 8 + k];
                }
                k += 1;
            }
            tables[byte][x] = acc;
            x += 1;
        }
        byte += 1;
    }
    tables
}

/// The second coordinate of Sobol' point `index`, bit-reversed, from the bit-reversed index:
/// `sobol_dim1(r.reverse_bits()).reverse_bits()` (XOR is linear, so reversal commutes with it).
#[inline(always)]
fn sobol_dim1_reversed(reversed_index: u32) -> u32 {
    let t = &SOBOL_DIM1_REVERSED_BYTES;
    t[0][(reversed_index & 0xff) as usize]
        ^ t[1][((reversed_index >> 8) & 0xff) as usize]
        ^ t[2][((reversed_index >> 16) & 0xff) as usize]
        ^ t[3][(reversed_index >> 24) as usize]
}

/// The second coordinate of Sobol' point `index` (the first is `index.reverse_bits()`); the
/// plain form of what the sampler computes bit-reversed.
#[inline(always)]
pub fn sobol_dim1(index: u32) -> u32 {
    sobol_dim1_reversed(index.reverse_bits()).reverse_bits()
}

/// Owen-scrambled first coordinate of Sobol' point `index`: `owen_scramble(index.reverse_bits())`.
#[inline(always)]
pub fn scrambled_dim0(index: u32, seed: u32) -> u32 {
    lk_permute(index, seed).reverse_bits()
}

/// Owen-scrambled second coordinate, `owen_scramble(sobol_dim1(index), seed)`, of the Sobol'
/// point whose index is given bit-reversed (one reversal, not three); returned in plain form.
#[inline(always)]
pub fn scrambled_dim1_of_reversed(reversed_index: u32, seed: u32) -> u32 {
    lk_permute(sobol_dim1_reversed(reversed_index), seed).reverse_bits()
}

/// A fixed-point number as an f32 in [0, 1): its top 24 bits, exactly.
#[inline(always)]
pub fn to_unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The plain Sobol' second dimension, bit by bit.
    fn dim1_reference(index: u32) -> u32 {
        let (mut x, mut v) = (0u32, 1u32 << 31);
        for b in 0..32 {
            if (index >> b) & 1 == 1 {
                x ^= v;
            }
            v ^= v >> 1;
        }
        x
    }

    #[test]
    fn dim1_tables_match_the_direction_numbers() {
        // Joe and Kuo's second dimension: m = 1, 3, 5, 15, 17, 51, …
        let m: Vec<u32> = (0..6).map(|b| sobol_dim1(1 << b) >> (31 - b)).collect();
        assert_eq!(m, [1, 3, 5, 15, 17, 51]);
        for index in (0..u32::MAX).step_by(99_991).chain([u32::MAX, 1 << 24, 0xabcd_ef01]) {
            assert_eq!(sobol_dim1(index), dim1_reference(index), "index {index:#x}");
        }
    }

    #[test]
    fn reversed_forms_equal_the_plain_ones() {
        for seed in [0u32, 7, 0x9e37_79b9, u32::MAX] {
            for index in (0..u32::MAX).step_by(1_000_003).chain([0, 1, u32::MAX]) {
                let r = index.reverse_bits();
                // Each fast form against the independent definition.
                assert_eq!(shuffle_reversed(r, seed), shuffle(index, seed).reverse_bits());
                let expected = owen_scramble(dim1_reference(index), seed);
                assert_eq!(scrambled_dim1_of_reversed(r, seed), expected);
            }
        }
    }

    #[test]
    fn lk_permute_is_nested() {
        // Bit j depends on bits 0..=j only: inputs that agree below bit j agree below bit j.
        for seed in [0u32, 1, 0xdead_beef] {
            for x in (0..1u32 << 20).step_by(7919) {
                for j in [1u32, 5, 12, 31] {
                    let mask = (1u32 << j) - 1;
                    let y = x ^ (0xffff_ffff << j); // differs only from bit j up
                    assert_eq!(lk_permute(x, seed) & mask, lk_permute(y, seed) & mask);
                }
            }
        }
    }

    #[test]
    fn shuffled_prefixes_are_aligned_blocks() {
        // The first 2^m shuffled indices are one aligned block of 2^m indices, in some order.
        for seed in [3u32, 0x1234_5678, 0xffff_ffff] {
            for m in [0u32, 1, 4, 7] {
                let mut block: Vec<u32> = (0..1u32 << m).map(|i| shuffle(i, seed)).collect();
                let base = block[0] >> m;
                assert!(block.iter().all(|&i| i >> m == base), "seed {seed} m {m}");
                block.sort_unstable();
                block.dedup();
                assert_eq!(block.len(), 1 << m);
            }
        }
    }
}
