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
