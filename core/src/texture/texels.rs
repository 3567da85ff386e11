//! A texture's texel values as the renderer holds them: 32-bit floats, or the 8-bit codes an
//! 8-bit file stores with each channel's value per code (its transfer curve undone once per
//! code, not once per texel). An 8-bit image is held in a quarter of the float's memory, and
//! shared with the file's pixels as read.

use std::sync::Arc;

/// Each channel's value for each of the 256 codes (channel 0–3 of a texel).
pub type CodeValues = [[f32; 256]; 4];

#[derive(Clone, Debug)]
pub enum Texels {
    /// One value per texel channel, row-major, channels interleaved.
    F32(Arc<Vec<f32>>),
    /// One byte per texel channel (laid out as `F32`); a byte `b` of channel `c` (its position
    /// in the texel) stands for `values[c][b]`.
    U8 { codes: Arc<Vec<u8>>, values: Arc<CodeValues> },
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

    /// The number of values (texels × channels).
    pub fn len(&self) -> usize {
        match self {
            Texels::F32(v) => v.len(),
            Texels::U8 { codes, .. } => codes.len(),
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
        }
        out
    }

    /// Every value as a float (a copy for 8-bit texels), for builds that read each once.
    pub fn to_f32(&self, channels: usize) -> Vec<f32> {
        match self {
            Texels::F32(v) => v.as_ref().clone(),
            Texels::U8 { .. } => (0..self.len()).map(|i| self.value(i, channels)).collect(),
        }
    }

    /// Whether both are the same shared data (not merely equal values).
    pub fn same(&self, other: &Texels) -> bool {
        match (self, other) {
            (Texels::F32(a), Texels::F32(b)) => Arc::ptr_eq(a, b),
            (Texels::U8 { codes: a, values: va }, Texels::U8 { codes: b, values: vb }) => Arc::ptr_eq(a, b) && Arc::ptr_eq(va, vb),
            _ => false,
        }
    }

    /// An address standing for the shared data (for caches keyed by it, beside [`Texels::same`]).
    pub fn address(&self) -> usize {
        match self {
            Texels::F32(v) => Arc::as_ptr(v) as usize,
            Texels::U8 { codes, .. } => Arc::as_ptr(codes) as usize,
        }
    }

    /// Whether every value is finite (for 8-bit texels: every code's value of the channels).
    pub fn all_finite(&self) -> bool {
        match self {
            Texels::F32(v) => v.iter().all(|x| x.is_finite()),
            Texels::U8 { values, .. } => values.iter().flatten().all(|x| x.is_finite()),
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
