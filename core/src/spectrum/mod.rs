//! Spectral rendering: sampled spectra and wavelengths, CIE observer, RGB → spectrum
//! uplifting, colour spaces.

pub mod cie;
pub mod color;
pub mod rgb2spec;
pub mod sampled;
pub mod spectra;
pub mod uplift;

pub use sampled::*;
pub use spectra::{Spectrum, SpectrumError, SpectrumKind};
