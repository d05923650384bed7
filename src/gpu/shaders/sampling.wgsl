// Deterministic sample patterns, bit for bit those of src/sampling: hash32 (sampling::hash32)
// and Owen-scrambled Sobol points (sampling::sobol::owen_sobol). WGSL's u32 arithmetic wraps
// as Rust's wrapping_* does, so every function here returns the CPU's exact bits.

// Wellons' "lowbias32": a bijective 32-bit hash.
fn hash32(key: u32) -> u32 {
    var x = key;
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    return x ^ (x >> 16u);
}

// Direction numbers v_k of Sobol dimensions 2-5 (Joe & Kuo's primitive polynomials and initial
// numbers, as src/sampling/sobol.rs derives them): bit k of the index toggles v_k. Dimension 1
// (van der Corput, v_k = 1 << (31 - k)) is the index's bits reversed and needs no table.
const SAMPLING_SOBOL_DIRECTIONS = array<u32, 128>(
    // Dimension 2.
    0x80000000u, 0xc0000000u, 0xa0000000u, 0xf0000000u, 0x88000000u, 0xcc000000u, 0xaa000000u, 0xff000000u,
    0x80800000u, 0xc0c00000u, 0xa0a00000u, 0xf0f00000u, 0x88880000u, 0xcccc0000u, 0xaaaa0000u, 0xffff0000u,
    0x80008000u, 0xc000c000u, 0xa000a000u, 0xf000f000u, 0x88008800u, 0xcc00cc00u, 0xaa00aa00u, 0xff00ff00u,
    0x80808080u, 0xc0c0c0c0u, 0xa0a0a0a0u, 0xf0f0f0f0u, 0x88888888u, 0xccccccccu, 0xaaaaaaaau, 0xffffffffu,
    // Dimension 3.
    0x80000000u, 0xc0000000u, 0x60000000u, 0x90000000u, 0xe8000000u, 0x5c000000u, 0x8e000000u, 0xc5000000u,
    0x68800000u, 0x9cc00000u, 0xee600000u, 0x55900000u, 0x80680000u, 0xc09c0000u, 0x60ee0000u, 0x90550000u,
    0xe8808000u, 0x5cc0c000u, 0x8e606000u, 0xc5909000u, 0x6868e800u, 0x9c9c5c00u, 0xeeee8e00u, 0x5555c500u,
    0x8000e880u, 0xc0005cc0u, 0x60008e60u, 0x9000c590u, 0xe8006868u, 0x5c009c9cu, 0x8e00eeeeu, 0xc5005555u,
    // Dimension 4.
    0x80000000u, 0xc0000000u, 0x20000000u, 0x50000000u, 0xf8000000u, 0x74000000u, 0xa2000000u, 0x93000000u,
    0xd8800000u, 0x25400000u, 0x59e00000u, 0xe6d00000u, 0x78080000u, 0xb40c0000u, 0x82020000u, 0xc3050000u,
    0x208f8000u, 0x51474000u, 0xfbea2000u, 0x75d93000u, 0xa0858800u, 0x914e5400u, 0xdbe79e00u, 0x25db6d00u,
    0x58800080u, 0xe54000c0u, 0x79e00020u, 0xb6d00050u, 0x800800f8u, 0xc00c0074u, 0x200200a2u, 0x50050093u,
    // Dimension 5.
    0x80000000u, 0x40000000u, 0x20000000u, 0xb0000000u, 0xf8000000u, 0xdc000000u, 0x7a000000u, 0x9d000000u,
    0x5a800000u, 0x2fc00000u, 0xa1600000u, 0xf0b00000u, 0xda880000u, 0x6fc40000u, 0x81620000u, 0x40bb0000u,
    0x22878000u, 0xb3c9c000u, 0xfb65a000u, 0xddb2d000u, 0x78022800u, 0x9c0b3c00u, 0x5a0fb600u, 0x2d0ddb00u,
    0xa2878080u, 0xf3c9c040u, 0xdb65a020u, 0x6db2d0b0u, 0x800228f8u, 0x400b3cdcu, 0x200fb67au, 0xb00ddb9du,
);

// The unscrambled Sobol point `index` in dimension `dim` (0-4), as a 32-bit fraction: the XOR
// of the direction numbers of the index's set bits (sobol_by_bits, which the CPU's byte tables
// equal).
fn sampling_sobol(index: u32, dim: u32) -> u32 {
    if dim == 0u {
        return reverseBits(index);
    }
    let base = (dim - 1u) * 32u;
    var x = 0u;
    var bits = index;
    while bits != 0u {
        x ^= SAMPLING_SOBOL_DIRECTIONS[base + countTrailingZeros(bits)];
        bits &= bits - 1u;
    }
    return x;
}

// Laine-Karras: a random permutation of the bits below each bit, keyed by `seed`.
fn sampling_laine_karras(value: u32, seed: u32) -> u32 {
    var x = value + seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

// Owen (nested uniform) scrambling of the 32-bit fraction `x`, keyed by `seed`.
fn sampling_nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    return reverseBits(sampling_laine_karras(reverseBits(x), seed));
}

// Sample `index` of the pattern keyed by `seed` in dimension `dim` (< 5), in [0, 1): the
// shuffled index's Sobol point, scrambled per dimension; its top 24 bits, exact in f32.
fn owen_sobol(index: u32, dim: u32, seed: u32) -> f32 {
    let shuffled = sampling_nested_uniform_scramble(index, seed);
    let x = sampling_nested_uniform_scramble(
        sampling_sobol(shuffled, dim),
        hash32(seed ^ (dim * 0x9e3779b9u)),
    );
    return f32(x >> 8u) * (1.0 / 16777216.0);
}
