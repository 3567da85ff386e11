//! Natural water whose coefficients vary with depth: the bio-optical model (Jerlov IOPs or pure
//! seawater, chlorophyll with a Gaussian depth profile, CDOM, SPM) plus constant RGB
//! coefficients, all times a density scale. Depth is z = `top` − y (the scene's up axis is +Y).
//!
//! Along a ray the depth is linear in t, so the concentrations over a segment lie between
//! their values at the depth in the segment farthest from and nearest to each profile's peak
//! ([`BioOptical::concentration_range`]); every coefficient is non-decreasing in every
//! concentration, so σt evaluated there bounds σt on the segment per wavelength from below
//! and above. The upper bound is the majorant of delta tracking, the lower one the control of
//! residual ratio tracking ([`super::tracking`]). Without a profile both bounds equal σt and
//! the medium behaves exactly as a homogeneous one.

use super::homogeneous::DistanceSample;
use super::phase::PhaseFunction;
use super::tracking::{sample_distance_tracking, transmittance_ratio_tracking};
use crate::spectrum::{SampledSpectrum, SampledWavelengths, Spectrum};
use crate::water::BioOptical;
use glam::Vec3;

/// A depth-varying water medium.
#[derive(Clone, Debug, PartialEq)]
pub struct BioOpticalMedium {
    /// σa(λ, z), σs(λ, z) of the water (m⁻¹ before `scale`).
    pub water: BioOptical,
    /// Constant coefficients added to the water's (before `scale`).
    pub extra_a: Spectrum,
    pub extra_s: Spectrum,
    pub scale: f32,
    pub phase: PhaseFunction,
    /// World y of depth 0.
    pub top: f32,
}

impl BioOpticalMedium {
    /// Depth below the water's top of a world point.
    #[inline]
    pub fn depth(&self, p: Vec3) -> f32 {
        self.top - p.y
    }

    #[inline]
    fn extra(&self, lambda: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        let c = |s: SampledSpectrum| s.map(|v| v.max(0.0));
        (c(self.extra_a.sample(lambda)), c(self.extra_s.sample(lambda)))
    }

    #[inline]
    fn with_concentrations(&self, c: [f32; 3], extra: (SampledSpectrum, SampledSpectrum), lambda: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        let (a, s) = self.water.sample_concentrations(c, lambda);
        ((a + extra.0) * self.scale, (s + extra.1) * self.scale)
    }

    /// (σa, σs) at world point `p`, at the path's wavelengths.
    pub fn coefficients_at(&self, p: Vec3, lambda: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        self.with_concentrations(self.water.concentrations(self.depth(p)), self.extra(lambda), lambda)
    }

    /// Per-wavelength (lower, upper) bounds of σt over depths in [z0, z1] (either order,
    /// infinite ends allowed).
    pub fn sigma_t_bounds(&self, z0: f32, z1: f32, lambda: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        let extra = self.extra(lambda);
        let (lo, hi) = self.water.concentration_range(z0, z1);
        let t = |c| {
            let (a, s) = self.with_concentrations(c, extra, lambda);
            a + s
        };
        (t(lo), t(hi))
    }

    /// Depths at the ends of `origin + t·dir`, t ∈ [0, t_max].
    fn depth_span(&self, origin: Vec3, dir: Vec3, t_max: f32) -> (f32, f32) {
        let z0 = self.top - origin.y;
        let dz = if dir.y == 0.0 { 0.0 } else { -dir.y * t_max };
        (z0, z0 + dz)
    }

    /// Delta tracking with spectral MIS against the segment's majorant.
    pub fn sample_distance(&self, origin: Vec3, dir: Vec3, t_max: f32, rng: &mut impl FnMut() -> f32, lambda: &SampledWavelengths) -> DistanceSample {
        let (z0, z1) = self.depth_span(origin, dir, t_max);
        let (_, maj) = self.sigma_t_bounds(z0, z1, lambda);
        let extra = self.extra(lambda);
        sample_distance_tracking(maj, t_max, rng, lambda, |t| self.with_concentrations(self.water.concentrations(z0 - dir.y * t), extra, lambda))
    }

    /// Residual ratio tracking over [0, t] (exact and drawing nothing without a profile).
    pub fn transmittance(&self, origin: Vec3, dir: Vec3, t: f32, rng: &mut impl FnMut() -> f32, lambda: &SampledWavelengths) -> SampledSpectrum {
        let (z0, z1) = self.depth_span(origin, dir, t);
        let (lo, hi) = self.sigma_t_bounds(z0, z1, lambda);
        let rate = (0..lo.0.len()).filter(|&j| lambda.pdf[j] > 0.0).map(|j| hi[j] - lo[j]).fold(0.0f32, f32::max);
        let extra = self.extra(lambda);
        transmittance_ratio_tracking(lo, rate, t, rng, lambda, |s| {
            let (a, b) = self.with_concentrations(self.water.concentrations(z0 - dir.y * s), extra, lambda);
            a + b
        })
    }

    /// σt bound over all depths.
    pub fn majorant(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        self.sigma_t_bounds(f32::NEG_INFINITY, f32::INFINITY, lambda).1
    }
}
