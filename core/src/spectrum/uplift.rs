//! RGB → spectrum uplifting. (Placeholder: grey of the RGB's mean.)

use super::spectra::Spectrum;
use crate::scene::ColorSpace;

/// A reflectance-like colour (each channel in [0,1]) as a smooth spectrum bounded by [0,1].
pub fn albedo(rgb: [f32; 3], cs: ColorSpace) -> Spectrum {
    let _ = cs;
    Spectrum::Constant(((rgb[0] + rgb[1] + rgb[2]) / 3.0).clamp(0.0, 1.0))
}

/// An unbounded non-negative quantity (e.g. a coefficient in 1/m) as a smooth spectrum.
pub fn unbounded(rgb: [f32; 3], cs: ColorSpace) -> Spectrum {
    let _ = cs;
    Spectrum::Constant((rgb[0] + rgb[1] + rgb[2]) / 3.0)
}

/// An emitted colour: RGB (1,1,1) renders as (1,1,1) in the working colour space.
pub fn illuminant(rgb: [f32; 3], cs: ColorSpace) -> Spectrum {
    let _ = cs;
    Spectrum::Constant((rgb[0] + rgb[1] + rgb[2]) / 3.0)
}
