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
//! | `exact.H0`, `exact.H1` | the triangle its sample 0 met (where ID passes were asked for), a `u64` as two words |
//!
//! `render --resume` reads the same layer from an interrupted render or a checkpoint
//! ([`super::resume`]), so the layer is also written there.
//! Most high words are 0 or all ones, which the file's ZIP compression packs to little.

use exr::prelude::{AnyChannel, AnyChannels, FlatSamples};

use super::film::{FeatureTotals, Film, PixelTotals, FEATURE_SLOTS};
use crate::record::{FirstHit, NO_HIT};

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
    if film.keeps_first_hits() {
        for w in 0..2 {
            let word = |i: usize| {
                let (x, y) = at(i);
                (film.first_hit_raw(x, y) >> (32 * w)) as u32
            };
            out.push(channel(
                format!("{EXACT_LAYER}.H{w}"),
                (0..n).map(word).collect(),
            ));
        }
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
    /// The two words of each pixel's first hit, where the part keeps them.
    first_hits: Option<[&'a [u32]; 2]>,
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
        let first_hits = match find(format!("{EXACT_LAYER}.H0"))? {
            None => None,
            Some(low) => Some([low, required(format!("{EXACT_LAYER}.H1"))?]),
        };
        Ok(ExactLayer {
            sums,
            sq_sums,
            counts,
            features,
            first_hits,
        })
    }

    /// Whether the part keeps feature sums.
    pub fn has_features(&self) -> bool {
        self.features.is_some()
    }

    /// Whether the part keeps each pixel's first hit.
    pub fn has_first_hits(&self) -> bool {
        self.first_hits.is_some()
    }

    /// Pixel `i`'s first hit ([`NO_HIT`] where it met nothing, or the part keeps none).
    pub fn first_hit(&self, i: usize) -> FirstHit {
        self.first_hits
            .map_or(NO_HIT, |[low, high]| low[i] as u64 | (high[i] as u64) << 32)
    }

    /// The film of `width` × `height` pixels this layer describes, keeping features and first
    /// hits as it does: what the render that wrote it had when it wrote it.
    pub fn to_film(&self, width: u32, height: u32) -> Result<Film, String> {
        let mut film = Film::new(width, height);
        if self.has_features() {
            film.keep_features();
        }
        if self.has_first_hits() {
            film.keep_first_hits();
        }
        for i in 0..width as usize * height as usize {
            let (totals, features) = self.pixel(i);
            (film.add_pixel_totals(i, totals, features.as_ref())).map_err(|e| e.to_string())?;
        }
        if self.has_first_hits() {
            let mut rows = film.rows_mut(&[(0, height)]);
            for i in 0..width as usize * height as usize {
                let (x, y) = ((i % width as usize) as u32, (i / width as usize) as u32);
                rows[0].set_first_hit(x, y, self.first_hit(i));
            }
        }
        Ok(film)
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
        // First hits, where the film keeps them, come back whole (both words).
        assert!(!layer.has_first_hits());
        let mut hits = Film::new(3, 2);
        hits.keep_first_hits();
        hits.add_sample(1, 0, Vec3::ONE);
        let far = (7u64 << 32) | 0xdead_beef;
        hits.rows_mut(&[(0, 1)])[0].set_first_hit(1, 0, far);
        let hit_channels = AnyChannels::sort(exact_channels(&hits).into());
        assert_eq!(hit_channels.list.len(), 3 * 8 + 1 + 2);
        let hit_layer = ExactLayer::find(&hit_channels, 6).unwrap();
        assert_eq!(
            (hit_layer.first_hit(1), hit_layer.first_hit(0)),
            (far, NO_HIT)
        );
        let back_hits = hit_layer.to_film(3, 2).unwrap();
        assert!(back_hits.keeps_first_hits() && !back_hits.keeps_features());
        assert_eq!(back_hits.first_hit(1, 0), Some(far));
        assert_eq!(back_hits.first_hit(0, 0), None);
        assert_eq!(back_hits.totals(1, 0), hits.totals(1, 0));
        // And a film read back whole equals the one written, features included.
        let whole = layer.to_film(3, 2).unwrap();
        for (x, y) in (0..2).flat_map(|y| (0..3).map(move |x| (x, y))) {
            assert_eq!(whole.totals(x, y), film.totals(x, y));
            assert_eq!(whole.feature_totals(x, y), film.feature_totals(x, y));
        }
        // A layer without the count, or of the wrong size, is refused by name.
        let mut short = channels.clone();
        short.list.retain(|c| !c.name.eq("exact.N"));
        let error = |c, n| ExactLayer::find(c, n).err().expect("refused");
        assert!(error(&short, 6).contains("exact.N"));
        assert!(error(&channels, 5).contains("not 5"));
    }
}
