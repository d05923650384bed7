//! Owen-scrambled Sobol points: samples that stay stratified jointly over several dimensions.
//!
//! A pixel's camera sample is a film point, a pupil point and, in a spectral render, a
//! wavelength; what the pixel sees varies with all of them together (an edge's coverage with
//! the film point, defocus and vignetting with the pupil point, colour with the wavelength),
//! and only a pattern stratified in the dimensions *jointly* keeps their product's sum from
//! picking up the product of the variances (independently stratified dimensions, paired at
//! random, do). Sobol's first dimensions are such a pattern; each pixel gets its own random
//! variant by nested uniform (Owen) scrambling, done with the hash-based permutation of Burley,
//! "Practical Hash-based Owen Scrambling" (JCGT 2020).

use super::hash32;

/// Dimensions provided.
pub const DIMENSIONS: usize = 5;

/// Primitive polynomials (degree s, inner coefficient bits a) and initial direction numbers
/// m₁…m_s of Sobol dimensions 2–5, from Joe & Kuo's tables (new-joe-kuo-6.21201); dimension 1
/// is van der Corput.
const PARAMETERS: [(u32, u32, [u32; 3]); DIMENSIONS - 1] = [
    (1, 0, [1, 0, 0]),
    (2, 1, [1, 3, 0]),
    (3, 1, [1, 3, 1]),
    (3, 2, [1, 1, 1]),
];

/// Direction numbers v_k of each dimension (bit k of the index toggles v_k).
const DIRECTIONS: [[u32; 32]; DIMENSIONS] = directions();

const fn directions() -> [[u32; 32]; DIMENSIONS] {
    let mut v = [[0u32; 32]; DIMENSIONS];
    let mut k = 0;
    while k < 32 {
        v[0][k] = 1 << (31 - k);
        k += 1;
    }
    let mut d = 1;
    while d < DIMENSIONS {
        let (s, a, m) = PARAMETERS[d - 1];
        let s = s as usize;
        let mut k = 0;
        while k < 32 {
            v[d][k] = if k < s {
                m[k] << (31 - k)
            } else {
                // v_k = v_{k−s} ⊕ (v_{k−s} ≫ s) ⊕ Σ a_i·v_{k−i}.
                let mut x = v[d][k - s] ^ (v[d][k - s] >> s);
                let mut i = 1;
                while i < s {
                    if (a >> (s - 1 - i)) & 1 == 1 {
                        x ^= v[d][k - i];
                    }
                    i += 1;
                }
                x
            };
            k += 1;
        }
        d += 1;
    }
    v
}

/// XOR of the direction numbers that each byte of an index selects, per dimension and byte
/// position: the Sobol point is linear over GF(2) in the index bits, so it is the XOR of four
/// table entries. 5 × 4 × 256 words = 20 KiB.
static BYTE_TABLES: [[[u32; 256]; 4]; DIMENSIONS] = byte_tables();

const fn byte_tables() -> [[[u32; 256]; 4]; DIMENSIONS] {
    let mut tables = [[[0u32; 256]; 4]; DIMENSIONS];
    let mut d = 0;
    while d < DIMENSIONS {
        let mut byte = 0;
        while byte < 4 {
            let mut value = 0;
            while value < 256 {
                let mut x = 0;
                let mut bit = 0;
                while bit < 8 {
                    if (value >> bit) & 1 == 1 {
                        x ^= DIRECTIONS[d][8 * byte + bit];
                    }
                    bit += 1;
                }
                tables[d][byte][value] = x;
                value += 1;
            }
            byte += 1;
        }
        d += 1;
    }
    tables
}

/// The unscrambled Sobol point `index` in dimension `dim`, as a 32-bit fraction.
///
/// Four table look-ups, whatever the index: the points are drawn at Owen-shuffled indices,
/// which are full 32-bit words (about 16 set bits), so a loop over set bits (the definition,
/// [`sobol_by_bits`]) cost 16 dependent, badly predicted steps per dimension.
#[inline]
pub fn sobol(index: u32, dim: usize) -> u32 {
    let tables = &BYTE_TABLES[dim];
    let [b0, b1, b2, b3] = index.to_le_bytes();
    tables[0][b0 as usize]
        ^ tables[1][b1 as usize]
        ^ tables[2][b2 as usize]
        ^ tables[3][b3 as usize]
}

/// [`sobol`] by its definition: the XOR of the direction numbers of the index's set bits.
/// The reference the table look-up is tested equal to.
pub fn sobol_by_bits(index: u32, dim: usize) -> u32 {
    let directions = &DIRECTIONS[dim];
    let mut x = 0;
    let mut bits = index;
    while bits != 0 {
        x ^= directions[bits.trailing_zeros() as usize];
        bits &= bits - 1;
    }
    x
}

/// A random permutation of the bits below each bit ("Laine–Karras"), keyed by `seed`: with the
/// bit order reversed around it, a nested uniform scramble of a 32-bit fraction.
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Owen (nested uniform) scrambling of the 32-bit fraction `x`, keyed by `seed`.
pub fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// Sample `index` of the pattern keyed by `seed` (a pixel's), in dimension `dim` <
/// [`DIMENSIONS`], in [0, 1). The reference [`owen_sobol_batch`] is tested equal to.
pub fn owen_sobol(index: u32, dim: usize, seed: u32) -> f32 {
    let shuffled = nested_uniform_scramble(index, seed);
    let x = nested_uniform_scramble(sobol(shuffled, dim), dimension_key(seed, dim));
    unit_f32(x)
}

/// The scramble key of dimension `dim` of the pattern keyed by `seed`.
#[inline(always)]
fn dimension_key(seed: u32, dim: usize) -> u32 {
    hash32(seed ^ (dim as u32).wrapping_mul(0x9e37_79b9))
}

/// The top 24 bits of a 32-bit fraction: an f32 below 1.
#[inline(always)]
fn unit_f32(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// Word buffers [`owen_sobol_batch`] works in, kept between calls.
#[derive(Clone, Debug, Default)]
pub struct SobolScratch {
    shuffled: Vec<u32>,
    points: Vec<u32>,
}

/// [`owen_sobol`]`(index, d, seeds[i])` into `out[d][i]` for every seed and the first `K`
/// dimensions, the same bits. The index is shuffled once per seed instead of once per
/// dimension, and each step runs over the whole batch in a loop of its own: the scrambles (bit
/// reversals, multiplications) vectorise, and only the table look-ups stay one lane at a time.
#[inline(always)]
pub fn owen_sobol_batch<const K: usize>(
    index: u32,
    seeds: &[u32],
    out: [&mut [f32]; K],
    scratch: &mut SobolScratch,
) {
    let n = seeds.len();
    let SobolScratch { shuffled, points } = scratch;
    shuffled.clear();
    shuffled.extend(
        seeds
            .iter()
            .map(|&seed| nested_uniform_scramble(index, seed)),
    );
    points.resize(n, 0);
    for (dim, out) in out.into_iter().enumerate() {
        for (point, &shuffled) in points.iter_mut().zip(shuffled.iter()) {
            *point = sobol(shuffled, dim);
        }
        for ((out, &point), &seed) in out[..n].iter_mut().zip(points.iter()).zip(seeds) {
            *out = unit_f32(nested_uniform_scramble(point, dimension_key(seed, dim)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Known first points of dimensions 2 and 3 (the unscrambled sequence, in index order
    /// rather than Gray-code order).
    /// The byte-table look-up gives the definition's point for every dimension at indices
    /// with every bit pattern: single bits, all ones, byte boundaries, and pseudo-random words
    /// (the Owen-shuffled indices the renderer uses).
    #[test]
    fn table_lookup_equals_the_definition() {
        let mut indices: Vec<u32> = (0..32).map(|k| 1u32 << k).collect();
        indices.extend([
            0,
            u32::MAX,
            0xff,
            0xff00,
            0x00ff_0000,
            0xff00_0000,
            0x8000_0001,
        ]);
        indices
            .extend((0..10_000u32).map(|i| crate::sampling::hash32(i.wrapping_mul(0x9e37_79b9))));
        indices.extend(0..4096);
        for dim in 0..DIMENSIONS {
            for &i in &indices {
                assert_eq!(
                    sobol(i, dim),
                    sobol_by_bits(i, dim),
                    "index {i:#x}, dimension {dim}"
                );
            }
        }
    }

    /// The batch gives the reference's bits for every seed, dimension and a spread of indices.
    #[test]
    fn the_batch_equals_the_reference() {
        let seeds: Vec<u32> = (0..1000u32).map(|i| hash32(i ^ 0x5eed)).collect();
        let mut scratch = SobolScratch::default();
        for index in [0u32, 1, 2, 7, 64, 1000, 65_535, 1 << 20, u32::MAX] {
            let mut out: [Vec<f32>; DIMENSIONS] = std::array::from_fn(|_| vec![0.0; seeds.len()]);
            owen_sobol_batch(
                index,
                &seeds,
                out.each_mut().map(|v| &mut v[..]),
                &mut scratch,
            );
            for (d, values) in out.iter().enumerate() {
                for (&value, &seed) in values.iter().zip(&seeds) {
                    assert_eq!(value.to_bits(), owen_sobol(index, d, seed).to_bits());
                }
            }
        }
    }

    /// The first 64 unscrambled points of all five dimensions, ×64, as an independent
    /// implementation gives them: SciPy's `qmc.Sobol(d=5, scramble=False).random(64)` (Joe &
    /// Kuo's numbers, generated in Gray-code order, so its point i is ours at i ⊕ (i ≫ 1)).
    /// 64 points fix the first six direction numbers of each dimension: the initial ones and
    /// three or more from each recurrence.
    #[test]
    fn unscrambled_points_are_scipys() {
        const SCIPY: [[u32; 64]; DIMENSIONS] = [
            [
                0, 32, 48, 16, 24, 56, 40, 8, 12, 44, 60, 28, 20, 52, 36, 4, 6, 38, 54, 22, 30, 62,
                46, 14, 10, 42, 58, 26, 18, 50, 34, 2, 3, 35, 51, 19, 27, 59, 43, 11, 15, 47, 63,
                31, 23, 55, 39, 7, 5, 37, 53, 21, 29, 61, 45, 13, 9, 41, 57, 25, 17, 49, 33, 1,
            ],
            [
                0, 32, 16, 48, 24, 56, 8, 40, 20, 52, 4, 36, 12, 44, 28, 60, 30, 62, 14, 46, 6, 38,
                22, 54, 10, 42, 26, 58, 18, 50, 2, 34, 17, 49, 1, 33, 9, 41, 25, 57, 5, 37, 21, 53,
                29, 61, 13, 45, 15, 47, 31, 63, 23, 55, 7, 39, 27, 59, 11, 43, 3, 35, 19, 51,
            ],
            [
                0, 32, 16, 48, 40, 8, 56, 24, 60, 28, 44, 12, 20, 52, 4, 36, 30, 62, 14, 46, 54,
                22, 38, 6, 34, 2, 50, 18, 10, 42, 26, 58, 45, 13, 61, 29, 5, 37, 21, 53, 17, 49, 1,
                33, 57, 25, 41, 9, 51, 19, 35, 3, 27, 59, 11, 43, 15, 47, 31, 63, 39, 7, 55, 23,
            ],
            [
                0, 32, 16, 48, 56, 24, 40, 8, 28, 60, 12, 44, 36, 4, 52, 20, 42, 10, 58, 26, 18,
                50, 2, 34, 54, 22, 38, 6, 14, 46, 30, 62, 35, 3, 51, 19, 27, 59, 11, 43, 63, 31,
                47, 15, 7, 39, 23, 55, 9, 41, 25, 57, 49, 17, 33, 1, 21, 53, 5, 37, 45, 13, 61, 29,
            ],
            [
                0, 32, 48, 16, 24, 56, 40, 8, 36, 4, 20, 52, 60, 28, 12, 44, 18, 50, 34, 2, 10, 42,
                58, 26, 54, 22, 6, 38, 46, 14, 30, 62, 9, 41, 57, 25, 17, 49, 33, 1, 45, 13, 29,
                61, 53, 21, 5, 37, 27, 59, 43, 11, 3, 35, 51, 19, 63, 31, 15, 47, 39, 7, 23, 55,
            ],
        ];
        for (dim, expected) in SCIPY.iter().enumerate() {
            for (i, &x) in expected.iter().enumerate() {
                let i = i as u32;
                let ours = sobol_by_bits(i ^ (i >> 1), dim);
                assert_eq!(ours, x << 26, "dimension {dim}, point {i}");
            }
        }
    }

    #[test]
    fn unscrambled_points_are_sobols() {
        let f = |i, d| sobol(i, d) as f64 / 2f64.powi(32);
        let second: Vec<f64> = (0..8).map(|i| f(i, 1)).collect();
        assert_eq!(second, [0.0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875]);
        let third: Vec<f64> = (0..8).map(|i| f(i, 2)).collect();
        assert_eq!(third, [0.0, 0.5, 0.75, 0.25, 0.375, 0.875, 0.625, 0.125]);
    }

    /// How a pixel's first 2^m scrambled points stratify, for any pixel (Owen scrambling keeps
    /// the unscrambled net's properties). Dimensions 1 and 2 (the camera's pupil point) put
    /// exactly one point in every elementary interval of area 2^−m (a (0, m, 2)-net);
    /// dimensions 3 and 4 (its film point) two in every one of area 2^(1−m) (a (1, m,
    /// 2)-net, the quality value of this pair of Joe & Kuo's dimensions); and every dimension
    /// alone one point in each of 2^m equal intervals.
    #[test]
    fn scrambled_points_stay_stratified() {
        for seed in [1u32, 77, 0xdead_beef] {
            let m = 6u32;
            let n = 1u32 << m;
            let points: Vec<[f32; DIMENSIONS]> = (0..n)
                .map(|i| std::array::from_fn(|d| owen_sobol(i, d, seed)))
                .collect();
            for ((a, b), t) in [((0, 1), 0), ((2, 3), 1)] {
                for bits_x in 0..=m - t {
                    let (cx, cy) = (1u32 << bits_x, 1u32 << (m - t - bits_x));
                    let mut cells = vec![0; (n >> t) as usize];
                    for p in &points {
                        let i = (p[a] * cx as f32) as u32 + cx * (p[b] * cy as f32) as u32;
                        cells[i as usize] += 1;
                    }
                    assert!(
                        cells.iter().all(|&c| c == 1 << t),
                        "seed {seed}, dimensions {a} and {b}, {cx}×{cy}"
                    );
                }
            }
            for d in 0..DIMENSIONS {
                let mut strata = vec![0; n as usize];
                for p in &points {
                    strata[(p[d] * n as f32) as usize] += 1;
                }
                assert!(strata.iter().all(|&c| c == 1), "seed {seed}, dimension {d}");
            }
        }
    }
}
