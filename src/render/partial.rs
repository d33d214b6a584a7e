//! A farm shard's partial EXR: the usual image of its samples (beauty, passes, header), plus
//! the film's exact sums as `uint` channels of the layer `exact`, from which `render merge`
//! rebuilds the film and adds the shards' films exactly ([`super::film`], "Exact sums").
//!
//! | channels | each pixel |
//! |---|---|
//! | `exact.R0` … `exact.R3` (and G, B) | the sum of its sample values' R in fixed point, an `i128` as four 32-bit words, least significant first |
//! | `exact.RR0` … `exact.RR3` (and GG, BB) | the sum of their squares, a `u128` likewise |
//! | `exact.N` | its number of samples |
//! | `exact.F00_0` … `exact.F12_3` | its 13 feature sums (where passes asked for features), `i128` each |
//!
//! Most high words are 0 or all ones, which the file's ZIP compression packs to little.

use exr::prelude::{AnyChannel, AnyChannels, FlatSamples};

use super::film::{FeatureTotals, Film, PixelTotals, FEATURE_SLOTS};

/// The layer that holds the exact sums.
pub const EXACT_LAYER: &str = "exact";

const RGB: [&str; 3] = ["R", "G", "B"];

/// The words of a 128-bit integer, least significant first.
fn words(v: u128) -> [u32; 4] {
    [0, 1, 2, 3].map(|w| (v >> (32 * w)) as u32)
}

/// The 128-bit integer of `words`, least significant first.
fn from_words(words: [u32; 4]) -> u128 {
    (0..4).fold(0u128, |v, w| v | (words[w] as u128) << (32 * w))
}

fn channel(name: String, values: Vec<u32>) -> AnyChannel<FlatSamples> {
    AnyChannel::new(name.as_str(), FlatSamples::U32(values))
}

/// Four channels `name0` … `name3` holding the words of each pixel's `value`.
fn wide_channels(
    name: &str,
    values: impl Fn(usize) -> u128,
    n: usize,
) -> Vec<AnyChannel<FlatSamples>> {
    let all: Vec<[u32; 4]> = (0..n).map(|i| words(values(i))).collect();
    (0..4)
        .map(|w| {
            channel(
                format!("{EXACT_LAYER}.{name}{w}"),
                all.iter().map(|v| v[w]).collect(),
            )
        })
        .collect()
}

/// The exact layer's channels of `film`, read from it pixel by pixel (no copy of its sums).
pub fn exact_channels(film: &Film) -> Vec<AnyChannel<FlatSamples>> {
    let n = film.width as usize * film.height as usize;
    let at = |i: usize| {
        (
            (i % film.width as usize) as u32,
            (i / film.width as usize) as u32,
        )
    };
    let totals = |i: usize| {
        let (x, y) = at(i);
        film.totals(x, y)
    };
    let mut out = Vec::new();
    for (c, name) in RGB.iter().enumerate() {
        out.extend(wide_channels(name, |i| totals(i).0[c] as u128, n));
        out.extend(wide_channels(&name.repeat(2), |i| totals(i).1[c], n));
    }
    out.push(channel(
        format!("{EXACT_LAYER}.N"),
        (0..n).map(|i| totals(i).2).collect(),
    ));
    if film.keeps_features() {
        out.extend((0..FEATURE_SLOTS).flat_map(|slot| {
            let feature = |i: usize| {
                let (x, y) = at(i);
                film.feature_totals(x, y)[slot] as u128
            };
            wide_channels(&format!("F{slot:02}_"), feature, n)
        }));
    }
    out
}

/// The exact layer of a partial file, read in place: each pixel's sums decoded from its
/// words when asked ([`ExactLayer::pixel`]), so that a merge adds a part to its film without
/// a second copy of the part's data.
pub struct ExactLayer<'a> {
    /// Per colour, the four words of the sums, then of the squares.
    sums: [[&'a [u32]; 4]; 3],
    sq_sums: [[&'a [u32]; 4]; 3],
    counts: &'a [u32],
    /// The four words of each feature slot, where the part keeps features.
    features: Option<Vec<[&'a [u32]; 4]>>,
}

impl<'a> ExactLayer<'a> {
    /// The exact layer among `channels` (of `n` pixels), or why there is none.
    pub fn find(channels: &'a AnyChannels<FlatSamples>, n: usize) -> Result<Self, String> {
        let find = |name: String| -> Result<Option<&'a [u32]>, String> {
            let Some(c) = channels.list.iter().find(|c| c.name.eq(name.as_str())) else {
                return Ok(None);
            };
            match &c.sample_data {
                FlatSamples::U32(v) if v.len() == n => Ok(Some(v.as_slice())),
                FlatSamples::U32(v) => {
                    Err(format!("channel {name} holds {} values, not {n}", v.len()))
                }
                _ => Err(format!("channel {name} is not of 32-bit unsigned integers")),
            }
        };
        let required = |name: String| -> Result<&'a [u32], String> {
            find(name.clone())?.ok_or_else(|| format!("it has no channel {name}"))
        };
        let wide = |name: &str| -> Result<[&'a [u32]; 4], String> {
            let w = |i: usize| required(format!("{EXACT_LAYER}.{name}{i}"));
            Ok([w(0)?, w(1)?, w(2)?, w(3)?])
        };
        let sums = [wide("R")?, wide("G")?, wide("B")?];
        let sq_sums = [wide("RR")?, wide("GG")?, wide("BB")?];
        let counts = required(format!("{EXACT_LAYER}.N"))?;
        let features = match find(format!("{EXACT_LAYER}.F00_0"))? {
            None => None,
            Some(_) => Some(
                (0..FEATURE_SLOTS)
                    .map(|slot| wide(&format!("F{slot:02}_")))
                    .collect::<Result<_, _>>()?,
            ),
        };
        Ok(ExactLayer {
            sums,
            sq_sums,
            counts,
            features,
        })
    }

    /// Whether the part keeps feature sums.
    pub fn has_features(&self) -> bool {
        self.features.is_some()
    }

    /// Pixel `i`'s sample count.
    pub fn count(&self, i: usize) -> u32 {
        self.counts[i]
    }

    /// Pixel `i`'s sums, squares and count, and its feature sums where the part keeps them.
    pub fn pixel(&self, i: usize) -> (PixelTotals, Option<FeatureTotals>) {
        let word = |w: &[&[u32]; 4]| from_words([w[0][i], w[1][i], w[2][i], w[3][i]]);
        let sums = self.sums.each_ref().map(|w| word(w) as i128);
        let sq_sums = self.sq_sums.each_ref().map(word);
        let features = (self.features.as_ref())
            .map(|f| -> FeatureTotals { std::array::from_fn(|s| word(&f[s]) as i128) });
        ((sums, sq_sums, self.counts[i]), features)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn words_round_trip_negative_and_wide_integers() {
        for v in [0i128, -1, 1 << 100, -(1 << 95) - 7, i128::MAX, i128::MIN] {
            assert_eq!(from_words(words(v as u128)) as i128, v);
        }
        assert_eq!(
            words(0x0000_0004_0000_0003_0000_0002_0000_0001),
            [1, 2, 3, 4]
        );
    }

    #[test]
    fn the_exact_layer_holds_the_films_sums() {
        let mut film = Film::new(3, 2);
        film.keep_features();
        film.add_sample(0, 0, Vec3::new(-1.0e9, 0.25, 3.0e-7));
        film.add_sample(2, 1, Vec3::new(1.0e12, -5.0, 1.0));
        film.add_sample(2, 1, Vec3::new(1.0e12, -5.0, 1.0));
        let features: FeatureTotals = std::array::from_fn(|s| (s as i128 - 6) << (8 * s));
        film.rows_mut(&[(1, 2)])[0].set_features(2, 1, &features);
        let channels = AnyChannels::sort(exact_channels(&film).into());
        // 3 colours × (4 + 4) words, the count, 13 features × 4 words.
        assert_eq!(channels.list.len(), 3 * 8 + 1 + 13 * 4);
        let layer = ExactLayer::find(&channels, 6).unwrap();
        assert!(layer.has_features());
        for (x, y) in (0..2).flat_map(|y| (0..3).map(move |x| (x, y))) {
            let (totals, f) = layer.pixel((y * 3 + x) as usize);
            assert_eq!(totals, film.totals(x, y), "({x}, {y})");
            assert_eq!(f, Some(film.feature_totals(x, y)), "({x}, {y})");
        }
        // Added to an empty film, the layer gives back the film's estimates.
        let mut back = Film::new(3, 2);
        back.keep_features();
        for i in 0..6 {
            let (totals, f) = layer.pixel(i);
            back.add_pixel_totals(i, totals, f.as_ref()).unwrap();
        }
        assert_eq!(back.pixel(0, 0), film.pixel(0, 0));
        assert_eq!(back.feature_totals(2, 1), features);
        // A layer without the count, or of the wrong size, is refused by name.
        let mut short = channels.clone();
        short.list.retain(|c| !c.name.eq("exact.N"));
        let error = |c, n| ExactLayer::find(c, n).err().expect("refused");
        assert!(error(&short, 6).contains("exact.N"));
        assert!(error(&channels, 5).contains("not 5"));
    }
}
