//! Spectral quantities carried along a path: four wavelengths per path (hero wavelength
//! plus three rotations, Wilkie et al. 2014) and the values of a spectrum at them.

use std::ops::{Add, AddAssign, Div, DivAssign, Index, IndexMut, Mul, MulAssign, Neg, Sub};

/// Number of wavelengths carried by one path.
pub const N_SPECTRUM: usize = 4;
/// Lower end of the sampled range in nm.
pub const LAMBDA_MIN: f32 = 360.0;
/// Upper end of the sampled range in nm.
pub const LAMBDA_MAX: f32 = 830.0;

/// Values of a spectral quantity at the path's wavelengths.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct SampledSpectrum(pub [f32; N_SPECTRUM]);

impl SampledSpectrum {
    pub const ZERO: Self = SampledSpectrum([0.0; N_SPECTRUM]);
    pub const ONE: Self = SampledSpectrum([1.0; N_SPECTRUM]);

    #[inline]
    pub fn splat(v: f32) -> Self {
        SampledSpectrum([v; N_SPECTRUM])
    }
    #[inline]
    pub fn from_fn(f: impl FnMut(usize) -> f32) -> Self {
        SampledSpectrum(std::array::from_fn(f))
    }
    #[inline]
    pub fn map(self, mut f: impl FnMut(f32) -> f32) -> Self {
        SampledSpectrum(self.0.map(&mut f))
    }
    #[inline]
    pub fn is_black(&self) -> bool {
        self.0.iter().all(|&v| v == 0.0)
    }
    #[inline]
    pub fn max_component(&self) -> f32 {
        self.0.iter().copied().fold(f32::NEG_INFINITY, f32::max)
    }
    #[inline]
    pub fn min_component(&self) -> f32 {
        self.0.iter().copied().fold(f32::INFINITY, f32::min)
    }
    #[inline]
    pub fn average(&self) -> f32 {
        self.0.iter().sum::<f32>() / N_SPECTRUM as f32
    }
    #[inline]
    pub fn exp(self) -> Self {
        self.map(f32::exp)
    }
    #[inline]
    pub fn sqrt(self) -> Self {
        self.map(|v| v.max(0.0).sqrt())
    }
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.0.iter().all(|v| v.is_finite())
    }
    /// Division that yields 0 where the divisor is 0.
    #[inline]
    pub fn safe_div(self, d: Self) -> Self {
        Self::from_fn(|i| if d.0[i] != 0.0 { self.0[i] / d.0[i] } else { 0.0 })
    }
}

macro_rules! binop {
    ($tr:ident, $f:ident, $op:tt) => {
        impl $tr for SampledSpectrum {
            type Output = Self;
            #[inline]
            fn $f(self, o: Self) -> Self { Self::from_fn(|i| self.0[i] $op o.0[i]) }
        }
        impl $tr<f32> for SampledSpectrum {
            type Output = Self;
            #[inline]
            fn $f(self, o: f32) -> Self { Self::from_fn(|i| self.0[i] $op o) }
        }
    };
}
binop!(Add, add, +);
binop!(Sub, sub, -);
binop!(Mul, mul, *);
binop!(Div, div, /);

impl Mul<SampledSpectrum> for f32 {
    type Output = SampledSpectrum;
    #[inline]
    fn mul(self, o: SampledSpectrum) -> SampledSpectrum {
        o * self
    }
}
impl Neg for SampledSpectrum {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        self.map(|v| -v)
    }
}
impl AddAssign for SampledSpectrum {
    #[inline]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}
impl MulAssign for SampledSpectrum {
    #[inline]
    fn mul_assign(&mut self, o: Self) {
        *self = *self * o;
    }
}
impl MulAssign<f32> for SampledSpectrum {
    #[inline]
    fn mul_assign(&mut self, o: f32) {
        *self = *self * o;
    }
}
impl DivAssign<f32> for SampledSpectrum {
    #[inline]
    fn div_assign(&mut self, o: f32) {
        *self = *self / o;
    }
}
impl Index<usize> for SampledSpectrum {
    type Output = f32;
    #[inline]
    fn index(&self, i: usize) -> &f32 {
        &self.0[i]
    }
}
impl IndexMut<usize> for SampledSpectrum {
    #[inline]
    fn index_mut(&mut self, i: usize) -> &mut f32 {
        &mut self.0[i]
    }
}

/// The wavelengths (nm) a path carries and the density each was sampled with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampledWavelengths {
    pub lambda: [f32; N_SPECTRUM],
    pub pdf: [f32; N_SPECTRUM],
}

impl SampledWavelengths {
    /// True once the secondary wavelengths were dropped (after a dispersive event).
    pub fn secondary_terminated(&self) -> bool {
        self.pdf[1..].iter().all(|&p| p == 0.0)
    }

    /// Drops wavelengths 1..N (dispersion makes their paths differ from the hero's).
    /// The hero's pdf is divided by N so the estimator stays unbiased.
    pub fn terminate_secondary(&mut self) {
        if self.secondary_terminated() {
            return;
        }
        for p in self.pdf[1..].iter_mut() {
            *p = 0.0;
        }
        self.pdf[0] /= N_SPECTRUM as f32;
    }

    /// Uniform hero sampling over [LAMBDA_MIN, LAMBDA_MAX] with equally spaced rotations.
    pub fn sample_uniform(u: f32) -> Self {
        let range = LAMBDA_MAX - LAMBDA_MIN;
        let lambda = std::array::from_fn(|i| {
            let mut l = LAMBDA_MIN + (u + i as f32 / N_SPECTRUM as f32).fract() * range;
            if l >= LAMBDA_MAX {
                l = LAMBDA_MIN;
            }
            l
        });
        SampledWavelengths { lambda, pdf: [1.0 / range; N_SPECTRUM] }
    }
}
