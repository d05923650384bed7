//! Deterministic random numbers for Monte Carlo sampling.
//!
//! Every camera sample owns its own stream, keyed by (seed, pixel, sample index), so the image
//! does not depend on which thread renders which tile or in which order: the same seed gives
//! the same image bit for bit whatever the thread count.

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

/// A keyed pseudo-random permutation of 0..`len`, evaluated one element at a time (Kensler
/// 2013, "Correlated Multi-Jittered Sampling", by cycle-walking a hash over the next power of
/// two).
pub fn permute(mut i: u32, len: u32, key: u32) -> u32 {
    debug_assert!(i < len);
    let mut w = len.wrapping_sub(1);
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    loop {
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
        i ^= i >> 5;
        if i < len {
            break;
        }
    }
    (i.wrapping_add(key)) % len
}

/// A keyed hash of `i` to [0, 1) (Kensler 2013).
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

/// Sample `index` of `count` correlated multi-jittered 2D points under `key` (Kensler 2013):
/// the `count` points of one key are stratified in x, in y and jointly on an m × n grid,
/// for any count. Each pixel and each pair of dimensions uses its own key, so pixels do not
/// share a pattern and film and pupil samples are decorrelated.
pub fn correlated_multi_jitter(index: u32, count: u32, key: u32) -> [f32; 2] {
    let s = permute(index, count, key.wrapping_mul(0x51633e2d));
    let m = (count as f32).sqrt() as u32;
    let m = m.max(1);
    let n = count.div_ceil(m);
    let (column, row) = (s % m, s / m);
    let sx = permute(column, m, key.wrapping_mul(0x68bc21eb));
    let sy = permute(row, n, key.wrapping_mul(0x02e5be93));
    let jx = hash_to_unit(s, key.wrapping_mul(0x967a889b));
    let jy = hash_to_unit(s, key.wrapping_mul(0x368cc8b7));
    let x = (column as f32 + (sy as f32 + jx) / n as f32) / m as f32;
    let y = (row as f32 + (sx as f32 + jy) / m as f32) / n as f32;
    [
        x.min(1.0 - f32::EPSILON / 2.0),
        y.min(1.0 - f32::EPSILON / 2.0),
    ]
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
    fn permute_is_a_bijection() {
        for len in [1u32, 2, 7, 64, 100] {
            let mut seen: Vec<u32> = (0..len).map(|i| permute(i, len, 0xdead_beef)).collect();
            seen.sort();
            assert_eq!(seen, (0..len).collect::<Vec<_>>());
        }
    }

    #[test]
    fn multi_jitter_fills_every_grid_cell_once() {
        // count = m × n: one point in each of the m × n cells, m in each row, n in each column.
        for (count, m, n) in [(16u32, 4u32, 4u32), (30, 5, 6), (64, 8, 8)] {
            let mut cells = vec![0; (m * n) as usize];
            for i in 0..count {
                let [x, y] = correlated_multi_jitter(i, count, 77 + count);
                assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
                let (cx, cy) = ((x * m as f32) as u32, (y * n as f32) as u32);
                cells[(cy * m + cx) as usize] += 1;
            }
            assert!(cells.iter().all(|&c| c == 1), "count {count}: {cells:?}");
        }
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
