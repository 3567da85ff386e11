//! Water optics: the data and models behind the USD contract's `TideWater` (dispersion) and
//! `TideMedium` (Jerlov types, bio-optical constituents with a depth profile, ocean phase
//! functions). Plain functions and structs producing `Spectrum::Tabulated` coefficients and
//! `PhaseFunction`s; the integrator is not involved.
//!
//! # API
//!
//! * [`ior`] — Quan–Fry n(S, T, λ): [`quan_fry_ior`] (one wavelength, checked ranges) and
//!   [`quan_fry_spectrum`] (n(λ) as a `Tabulated` spectrum for `dispersion = true`); a glass's
//!   n(λ) from its Abbe number, [`abbe_spectrum`] (`WaterDesc::abbe`).
//! * [`jerlov`] — [`JerlovType`], [`JerlovSource`], [`jerlov_iop`] → [`JerlovIop`] with total
//!   a(λ), b(λ) (pure water included) over 360–830 nm; [`jerlov_table`] for the raw table and
//!   [`jerlov_kd`] for Solonenko's Kd column. A type missing from a source (Williamson 2022
//!   lacks I, IA, 7C, 9C) is [`WaterError::TypeNotInSource`].
//! * [`bio`] — [`BioOptical`]: pure water + chlorophyll + CDOM + SPM (+ an optional
//!   depth-independent background such as a Jerlov type), each constituent with an optional
//!   Gaussian [`DepthProfile`]. Per depth: [`BioOptical::sample`] (allocation-free, at a path's
//!   wavelengths), [`BioOptical::coefficients_at`], [`BioOptical::sigma_a`] /
//!   [`BioOptical::sigma_s`] (`Tabulated`). Over depth: [`BioOptical::majorant_sampled`]
//!   (exact per wavelength), [`BioOptical::majorant_spectrum`], [`BioOptical::majorant`]
//!   (scalar over a wavelength range).
//! * [`phase`] — [`PhaseTable`] (normalised, piecewise linear in cosθ) for Fournier–Forand,
//!   Petzold (8 stations and the average-particle function, the default), the molecular
//!   function of water (depolarisation 0.09), HG and dual HG; `mix_molecular(w)`;
//!   [`phase_function`] turns a [`ParticlePhase`] and a molecular weight into a
//!   `PhaseFunction` (`Tabulated` via `TabulatedPhase::from_angles`, or analytic HG/dual HG
//!   when w = 0).
//! * [`MediumParams`] mirrors the `TideMedium` inputs this module interprets and
//!   [`build_medium`] turns them into a [`WaterMedium`] (coefficients + phase function).
//!
//! # Contract mapping ([`build_medium`])
//!
//! * `jerlovType` set: its IOPs from `jerlovSource` are the background; they contain pure
//!   water, so the model's own pure-water term is off unless `pure_water` says otherwise.
//!   `jerlovType` empty: pure water (Buiteveld absorption, Morel seawater scattering at the
//!   given salinity) is the base. (`absorption`/`scattering` RGB inputs are uplifted by the
//!   caller, not here.)
//! * `chlorophyll` (mg m⁻³), `cdom` (g m⁻³), `spm` (g m⁻³) add on top. The single
//!   `profileDepth/Width/Peak` of the contract is the Gaussian depth profile of the
//!   constituents (the thesis' Eq. 4.16, which it uses for chlorophyll and CDOM alike):
//!   `profilePeak` is added, in each constituent's own unit, at `profileDepth` m, σ =
//!   `profileWidth` m: to chlorophyll where the water holds chlorophyll or nothing (a deep
//!   chlorophyll maximum, over whatever CDOM and SPM there are), else to the CDOM and SPM it
//!   holds (a layer of those in water without algae); width or peak 0 means uniform. See
//!   [`profiled`].
//! * `phase`: `hg` (g), `dualHG` (g, g2, lobeMix), `fournierForand` (backscatter fraction
//!   0.0183 with n = 1.10, i.e. μ ≈ 3.58), `petzold` (average-particle); `molecularWeight` w
//!   mixes in the molecular function: p = w·p_mol + (1 − w)·p_particle.

pub mod bio;
mod data;
pub mod ior;
pub mod jerlov;
pub mod phase;

#[cfg(test)]
mod tests;

pub use bio::{BioOptical, BioOpticalParams, Constituent, DepthProfile};
pub use ior::{abbe_spectrum, quan_fry_ior, quan_fry_spectrum, IOR_SALINITY_RANGE, IOR_TEMPERATURE_RANGE};
pub use jerlov::{jerlov_iop, jerlov_kd, jerlov_table, JerlovIop, JerlovSource, JerlovType};
pub use phase::{phase_desc, phase_function, FournierForand, ParticlePhase, PetzoldStation, PhaseTable};

use crate::medium::{MediumError, PhaseFunction};
use crate::spectrum::SpectrumError;

/// What is wrong with water-optics input.
#[derive(Clone, Debug, PartialEq)]
pub enum WaterError {
    /// A number outside its accepted range.
    OutOfRange { name: &'static str, value: f32, min: f32, max: f32, unit: &'static str },
    /// A token that is not one of the attribute's allowed values.
    UnknownToken { attribute: &'static str, token: String },
    /// The data source has no table for this Jerlov type.
    TypeNotInSource { water_type: &'static str, source: &'static str },
    /// A table without the requested data.
    NoData { what: String },
    /// A constituent concentration or profile value that is invalid.
    BadConcentration { constituent: &'static str, what: &'static str, value: f32, reason: &'static str },
    /// An invalid wavelength range.
    BadRange { lo: f32, hi: f32 },
    /// A phase-function table that cannot be normalised.
    BadPhaseTable(String),
    /// A spectrum that could not be built.
    Spectrum(SpectrumError),
    /// A phase function the medium module rejected.
    Medium(MediumError),
}

impl std::fmt::Display for WaterError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            WaterError::OutOfRange { name, value, min, max, unit } => {
                write!(f, "{name} = {value} {unit} is outside [{min}, {max}] {unit}")
            }
            WaterError::UnknownToken { attribute, token } => write!(f, "{attribute}: unknown value '{token}'"),
            WaterError::TypeNotInSource { water_type, source } => {
                write!(f, "Jerlov type {water_type} is not tabulated by source {source}")
            }
            WaterError::NoData { what } => write!(f, "no data for {what}"),
            WaterError::BadConcentration { constituent, what, value, reason } => {
                write!(f, "{constituent} {what} = {value}: {reason}")
            }
            WaterError::BadRange { lo, hi } => write!(f, "wavelength range [{lo}, {hi}] nm is empty or invalid"),
            WaterError::BadPhaseTable(m) => write!(f, "phase table: {m}"),
            WaterError::Spectrum(e) => write!(f, "{e}"),
            WaterError::Medium(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for WaterError {}

impl From<SpectrumError> for WaterError {
    fn from(e: SpectrumError) -> Self {
        WaterError::Spectrum(e)
    }
}

impl From<MediumError> for WaterError {
    fn from(e: MediumError) -> Self {
        WaterError::Medium(e)
    }
}

/// The `TideMedium` inputs interpreted here (names and defaults as in the contract), plus the
/// salinity of the enclosing `TideWater` for pure-seawater scattering.
#[derive(Clone, Debug, PartialEq)]
pub struct MediumParams {
    /// `jerlovType`; empty for none.
    pub jerlov_type: String,
    /// `jerlovSource`.
    pub jerlov_source: String,
    /// `phase`.
    pub phase: String,
    pub g: f32,
    pub g2: f32,
    pub lobe_mix: f32,
    pub molecular_weight: f32,
    pub chlorophyll: f32,
    pub cdom: f32,
    pub spm: f32,
    pub profile_depth: f32,
    pub profile_width: f32,
    pub profile_peak: f32,
    /// `TideWater.salinity` (PSU).
    pub salinity: f32,
    /// Add the model's pure water; None: only when `jerlov_type` is empty.
    pub pure_water: Option<bool>,
}

impl Default for MediumParams {
    fn default() -> Self {
        MediumParams {
            jerlov_type: String::new(),
            jerlov_source: "williamson2022".into(),
            phase: "hg".into(),
            g: 0.0,
            g2: -0.3,
            lobe_mix: 0.9,
            molecular_weight: 0.0,
            chlorophyll: 0.0,
            cdom: 0.0,
            spm: 0.0,
            profile_depth: 0.0,
            profile_width: 0.0,
            profile_peak: 0.0,
            salinity: 0.0,
            pure_water: None,
        }
    }
}

/// Spectral, depth-dependent coefficients and the phase function of a water medium.
#[derive(Clone, Debug, PartialEq)]
pub struct WaterMedium {
    pub coefficients: BioOptical,
    pub phase: PhaseFunction,
}

/// Chlorophyll, CDOM and SPM of base concentrations `base` with the contract's one depth
/// profile: on chlorophyll where the water holds chlorophyll, or nothing (the deep chlorophyll
/// maximum of natural water, over uniform CDOM and SPM); otherwise on the CDOM and SPM it
/// holds, each taking `peak` in its own unit (g m⁻³): a layer of what the water carries.
pub fn profiled(base: [f32; 3], profile: Option<DepthProfile>) -> [Constituent; 3] {
    let algae = base[0] > 0.0 || base.iter().all(|&b| !(b > 0.0));
    let on = [algae, !algae && base[1] > 0.0, !algae && base[2] > 0.0];
    [0, 1, 2].map(|k| Constituent { base: base[k], profile: profile.filter(|_| on[k]) })
}

/// Builds the medium the contract inputs describe (see the module docs for the mapping).
pub fn build_medium(p: &MediumParams) -> Result<WaterMedium, WaterError> {
    let background = if p.jerlov_type.is_empty() {
        None
    } else {
        let t = JerlovType::parse(&p.jerlov_type)?;
        let s = JerlovSource::parse(&p.jerlov_source)?;
        let iop = jerlov_iop(t, s)?;
        Some((iop.a, iop.b))
    };
    let [chlorophyll, cdom, spm] = profiled([p.chlorophyll, p.cdom, p.spm], Some(DepthProfile { depth: p.profile_depth, width: p.profile_width, peak: p.profile_peak }));
    let params = BioOpticalParams {
        chlorophyll,
        cdom,
        spm,
        pure_water: p.pure_water.unwrap_or(background.is_none()),
        salinity: p.salinity,
        background,
        ..BioOpticalParams::default()
    };
    let coefficients = BioOptical::new(params)?;
    let particle = ParticlePhase::from_contract(&p.phase, p.g, p.g2, p.lobe_mix)?;
    let phase = phase_function(particle, p.molecular_weight)?;
    Ok(WaterMedium { coefficients, phase })
}

/// The bio-optical model a scene's [`crate::scene::WaterIopDesc`] describes (the mapping is
/// documented there): Jerlov IOPs or pure seawater as the base, constituents on top, the
/// profile on them ([`profiled`]).
pub fn bio_optical_from_desc(d: &crate::scene::WaterIopDesc) -> Result<BioOptical, WaterError> {
    let background = match d.jerlov {
        Some(j) => {
            let iop = jerlov_iop(j.water_type, j.source)?;
            Some((iop.a, iop.b))
        }
        None => None,
    };
    let [chlorophyll, cdom, spm] = profiled([d.chlorophyll, d.cdom, d.spm], d.profile.map(|p| DepthProfile { depth: p.depth, width: p.width, peak: p.peak }));
    BioOptical::new(BioOpticalParams {
        chlorophyll,
        cdom,
        spm,
        pure_water: background.is_none(),
        salinity: d.salinity,
        background,
        ..BioOpticalParams::default()
    })
}
