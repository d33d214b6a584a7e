//! Owen-scrambled Sobol points in dimensions 0–3 (Burley 2020, "Practical Hash-based Owen
//! Scrambling"), evaluated with byte tables.
//!
//! Sobol's generator matrices are linear over GF(2): the point of index i is the XOR of the
//! direction vectors of i's set bits. `sobol_burley` walks those bits one at a time, a loop
//! whose length and branches depend on the (shuffled, so random) index; perf put it at about
//! a sixth of a path-traced render. With the sampler's 16-bit indices, two 256-entry tables
//! (one per index byte, each entry the XOR of that byte's direction vectors) give the same
//! point with two loads and one XOR. The tables are built once from the crate's own
//! `parts::sobol_int4_rev`, so they hold its matrices by construction. The index shuffle and
//! the per-dimension Owen scrambles are Burley's hash with the crate's constants (tested equal
//! to its `owen_scramble_rev`), keyed here by our seeds. All of it is written once over
//! [`Bits`] ([`Sequence::points`]): one sequence per lane, one lane or eight with the same
//! bits, and a 2D point costs half a 4D one.
//!
//! Dimensions 4 to 31 (sets 1–7, [`Sequence::sample_4d_of_set`]) have tables too, 8 KiB
//! each, for a path's later bounces, which take further dimensions of their first bounce's
//! sequence ([`Sequence::with_shuffle_of`]) rather than dimensions 0–3 of sequences of
//! their own.

use std::sync::OnceLock;

use crate::lanes::{Bits, Real};
use sobol_burley::parts::hash;

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

/// Burley's hash-based Owen scramble of a bit-reversed word keyed by `scramble` ("Practical
/// Hash-based Owen Scrambling", JCGT 9(4), 2020, §3, with the constants `sobol_burley` 0.5
/// settled on; tested equal to its `owen_scramble_rev`), at any width: a nested uniform
/// scramble, each bit flipped by a hash of the bits above it (below it, reversed).
#[inline(always)]
fn owen_scramble_rev<B: Bits>(n: B, scramble: B) -> B {
    let n = n ^ n.wrapping_mul(B::splat(0x3d20_adea));
    let n = n.wrapping_add(scramble);
    let n = n.wrapping_mul(scramble.shr(16) | B::splat(1));
    let n = n ^ n.wrapping_mul(B::splat(0x0552_6c56));
    n ^ n.wrapping_mul(B::splat(0x53a2_2864))
}

/// The index shuffle of Burley §4: an Owen scramble of the index's bits keyed by `shuffle`,
/// left bit-reversed, as the tables take it.
#[inline(always)]
fn shuffled_rev<B: Bits>(index: B, shuffle: B) -> B {
    owen_scramble_rev(index.reverse_bits(), shuffle)
}

/// The unscrambled Sobol point (the tables' four dimensions, bit-reversed) of the shuffled,
/// bit-reversed index `shuffled`: the XOR of the two byte tables' rows, one 16-byte load
/// each per lane.
#[inline(always)]
fn sobol_rev<B: Bits>(t: &Tables, shuffled: B) -> [B; 4] {
    let top = B::gather4(&t.top, shuffled.shr(24));
    let next = B::gather4(&t.next, shuffled.shr(16) & B::splat(0xff));
    [
        top[0] ^ next[0],
        top[1] ^ next[1],
        top[2] ^ next[2],
        top[3] ^ next[3],
    ]
}

/// One dimension of an unscrambled point: its Owen scramble keyed by `key`, the bits put
/// back in order, and the top 23 as a multiple of 2^-23 in [0, 1).
#[inline(always)]
fn scrambled<R: Real>(sobol_rev: R::Bits, key: R::Bits) -> R {
    let v = owen_scramble_rev(sobol_rev, key).reverse_bits();
    // The top 23 bits as the mantissa of a float in [1, 2), less 1.
    R::from_bits(v.shr(9) | R::Bits::splat(0x3f80_0000)) - 1.0
}

/// The seeds of the four dimensions' nested uniform scrambles, XORed with the sequence's.
const DIMENSION_KEYS: [u32; 4] = [0x8f1b_bcdc, 0x3c6e_f372, 0xa54f_f53a, 0x510e_527f];

/// Point `index` (< 2^16) of the Owen-scrambled Sobol sequence keyed by `seed`, dimensions
/// 0–3, each a multiple of 2^-23 in [0, 1). Different seeds give statistically independent
/// sequences (Burley's index shuffle and padding).
///
/// One lane, bit for bit the crate's 4-lane `owen_scramble_int4_rev` form (tested). That
/// form's four lanes are four dimensions of one point; strata's lanes are eight points, one
/// per path, whose multiplies AVX2 does in one instruction each ([`Sequence::points`] at
/// eight lanes inside `lanes::dispatch`). Measured with `cargo bench --bench ao -- sobol`,
/// in BENCHMARKS.md.
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
///
/// `Sequence<U8>` holds eight sequences, one per lane, whose points [`Sequence::points`]
/// computes side by side with the bits of one at a time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sequence<B = u32> {
    shuffle: B,
    dims: [B; 4],
}

impl<B: Bits> Sequence<B> {
    /// The sequences of the lanes, lane `i` from `f(i)`.
    #[inline(always)]
    pub fn from_lanes(mut f: impl FnMut(usize) -> Sequence) -> Sequence<B> {
        let lanes: [Sequence; 8] = std::array::from_fn(|i| f(i.min(B::LANES - 1)));
        Sequence {
            shuffle: B::from_fn(|i| lanes[i].shuffle),
            dims: std::array::from_fn(|d| B::from_fn(|i| lanes[i].dims[d])),
        }
    }

    /// Dimensions 4·`set` to 4·`set` + N − 1 of point `index` (< 2^16) of each lane's
    /// sequence, each a multiple of 2^-23 in [0, 1): the index shuffle of Burley §4 (an
    /// Owen scramble of the index's bits, left bit-reversed, as the tables take it), the
    /// two byte tables' XOR, each dimension's Owen scramble, and the bits put back in order.
    #[inline(always)]
    pub fn points<R: Real<Bits = B>, const N: usize>(&self, index: B, set: u32) -> [R; N] {
        let sobol = sobol_rev(tables(set), shuffled_rev(index, self.shuffle));
        // A loop, not `array::from_fn`: LLVM left that closure out of line, outside the
        // AVX2 function.
        let mut out = [R::ZERO; N];
        for (d, out) in out.iter_mut().enumerate() {
            *out = scrambled(sobol[d], self.dims[d]);
        }
        out
    }
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
        debug_assert!(index < MAX_INDEX);
        self.points::<f32, N>(index, set)
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
/// The points of `N` sequences side by side, each at one lane, in two phases (every
/// lane's index shuffle, then every lane's dimensions) so that the lanes' chains of
/// multiplies and lookups overlap. Moving sequences stored one per pixel into eight-lane
/// form ([`Sequence::from_lanes`]) and the points back cost more than eight-lane arithmetic
/// saves here (13.8 against 7.5 ns per 2D point, `cargo bench --bench ao -- "sobol point"`);
/// the wavefront integrator keeps its sequences in lanes and calls [`Sequence::points`].
#[inline]
fn sample_lanes<const N: usize, const D: usize>(
    sequences: &[Sequence; N],
    indices: &[u32; N],
) -> [[f32; D]; N] {
    let mut shuffled = [0u32; N];
    for ((shuffled, &index), sequence) in shuffled.iter_mut().zip(indices).zip(sequences) {
        *shuffled = shuffled_rev(index, sequence.shuffle);
    }
    let t = tables(0);
    let sobol: [[u32; 4]; N] = std::array::from_fn(|i| sobol_rev(t, shuffled[i]));
    let mut out = [[0.0; D]; N];
    for ((out, sobol), sequence) in out.iter_mut().zip(&sobol).zip(sequences) {
        for (d, out) in out.iter_mut().enumerate() {
            *out = scrambled(sobol[d], sequence.dims[d]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use sobol_burley::parts::{hash_int4, owen_scramble_int4_rev, sobol_int4_rev, Int4};

    /// The unscrambled Sobol point of tables `t` for the 16-bit index whose bit-reversal is
    /// `index_rev`, looked up apart from [`Sequence::points`].
    fn lookup(t: &Tables, index_rev: u32) -> [u32; 4] {
        let (top, next) = (
            t.top[(index_rev >> 24) as usize],
            t.next[((index_rev >> 16) & 0xff) as usize],
        );
        std::array::from_fn(|d| top[d] ^ next[d])
    }

    /// The unscrambled Sobol point (dimensions 0–3, bit-reversed) of a 16-bit index.
    fn sobol_rev(index: u32) -> Int4 {
        lookup(tables(0), index.reverse_bits()).into()
    }

    /// [`sample_4d`] written with the crate's 4-lane scramble and its bit-serial matrix
    /// product instead of our tables: the reference the scalar code must equal.
    fn sample_4d_lanes(index: u32, seed: u32) -> [f32; 4] {
        let shuffled =
            sobol_burley::parts::owen_scramble_rev(index.reverse_bits(), hash(seed ^ 0x2c1b_3c6d))
                .reverse_bits();
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

    /// The scramble equals the crate's, over random words and keys.
    #[test]
    fn the_scramble_is_the_crates() {
        let mut x = 0x1234_5678u32;
        for _ in 0..1_000_000 {
            let (n, k) = (hash(x), hash(x ^ 0x9e37_79b9));
            x = x.wrapping_add(1);
            let want = sobol_burley::parts::owen_scramble_rev(n, k);
            assert_eq!(owen_scramble_rev(n, k), want, "{n:#x} {k:#x}");
        }
    }

    /// Points of every dimension set at eight lanes, in and out of the AVX2 dispatch, have
    /// the bits of the same points at one lane.
    #[test]
    fn points_have_the_same_bits_at_every_width() {
        #[inline(always)]
        fn kernel<R: Real>([seed, index, set]: [R; 3]) -> [R; 4] {
            let (seed, index) = (seed.to_bits(), index.to_bits());
            let set = (set.lane(0) as u32).min(DIMENSION_SETS - 1);
            let sequence = Sequence::from_lanes(|i| Sequence::new(seed.lane(i)));
            sequence.points(index, set)
        }
        let mut x = 7u32;
        let inputs = (0..4096).map(|k| {
            x = hash(x);
            // The set is the group's (lane 0's), so it varies by group of eight.
            let set = ((k / 8) % DIMENSION_SETS as usize) as f32;
            [f32::from_bits(x), f32::from_bits(x % MAX_INDEX), set]
        });
        crate::lanes::assert_same_bits_at_every_width!(kernel: [3] -> [4], inputs);
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
