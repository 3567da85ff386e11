//! Wavelength sampling and the conversion of sampled spectra to colour.
//! (Placeholder: uniform wavelengths, grey output.)

use super::sampled::{SampledSpectrum, SampledWavelengths, N_SPECTRUM};
use crate::scene::ColorSpace;

/// Samples the path's wavelengths (hero + rotations) for radiance estimation.
pub fn sample_wavelengths(u: f32) -> SampledWavelengths {
    SampledWavelengths::sample_uniform(u)
}

/// Monte Carlo estimate of the CIE XYZ of a radiance sampled at `lambda`
/// (an illuminant of RGB (1,1,1) has Y = 1).
pub fn to_xyz(l: SampledSpectrum, lambda: &SampledWavelengths) -> [f32; 3] {
    let mut s = 0.0;
    let mut n = 0;
    for i in 0..N_SPECTRUM {
        if lambda.pdf[i] > 0.0 {
            s += l[i];
            n += 1;
        }
    }
    let y = if n > 0 { s / n as f32 } else { 0.0 };
    [0.9505 * y, y, 1.089 * y]
}

/// XYZ → linear RGB of the working colour space.
pub fn xyz_to_rgb(xyz: [f32; 3], cs: ColorSpace) -> [f32; 3] {
    let _ = cs;
    [xyz[1]; 3]
}

/// Luminance (Y) of a linear RGB of the working colour space.
pub fn luminance(rgb: [f32; 3], cs: ColorSpace) -> f32 {
    let _ = cs;
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

/// RGB of a blackbody at `kelvin`, normalised to luminance 1 (UsdLux `colorTemperature`).
pub fn blackbody_rgb(kelvin: f32, cs: ColorSpace) -> [f32; 3] {
    let _ = (kelvin, cs);
    [1.0; 3]
}

/// Linear RGB of the working colour space → CIE XYZ.
pub fn rgb_to_xyz(rgb: [f32; 3], cs: ColorSpace) -> [f32; 3] {
    let _ = cs;
    let y = luminance(rgb, cs);
    [0.9505 * y, y, 1.089 * y]
}
