//! Owen-scrambled Sobol points in dimensions 0–3 (Burley 2020, "Practical Hash-based Owen
//! Scrambling"), evaluated with byte tables.
//!
//! Sobol's generator matrices are linear over GF(2): the point of index i is the XOR of the
//! direction vectors of i's set bits. `sobol_burley` walks those bits one at a time, a loop
//! whose length and branches depend on the (shuffled, so random) index; perf put it at about
//! a sixth of a path-traced render. With the sampler's 16-bit indices, two 256-entry tables
//! (one per index byte, each entry the XOR of that byte's direction vectors) give the same
//! point with two loads and one XOR. The tables are built once from the crate's own
//! `parts::sobol_int4_rev`, so they hold its matrices by construction; the index shuffle and
//! the per-dimension Owen scrambles are the crate's `parts` too, keyed here by our seeds.

use std::sync::OnceLock;

use sobol_burley::parts::{hash, hash_int4, owen_scramble_int4_rev, owen_scramble_rev, Int4};

/// The most sample indices per sequence: the tables cover 16 index bits.
pub const MAX_INDEX: u32 = 1 << 16;

struct Tables {
    /// XOR of the bit-reversed direction vectors of the index bits 0–7 / 8–15, by byte value.
    low: [[u32; 4]; 256],
    high: [[u32; 4]; 256],
}

fn tables() -> &'static Tables {
    static TABLES: OnceLock<Tables> = OnceLock::new();
    TABLES.get_or_init(|| {
        let mut t = Tables {
            low: [[0; 4]; 256],
            high: [[0; 4]; 256],
        };
        for b in 0..256u32 {
            // Bit-reversed indices: index bit k sits at bit 31 − k.
            t.low[b as usize] = sobol_burley::parts::sobol_int4_rev(b.reverse_bits(), 0).into();
            t.high[b as usize] =
                sobol_burley::parts::sobol_int4_rev((b << 8).reverse_bits(), 0).into();
        }
        t
    })
}

/// The unscrambled Sobol point (dimensions 0–3, bit-reversed) of a 16-bit index.
#[inline]
fn sobol_rev(index: u32) -> Int4 {
    let t = tables();
    let lo: Int4 = t.low[(index & 0xff) as usize].into();
    let hi: Int4 = t.high[((index >> 8) & 0xff) as usize].into();
    lo ^ hi
}

/// Point `index` (< 2^16) of the Owen-scrambled Sobol sequence keyed by `seed`, dimensions
/// 0–3, each a multiple of 2^-23 in [0, 1). Different seeds give statistically independent
/// sequences (Burley's index shuffle and padding).
#[inline]
pub fn sample_4d(index: u32, seed: u32) -> [f32; 4] {
    debug_assert!(index < MAX_INDEX);
    // Shuffle the index by an Owen scramble of its bits (Burley §4), then look up the point.
    let shuffled = owen_scramble_rev(index.reverse_bits(), hash(seed ^ 0x2c1b_3c6d)).reverse_bits();
    let sobol = sobol_rev(shuffled & 0xffff);
    // A different nested uniform scramble per dimension.
    let keys: Int4 = [
        seed ^ 0x8f1b_bcdc,
        seed ^ 0x3c6e_f372,
        seed ^ 0xa54f_f53a,
        seed ^ 0x510e_527f,
    ]
    .into();
    owen_scramble_int4_rev(sobol, hash_int4(keys))
        .reverse_bits()
        .to_f32_norm()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tables reproduce the crate's bit-serial matrix product for every 16-bit index.
    #[test]
    fn tables_match_the_bit_serial_product() {
        for i in 0..MAX_INDEX {
            let want: [u32; 4] = sobol_burley::parts::sobol_int4_rev(i.reverse_bits(), 0).into();
            let got: [u32; 4] = sobol_rev(i).into();
            assert_eq!(got, want, "index {i}");
        }
    }

    /// Without scrambling the first points are the textbook Sobol points: dimension 0 is the
    /// van der Corput sequence, dimension 1 the next Sobol dimension (1/2, 3/4 1/4, ...).
    #[test]
    fn unscrambled_points_are_sobol() {
        let point = |i: u32| -> [f64; 4] {
            let v: [u32; 4] = sobol_rev(i).into();
            v.map(|x| x.reverse_bits() as f64 / 4294967296.0)
        };
        assert_eq!(point(0), [0.0; 4]);
        assert_eq!(point(1)[..2], [0.5, 0.5]);
        assert_eq!(point(2)[..2], [0.25, 0.75]);
        assert_eq!(point(3)[..2], [0.75, 0.25]);
        assert_eq!(point(4)[0], 0.125);
    }

    /// Every power-of-two prefix of a scrambled sequence is a (0, m, 2)-net in dimensions
    /// (0, 1): one point in each elementary interval of area 1/n. Dimensions 2 and 3 (whose
    /// pair is not a (0, 2)-sequence) are each stratified in 1D: one point per 1/n.
    #[test]
    fn scrambled_prefixes_are_nets() {
        for seed in [0u32, 1, 0xdead_beef] {
            for m in 0..=10u32 {
                let n = 1u32 << m;
                let pts: Vec<[f32; 4]> = (0..n).map(|i| sample_4d(i, seed)).collect();
                for a in 0..=m {
                    let (cols, rows) = (1u32 << a, 1u32 << (m - a));
                    let mut seen = vec![false; n as usize];
                    for p in &pts {
                        let cx = (p[0] * cols as f32) as u32;
                        let cy = (p[1] * rows as f32) as u32;
                        let cell = (cy * cols + cx) as usize;
                        assert!(!seen[cell], "seed {seed} n {n}: {cols}x{rows} cell twice");
                        seen[cell] = true;
                    }
                }
                for d in 2..4 {
                    let mut seen = vec![false; n as usize];
                    for p in &pts {
                        let cell = (p[d] * n as f32) as usize;
                        assert!(
                            !seen[cell],
                            "seed {seed} n {n}: dimension {d} stratum twice"
                        );
                        seen[cell] = true;
                    }
                }
            }
        }
    }

    /// Different seeds give different sequences.
    #[test]
    fn seeds_decorrelate() {
        let a: Vec<[f32; 4]> = (0..64).map(|i| sample_4d(i, 1)).collect();
        let b: Vec<[f32; 4]> = (0..64).map(|i| sample_4d(i, 2)).collect();
        let same = a.iter().zip(&b).filter(|(x, y)| x == y).count();
        assert!(same < 2, "{same} of 64 points coincide");
    }
}
