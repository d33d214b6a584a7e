//! Integer hashing for counter-based random numbers: every random value in strata is a pure
//! function of (seed, pixel, sample index, dimension), so images do not depend on threads.

/// The SplitMix64 finaliser (Steele, Lea & Flood 2014): a bijective 64-bit mixer with full
/// avalanche.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Hashes a sequence of words into one 64-bit value.
#[inline]
pub fn hash_words(words: &[u64]) -> u64 {
    let mut h = 0x9e37_79b9_7f4a_7c15u64;
    for &w in words {
        h = mix64(h ^ w.wrapping_add(0x9e37_79b9_7f4a_7c15));
    }
    h
}

/// Maps 32 random bits to a float in the open interval (0, 1): the top 23 bits pick one of
/// 2^23 equal cells and the result is the cell's centre, (2k + 1)·2^-24. Never exactly 0 or
/// 1, so warps never produce the exactly grazing directions of the square's boundary.
#[inline]
pub fn u32_to_unit_f32(x: u32) -> f32 {
    ((x >> 9) as f32 + 0.5) * (1.0 / (1u32 << 23) as f32)
}

/// A uniform float in (0, 1) from a 64-bit hash (its high bits).
#[inline]
pub fn unit_f32(h: u64) -> f32 {
    u32_to_unit_f32((h >> 32) as u32)
}

/// Uniform floats in (0, 1), the i-th being `unit_f32(hash_words(&[seed, i]))`: random
/// inputs for unit tests.
#[cfg(test)]
pub(crate) fn uniform_sequence(seed: u64) -> impl FnMut() -> f32 {
    let mut i = 0;
    move || {
        i += 1;
        unit_f32(hash_words(&[seed, i]))
    }
}

/// A bijection on `[0, 2^bits)` keyed by `key`: a chain of steps each invertible modulo
/// 2^bits (xor with a key, multiplication by an odd constant, xorshift right), in the spirit
/// of Kensler's hash-based permutations (Correlated Multi-Jittered Sampling, 2013).
#[inline]
fn masked_bijection(mut i: u32, key: u32, mask: u32, bits: u32) -> u32 {
    let half = (bits / 2).max(1);
    i ^= key;
    i = i.wrapping_mul(0x2c1b_3c6d) & mask;
    i ^= i >> half;
    i = i.wrapping_add(key.rotate_left(13)) & mask;
    i = i.wrapping_mul(0x297a_2d39) & mask;
    i ^= i >> half;
    i = (i ^ (key >> 7)) & mask;
    i = i.wrapping_mul(0x9e37_79b1) & mask;
    i ^= i >> half;
    i & mask
}

/// A pseudo-random permutation of `[0, n)` keyed by `key`: `permute(i, n, key)` for i in
/// 0..n visits every value in 0..n once. Values of the power-of-two bijection that fall
/// outside `[0, n)` are mapped again until they land inside (cycle walking); the result is
/// then rotated by a keyed offset modulo n, as Kensler (2013) ends his `permute`.
///
/// The rotation makes the image of every i uniform over the keys. Without it, the few
/// permutations the bijection family reaches on small domains are not equally likely (for
/// n = 3, 0 went to 1 for half of all keys), and a stratified sampler built on them was
/// biased: its points, pooled over pixels, were not uniform (tests/sampling.rs,
/// `pooled_points_are_uniform_for_any_spp`).
#[inline]
pub fn permute(i: u32, n: u32, key: u32) -> u32 {
    debug_assert!(i < n);
    if n <= 1 {
        return 0;
    }
    let bits = 32 - (n - 1).leading_zeros();
    let mask = if bits >= 32 {
        u32::MAX
    } else {
        (1u32 << bits) - 1
    };
    let mut x = i;
    loop {
        x = masked_bijection(x, key, mask, bits);
        if x < n {
            break;
        }
    }
    // A keyed offset in [0, n): the top bits of a mixed key scaled to n (Lemire's reduction).
    let offset = (((mix64(key as u64 ^ 0x5bd1_e995) >> 32) * n as u64) >> 32) as u32;
    let y = x + offset;
    if y >= n {
        y - n
    } else {
        y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permute_is_a_permutation_for_many_sizes_and_keys() {
        for n in [1u32, 2, 3, 5, 7, 16, 17, 100, 255, 256, 1000, 4097] {
            for key in [0u32, 1, 0xdead_beef, 12345] {
                let mut seen = vec![false; n as usize];
                for i in 0..n {
                    let p = permute(i, n, key);
                    assert!(p < n, "n={n} key={key}: {p} out of range");
                    assert!(!seen[p as usize], "n={n} key={key}: {p} repeated");
                    seen[p as usize] = true;
                }
            }
        }
    }

    /// Over keys, every i goes to every value with the same probability (checked for the
    /// image of 0 and of n − 1 against a 5σ binomial bound).
    #[test]
    fn permute_images_are_uniform_over_keys() {
        let keys = 60_000u64;
        for n in [2u32, 3, 5, 7, 12, 100] {
            for i in [0, n - 1] {
                let mut counts = vec![0u32; n as usize];
                for k in 0..keys {
                    counts[permute(i, n, mix64(k) as u32) as usize] += 1;
                }
                let p = 1.0 / n as f64;
                let (mean, sd) = (keys as f64 * p, (keys as f64 * p * (1.0 - p)).sqrt());
                for (v, &c) in counts.iter().enumerate() {
                    assert!(
                        (c as f64 - mean).abs() < 5.0 * sd,
                        "n={n}: {i} went to {v} {c} times, expected {mean:.0} ± {sd:.0}"
                    );
                }
            }
        }
    }

    #[test]
    fn permutations_differ_between_keys() {
        let a: Vec<u32> = (0..64).map(|i| permute(i, 64, 1)).collect();
        let b: Vec<u32> = (0..64).map(|i| permute(i, 64, 2)).collect();
        let identity: Vec<u32> = (0..64).collect();
        assert_ne!(a, b);
        assert_ne!(a, identity);
    }

    #[test]
    fn unit_floats_stay_inside_the_open_interval() {
        assert!(u32_to_unit_f32(0) > 0.0);
        assert!(u32_to_unit_f32(u32::MAX) < 1.0);
        assert!(unit_f32(u64::MAX) < 1.0);
        assert!(unit_f32(0) > 0.0);
    }
}
