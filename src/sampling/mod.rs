//! Deterministic random numbers for Monte Carlo sampling.
//!
//! Every camera sample owns its own stream, keyed by (seed, pixel, sample index), so the image
//! does not depend on which thread renders which tile or in which order: the same seed gives
//! the same image bit for bit whatever the thread count.

pub mod sobol;

/// PCG32 (O'Neill 2014, XSH-RR variant): small state, good statistical quality, cheap to seed.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    increment: u64,
}

const PCG_MULTIPLIER: u64 = 6364136223846793005;

/// SplitMix64 finaliser: decorrelates nearby keys (neighbouring pixels, consecutive samples).
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
    z ^ (z >> 31)
}

impl Rng {
    /// A stream from an arbitrary 64-bit state and stream selector.
    pub fn new(state: u64, stream: u64) -> Self {
        let mut rng = Rng {
            state: 0,
            increment: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(state);
        rng.next_u32();
        rng
    }

    /// The stream of one camera sample: sample `sample` of pixel `pixel` under `seed`.
    pub fn for_sample(seed: u64, pixel: u32, sample: u32) -> Self {
        let key = mix64(seed ^ mix64(((pixel as u64) << 32) | sample as u64));
        Rng::new(key, mix64(key ^ 0x9e3779b97f4a7c15))
    }

    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(PCG_MULTIPLIER)
            .wrapping_add(self.increment);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1): the top 24 bits, so the result is exact in f32 and never 1.0.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// Uniform in [0, 1) with 53 bits, for the f64 optics code.
    pub fn next_f64(&mut self) -> f64 {
        let hi = (self.next_u32() as u64) << 21;
        let lo = (self.next_u32() >> 11) as u64;
        (hi | lo) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    pub fn next_2d(&mut self) -> [f32; 2] {
        [self.next_f32(), self.next_f32()]
    }
}

/// A bijective 32-bit integer hash (Wellons' "lowbias32"): turns neighbouring indices into
/// unrelated keys with 32-bit operations only, so a loop of them vectorises.
#[inline(always)]
pub fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846ca68b);
    x ^ (x >> 16)
}

/// A keyed pseudo-random permutation of 0..`len` (Kensler 2013, "Correlated Multi-Jittered
/// Sampling"), evaluated one element at a time: a hash that is a bijection on the next power of
/// two, cycle-walked until it lands in 0..`len`, then a keyed rotation. For a power-of-two
/// `len` the walk always stops after one round.
#[derive(Clone, Copy, Debug)]
pub struct Permutation {
    len: u32,
    mask: u32,
}

impl Permutation {
    pub fn new(len: u32) -> Self {
        assert!(len > 0, "a permutation of nothing");
        let mask = if len == 1 {
            0
        } else {
            u32::MAX >> (len - 1).leading_zeros()
        };
        Permutation { len, mask }
    }

    pub fn len(&self) -> u32 {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        false
    }

    /// Element `i` (< len) of the permutation under `key`.
    pub fn apply(&self, i: u32, key: u32) -> u32 {
        debug_assert!(i < self.len);
        let mut j = self.round(i, key);
        while !self.landed(j) {
            j = self.round(j, key);
        }
        self.rotate(j, key)
    }

    /// Whether one round ever leaves 0..len, i.e. whether cycle walking can be needed.
    fn walks(&self) -> bool {
        self.mask != self.len - 1
    }

    fn landed(&self, j: u32) -> bool {
        j < self.len
    }

    /// One round of Kensler's hash: a bijection on 0..=mask.
    #[inline(always)]
    fn round(&self, mut i: u32, key: u32) -> u32 {
        let w = self.mask;
        i ^= key;
        i = i.wrapping_mul(0xe170893d);
        i ^= key >> 16;
        i ^= (i & w) >> 4;
        i ^= key >> 8;
        i = i.wrapping_mul(0x0929eb3f);
        i ^= key >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | key >> 27);
        i = i.wrapping_mul(0x6935fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dcb303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e501cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860a3df);
        i &= w;
        i ^ (i >> 5)
    }

    /// Kensler's final `(i + key) % len`, as a rotation by an offset taken from the key's high
    /// bits with a multiply (Lemire's range reduction) instead of a division.
    #[inline(always)]
    fn rotate(&self, j: u32, key: u32) -> u32 {
        let offset = ((key as u64 * self.len as u64) >> 32) as u32;
        let room = self.len - offset;
        if j >= room { j - room } else { j + offset }
    }
}

/// A keyed hash of `i` to [0, 1) (Kensler 2013).
#[inline(always)]
fn hash_to_unit(mut i: u32, key: u32) -> f32 {
    i ^= key;
    i ^= i >> 17;
    i ^= i >> 10;
    i = i.wrapping_mul(0xb36534e5);
    i ^= i >> 12;
    i ^= i >> 21;
    i = i.wrapping_mul(0x93fc4795);
    i ^= 0xdf6e307f;
    i ^= i >> 17;
    i = i.wrapping_mul(1 | key >> 18);
    ((i >> 8) as f32 * (1.0 / (1u32 << 24) as f32)).min(1.0 - f32::EPSILON / 2.0)
}

/// Keys of the permutations and jitters inside one pattern, from the pattern's key.
const COUNT_KEY: u32 = 0x51633e2d;
const COLUMN_KEY: u32 = 0x68bc21eb;
const ROW_KEY: u32 = 0x02e5be93;
const JITTER_X_KEY: u32 = 0x967a889b;
const JITTER_Y_KEY: u32 = 0x368cc8b7;

/// Correlated multi-jittered 2D points (Kensler 2013): the `count` points of one key are
/// stratified in x and in y (one per 1/`count` strip) and jointly on an m × n grid, for any
/// count. Each key gives its own pattern, so pixels do not share one and film and pupil samples
/// are decorrelated. The per-count constants are worked out once here, not per point.
#[derive(Clone, Copy, Debug)]
pub struct CorrelatedMultiJitter {
    points: Permutation,
    columns: Permutation,
    rows: Permutation,
    /// ⌈2³¹ / m⌉: `s / m` as a multiply and shift, exact for s · m < 2³¹ (Lemire, Kaser &
    /// Kurz 2019), which `MAX_COUNT` guarantees.
    row_magic: u32,
    inv_columns: f32,
    inv_rows: f32,
}

/// Points processed together by [`CorrelatedMultiJitter::fill`]: scratch on the stack.
const CHUNK: usize = 256;

impl CorrelatedMultiJitter {
    /// The largest pattern: s · m < count^1.5 ≤ 2³⁰ keeps the row division exact.
    pub const MAX_COUNT: u32 = 1 << 20;

    pub fn new(count: u32) -> Self {
        assert!(
            (1..=Self::MAX_COUNT).contains(&count),
            "pattern of {count} points"
        );
        let columns = grid_columns(count);
        let rows = count.div_ceil(columns);
        CorrelatedMultiJitter {
            points: Permutation::new(count),
            columns: Permutation::new(columns),
            rows: Permutation::new(rows),
            row_magic: (1u32 << 31).div_ceil(columns),
            inv_columns: 1.0 / columns as f32,
            inv_rows: 1.0 / rows as f32,
        }
    }

    pub fn count(&self) -> u32 {
        self.points.len()
    }

    /// The grid of joint strata: (columns m, rows n).
    pub fn grid(&self) -> (u32, u32) {
        (self.columns.len(), self.rows.len())
    }

    /// Point `index` of the pattern under `key`.
    pub fn sample(&self, index: u32, key: u32) -> [f32; 2] {
        let (mut x, mut y) = ([0.0], [0.0]);
        self.fill(index, &[key], &mut x, &mut y);
        [x[0], y[0]]
    }

    /// Point `index` of the pattern under each of `keys`, into `x` and `y`. Every step runs
    /// over a whole chunk of keys at once, so the hashes vectorise; only the cycle walks of
    /// non-power-of-two permutations go back to one key at a time.
    #[inline(always)]
    pub fn fill(&self, index: u32, keys: &[u32], x: &mut [f32], y: &mut [f32]) {
        assert!(index < self.count() && x.len() == keys.len() && y.len() == keys.len());
        for ((keys, x), y) in keys
            .chunks(CHUNK)
            .zip(x.chunks_mut(CHUNK))
            .zip(y.chunks_mut(CHUNK))
        {
            self.fill_chunk(index, keys, x, y);
        }
    }

    #[inline(always)]
    fn fill_chunk(&self, index: u32, keys: &[u32], x: &mut [f32], y: &mut [f32]) {
        let n = keys.len();
        let mut s = [0u32; CHUNK];
        let mut sx = [0u32; CHUNK];
        let mut sy = [0u32; CHUNK];
        let (s, sx, sy) = (&mut s[..n], &mut sx[..n], &mut sy[..n]);
        let key = |i: usize, k: u32| keys[i].wrapping_mul(k);

        permute_all(&self.points, s, |i| (index, key(i, COUNT_KEY)));
        let row = |s: u32| ((s as u64 * self.row_magic as u64) >> 31) as u32;
        let m = self.columns.len();
        permute_all(&self.columns, sx, |i| {
            (s[i] - row(s[i]) * m, key(i, COLUMN_KEY))
        });
        permute_all(&self.rows, sy, |i| (row(s[i]), key(i, ROW_KEY)));

        let below_one = |v: f32| v.min(1.0 - f32::EPSILON / 2.0);
        for i in 0..n {
            let (r, c) = (row(s[i]), s[i] - row(s[i]) * m);
            let jx = hash_to_unit(s[i], key(i, JITTER_X_KEY));
            let jy = hash_to_unit(s[i], key(i, JITTER_Y_KEY));
            x[i] = below_one((c as f32 + (sy[i] as f32 + jx) * self.inv_rows) * self.inv_columns);
            y[i] = below_one((r as f32 + (sx[i] as f32 + jy) * self.inv_columns) * self.inv_rows);
        }
    }
}

/// `out[i]` = element `input(i).0` of `permutation` under key `input(i).1`, for every i: the
/// first round over all of them (vectorisable), then cycle walks where one is needed.
#[inline(always)]
fn permute_all(permutation: &Permutation, out: &mut [u32], input: impl Fn(usize) -> (u32, u32)) {
    for (i, o) in out.iter_mut().enumerate() {
        let (v, key) = input(i);
        *o = permutation.round(v, key);
    }
    if permutation.walks() {
        for (i, o) in out.iter_mut().enumerate() {
            let (_, key) = input(i);
            while !permutation.landed(*o) {
                *o = permutation.round(*o, key);
            }
        }
    }
    for (i, o) in out.iter_mut().enumerate() {
        let (_, key) = input(i);
        *o = permutation.rotate(*o, key);
    }
}

/// Columns m of the joint-strata grid of `count` points: a divisor of `count` when one gives
/// cells no longer than 2 : 1 (every cell then holds a point: 32 points fill 4 × 8, where
/// ⌊√32⌋ = 5 would leave 3 of 5 × 7 empty; powers of two get power-of-two grids, so no cycle
/// walks), else ⌊√count⌋ with n = ⌈count / m⌉ rows as Kensler.
fn grid_columns(count: u32) -> u32 {
    let root = (count as f64).sqrt() as u32;
    let root = root.max(1);
    (1..=root)
        .rev()
        .take_while(|&m| count <= 2 * m * m)
        .find(|&m| count.is_multiple_of(m))
        .unwrap_or(root)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<u32> = (0..8)
            .map({
                let mut r = Rng::for_sample(7, 3, 1);
                move |_| r.next_u32()
            })
            .collect();
        let b: Vec<u32> = (0..8)
            .map({
                let mut r = Rng::for_sample(7, 3, 1);
                move |_| r.next_u32()
            })
            .collect();
        let c: Vec<u32> = (0..8)
            .map({
                let mut r = Rng::for_sample(7, 3, 2);
                move |_| r.next_u32()
            })
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn permutations_are_bijections() {
        for len in (1u32..=70).chain([100, 127, 128, 129, 1000]) {
            let permutation = Permutation::new(len);
            for key in [0, 1, 0xdead_beef, u32::MAX] {
                let mut seen: Vec<u32> = (0..len).map(|i| permutation.apply(i, key)).collect();
                seen.sort();
                assert_eq!(seen, (0..len).collect::<Vec<_>>(), "len {len} key {key:#x}");
            }
        }
    }

    #[test]
    fn grids_cover_every_count_with_cells_near_square() {
        for count in 1..=5000 {
            let (m, n) = CorrelatedMultiJitter::new(count).grid();
            assert!(m * n >= count && m * (n - 1) < count, "{count}: {m} × {n}");
            assert!(n >= m && n <= 2 * m + 2, "{count}: {m} × {n}");
            if count.is_power_of_two() {
                assert_eq!(m * n, count, "{count}: {m} × {n}");
            }
        }
        assert_eq!(CorrelatedMultiJitter::new(32).grid(), (4, 8));
        assert_eq!(CorrelatedMultiJitter::new(100).grid(), (10, 10));
        let largest = CorrelatedMultiJitter::new(CorrelatedMultiJitter::MAX_COUNT);
        assert_eq!(largest.grid(), (1024, 1024));
    }

    /// The CMJ properties, for grids filled exactly and not: every point in [0, 1)², at most
    /// one point per cell of the m × n grid and per 1/(m n) strip in x and in y (so exactly
    /// one each when count = m n).
    #[test]
    fn multi_jitter_is_stratified_in_x_y_and_jointly() {
        for count in (1u32..=70).chain([100, 128, 256, 1000]) {
            let pattern = CorrelatedMultiJitter::new(count);
            let (m, n) = pattern.grid();
            let strips = (m * n) as usize;
            for key in [0u32, 7, 0x9e37_79b9, u32::MAX] {
                let keys = vec![key; 300];
                let (mut cells, mut x_strips, mut y_strips) =
                    (vec![0; strips], vec![0; strips], vec![0; strips]);
                for i in 0..count {
                    let [x, y] = pattern.sample(i, key);
                    assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
                    let (cx, cy) = ((x * m as f32) as u32, (y * n as f32) as u32);
                    cells[(cy * m + cx) as usize] += 1;
                    x_strips[(x * strips as f32) as usize] += 1;
                    y_strips[(y * strips as f32) as usize] += 1;
                    // The batched fill (more keys than one chunk) gives the same points.
                    let (mut bx, mut by) = (vec![0.0; keys.len()], vec![0.0; keys.len()]);
                    pattern.fill(i, &keys, &mut bx, &mut by);
                    assert!(bx.iter().all(|&v| v == x) && by.iter().all(|&v| v == y));
                }
                for (what, hits) in [
                    ("cell", &cells),
                    ("x strip", &x_strips),
                    ("y strip", &y_strips),
                ] {
                    assert!(
                        hits.iter().all(|&c| c <= 1),
                        "count {count} key {key:#x}: {what}s {hits:?}"
                    );
                }
            }
        }
    }

    /// Different keys give different patterns (pixels and film / pupil do not share one).
    #[test]
    fn keys_give_distinct_patterns() {
        let pattern = CorrelatedMultiJitter::new(32);
        let points = |key| (0..32).map(|i| pattern.sample(i, key)).collect::<Vec<_>>();
        let (a, b) = (points(hash32(1)), points(hash32(2)));
        assert!(a.iter().zip(&b).filter(|(p, q)| p != q).count() > 28);
    }

    #[test]
    fn uniform_mean_and_range() {
        let mut rng = Rng::new(1, 2);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let u = rng.next_f32();
            assert!((0.0..1.0).contains(&u));
            sum += u as f64;
        }
        // Standard error of the mean of U(0,1) is 1/sqrt(12 n) ≈ 6.5e-4: five sigma.
        assert!((sum / n as f64 - 0.5).abs() < 3.3e-3);
    }
}
