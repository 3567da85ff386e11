//! Jerlov water types: spectral total absorption a(λ) and scattering b(λ) (both including pure
//! water, m⁻¹) from one of two published sources, as `Spectrum::Tabulated` over 360–830 nm.
//!
//! * [`JerlovSource::Williamson2022`] (default of the USD contract): Williamson & Hollins (2022),
//!   measured IOPs of types IB, II, III, 1C, 3C, 5C at 1 nm. Measurements span 412–715 nm; the
//!   rest of 300–800 nm is the paper's model (flagged `model_extrapolation` in the table). Types
//!   I, IA, 7C and 9C are absent from this source: asking for them is
//!   [`WaterError::TypeNotInSource`], never a silent substitute.
//! * [`JerlovSource::Solonenko2015`]: Solonenko & Mobley (2015), a and b of all ten types at 17
//!   wavelengths (300, 310, 350, 375, …, 700 nm), obtained by inverting Kd. Where the published
//!   `a` row is lost (3C at 675–700 nm, 5C at 600–700 nm; status `missing`), Williamson & Hollins'
//!   gap-fill given in the same table is used; `b` there is the table's `reconstructed` value.
//!
//! Wavelength handling (the renderer samples 360–830 nm):
//! * Williamson 2022: the 1 nm nodes from 360 to 800 nm; above 800 nm both spectra hold their
//!   800 nm value (ȳ(800 nm) ≈ 10⁻⁴ of its peak, so this is invisible in colour).
//! * Solonenko 2015: the nodes from 350 to 700 nm, linear in λ in between. Above 700 nm the
//!   absorption follows pure water: a(λ) = a(700) + a_w(λ) − a_w(700) with a_w the Buiteveld
//!   (1994) table of Williamson & Hollins (5 nm nodes to 800 nm, then held), i.e. the water's
//!   contents keep their 700 nm absorption while water's own steep red rise continues; b holds
//!   its 700 nm value.
//!
//! [`jerlov_kd`] returns the Solonenko 2015 Kd column (downwelling diffuse attenuation) where
//! present, for checks against radiative-transfer estimates.

use super::data::{lerp_table, tables, IopRow};
use super::WaterError;
use crate::spectrum::Spectrum;

/// The ten Jerlov water types: open ocean I (clearest) … III, coastal 1C (clearest) … 9C.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum JerlovType {
    I,
    IA,
    IB,
    II,
    III,
    C1,
    C3,
    C5,
    C7,
    C9,
}

impl JerlovType {
    /// All types from clearest ocean to most turbid coastal.
    pub const ALL: [JerlovType; 10] = [
        JerlovType::I,
        JerlovType::IA,
        JerlovType::IB,
        JerlovType::II,
        JerlovType::III,
        JerlovType::C1,
        JerlovType::C3,
        JerlovType::C5,
        JerlovType::C7,
        JerlovType::C9,
    ];

    /// The token used by the USD contract and the tables (`I`, `IA`, …, `1C`, …, `9C`).
    pub fn name(self) -> &'static str {
        match self {
            JerlovType::I => "I",
            JerlovType::IA => "IA",
            JerlovType::IB => "IB",
            JerlovType::II => "II",
            JerlovType::III => "III",
            JerlovType::C1 => "1C",
            JerlovType::C3 => "3C",
            JerlovType::C5 => "5C",
            JerlovType::C7 => "7C",
            JerlovType::C9 => "9C",
        }
    }

    /// Parses a contract token (exact spelling, as in the contract).
    pub fn parse(token: &str) -> Result<JerlovType, WaterError> {
        JerlovType::ALL
            .into_iter()
            .find(|t| t.name() == token)
            .ok_or_else(|| WaterError::UnknownToken { attribute: "jerlovType", token: token.to_string() })
    }
}

/// Which published table the IOPs come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum JerlovSource {
    #[default]
    Williamson2022,
    Solonenko2015,
}

impl JerlovSource {
    /// The contract token.
    pub fn name(self) -> &'static str {
        match self {
            JerlovSource::Williamson2022 => "williamson2022",
            JerlovSource::Solonenko2015 => "solonenko2015",
        }
    }

    /// Parses `williamson2022` or `solonenko2015`.
    pub fn parse(token: &str) -> Result<JerlovSource, WaterError> {
        match token {
            "williamson2022" => Ok(JerlovSource::Williamson2022),
            "solonenko2015" => Ok(JerlovSource::Solonenko2015),
            _ => Err(WaterError::UnknownToken { attribute: "jerlovSource", token: token.to_string() }),
        }
    }

    /// The types this source tabulates.
    pub fn has_type(self, t: JerlovType) -> bool {
        match self {
            JerlovSource::Solonenko2015 => true,
            JerlovSource::Williamson2022 => !matches!(t, JerlovType::I | JerlovType::IA | JerlovType::C7 | JerlovType::C9),
        }
    }
}

/// Total absorption and scattering of a Jerlov water type (pure water included), m⁻¹.
#[derive(Clone, Debug, PartialEq)]
pub struct JerlovIop {
    pub water_type: JerlovType,
    pub source: JerlovSource,
    /// a(λ), `Spectrum::Tabulated`.
    pub a: Spectrum,
    /// b(λ), `Spectrum::Tabulated`.
    pub b: Spectrum,
}

fn rows_of(source: JerlovSource) -> &'static [IopRow] {
    match source {
        JerlovSource::Williamson2022 => &tables().williamson,
        JerlovSource::Solonenko2015 => &tables().solonenko,
    }
}

/// The table's (λ, value) pairs of one quantity (`a`, `b`, `Kd`, `KdH`, `Kd0`) of one type, in
/// increasing λ, as printed in the vendored CSV. Missing values are replaced by the table's
/// gap-fill where it has one and left out otherwise.
pub fn jerlov_table(t: JerlovType, source: JerlovSource, quantity: &str) -> Result<Vec<(f32, f32)>, WaterError> {
    if !source.has_type(t) {
        return Err(WaterError::TypeNotInSource { water_type: t.name(), source: source.name() });
    }
    let mut v: Vec<(f32, f32)> = rows_of(source)
        .iter()
        .filter(|r| r.water_type == t.name() && r.quantity == quantity)
        .filter_map(|r| r.value.or(r.gap_fill).map(|x| (r.lambda as f32, x as f32)))
        .collect();
    if v.is_empty() {
        return Err(WaterError::NoData { what: format!("quantity '{quantity}' of type {} in {}", t.name(), source.name()) });
    }
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(v)
}

/// Status flag of a table row (`ok`, `suspect`, `missing`, `model_extrapolation`, …), if the
/// row exists.
pub fn jerlov_status(t: JerlovType, source: JerlovSource, quantity: &str, lambda_nm: f32) -> Option<&'static str> {
    rows_of(source)
        .iter()
        .find(|r| r.water_type == t.name() && r.quantity == quantity && r.lambda as f32 == lambda_nm)
        .map(|r| r.status.as_str())
}

fn aw_at(l: f64) -> f64 {
    let aw = &tables().aw;
    let xs: Vec<f64> = aw.iter().map(|p| p.0).collect();
    let ys: Vec<f64> = aw.iter().map(|p| p.1).collect();
    lerp_table(&xs, &ys, l)
}

/// The IOPs of type `t` from `source` as spectra over 360–830 nm (see the module docs for the
/// interpolation and extrapolation). A type the source lacks is
/// [`WaterError::TypeNotInSource`].
pub fn jerlov_iop(t: JerlovType, source: JerlovSource) -> Result<JerlovIop, WaterError> {
    let a = jerlov_table(t, source, "a")?;
    let b = jerlov_table(t, source, "b")?;
    let (a, b) = match source {
        JerlovSource::Williamson2022 => {
            let keep = |v: Vec<(f32, f32)>| -> Vec<(f32, f32)> { v.into_iter().filter(|p| (360.0..=800.0).contains(&p.0)).collect() };
            (keep(a), keep(b))
        }
        JerlovSource::Solonenko2015 => {
            let mut a: Vec<(f32, f32)> = a.into_iter().filter(|p| p.0 >= 350.0).collect();
            let b: Vec<(f32, f32)> = b.into_iter().filter(|p| p.0 >= 350.0).collect();
            let &(l_end, a_end) = a.last().expect("table has values");
            let aw_end = aw_at(l_end as f64);
            let mut l = l_end as f64 + 5.0;
            while l <= 800.0 {
                a.push((l as f32, (a_end as f64 + aw_at(l) - aw_end).max(0.0) as f32));
                l += 5.0;
            }
            (a, b)
        }
    };
    let spectrum = |v: &[(f32, f32)]| -> Result<Spectrum, WaterError> {
        let l: Vec<f32> = v.iter().map(|p| p.0).collect();
        let y: Vec<f32> = v.iter().map(|p| p.1).collect();
        Ok(Spectrum::tabulated(&l, &y)?)
    };
    Ok(JerlovIop { water_type: t, source, a: spectrum(&a)?, b: spectrum(&b)? })
}

/// Solonenko & Mobley's tabulated downwelling diffuse attenuation Kd(λ) of type `t` (m⁻¹) at
/// the wavelengths where it is present.
pub fn jerlov_kd(t: JerlovType) -> Result<Vec<(f32, f32)>, WaterError> {
    jerlov_table(t, JerlovSource::Solonenko2015, "Kd")
}
