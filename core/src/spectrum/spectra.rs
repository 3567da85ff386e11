//! Continuous spectra: what materials, media and lights store, sampled at a path's
//! wavelengths. (Placeholder implementation: grey; the real one uplifts RGB smoothly.)

use super::sampled::{SampledSpectrum, SampledWavelengths};

#[derive(Clone, Debug, PartialEq)]
pub enum Spectrum {
    Constant(f32),
}

impl Spectrum {
    /// Values at the path's wavelengths.
    pub fn sample(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        let _ = lambda;
        match self {
            Spectrum::Constant(c) => SampledSpectrum::splat(*c),
        }
    }
    /// Value at one wavelength (nm).
    pub fn eval(&self, lambda: f32) -> f32 {
        let _ = lambda;
        match self {
            Spectrum::Constant(c) => *c,
        }
    }
    /// An upper bound of the spectrum over the sampled range.
    pub fn max_value(&self) -> f32 {
        match self {
            Spectrum::Constant(c) => *c,
        }
    }
}
