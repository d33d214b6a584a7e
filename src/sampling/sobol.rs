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
//! the per-dimension Owen scrambles are the crate's `parts` too, keyed here by our seeds, and
//! run in scalar code per dimension, so a 2D point costs half a 4D one.
//!
//! Dimensions 4 to 31 (sets 1–7, [`Sequence::sample_4d_of_set`]) have tables too, 8 KiB
//! each, for a path's later bounces, which take further dimensions of their first bounce's
//! sequence ([`Sequence::with_shuffle_of`]) rather than dimensions 0–3 of sequences of
//! their own.

use std::sync::OnceLock;

use sobol_burley::parts::{hash, owen_scramble_rev, u32_to_f32_norm};

/// The most sample indices per sequence: the tables cover 16 index bits.
pub const MAX_INDEX: u32 = 1 << 16;

struct Tables {
    /// XOR of the bit-reversed direction vectors of index bits 0–7 / 8–15, by the value of
    /// the *bit-reversed* index's top byte / next byte (index bit k sits at bit 31 − k), so
    /// that the shuffled index, which the scramble leaves bit-reversed, needs no reversal.
    top: [[u32; 4]; 256],
    next: [[u32; 4]; 256],
}

/// Dimension sets with tables: dimensions 0–31 of the sequence, in sets of four.
pub const DIMENSION_SETS: u32 = 8;

/// The tables of dimension set `set` (dimensions 4·set to 4·set + 3), `set` < [`DIMENSION_SETS`],
/// each built on its first use (a render that never reaches a path's second bounce builds
/// set 0 alone).
fn tables(set: u32) -> &'static Tables {
    static TABLES: [OnceLock<Tables>; DIMENSION_SETS as usize] =
        [const { OnceLock::new() }; DIMENSION_SETS as usize];
    TABLES[set as usize].get_or_init(|| {
        let mut t = Tables {
            top: [[0; 4]; 256],
            next: [[0; 4]; 256],
        };
        for b in 0..256u32 {
            t.top[b as usize] = sobol_burley::parts::sobol_int4_rev(b << 24, set).into();
            t.next[b as usize] = sobol_burley::parts::sobol_int4_rev(b << 16, set).into();
        }
        t
    })
}

/// The unscrambled Sobol point of tables `t` (a dimension set, bit-reversed) for the 16-bit
/// index whose bit-reversal is `index_rev` (only its top 16 bits are read).
#[inline(always)]
fn lookup(t: &Tables, index_rev: u32) -> [u32; 4] {
    let (top, next) = (
        t.top[(index_rev >> 24) as usize],
        t.next[((index_rev >> 16) & 0xff) as usize],
    );
    std::array::from_fn(|d| top[d] ^ next[d])
}

/// The index shuffle of Burley §4, an Owen scramble of the index's bits with the hashed key
/// `scramble`; returns the shuffled index bit-reversed, as the tables take it.
#[inline]
fn shuffled_rev(index: u32, scramble: u32) -> u32 {
    debug_assert!(index < MAX_INDEX);
    // The 16-bit index reversed by bytes: two loads instead of a 32-bit reversal (x86-64
    // has no bit-reversal instruction).
    let index_rev = ((REVERSED_BYTE[(index & 0xff) as usize] as u32) << 24)
        | ((REVERSED_BYTE[((index >> 8) & 0xff) as usize] as u32) << 16);
    owen_scramble_rev(index_rev, scramble)
}

/// Each byte value with its bits in reverse order.
const REVERSED_BYTE: [u8; 256] = {
    let mut t = [0u8; 256];
    let mut b = 0;
    while b < 256 {
        t[b] = (b as u8).reverse_bits();
        b += 1;
    }
    t
};

/// The seeds of the four dimensions' nested uniform scrambles, XORed with the sequence's.
const DIMENSION_KEYS: [u32; 4] = [0x8f1b_bcdc, 0x3c6e_f372, 0xa54f_f53a, 0x510e_527f];

/// Point `index` (< 2^16) of the Owen-scrambled Sobol sequence keyed by `seed`, dimensions
/// 0–3, each a multiple of 2^-23 in [0, 1). Different seeds give statistically independent
/// sequences (Burley's index shuffle and padding).
///
/// Scalar code, bit for bit the crate's 4-lane `owen_scramble_int4_rev` form (tested): the
/// x86-64 baseline (SSE2) has no 32-bit vector multiply, so each of that form's six
/// multiplies is emulated in several instructions, and its bit reversal takes a dozen
/// shuffles, where the scalar form reverses with byte lookups. Measured with
/// `cargo bench --bench ao -- sobol`, in BENCHMARKS.md.
#[inline]
pub fn sample_4d(index: u32, seed: u32) -> [f32; 4] {
    Sequence::new(seed).sample_4d(index)
}

/// Dimensions 0 and 1 of [`sample_4d`], for about half its cost.
#[inline]
pub fn sample_2d(index: u32, seed: u32) -> [f32; 2] {
    Sequence::new(seed).sample_2d(index)
}

/// Dimension 0 of [`sample_4d`].
#[inline]
pub fn sample_1d(index: u32, seed: u32) -> f32 {
    Sequence::new(seed).sample_1d(index)
}

/// The Sobol sequence keyed by one seed, as the hashed scramble keys of its index shuffle
/// and of its four dimensions: they depend on the seed alone, so a caller that draws several
/// points of one sequence (a pixel's samples in one dimension slot) hashes them once.
/// Its points are those of [`sample_4d`] with the same seed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sequence {
    shuffle: u32,
    dims: [u32; 4],
}

impl Sequence {
    #[inline]
    pub fn new(seed: u32) -> Sequence {
        Sequence {
            shuffle: hash(seed ^ 0x2c1b_3c6d),
            dims: DIMENSION_KEYS.map(|k| hash(seed ^ k)),
        }
    }

    #[inline]
    pub fn sample_4d(&self, index: u32) -> [f32; 4] {
        self.sample::<4>(index)
    }

    #[inline]
    pub fn sample_2d(&self, index: u32) -> [f32; 2] {
        self.sample::<2>(index)
    }

    #[inline]
    pub fn sample_1d(&self, index: u32) -> f32 {
        self.sample::<1>(index)[0]
    }

    /// This sequence's dimension scrambles under `other`'s index shuffle: dimension set `s`
    /// of the result ([`Sequence::sample_4d_of_set`]) and set `t` ≠ `s` of `other` are then
    /// dimensions of one Sobol sequence, stratified jointly, where two sequences with their
    /// own shuffles are independent of each other (padding).
    #[inline]
    pub fn with_shuffle_of(self, other: &Sequence) -> Sequence {
        Sequence {
            shuffle: other.shuffle,
            dims: self.dims,
        }
    }

    /// Dimensions 4·`set` to 4·`set` + 3 of point `index` (< [`DIMENSION_SETS`] sets), each
    /// scrambled with this sequence's keys; set 0 is [`Sequence::sample_4d`].
    #[inline]
    pub fn sample_4d_of_set(&self, index: u32, set: u32) -> [f32; 4] {
        self.sample_of_set::<4>(index, set)
    }

    /// The first `N` ≤ 4 dimensions of point `index`.
    #[inline(always)]
    fn sample<const N: usize>(&self, index: u32) -> [f32; N] {
        self.sample_of_set::<N>(index, 0)
    }

    /// The first `N` ≤ 4 dimensions of dimension set `set` of point `index`.
    #[inline(always)]
    fn sample_of_set<const N: usize>(&self, index: u32, set: u32) -> [f32; N] {
        // Shuffle the index by an Owen scramble of its bits (Burley §4), look up the point,
        // then scramble each dimension with its own key.
        let sobol = lookup(tables(set), shuffled_rev(index, self.shuffle));
        std::array::from_fn(|d| scrambled(sobol[d], self.dims[d]))
    }
}

/// [`Sequence::sample_2d`] of `N` points (`indices[i]` of `sequences[i]`), computed a step at
/// a time over all of them: each point is one long dependent chain of multiplies and table
/// lookups, and interleaving the chains of independent points lets them overlap.
#[inline]
pub fn sample_2d_lanes<const N: usize>(
    sequences: &[Sequence; N],
    indices: &[u32; N],
) -> [[f32; 2]; N] {
    sample_lanes(sequences, indices)
}

/// [`Sequence::sample_4d`] of `N` points, computed side by side as [`sample_2d_lanes`]
/// computes their first two dimensions.
#[inline]
pub fn sample_4d_lanes<const N: usize>(
    sequences: &[Sequence; N],
    indices: &[u32; N],
) -> [[f32; 4]; N] {
    sample_lanes(sequences, indices)
}

/// Dimensions 0 to `D` − 1 (`D` ≤ 4) of `N` points, a step at a time over all of them.
#[inline]
fn sample_lanes<const N: usize, const D: usize>(
    sequences: &[Sequence; N],
    indices: &[u32; N],
) -> [[f32; D]; N] {
    let shuffled: [u32; N] =
        std::array::from_fn(|i| shuffled_rev(indices[i], sequences[i].shuffle));
    let t = tables(0);
    let sobol: [[u32; 4]; N] = std::array::from_fn(|i| lookup(t, shuffled[i]));
    std::array::from_fn(|i| std::array::from_fn(|d| scrambled(sobol[i][d], sequences[i].dims[d])))
}

/// One dimension's nested uniform scramble with the hashed key `scramble`, as a float in
/// [0, 1).
#[inline]
fn scrambled(sobol_rev: u32, scramble: u32) -> f32 {
    let v = owen_scramble_rev(sobol_rev, scramble);
    // The float keeps the top 23 bits of the reversed value, which are v's low 23 bits
    // reversed: three byte lookups (bits 24–31 of v would land below bit 8, which the
    // conversion drops).
    let r = |k: u32| REVERSED_BYTE[((v >> (8 * k)) & 0xff) as usize] as u32;
    u32_to_f32_norm((r(0) << 24) | (r(1) << 16) | (r(2) << 8))
}

#[cfg(test)]
mod tests {
    use super::*;
    use sobol_burley::parts::{hash_int4, owen_scramble_int4_rev, sobol_int4_rev, Int4};

    /// The unscrambled Sobol point (dimensions 0–3, bit-reversed) of a 16-bit index.
    fn sobol_rev(index: u32) -> Int4 {
        lookup(tables(0), index.reverse_bits()).into()
    }

    /// [`sample_4d`] written with the crate's 4-lane scramble and its bit-serial matrix
    /// product instead of our tables: the reference the scalar code must equal.
    fn sample_4d_lanes(index: u32, seed: u32) -> [f32; 4] {
        let shuffled =
            owen_scramble_rev(index.reverse_bits(), hash(seed ^ 0x2c1b_3c6d)).reverse_bits();
        let sobol = sobol_int4_rev((shuffled & 0xffff).reverse_bits(), 0);
        let keys: Int4 = DIMENSION_KEYS.map(|k| seed ^ k).into();
        owen_scramble_int4_rev(sobol, hash_int4(keys))
            .reverse_bits()
            .to_f32_norm()
    }

    /// The tables reproduce the crate's bit-serial matrix product for every 16-bit index.
    #[test]
    fn tables_match_the_bit_serial_product() {
        for i in 0..MAX_INDEX {
            let want: [u32; 4] = sobol_burley::parts::sobol_int4_rev(i.reverse_bits(), 0).into();
            let got: [u32; 4] = sobol_rev(i).into();
            assert_eq!(got, want, "index {i}");
        }
    }

    /// Every dimension set's tables reproduce the crate's bit-serial product for that set,
    /// and set 0 under a sequence's own shuffle is [`Sequence::sample_4d`].
    #[test]
    fn every_set_s_tables_match_the_bit_serial_product() {
        for set in 0..DIMENSION_SETS {
            for i in (0..MAX_INDEX).step_by(7) {
                let want: [u32; 4] = sobol_int4_rev(i.reverse_bits(), set).into();
                assert_eq!(
                    lookup(tables(set), i.reverse_bits()),
                    want,
                    "set {set}, index {i}"
                );
            }
        }
        let (a, b) = (Sequence::new(5), Sequence::new(6));
        for i in 0..64 {
            assert_eq!(a.sample_4d_of_set(i, 0), a.sample_4d(i));
            // Another sequence's shuffle, with this one's scrambles: a different point.
            assert_ne!(
                a.with_shuffle_of(&b).sample_4d_of_set(i, 1),
                a.sample_4d_of_set(i, 1)
            );
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

    /// The scalar points equal the 4-lane reference bit for bit, and the 2D and 1D points
    /// are the 4D point's first dimensions.
    #[test]
    fn scalar_points_equal_the_four_lane_reference() {
        for seed in [0u32, 1, 0x8f1b_bcdc, 0xdead_beef, u32::MAX] {
            for i in 0..MAX_INDEX {
                let want = sample_4d_lanes(i, seed).map(f32::to_bits);
                assert_eq!(sample_4d(i, seed).map(f32::to_bits), want, "{i} {seed}");
                assert_eq!(sample_2d(i, seed).map(f32::to_bits), [want[0], want[1]]);
                assert_eq!(sample_1d(i, seed).to_bits(), want[0]);
            }
        }
    }

    /// Points computed side by side equal the points computed one at a time, for group
    /// sizes that do and do not fill the lanes.
    #[test]
    fn side_by_side_points_equal_single_points() {
        let seeds: [u32; 8] = std::array::from_fn(|i| hash(i as u32 ^ 0x51ed));
        let sequences = seeds.map(Sequence::new);
        for start in (0..MAX_INDEX).step_by(8 * 97) {
            let indices: [u32; 8] = std::array::from_fn(|i| (start + 8191 * i as u32) % MAX_INDEX);
            let lanes = sample_2d_lanes(&sequences, &indices);
            for i in 0..8 {
                let want = sample_2d(indices[i], seeds[i]);
                assert_eq!(lanes[i].map(f32::to_bits), want.map(f32::to_bits));
            }
            let four = super::sample_4d_lanes(&sequences, &indices);
            for i in 0..8 {
                let want = sequences[i].sample_4d(indices[i]);
                assert_eq!(four[i].map(f32::to_bits), want.map(f32::to_bits));
            }
            let three = sample_2d_lanes::<3>(&[sequences[5]; 3], &[indices[0], 7, 1]);
            assert_eq!(
                three[1].map(f32::to_bits),
                sample_2d(7, seeds[5]).map(f32::to_bits)
            );
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
