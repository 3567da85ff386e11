//! Refractive index of (sea)water after Quan & Fry (1995), "Empirical equation for the index of
//! refraction of seawater", Appl. Opt. 34(18), 3477–3480:
//!
//! n(S, T, λ) = n0 + (n1 + n2·T + n3·T²)·S + n4·T² + (n5 + n6·S + n7·T)/λ + n8/λ² + n9/λ³
//!
//! with S the salinity in PSU, T the temperature in °C and λ the wavelength in nm. The fit covers
//! 400–700 nm, 0–30 °C and 0–35 PSU (its authors quote it to about 3·10⁻⁵ over 400–700 nm and
//! use it over 200–1100 nm with a worse bound); [`quan_fry_ior`] accepts 300–1100 nm, −2–40 °C
//! and 0–45 PSU and reports anything else as an error. With S = 0 the formula reduces to the
//! temperature-only form quoted in the Weta course notes (their Eq. 4.1).

use super::WaterError;

const N0: f64 = 1.31405;
const N1: f64 = 1.779e-4;
const N2: f64 = -1.05e-6;
const N3: f64 = 1.6e-8;
const N4: f64 = -2.02e-6;
const N5: f64 = 15.868;
const N6: f64 = 0.01155;
const N7: f64 = -0.00423;
const N8: f64 = -4382.0;
const N9: f64 = 1.1455e6;

/// Accepted wavelength range of [`quan_fry_ior`] in nm.
pub const IOR_LAMBDA_RANGE: (f32, f32) = (300.0, 1100.0);
/// Accepted temperature range in °C.
pub const IOR_TEMPERATURE_RANGE: (f32, f32) = (-2.0, 40.0);
/// Accepted salinity range in PSU.
pub const IOR_SALINITY_RANGE: (f32, f32) = (0.0, 45.0);

/// The Quan–Fry formula without range checks (f64; λ in nm, T in °C, S in PSU).
#[inline]
pub fn quan_fry_unchecked(salinity: f64, temperature: f64, lambda_nm: f64) -> f64 {
    let (s, t, l) = (salinity, temperature, lambda_nm);
    N0 + (N1 + N2 * t + N3 * t * t) * s + N4 * t * t + (N5 + N6 * s + N7 * t) / l + N8 / (l * l) + N9 / (l * l * l)
}

fn check(name: &'static str, v: f32, (lo, hi): (f32, f32), unit: &'static str) -> Result<(), WaterError> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(WaterError::OutOfRange { name, value: v, min: lo, max: hi, unit })
    }
}

/// Index of refraction of water of salinity `salinity` (PSU) at `temperature` (°C) and
/// wavelength `lambda_nm` (nm). Errors name the argument outside its accepted range.
pub fn quan_fry_ior(salinity: f32, temperature: f32, lambda_nm: f32) -> Result<f32, WaterError> {
    check("salinity", salinity, IOR_SALINITY_RANGE, "PSU")?;
    check("temperature", temperature, IOR_TEMPERATURE_RANGE, "°C")?;
    check("wavelength", lambda_nm, IOR_LAMBDA_RANGE, "nm")?;
    Ok(quan_fry_unchecked(salinity as f64, temperature as f64, lambda_nm as f64) as f32)
}

/// n(λ) of the given water as a `Tabulated` spectrum over 360–830 nm (1 nm nodes), for a
/// dispersive interface (`TideWater.dispersion`).
pub fn quan_fry_spectrum(salinity: f32, temperature: f32) -> Result<crate::spectrum::Spectrum, WaterError> {
    quan_fry_ior(salinity, temperature, 550.0)?;
    let lambda: Vec<f32> = (360..=830).map(|l| l as f32).collect();
    let value: Vec<f32> =
        lambda.iter().map(|&l| quan_fry_unchecked(salinity as f64, temperature as f64, l as f64) as f32).collect();
    Ok(crate::spectrum::Spectrum::tabulated(&lambda, &value)?)
}

/// Fraunhofer lines (nm) of the Abbe number V = (n_d − 1) / (n_F − n_C).
pub const ABBE_LINES: (f64, f64, f64) = (486.13, 587.56, 656.27);

/// n(λ) of a glass of index `n_d` at the d line and Abbe number `abbe`, as OpenPBR defines it:
/// Cauchy's n(λ) = A + B / λ² through n_d, with B = (n_d − 1) / (V (λ_F⁻² − λ_C⁻²)) (so that
/// its Abbe number is V exactly), tabulated over 360–830 nm (1 nm nodes). Errors name the
/// argument that is not a positive finite number (`n_d` must be at least 1).
pub fn abbe_spectrum(n_d: f32, abbe: f32) -> Result<crate::spectrum::Spectrum, String> {
    if !(abbe.is_finite() && abbe > 0.0) {
        return Err(format!("Abbe number {abbe}: must be a positive number"));
    }
    if !(n_d.is_finite() && n_d >= 1.0) {
        return Err(format!("ior {n_d}: must be at least 1 for a dispersive interface"));
    }
    let (f, d, c) = ABBE_LINES;
    let b = (n_d as f64 - 1.0) / (abbe as f64 * (1.0 / (f * f) - 1.0 / (c * c)));
    let a = n_d as f64 - b / (d * d);
    let lambda: Vec<f32> = (360..=830).map(|l| l as f32).collect();
    let value: Vec<f32> = lambda.iter().map(|&l| (a + b / (l as f64 * l as f64)) as f32).collect();
    crate::spectrum::Spectrum::tabulated(&lambda, &value).map_err(|e| e.to_string())
}
