//! The ocean's random numbers: a counter-based generator keyed by (seed, wave index), so each
//! Fourier component's random amplitude depends only on the seed and its integer wavevector —
//! not on the order of evaluation, the thread count or the grid resolution — and is the same
//! bits on every machine (integer hashing, then Box–Muller in f64 through `libm`).

/// SplitMix64's finaliser: a bijective 64-bit mix.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

const GOLDEN: u64 = 0x9E37_79B9_7F4A_7C15;

/// Uniform in (0, 1] with 53 random bits.
#[inline]
fn unit_open_closed(bits: u64) -> f64 {
    ((bits >> 11) + 1) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A pair of independent standard normal variates for wave index (`m`, `n`) under `seed`.
pub fn gaussian_pair(seed: i64, m: i32, n: i32) -> (f64, f64) {
    let base = mix64((seed as u64) ^ 0x0CEA_4D5E_ED00_0000);
    let key = mix64(base ^ ((m as u32 as u64) | ((n as u32 as u64) << 32)));
    let u1 = unit_open_closed(mix64(key.wrapping_add(GOLDEN)));
    let u2 = unit_open_closed(mix64(key.wrapping_add(GOLDEN.wrapping_mul(2))));
    let r = libm::sqrt(-2.0 * libm::log(u1));
    let phi = 2.0 * std::f64::consts::PI * u2;
    (r * libm::cos(phi), r * libm::sin(phi))
}
