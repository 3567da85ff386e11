//! The sky as an infinite light: the Hošek–Wilkie dome radiance times a scale, with its
//! luminance-proportional sampler. What `core/src/light/` needs to wire it in as a
//! `Light::Sky(SkyLight)` variant is listed in the module docs of [`crate::sky`].

use glam::{Vec2, Vec3};

use super::model::HosekWilkieSky;
use super::sampling::SkySampler;
use super::SkyError;
use crate::math::PI;
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

/// The sky dome as a light (the sun is a separate distant light, see
/// [`HosekWilkieSky::sun_spectrum`]).
#[derive(Clone, Debug, PartialEq)]
pub struct SkyLight {
    pub sky: HosekWilkieSky,
    pub sampler: SkySampler,
    /// Multiplies the model's radiance (W m⁻² sr⁻¹ nm⁻¹ → Tide radiance), e.g. the dome's
    /// `intensity` × 2^`exposure`.
    pub scale: f32,
}

impl SkyLight {
    /// `scale` must be finite and non-negative.
    pub fn new(sky: HosekWilkieSky, scale: f32) -> Result<SkyLight, SkyError> {
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(SkyError::Scale(scale));
        }
        let sampler = SkySampler::new(&sky);
        Ok(SkyLight { sky, sampler, scale })
    }

    /// Radiance arriving from unit direction `w` (towards the sky).
    #[inline]
    pub fn le(&self, w: Vec3, lambda: &SampledWavelengths) -> SampledSpectrum {
        self.sky.radiance(w, lambda) * self.scale
    }

    /// Solid-angle density with which [`SkyLight::sample_li`] picks `w`.
    #[inline]
    pub fn pdf_li(&self, w: Vec3) -> f32 {
        self.sampler.pdf(w)
    }

    /// A direction towards the sky, its radiance and solid-angle density.
    #[inline]
    pub fn sample_li(&self, u: Vec2, lambda: &SampledWavelengths) -> Option<(Vec3, SampledSpectrum, f32)> {
        let (w, pdf) = self.sampler.sample(u)?;
        Some((w, self.le(w, lambda), pdf))
    }

    /// Solid-angle mean of the luminance over the whole sphere (∫ Y dω / 4π, scale included),
    /// the quantity a dome light's power is computed from.
    pub fn mean_luminance(&self) -> f32 {
        self.sampler.luminance_integral() * self.scale / (4.0 * PI)
    }
}
