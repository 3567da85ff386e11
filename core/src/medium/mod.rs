//! Participating media: phase functions, the homogeneous medium that fills water bodies, the
//! depth-varying water medium, and spectral-MIS free-flight sampling.
//!
//! [`Medium`] is the enum the integrator holds. Its position-aware interface
//! ([`Medium::sample_distance`] and [`Medium::transmittance`] take the ray and a source of
//! uniform numbers) serves every variant: [`Medium::Homogeneous`] consumes exactly one number
//! per call of `sample_distance` and none for `transmittance`; so does [`Medium::BioOptical`]
//! (natural water whose coefficients vary with depth), through a table of its optical depth
//! over depth: collisions by inverting it, with the same one-sample spectral MIS over
//! wavelengths as the homogeneous case, and transmittance in closed form ([`bio_optical`];
//! delta and residual ratio tracking, [`tracking`], only where no table is built);
//! [`Medium::Grid`] (a volume's density grid times a medium's coefficients) uses delta and
//! ratio tracking against a majorant grid ([`grid`]).

pub mod bio_optical;
pub mod grid;
pub mod homogeneous;
pub mod phase;
pub mod tracking;

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tracking_tests;
#[cfg(test)]
mod grid_tests;

pub use homogeneous::{
    distance_pdf, pass_probability, sample_distance_spectral, transmittance_spectral, DistanceSample,
    HomogeneousMedium,
};
pub use bio_optical::BioOpticalMedium;
pub use grid::{DensityGrid, GridError, GridMedium};
pub use phase::{PhaseFunction, TabulatedPhase, G_MAX};
pub use tracking::{sample_distance_tracking, transmittance_ratio_tracking};

use crate::scene::{ColorSpace, MediumDesc};
use crate::spectrum::{SampledSpectrum, SampledWavelengths};
use glam::Vec3;

/// Invalid medium or phase-function input, naming what is wrong.
#[derive(Clone, Debug, PartialEq)]
pub enum MediumError {
    /// A scalar parameter out of its domain.
    BadParameter { name: &'static str, value: f32, expected: &'static str },
    /// A tabulated phase function that cannot be normalised or sampled.
    BadTable(String),
    /// A scene medium with an invalid field.
    BadMedium { medium: String, reason: String },
}

impl std::fmt::Display for MediumError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MediumError::BadParameter { name, value, expected } => {
                write!(f, "phase function parameter {name} = {value}: expected {expected}")
            }
            MediumError::BadTable(m) => write!(f, "tabulated phase function: {m}"),
            MediumError::BadMedium { medium, reason } => write!(f, "medium '{medium}': {reason}"),
        }
    }
}

impl std::error::Error for MediumError {}

/// A participating medium.
#[derive(Clone, Debug, PartialEq)]
pub enum Medium {
    Homogeneous(HomogeneousMedium),
    /// Natural water varying with depth (Jerlov / bio-optical IOPs).
    BioOptical(Box<BioOpticalMedium>),
    /// A volume: a density grid times a medium's coefficients.
    Grid(Box<GridMedium>),
}

impl Medium {
    /// The medium a scene describes, RGB coefficients uplifted in `cs`: homogeneous, or
    /// [`Medium::BioOptical`] when `desc.water` is set (depth origin `water.top`, 0 if unset;
    /// the world builder fills it in from the water bodies' bounds).
    pub fn from_desc(desc: &MediumDesc, cs: ColorSpace) -> Result<Self, MediumError> {
        let h = HomogeneousMedium::from_desc_in(desc, cs)?;
        let Some(w) = &desc.water else { return Ok(Medium::Homogeneous(h)) };
        let water = crate::water::bio_optical_from_desc(w).map_err(|e| MediumError::BadMedium { medium: desc.name.clone(), reason: e.to_string() })?;
        // the RGB part unscaled: the scale multiplies the sum with the water's coefficients
        let rgb = HomogeneousMedium::from_desc_in(&MediumDesc { scale: 1.0, water: None, ..desc.clone() }, cs)?;
        if water.is_uniform() {
            // the same water at every depth: its coefficients tabulated once at 1 nm (the
            // model's own data sit on whole nanometres, so this only linearises its smooth
            // power laws between nodes, by under 10⁻⁴) make a homogeneous medium, which
            // samples distances and transmittance in closed form
            let bad = |e: crate::spectrum::SpectrumError| MediumError::BadMedium { medium: desc.name.clone(), reason: e.to_string() };
            let l: Vec<f32> = (crate::spectrum::LAMBDA_MIN as i32..=crate::spectrum::LAMBDA_MAX as i32).map(|l| l as f32).collect();
            let (mut a, mut b) = (Vec::with_capacity(l.len()), Vec::with_capacity(l.len()));
            for &x in &l {
                let (wa, wb) = water.coefficients_at(0.0, x);
                a.push(((wa + rgb.sigma_a.eval(x).max(0.0)) * desc.scale).max(0.0));
                b.push(((wb + rgb.sigma_s.eval(x).max(0.0)) * desc.scale).max(0.0));
            }
            return Ok(Medium::Homogeneous(HomogeneousMedium {
                sigma_a: crate::spectrum::Spectrum::tabulated(&l, &a).map_err(bad)?,
                sigma_s: crate::spectrum::Spectrum::tabulated(&l, &b).map_err(bad)?,
                phase: h.phase,
            }));
        }
        Ok(Medium::BioOptical(Box::new(BioOpticalMedium::new(water, rgb.sigma_a, rgb.sigma_s, desc.scale, h.phase, w.top.unwrap_or(0.0)).facing_up(w.up))))
    }

    /// The medium of a volume: `grid` times the coefficients of `desc` (RGB or tabulated,
    /// `scale` included). Natural-water inputs (`desc.water`) do not apply to a grid and are
    /// left out; the caller reports them.
    pub fn grid(desc: &MediumDesc, grid: DensityGrid, cs: ColorSpace) -> Result<Self, MediumError> {
        let h = HomogeneousMedium::from_desc_in(&MediumDesc { water: None, ..desc.clone() }, cs)?;
        Ok(Medium::Grid(Box::new(GridMedium { grid, sigma_a: h.sigma_a, sigma_s: h.sigma_s, phase: h.phase })))
    }

    /// True when coefficients and phase function are the same everywhere.
    #[inline]
    pub fn is_homogeneous(&self) -> bool {
        match self {
            Medium::Homogeneous(_) => true,
            Medium::BioOptical(m) => m.water.is_uniform(),
            Medium::Grid(_) => false,
        }
    }

    /// Phase function at point `p`.
    #[inline]
    pub fn phase(&self, p: Vec3) -> &PhaseFunction {
        let _ = p;
        match self {
            Medium::Homogeneous(m) => &m.phase,
            Medium::BioOptical(m) => &m.phase,
            Medium::Grid(m) => &m.phase,
        }
    }

    /// σs at point `p`, at the path's wavelengths.
    #[inline]
    pub fn sigma_s_at(&self, p: Vec3, lambda: &SampledWavelengths) -> SampledSpectrum {
        match self {
            Medium::Homogeneous(m) => m.coefficients(lambda).1,
            Medium::BioOptical(m) => m.coefficients_at(p, lambda).1,
            Medium::Grid(m) => m.coefficients_at(p, lambda).1,
        }
    }

    /// Whether the medium scatters light at all (σs > 0 at some visible wavelength).
    pub fn scatters(&self) -> bool {
        let lambda = SampledWavelengths::sample_uniform(0.37);
        if let Medium::Grid(m) = self {
            return m.coefficients(&lambda).1.max_component() > 0.0;
        }
        let probe = [Vec3::ZERO, Vec3::new(0.0, -10.0, 0.0), Vec3::new(0.0, -100.0, 0.0)];
        probe.iter().any(|p| self.sigma_s_at(*p, &lambda).max_component() > 0.0)
    }

    /// A ray at shutter time `time` in the frame where the medium's coefficients are defined:
    /// moving volumes ([`DensityGrid::rest_ray`]) map it to their rest placement; every other
    /// medium is still and returns it unchanged. Call before `sample_distance` and
    /// `transmittance` with the path's time.
    #[inline]
    pub fn rest_ray(&self, time: f32, o: Vec3, d: Vec3) -> (Vec3, Vec3) {
        match self {
            Medium::Grid(m) => m.grid.rest_ray(time, o, d),
            _ => (o, d),
        }
    }

    /// Per-wavelength upper bound of σt along any ray (σt itself when homogeneous).
    #[inline]
    pub fn majorant(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        match self {
            Medium::Homogeneous(m) => m.sigma_t(lambda),
            Medium::BioOptical(m) => m.majorant(lambda),
            Medium::Grid(m) => m.majorant(lambda),
        }
    }

    /// Free-flight sampling along `origin + t·dir`, t ∈ (0, t_max); `rng` yields uniform
    /// numbers in [0, 1). See [`DistanceSample`] for the weights.
    #[inline]
    pub fn sample_distance(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
        rng: &mut impl FnMut() -> f32,
        lambda: &SampledWavelengths,
    ) -> DistanceSample {
        match self {
            Medium::Homogeneous(m) => m.sample_distance(t_max, rng(), lambda),
            Medium::BioOptical(m) => m.sample_distance(origin, dir, t_max, rng, lambda),
            Medium::Grid(m) => m.sample_distance(origin, dir, t_max, rng, lambda),
        }
    }

    /// Transmittance along `origin + t·dir` over [0, t] (an unbiased estimate for media
    /// that need tracking; exact for a homogeneous one, which draws nothing from `rng`).
    #[inline]
    pub fn transmittance(
        &self,
        origin: Vec3,
        dir: Vec3,
        t: f32,
        rng: &mut impl FnMut() -> f32,
        lambda: &SampledWavelengths,
    ) -> SampledSpectrum {
        match self {
            Medium::Homogeneous(m) => m.transmittance(t, lambda),
            Medium::BioOptical(m) => m.transmittance(origin, dir, t, rng, lambda),
            Medium::Grid(m) => m.transmittance(origin, dir, t, rng, lambda),
        }
    }
}

/// A medium seen at one path's wavelengths: a homogeneous medium's coefficients are looked up
/// once (a spectrum evaluation at every wavelength, per call otherwise), for loops that query it
/// many times with the same wavelengths, such as gathering photon beams. Gives the same bits as
/// the medium's own queries.
pub struct MediumAt<'a> {
    medium: &'a Medium,
    lambda: &'a SampledWavelengths,
    /// (σa, σs) of a homogeneous medium.
    fixed: Option<(SampledSpectrum, SampledSpectrum)>,
}

impl<'a> MediumAt<'a> {
    pub fn new(medium: &'a Medium, lambda: &'a SampledWavelengths) -> MediumAt<'a> {
        let fixed = match medium {
            Medium::Homogeneous(m) => Some(m.coefficients(lambda)),
            _ => None,
        };
        MediumAt { medium, lambda, fixed }
    }

    /// [`Medium::sigma_s_at`].
    #[inline]
    pub fn sigma_s_at(&self, p: Vec3) -> SampledSpectrum {
        match self.fixed {
            Some((_, s)) => s,
            None => self.medium.sigma_s_at(p, self.lambda),
        }
    }

    /// [`Medium::transmittance`].
    #[inline]
    pub fn transmittance(&self, origin: Vec3, dir: Vec3, t: f32, rng: &mut impl FnMut() -> f32) -> SampledSpectrum {
        match self.fixed {
            Some((a, s)) => homogeneous::transmittance_spectral(a + s, t),
            None => self.medium.transmittance(origin, dir, t, rng, self.lambda),
        }
    }

    /// The product of the transmittances along two segments, each `(origin, dir, t)`: in a
    /// homogeneous medium the transmittance over their summed length (one exponential per
    /// wavelength instead of two).
    #[inline]
    pub fn transmittance_of_two(&self, a: (Vec3, Vec3, f32), b: (Vec3, Vec3, f32), rng: &mut impl FnMut() -> f32) -> SampledSpectrum {
        match self.fixed {
            Some((sa, ss)) => homogeneous::transmittance_spectral(sa + ss, a.2 + b.2),
            None => self.medium.transmittance(a.0, a.1, a.2, rng, self.lambda) * self.medium.transmittance(b.0, b.1, b.2, rng, self.lambda),
        }
    }
}
