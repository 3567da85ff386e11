//! Spectral rendering: sampled spectra and wavelengths, CIE observer, RGB → spectrum
//! uplifting, colour spaces.

pub mod sampled;

pub use sampled::*;
