//! A texture's texel values as the renderer holds them: 32-bit floats, or the codes an 8- or
//! 16-bit file stores (16-bit integers, or half floats' bits) with each channel's value per
//! code (its transfer curve undone once per code, not once per texel). An 8-bit image is held
//! in a quarter of the float's memory, a 16-bit one in half, each shared with the file's
//! pixels as read.

use std::sync::{Arc, LazyLock};

/// Each channel's value for each of the 256 codes (channel 0–3 of a texel).
pub type CodeValues = [[f32; 256]; 4];

/// The number of 16-bit codes.
pub const CODES16: usize = 1 << 16;

/// Each channel's value for each 16-bit code, channel by channel (`channel * CODES16 + code`,
/// channels 0–3).
pub type CodeValues16 = Vec<f32>;

/// The value of a half float (IEEE 754 binary16) from its bits: exact, subnormals, infinities
/// and NaNs included.
pub fn half_to_f32(h: u16) -> f32 {
    let sign = ((h as u32) & 0x8000) << 16;
    let exp = ((h >> 10) & 0x1f) as u32;
    let man = (h & 0x3ff) as u32;
    let bits = match exp {
        // zero, or a subnormal: man × 2^-24, exact in f32
        0 => {
            let v = man as f32 / 16_777_216.0;
            return if sign != 0 { -v } else { v };
        }
        // infinity or NaN (the payload kept)
        0x1f => sign | 0x7f80_0000 | (man << 13),
        _ => sign | ((exp + 127 - 15) << 23) | (man << 13),
    };
    f32::from_bits(bits)
}

/// The values of codes read as code / 65535, in every channel (shared by every texture that
/// reads them undecoded).
static UNIT16: LazyLock<Arc<CodeValues16>> = LazyLock::new(|| Arc::new((0..4 * CODES16).map(|i| (i % CODES16) as f32 / 65535.0).collect()));

/// The values of half-float bits, in every channel.
static HALVES: LazyLock<Arc<CodeValues16>> = LazyLock::new(|| Arc::new((0..4 * CODES16).map(|i| half_to_f32((i % CODES16) as u16)).collect()));

#[derive(Clone, Debug)]
pub enum Texels {
    /// One value per texel channel, row-major, channels interleaved.
    F32(Arc<Vec<f32>>),
    /// One byte per texel channel (laid out as `F32`); a byte `b` of channel `c` (its position
    /// in the texel) stands for `values[c][b]`.
    U8 { codes: Arc<Vec<u8>>, values: Arc<CodeValues> },
    /// Two bytes per texel channel (laid out as `F32`); a code `b` of channel `c` stands for
    /// `values[c * CODES16 + b]`.
    U16 { codes: Arc<Vec<u16>>, values: Arc<CodeValues16> },
}

impl Default for Texels {
    fn default() -> Self {
        Texels::F32(Arc::default())
    }
}

impl From<Vec<f32>> for Texels {
    fn from(v: Vec<f32>) -> Self {
        Texels::F32(Arc::new(v))
    }
}

impl From<Arc<Vec<f32>>> for Texels {
    fn from(v: Arc<Vec<f32>>) -> Self {
        Texels::F32(v)
    }
}

impl PartialEq for Texels {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (Texels::F32(a), Texels::F32(b)) => a == b,
            (Texels::U8 { codes: a, values: va }, Texels::U8 { codes: b, values: vb }) => a == b && va == vb,
            // (the half table holds NaNs: the same table is equal to itself)
            (Texels::U16 { codes: a, values: va }, Texels::U16 { codes: b, values: vb }) => a == b && (Arc::ptr_eq(va, vb) || va == vb),
            // values held differently are told apart (a code's channel needs the texture's
            // channel count, which the texels do not hold)
            _ => false,
        }
    }
}

impl Texels {
    /// 8-bit codes read as code / 255 in every channel (the file's values, undecoded).
    pub fn unit_codes(codes: Arc<Vec<u8>>) -> Texels {
        let unit: [f32; 256] = std::array::from_fn(|b| b as f32 / 255.0);
        Texels::U8 { codes, values: Arc::new([unit; 4]) }
    }

    /// 16-bit codes read as code / 65535 in every channel (a 16-bit integer file's values).
    pub fn unit_codes16(codes: Arc<Vec<u16>>) -> Texels {
        Texels::U16 { codes, values: UNIT16.clone() }
    }

    /// Half floats held as their bits, read as the floats they stand for.
    pub fn halves(bits: Arc<Vec<u16>>) -> Texels {
        Texels::U16 { codes: bits, values: HALVES.clone() }
    }

    /// The number of values (texels × channels).
    pub fn len(&self) -> usize {
        match self {
            Texels::F32(v) => v.len(),
            Texels::U8 { codes, .. } => codes.len(),
            Texels::U16 { codes, .. } => codes.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Value `i` of a texture of `channels` channels (panics past the end).
    #[inline]
    pub fn value(&self, i: usize, channels: usize) -> f32 {
        match self {
            Texels::F32(v) => v[i],
            Texels::U8 { codes, values } => values[i % channels.max(1)][codes[i] as usize],
            Texels::U16 { codes, values } => values[(i % channels.max(1)) * CODES16 + codes[i] as usize],
        }
    }

    /// The `n` values from `start` (the `n` channels of one texel), in the first `n` slots.
    #[inline]
    pub fn texel(&self, start: usize, n: usize) -> [f32; 4] {
        let mut out = [0.0; 4];
        match self {
            Texels::F32(v) => out[..n].copy_from_slice(&v[start..start + n]),
            Texels::U8 { codes, values } => {
                for (k, (o, &b)) in out.iter_mut().zip(&codes[start..start + n]).enumerate() {
                    *o = values[k][b as usize];
                }
            }
            Texels::U16 { codes, values } => {
                for (k, (o, &b)) in out.iter_mut().zip(&codes[start..start + n]).enumerate() {
                    *o = values[k * CODES16 + b as usize];
                }
            }
        }
        out
    }

    /// Every value as a float (a copy for 8-bit texels), for builds that read each once.
    pub fn to_f32(&self, channels: usize) -> Vec<f32> {
        match self {
            Texels::F32(v) => v.as_ref().clone(),
            Texels::U8 { .. } | Texels::U16 { .. } => (0..self.len()).map(|i| self.value(i, channels)).collect(),
        }
    }

    /// Whether both are the same shared data (not merely equal values).
    pub fn same(&self, other: &Texels) -> bool {
        match (self, other) {
            (Texels::F32(a), Texels::F32(b)) => Arc::ptr_eq(a, b),
            (Texels::U8 { codes: a, values: va }, Texels::U8 { codes: b, values: vb }) => Arc::ptr_eq(a, b) && Arc::ptr_eq(va, vb),
            (Texels::U16 { codes: a, values: va }, Texels::U16 { codes: b, values: vb }) => Arc::ptr_eq(a, b) && Arc::ptr_eq(va, vb),
            _ => false,
        }
    }

    /// An address standing for the shared data (for caches keyed by it, beside [`Texels::same`]).
    pub fn address(&self) -> usize {
        match self {
            Texels::F32(v) => Arc::as_ptr(v) as usize,
            Texels::U8 { codes, .. } => Arc::as_ptr(codes) as usize,
            Texels::U16 { codes, .. } => Arc::as_ptr(codes) as usize,
        }
    }

    /// Whether every value is finite (for 8-bit texels: every code's value of the channels;
    /// for 16-bit ones: every channel's value of each code used, since half floats have codes
    /// for infinities and NaNs).
    pub fn all_finite(&self) -> bool {
        match self {
            Texels::F32(v) => v.iter().all(|x| x.is_finite()),
            Texels::U8 { values, .. } => values.iter().flatten().all(|x| x.is_finite()),
            Texels::U16 { codes, values } => {
                let bad: Vec<bool> = (0..CODES16).map(|b| (0..4).any(|c| !values[c * CODES16 + b].is_finite())).collect();
                !bad.iter().any(|&x| x) || !codes.iter().any(|&b| bad[b as usize])
            }
        }
    }

    /// Non-finite values replaced by 0.
    pub fn zero_non_finite(&mut self) {
        let fix = |x: &mut f32| {
            if !x.is_finite() {
                *x = 0.0
            }
        };
        match self {
            Texels::F32(v) => Arc::make_mut(v).iter_mut().for_each(fix),
            Texels::U8 { values, .. } => Arc::make_mut(values).iter_mut().flatten().for_each(fix),
            Texels::U16 { values, .. } => Arc::make_mut(values).iter_mut().for_each(fix),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_read_through_their_channel_values() {
        // 2 texels of 3 channels; channel 1 reads codes doubled, channel 2 their negation
        let mut values: CodeValues = [std::array::from_fn(|b| b as f32); 4];
        values[1] = std::array::from_fn(|b| 2.0 * b as f32);
        values[2] = std::array::from_fn(|b| -(b as f32));
        let t = Texels::U8 { codes: Arc::new(vec![1, 2, 3, 4, 5, 6]), values: Arc::new(values) };
        assert_eq!(t.to_f32(3), vec![1.0, 4.0, -3.0, 4.0, 10.0, -6.0]);
        assert_eq!(t.texel(3, 3), [4.0, 10.0, -6.0, 0.0]);
        assert_eq!(t.value(5, 3), -6.0);
        // equal codes and values are equal; shared data is the same
        let u = Texels::U8 { codes: Arc::new(vec![1, 2, 3, 4, 5, 6]), values: Arc::new(values) };
        assert!(t == u && !t.same(&u) && t.same(&t.clone()));
        assert!(Texels::unit_codes(Arc::new(vec![0, 51, 255])).to_f32(1) == vec![0.0, 0.2, 1.0]);
    }

    /// A half's value by its definition: (-1)^s 2^(e-15) (1 + m/1024), subnormals
    /// (-1)^s 2^-14 (m/1024), e = 31 infinities (m = 0) and NaNs.
    fn half_by_definition(h: u16) -> f64 {
        let s = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
        let (e, m) = (((h >> 10) & 0x1f) as i32, (h & 0x3ff) as f64);
        match e {
            0 => s * 2f64.powi(-14) * (m / 1024.0),
            31 if m == 0.0 => s * f64::INFINITY,
            31 => f64::NAN,
            _ => s * 2f64.powi(e - 15) * (1.0 + m / 1024.0),
        }
    }

    #[test]
    fn every_half_reads_as_the_number_it_stands_for() {
        for h in 0..=u16::MAX {
            let (got, want) = (half_to_f32(h), half_by_definition(h));
            if want.is_nan() {
                assert!(got.is_nan(), "{h:#06x}: {got}");
            } else {
                assert!(got as f64 == want && got.is_sign_negative() == (h & 0x8000 != 0), "{h:#06x}: {got} for {want}");
            }
        }
        // a few known ones
        assert_eq!((half_to_f32(0x3c00), half_to_f32(0xc000), half_to_f32(0x7bff), half_to_f32(0x0001)), (1.0, -2.0, 65504.0, 2f32.powi(-24)));
    }

    #[test]
    fn sixteen_bit_codes_read_through_their_channel_values() {
        let ints = Texels::unit_codes16(Arc::new(vec![0, 65535, 13107, 32768]));
        assert_eq!(ints.to_f32(2), vec![0.0, 1.0, 0.2, 32768.0 / 65535.0]);
        // 1.0, -2.0, 0.5 | 65504, 0, -0
        let halves = Texels::halves(Arc::new(vec![0x3c00, 0xc000, 0x3800, 0x7bff, 0x0000, 0x8000]));
        assert_eq!(halves.texel(3, 3), [65504.0, 0.0, 0.0, 0.0]);
        assert_eq!(halves.value(1, 3), -2.0);
        assert!(halves.value(5, 3).is_sign_negative());
        // a table of its own per channel: channel 1 doubled
        let mut values = vec![0.0; 4 * CODES16];
        for (i, v) in values.iter_mut().enumerate() {
            *v = (i % CODES16) as f32 * if i / CODES16 == 1 { 2.0 } else { 1.0 };
        }
        let t = Texels::U16 { codes: Arc::new(vec![7, 7, 9, 9]), values: Arc::new(values) };
        assert_eq!(t.to_f32(2), vec![7.0, 14.0, 9.0, 18.0]);
        // the shared tables are the same for every texture
        let other = Texels::halves(Arc::new(vec![0x3c00]));
        let (Texels::U16 { values: a, .. }, Texels::U16 { values: b, .. }) = (&halves, &other) else { unreachable!() };
        assert!(Arc::ptr_eq(a, b));
        assert!(halves == Texels::halves(Arc::new(vec![0x3c00, 0xc000, 0x3800, 0x7bff, 0x0000, 0x8000])) && halves != other);
    }

    #[test]
    fn only_the_half_codes_in_use_decide_finiteness() {
        // the half table has infinities and NaNs; texels not using them are finite
        assert!(Texels::halves(Arc::new(vec![0x3c00, 0x7bff])).all_finite());
        for bad in [0x7c00u16, 0xfc00, 0x7e00] {
            let mut t = Texels::halves(Arc::new(vec![0x3c00, bad, 0x3800]));
            assert!(!t.all_finite(), "{bad:#06x}");
            t.zero_non_finite();
            assert!(t.all_finite() && t.to_f32(3) == vec![1.0, 0.0, 0.5], "{bad:#06x}");
        }
        // zeroing copies the shared table; other textures still read it
        assert!(Texels::halves(Arc::new(vec![0x7c00])).value(0, 1) == f32::INFINITY);
    }

    #[test]
    fn non_finite_code_values_are_found_and_zeroed() {
        let mut values: CodeValues = [[0.5; 256]; 4];
        values[3][7] = f32::NAN;
        let mut t = Texels::U8 { codes: Arc::new(vec![7, 7, 7, 7]), values: Arc::new(values) };
        assert!(!t.all_finite());
        t.zero_non_finite();
        assert!(t.all_finite() && t.to_f32(4) == vec![0.5, 0.5, 0.5, 0.0]);
    }
}
