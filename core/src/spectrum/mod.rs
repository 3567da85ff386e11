//! Spectral rendering: sampled spectra and wavelengths, CIE observer, RGB → spectrum
//! uplifting, colour spaces.

pub mod color;
pub mod sampled;
pub mod spectra;
pub mod uplift;

pub use sampled::*;
pub use spectra::Spectrum;
