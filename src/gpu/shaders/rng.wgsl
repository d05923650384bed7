// sampling::Rng on the GPU: PCG32 (XSH-RR) with its 64-bit state and increment emulated as
// (lo, hi) pairs of u32, seeded exactly as the CPU seeds it (SplitMix64 of the key), so a
// kernel draws the same numbers, bit for bit, as the CPU stream of the same (seed, pixel,
// sample). WGSL has no 64-bit integers.

struct Rng {
    state: vec2u,      // (lo, hi)
    increment: vec2u,  // (lo, hi), always odd
}

// PCG's multiplier 6364136223846793005 = 0x5851f42d_4c957f2d.
const RNG_PCG_MULTIPLIER: vec2u = vec2u(0x4c957f2du, 0x5851f42du);

// The full 64-bit product of two u32s, from 16-bit halves (no carries lost).
fn rng_mul_wide(a: u32, b: u32) -> vec2u {
    let a_lo = a & 0xffffu;
    let a_hi = a >> 16u;
    let b_lo = b & 0xffffu;
    let b_hi = b >> 16u;
    let lo_lo = a_lo * b_lo;
    let hi_lo = a_hi * b_lo;
    let lo_hi = a_lo * b_hi;
    let hi_hi = a_hi * b_hi;
    let middle = (lo_lo >> 16u) + (hi_lo & 0xffffu) + lo_hi;
    let lo = (middle << 16u) | (lo_lo & 0xffffu);
    let hi = hi_hi + (hi_lo >> 16u) + (middle >> 16u);
    return vec2u(lo, hi);
}

// a × b mod 2⁶⁴ (u64::wrapping_mul).
fn rng_mul64(a: vec2u, b: vec2u) -> vec2u {
    let low = rng_mul_wide(a.x, b.x);
    return vec2u(low.x, low.y + a.x * b.y + a.y * b.x);
}

// a + b mod 2⁶⁴ (u64::wrapping_add).
fn rng_add64(a: vec2u, b: vec2u) -> vec2u {
    let lo = a.x + b.x;
    return vec2u(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}

// a >> n for 0 < n < 32.
fn rng_shr64_small(a: vec2u, n: u32) -> vec2u {
    return vec2u((a.x >> n) | (a.y << (32u - n)), a.y >> n);
}

// a >> n for 32 ≤ n < 64.
fn rng_shr64_large(a: vec2u, n: u32) -> vec2u {
    return vec2u(a.y >> (n - 32u), 0u);
}

// SplitMix64's finaliser (sampling::mix64).
fn rng_mix64(value: vec2u) -> vec2u {
    var z = value;
    z = rng_mul64(z ^ rng_shr64_small(z, 30u), vec2u(0x1ce4e5b9u, 0xbf58476du));
    z = rng_mul64(z ^ rng_shr64_small(z, 27u), vec2u(0x133111ebu, 0x94d049bbu));
    return z ^ rng_shr64_small(z, 31u);
}

// Rng::new(state, stream).
fn rng_new(state: vec2u, stream: vec2u) -> Rng {
    // (stream << 1) | 1
    let increment = vec2u((stream.x << 1u) | 1u, (stream.y << 1u) | (stream.x >> 31u));
    var rng = Rng(vec2u(0u, 0u), increment);
    rng_next_u32(&rng);
    rng.state = rng_add64(rng.state, state);
    rng_next_u32(&rng);
    return rng;
}

// Rng::for_sample(seed, pixel, sample), the seed given as its (lo, hi) halves.
fn rng_for_sample(seed_lo: u32, seed_hi: u32, pixel: u32, sample: u32) -> Rng {
    // ((pixel as u64) << 32) | sample
    let key = rng_mix64(vec2u(seed_lo, seed_hi) ^ rng_mix64(vec2u(sample, pixel)));
    // 0x9e3779b97f4a7c15: the golden-ratio constant the CPU mixes into the stream selector.
    return rng_new(key, rng_mix64(key ^ vec2u(0x7f4a7c15u, 0x9e3779b9u)));
}

fn rng_next_u32(rng: ptr<function, Rng>) -> u32 {
    let old = (*rng).state;
    (*rng).state = rng_add64(rng_mul64(old, RNG_PCG_MULTIPLIER), (*rng).increment);
    // ((old >> 18) ^ old) >> 27, truncated to 32 bits.
    let mixed = rng_shr64_small(old, 18u) ^ old;
    let xorshifted = rng_shr64_small(mixed, 27u).x;
    let rotation = rng_shr64_large(old, 59u).x;
    return (xorshifted >> rotation) | (xorshifted << ((32u - rotation) & 31u));
}

// Uniform in [0, 1): the top 24 bits, exact in f32 and never 1.
fn rng_next_f32(rng: ptr<function, Rng>) -> f32 {
    return f32(rng_next_u32(rng) >> 8u) * (1.0 / 16777216.0);
}

fn rng_next_2d(rng: ptr<function, Rng>) -> vec2f {
    let u0 = rng_next_f32(rng);
    let u1 = rng_next_f32(rng);
    return vec2f(u0, u1);
}
