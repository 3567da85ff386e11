//! The Hošek–Wilkie spectral sky and sun (`UsdLuxDomeLight` with `TideSkyAPI`,
//! `tide:sky:model` = `hosekWilkie`; USD contract §6).
//!
//! # API
//!
//! * [`HosekWilkieSky::new`]`(sun_elevation, turbidity, ground_albedo)` in Tide's default frame
//!   (zenith +Y, sun in the +Y/+Z half-plane), or [`HosekWilkieSky::with_frame`]`(zenith,
//!   to_sun, turbidity, ground_albedo)` for a sun given by a direction (e.g. the `tide:sky:sun`
//!   DistantLight's `to_light`). `ground_albedo` is anything `Into<`[`GroundAlbedo`]`>`: an
//!   `f32`, a [`Spectrum`](crate::spectrum::Spectrum), or `GroundAlbedo::Rgb` (uplifted as a
//!   reflectance). Errors are [`SkyError`] values naming the attribute.
//! * [`HosekWilkieSky::radiance`]`(dir, &lambda)`: sky radiance at the path's wavelengths
//!   (the sun's disc excluded); [`HosekWilkieSky::radiance_at`] for one wavelength;
//!   [`HosekWilkieSky::luminance`] on Tide's scale.
//! * [`HosekWilkieSky::sun_radiance`]`(dir, &lambda)`: the solar disc (angular radius
//!   [`SUN_ANGULAR_RADIUS`] = 0.255°) with limb darkening (Hošek & Wilkie 2013);
//!   [`HosekWilkieSky::sun_irradiance`], [`HosekWilkieSky::sun_spectrum`] (mean disc radiance as
//!   a tabulated spectrum, for a distant light of the disc's size) and
//!   [`HosekWilkieSky::sun_irradiance_spectrum`] (for a delta distant light).
//! * [`SkySampler`]: `sample(u) -> Option<(dir, pdf)>`, `pdf(dir)`, solid-angle densities
//!   proportional to a 64 × 128 table of luminance over (θ, azimuth from the sun).
//! * [`SkyLight`]: sky × scale with `le`, `sample_li`, `pdf_li`, `mean_luminance`.
//!
//! # The model
//!
//! Per band (11 bands, 320–720 nm every 40 nm) the radiance is
//! L = F(θ, γ) · L_M with F = (1 + A e^{B/(cos θ + 0.01)}) (C + D e^{Eγ} + F cos²γ +
//! G (1 + cos²γ)/(1 + H² − 2H cos γ)^{3/2} + I √cos θ), θ the view zenith angle and γ the
//! angle to the sun. The 9 parameters and L_M are quintic Bézier curves in
//! t = (elevation / (π/2))^{1/3}, blended linearly in turbidity (integer tables 1..10) and in
//! ground albedo (tables at 0 and 1), each band with its own albedo.
//!
//! Wavelengths: between 320 and 720 nm the bands are interpolated linearly, as in the reference
//! implementation. Tide samples 360–830 nm: from 720 to 830 nm (where the reference returns 0)
//! the 720 nm value is held. The sky's and sun's spectra fall slowly there, so holding slightly
//! overestimates them, but x̄ and ȳ over 720–830 nm carry under 0.1% of their integrals, so luminance and
//! colour change by well under 1%. Below 320 nm and above 830 nm the model returns 0.
//!
//! Directions below the horizon (cos θ < 0) receive no sky radiance (the ground is scene
//! geometry); the sampler never picks them. Sun positions below the horizon have no data in the
//! model: construction fails with [`SkyError::SunBelowHorizon`] (a caller wanting a twilight
//! sky can clamp the elevation to 0, the model's lowest). Fitted radiance that comes out
//! negative (it does not for the published tables over the valid range) is clamped to 0.
//!
//! Sun: direct radiance is a piecewise cubic in elevation (45 pieces), blended linearly in
//! turbidity and wavelength, times the limb-darkening polynomial in μ = √(1 − sin²γ / sin²r),
//! also blended in wavelength. The elevation used is that of the viewed point of the disc.
//!
//! # Units
//!
//! Everything returned is in the dataset's units: radiance in W m⁻² sr⁻¹ nm⁻¹, irradiance in
//! W m⁻² nm⁻¹. Tide's radiance scale is defined by its colour pipeline: a spectrum's luminance
//! is Y = ∫ L ȳ dλ / ∫ ȳ dλ, so a constant spectrum 1 (and an RGB-(1,1,1) illuminant) has
//! luminance 1. Used unscaled (scale 1, the default for a dome of `intensity` 1, `exposure` 0),
//! one Tide radiance unit is 1 W m⁻² sr⁻¹ nm⁻¹, and Tide luminance 1 is
//! 683 lm W⁻¹ × ∫ȳ dλ (106.86 nm) ≈ 7.30·10⁴ cd m⁻² ([`cd_per_m2_per_unit_luminance`]).
//! A clear sky's zenith then has a luminance of order 0.02–0.2 (a few thousand cd m⁻²) and
//! the sun's disc of order 10⁴. [`SkyLight::scale`] multiplies the sky (the dome's
//! `intensity` × 2^`exposure`).
//!
//! # Wiring (done elsewhere)
//!
//! `core/src/light/` needs a `Light::Sky(SkyLight)` variant that forwards `le` (from
//! [`SkyLight::le`]), `pdf_li` ([`SkyLight::pdf_li`]) and `sample_li` ([`SkyLight::sample_li`],
//! with `dist` = ∞ and `p_light` beyond the scene as for a dome), is infinite and not delta,
//! and has power 4π · [`SkyLight::mean_luminance`] · π r² like a dome. The sun is a distant
//! light along `to_sun`: with `tide:sky:physicalSun` its emission is
//! [`HosekWilkieSky::sun_spectrum`] at an angle of 2 · [`SUN_ANGULAR_RADIUS`] (or
//! [`HosekWilkieSky::sun_irradiance_spectrum`] for a delta light), not normalised by the
//! light's own `intensity`. The delegate maps `tide:sky:turbidity` (default 3),
//! `tide:sky:groundAlbedo` (default 0.3) and the sun relationship to [`HosekWilkieSky::with_frame`].
//!
//! Data: `core/data/hosek-wilkie/` (BSD-3-Clause, Hošek & Wilkie; see `core/data/README.md`).

// `!(x >= 0.0)` is used on purpose: it rejects NaN along with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod data;
pub mod light;
pub mod model;
pub mod sampling;

#[cfg(test)]
mod tests;

pub use light::SkyLight;
pub use model::{band_wavelength, sun_solid_angle, GroundAlbedo, HosekWilkieSky, SUN_ANGULAR_RADIUS};
pub use sampling::SkySampler;

use std::fmt;

/// The sky models `tide:sky:model` may name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkyModel {
    HosekWilkie,
}

impl SkyModel {
    /// Parses the `tide:sky:model` token.
    pub fn from_token(token: &str) -> Result<SkyModel, SkyError> {
        match token {
            "hosekWilkie" => Ok(SkyModel::HosekWilkie),
            other => Err(SkyError::Model(other.to_string())),
        }
    }
}

/// What is wrong with a sky's description.
#[derive(Clone, Debug, PartialEq)]
pub enum SkyError {
    /// `tide:sky:model` names no known model.
    Model(String),
    /// Turbidity not finite or outside [1, 10].
    Turbidity(f32),
    /// Ground albedo out of [0, 1] (the message says where).
    GroundAlbedo(String),
    /// The solar elevation is not a finite angle.
    SunElevation(String),
    /// The sun is below the horizon, where the model has no data.
    SunBelowHorizon { elevation_deg: f32 },
    /// A zero or non-finite zenith or sun direction.
    Direction(String),
    /// A light scale that is negative or not finite.
    Scale(f32),
    /// The compiled-in tables failed to parse (a build defect).
    Data(String),
}

impl fmt::Display for SkyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SkyError::Model(m) => write!(f, "tide:sky:model: '{m}' is not a known sky model (expected 'hosekWilkie')"),
            SkyError::Turbidity(t) => write!(f, "tide:sky:turbidity: {t} is outside [1, 10]"),
            SkyError::GroundAlbedo(m) => write!(f, "tide:sky:groundAlbedo: {m}"),
            SkyError::SunElevation(m) => write!(f, "tide:sky:sun: solar elevation {m}"),
            SkyError::SunBelowHorizon { elevation_deg } => {
                write!(f, "tide:sky:sun: the sun is {:.3}° below the horizon; the Hošek–Wilkie model covers elevations 0–90°", -elevation_deg)
            }
            SkyError::Direction(m) => write!(f, "tide:sky:sun: {m}"),
            SkyError::Scale(s) => write!(f, "sky light scale {s} is negative or not finite"),
            SkyError::Data(m) => write!(f, "Hošek–Wilkie tables: {m}"),
        }
    }
}

impl std::error::Error for SkyError {}

/// Tide radiance per model unit (W m⁻² sr⁻¹ nm⁻¹) that makes Tide luminance read in cd m⁻²
/// (nits): 683 lm W⁻¹ × ∫ ȳ dλ ≈ 7.30·10⁴. It is the `scale` the delegate gives
/// [`crate::scene::LightShape::Sky`] and [`crate::scene::LightShape::SkySun`]; the dome's
/// `intensity` × 2^`exposure` multiplies it. With it, a camera's physical exposure
/// ([`crate::camera`]) maps the sky and sun to pixel values as seed 000 §3.3 describes.
pub fn nits_per_model_unit() -> f32 {
    cd_per_m2_per_unit_luminance() as f32
}

/// Photometric luminance (cd m⁻²) of one unit of Tide luminance when radiance is in
/// W m⁻² sr⁻¹ nm⁻¹: 683 lm W⁻¹ × ∫ ȳ dλ over 360–830 nm.
pub fn cd_per_m2_per_unit_luminance() -> f64 {
    683.0 * crate::spectrum::cie::cie().y_integral
}
