//! Bio-optical model of natural water: absorption σa(λ, z) and scattering σs(λ, z) (m⁻¹) from
//! pure water and three constituents whose concentrations may vary with depth z (metres below
//! the water's top). The structure is that of Ma et al. (2016) as summarised in the seed thesis
//! (ch. 4.4.1): coefficients add up,
//!
//! σa = a_w + a_φ(Chl) + a_g(CDOM) + a_NAP(SPM) [+ background a],
//! σs = b_w + b_p(Chl) + b_SPM(SPM) [+ background b].
//!
//! | term | model | source |
//! |---|---|---|
//! | a_w | tabulated pure-water absorption, 300–800 nm at 1 nm (held beyond) | Buiteveld et al. 1994, as used by Williamson & Hollins 2022 (`williamson2022_aw.csv`) |
//! | b_w | 16.06·β90, β90 = 1.38·10⁻⁴ (λ/500)^−4.32 (1 + 0.3 S/37) m⁻¹ sr⁻¹ | Morel 1974 pure seawater, via Boss & Pegau 2001 Eqs. 4–5 |
//! | a_φ | A_φ(λ)·Chl^E_φ(λ), Chl in mg m⁻³ | Bricaud et al. 1998 (`bricaud1998_aph_coefficients.csv`, 400–700 nm; the 400 nm coefficients below, linear to zero from 700 to 730 nm above) |
//! | b_p | 0.30·Chl^0.62·(550/λ) | Gordon & Morel 1983 / Loisel & Morel 1998, Eq. 4.17 of the thesis (Chl in mg m⁻³) |
//! | a_g | a*_g(440)·CDOM·exp(−0.014 (λ − 440)), CDOM in g m⁻³ | exponential slope 0.014 nm⁻¹ of Bricaud, Morel & Prieur 1981 (thesis Eq. 4.15); a*_g(440) = 0.3 m² g⁻¹ ([`CDOM_SPECIFIC_ABSORPTION_440`]) is a representative DOC-specific value, adjustable per medium |
//! | a_NAP | 0.041·SPM·exp(−0.0123 (λ − 443)), SPM in g m⁻³ | Babin et al. 2003 (JGR 108(C7) 3211), mean mass-specific non-algal absorption of European coastal waters |
//! | b_SPM | 0.5·SPM·(555/λ) | Babin et al. 2003 (L&O 48(2) 843): b_p(555)/SPM ≈ 0.5 m² g⁻¹; λ⁻¹ spectral shape assumed |
//!
//! Depth profile: a [`Constituent`] has a base concentration and an optional Gaussian
//! [`DepthProfile`]: c(z) = base + peak·exp(−(z − depth)²/(2·width²)).
//!
//! Every term is non-decreasing in its concentration (E_φ > 0 at every tabulated λ, checked by
//! a test), so σt(λ, z) ≤ σt(λ) evaluated at the largest concentrations base + peak: that is
//! the per-wavelength majorant over depth ([`BioOptical::majorant_sampled`],
//! [`BioOptical::majorant_spectrum`], [`BioOptical::majorant`]).
//!
//! Hot-path evaluation ([`BioOptical::sample`], [`BioOptical::coefficients_at`]) allocates
//! nothing: the tables are `Spectrum::Tabulated` (shared pointers) built once.

use super::data::tables;
use super::WaterError;
use crate::spectrum::{SampledSpectrum, SampledWavelengths, Spectrum, LAMBDA_MAX, LAMBDA_MIN};
use std::ops::RangeInclusive;
use std::sync::OnceLock;

/// CDOM slope S in a_g(λ) = a_g(440)·exp(−S (λ − 440)), nm⁻¹.
pub const CDOM_SLOPE: f32 = 0.014;
/// Default mass-specific CDOM absorption at 440 nm, m² g⁻¹.
pub const CDOM_SPECIFIC_ABSORPTION_440: f32 = 0.3;
/// Mass-specific non-algal particle absorption at 443 nm, m² g⁻¹ (Babin et al. 2003).
pub const SPM_SPECIFIC_ABSORPTION_443: f32 = 0.041;
/// Non-algal absorption slope, nm⁻¹ (Babin et al. 2003).
pub const SPM_ABSORPTION_SLOPE: f32 = 0.0123;
/// Mass-specific SPM scattering at 555 nm, m² g⁻¹ (Babin et al. 2003).
pub const SPM_SPECIFIC_SCATTERING_555: f32 = 0.5;

/// Morel (1974) pure-seawater β(90°) (m⁻¹ sr⁻¹) and b_w (m⁻¹) at `lambda` nm, salinity in PSU.
pub fn seawater_beta90(lambda: f64, salinity: f64) -> (f64, f64) {
    let a = 1.38e-4 * (lambda / 500.0).powf(-4.32) * (1.0 + 0.3 * salinity / 37.0);
    (a, 16.06 * a)
}

/// Gaussian addition to a concentration: peak·exp(−(z − depth)²/(2·width²)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthProfile {
    /// Depth of the maximum, m below the water's top.
    pub depth: f32,
    /// Standard deviation, m (0: no profile).
    pub width: f32,
    /// Concentration added at the maximum (units of the constituent, ≥ 0).
    pub peak: f32,
}

/// A constituent's concentration: `base` everywhere plus an optional profile.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Constituent {
    pub base: f32,
    pub profile: Option<DepthProfile>,
}

impl Constituent {
    /// A uniform concentration.
    pub fn uniform(base: f32) -> Self {
        Constituent { base, profile: None }
    }

    /// Concentration at depth z.
    #[inline]
    pub fn at(&self, z: f32) -> f32 {
        match self.profile {
            Some(p) if p.width > 0.0 && p.peak > 0.0 => {
                let t = (z - p.depth) / p.width;
                self.base + p.peak * (-0.5 * t * t).exp()
            }
            _ => self.base,
        }
    }

    /// Smallest and largest concentration over depths in [z0, z1] (z0 ≤ z1, either may be
    /// infinite): the Gaussian is largest at the depth in the interval nearest its peak and
    /// smallest at the end farthest from it.
    pub fn range(&self, z0: f32, z1: f32) -> (f32, f32) {
        match self.profile {
            Some(p) if p.width > 0.0 && p.peak > 0.0 => {
                let g = |z: f32| {
                    let t = (z - p.depth) / p.width;
                    if t.is_finite() {
                        p.peak * (-0.5 * t * t).exp()
                    } else {
                        0.0
                    }
                };
                let near = p.depth.clamp(z0, z1);
                let far = if (z0 - p.depth).abs() >= (z1 - p.depth).abs() { z0 } else { z1 };
                (self.base + g(far), self.base + g(near))
            }
            _ => (self.base, self.base),
        }
    }

    /// Largest concentration over all depths.
    pub fn max(&self) -> f32 {
        match self.profile {
            Some(p) if p.width > 0.0 => self.base + p.peak,
            _ => self.base,
        }
    }

    fn check(&self, name: &'static str) -> Result<(), WaterError> {
        let bad = |what: &'static str, v: f32, reason: &'static str| WaterError::BadConcentration { constituent: name, what, value: v, reason };
        if !(self.base.is_finite() && self.base >= 0.0) {
            return Err(bad("base concentration", self.base, "must be finite and ≥ 0"));
        }
        if let Some(p) = self.profile {
            if !(p.peak.is_finite() && p.peak >= 0.0) {
                return Err(bad("profile peak", p.peak, "must be finite and ≥ 0"));
            }
            if !(p.width.is_finite() && p.width >= 0.0) {
                return Err(bad("profile width", p.width, "must be finite and ≥ 0"));
            }
            if !p.depth.is_finite() {
                return Err(bad("profile depth", p.depth, "must be finite"));
            }
        }
        Ok(())
    }
}

/// Inputs of the bio-optical model.
#[derive(Clone, Debug, PartialEq)]
pub struct BioOpticalParams {
    /// Chlorophyll-a, mg m⁻³ (Bricaud's fit covers 0.02–25).
    pub chlorophyll: Constituent,
    /// Coloured dissolved organic matter, g m⁻³.
    pub cdom: Constituent,
    /// Suspended particulate (mineral) matter, g m⁻³.
    pub spm: Constituent,
    /// Add pure-water absorption and scattering (off when a background already contains
    /// them, e.g. Jerlov IOPs).
    pub pure_water: bool,
    /// Salinity for pure-seawater scattering, PSU.
    pub salinity: f32,
    /// a*_g(440) in m² g⁻¹.
    pub cdom_specific_absorption: f32,
    /// Depth-independent absorption and scattering added to the model (e.g. a Jerlov type).
    pub background: Option<(Spectrum, Spectrum)>,
}

impl Default for BioOpticalParams {
    fn default() -> Self {
        BioOpticalParams {
            chlorophyll: Constituent::default(),
            cdom: Constituent::default(),
            spm: Constituent::default(),
            pure_water: true,
            salinity: 35.0,
            cdom_specific_absorption: CDOM_SPECIFIC_ABSORPTION_440,
            background: None,
        }
    }
}

/// Shared tables of the model.
struct BaseSpectra {
    aw: Spectrum,
    a_phi: Spectrum,
    e_phi: Spectrum,
}

fn base() -> &'static BaseSpectra {
    static B: OnceLock<BaseSpectra> = OnceLock::new();
    B.get_or_init(|| {
        let t = tables();
        let l: Vec<f32> = t.aw.iter().map(|p| p.0 as f32).collect();
        let v: Vec<f32> = t.aw.iter().map(|p| p.1 as f32).collect();
        let aw = Spectrum::tabulated(&l, &v).expect("vendored a_w table is valid");
        let mut l: Vec<f32> = t.bricaud.iter().map(|p| p.0 as f32).collect();
        let mut a: Vec<f32> = t.bricaud.iter().map(|p| p.1 as f32).collect();
        let e: Vec<f32> = t.bricaud.iter().map(|p| p.2 as f32).collect();
        let le = l.clone();
        l.push(730.0);
        a.push(0.0);
        BaseSpectra {
            aw,
            a_phi: Spectrum::tabulated(&l, &a).expect("vendored Bricaud table is valid"),
            e_phi: Spectrum::tabulated(&le, &e).expect("vendored Bricaud table is valid"),
        }
    })
}

/// The model, ready to evaluate.
#[derive(Clone, Debug, PartialEq)]
pub struct BioOptical {
    params: BioOpticalParams,
    aw: Spectrum,
    a_phi: Spectrum,
    e_phi: Spectrum,
}

/// Safety factor of the scalar and tabulated majorants: between the 1 nm nodes they are
/// taken at, A_φ·Chl^E_φ (a product of linearly interpolated factors) can exceed both ends by
/// far less than 1 %.
const MAJORANT_MARGIN: f32 = 1.01;

impl BioOptical {
    /// Validates the parameters (concentrations, widths and peaks ≥ 0 and finite, salinity in
    /// 0–45 PSU, a*_g ≥ 0).
    pub fn new(params: BioOpticalParams) -> Result<BioOptical, WaterError> {
        params.chlorophyll.check("chlorophyll")?;
        params.cdom.check("cdom")?;
        params.spm.check("spm")?;
        if !(params.salinity.is_finite() && (0.0..=45.0).contains(&params.salinity)) {
            return Err(WaterError::OutOfRange { name: "salinity", value: params.salinity, min: 0.0, max: 45.0, unit: "PSU" });
        }
        let s = params.cdom_specific_absorption;
        if !(s.is_finite() && s >= 0.0) {
            return Err(WaterError::OutOfRange { name: "CDOM specific absorption", value: s, min: 0.0, max: f32::INFINITY, unit: "m²/g" });
        }
        let b = base();
        Ok(BioOptical { params, aw: b.aw.clone(), a_phi: b.a_phi.clone(), e_phi: b.e_phi.clone() })
    }

    /// The parameters.
    pub fn params(&self) -> &BioOpticalParams {
        &self.params
    }

    /// (chlorophyll, cdom, spm) at depth z.
    #[inline]
    pub fn concentrations(&self, z: f32) -> [f32; 3] {
        [self.params.chlorophyll.at(z), self.params.cdom.at(z), self.params.spm.at(z)]
    }

    /// The depths over which some constituent's profile differs from its base concentration
    /// by more than e⁻³² of its peak (8 widths either side of each peak), and the narrowest
    /// profile width; None when no constituent varies.
    pub fn varying_span(&self) -> Option<(f32, f32, f32)> {
        let mut span: Option<(f32, f32, f32)> = None;
        for c in [&self.params.chlorophyll, &self.params.cdom, &self.params.spm] {
            if let Some(p) = c.profile.filter(|p| p.width > 0.0 && p.peak > 0.0) {
                let (lo, hi) = (p.depth - 8.0 * p.width, p.depth + 8.0 * p.width);
                span = Some(match span {
                    None => (lo, hi, p.width),
                    Some((a, b, w)) => (a.min(lo), b.max(hi), w.min(p.width)),
                });
            }
        }
        span
    }

    fn max_concentrations(&self) -> [f32; 3] {
        [self.params.chlorophyll.max(), self.params.cdom.max(), self.params.spm.max()]
    }

    /// Pure-water scattering b_w(λ) of this model's salinity (0 when pure water is off).
    #[inline]
    pub fn water_scattering(&self, lambda: f32) -> f32 {
        if !self.params.pure_water {
            return 0.0;
        }
        let k = 16.06 * 1.38e-4 * (1.0 + 0.3 * self.params.salinity / 37.0);
        k * (lambda / 500.0).powf(-4.32)
    }

    /// (σa, σs) at wavelength λ for concentrations c = [chl, cdom, spm].
    #[inline]
    fn eval(&self, c: [f32; 3], lambda: f32) -> (f32, f32) {
        let [chl, cdom, spm] = c;
        let mut a = 0.0;
        let mut b = self.water_scattering(lambda);
        if self.params.pure_water {
            a += self.aw.eval(lambda);
        }
        if chl > 0.0 {
            a += self.a_phi.eval(lambda) * chl.powf(self.e_phi.eval(lambda));
            b += 0.30 * chl.powf(0.62) * (550.0 / lambda);
        }
        if cdom > 0.0 {
            a += self.params.cdom_specific_absorption * cdom * (-CDOM_SLOPE * (lambda - 440.0)).exp();
        }
        if spm > 0.0 {
            a += SPM_SPECIFIC_ABSORPTION_443 * spm * (-SPM_ABSORPTION_SLOPE * (lambda - 443.0)).exp();
            b += SPM_SPECIFIC_SCATTERING_555 * spm * (555.0 / lambda);
        }
        if let Some((ba, bb)) = &self.params.background {
            a += ba.eval(lambda);
            b += bb.eval(lambda);
        }
        (a, b)
    }

    /// (σa, σs) in m⁻¹ at depth z and wavelength λ (nm).
    #[inline]
    pub fn coefficients_at(&self, z: f32, lambda: f32) -> (f32, f32) {
        self.eval(self.concentrations(z), lambda)
    }

    /// (σa, σs) at depth z for a path's wavelengths; allocation-free.
    #[inline]
    pub fn sample(&self, z: f32, lambda: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        let c = self.concentrations(z);
        let mut sa = SampledSpectrum::ZERO;
        let mut ss = SampledSpectrum::ZERO;
        for i in 0..sa.0.len() {
            let (a, b) = self.eval(c, lambda.lambda[i]);
            sa.0[i] = a;
            ss.0[i] = b;
        }
        (sa, ss)
    }

    /// (σa, σs) for given concentrations [chl, cdom, spm] at a path's wavelengths (with
    /// [`BioOptical::concentration_range`] this bounds σ over a depth interval: every term is
    /// non-decreasing in its concentration).
    #[inline]
    pub fn sample_concentrations(&self, c: [f32; 3], lambda: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        let mut sa = SampledSpectrum::ZERO;
        let mut ss = SampledSpectrum::ZERO;
        for i in 0..sa.0.len() {
            let (a, b) = self.eval(c, lambda.lambda[i]);
            sa.0[i] = a;
            ss.0[i] = b;
        }
        (sa, ss)
    }

    /// Per-constituent (smallest, largest) concentrations over depths in [z0, z1].
    pub fn concentration_range(&self, z0: f32, z1: f32) -> ([f32; 3], [f32; 3]) {
        let (z0, z1) = if z0 <= z1 { (z0, z1) } else { (z1, z0) };
        let r = [self.params.chlorophyll.range(z0, z1), self.params.cdom.range(z0, z1), self.params.spm.range(z0, z1)];
        (r.map(|x| x.0), r.map(|x| x.1))
    }

    /// True when no constituent varies with depth.
    pub fn is_uniform(&self) -> bool {
        let (lo, hi) = self.concentration_range(f32::NEG_INFINITY, f32::INFINITY);
        lo == hi
    }

    /// Fraction of σs due to pure water at (z, λ): the weight of the molecular phase function
    /// in the scattering-weighted mixture of the thesis' Eq. 4.18.
    pub fn molecular_fraction(&self, z: f32, lambda: f32) -> f32 {
        let (_, s) = self.coefficients_at(z, lambda);
        if s > 0.0 {
            self.water_scattering(lambda) / s
        } else {
            0.0
        }
    }

    fn dense(&self, f: impl Fn(f32) -> f32) -> Result<Spectrum, WaterError> {
        let l: Vec<f32> = (LAMBDA_MIN as i32..=LAMBDA_MAX as i32).map(|l| l as f32).collect();
        let v: Vec<f32> = l.iter().map(|&l| f(l)).collect();
        Ok(Spectrum::tabulated(&l, &v)?)
    }

    /// σa(λ) at depth z as a `Tabulated` spectrum (1 nm nodes, 360–830 nm).
    pub fn sigma_a(&self, z: f32) -> Result<Spectrum, WaterError> {
        let c = self.concentrations(z);
        self.dense(|l| self.eval(c, l).0)
    }

    /// σs(λ) at depth z as a `Tabulated` spectrum (1 nm nodes, 360–830 nm).
    pub fn sigma_s(&self, z: f32) -> Result<Spectrum, WaterError> {
        let c = self.concentrations(z);
        self.dense(|l| self.eval(c, l).1)
    }

    /// Exact per-wavelength bound of σt over all depths at the path's wavelengths.
    #[inline]
    pub fn majorant_sampled(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        let c = self.max_concentrations();
        SampledSpectrum::from_fn(|i| {
            let (a, b) = self.eval(c, lambda.lambda[i]);
            a + b
        })
    }

    /// A per-wavelength bound of σt over all depths as a `Tabulated` spectrum (1 nm nodes,
    /// with a 1 % margin for what lies between nodes).
    pub fn majorant_spectrum(&self) -> Result<Spectrum, WaterError> {
        let c = self.max_concentrations();
        self.dense(|l| {
            let (a, b) = self.eval(c, l);
            MAJORANT_MARGIN * (a + b)
        })
    }

    /// A bound of σt over all depths and all wavelengths in `lambda_range` (nm): the largest
    /// value at the range's ends and every whole nm inside, plus a 1 % margin.
    pub fn majorant(&self, lambda_range: RangeInclusive<f32>) -> Result<f32, WaterError> {
        let (lo, hi) = (*lambda_range.start(), *lambda_range.end());
        if !(lo.is_finite() && hi.is_finite() && lo <= hi && lo > 0.0) {
            return Err(WaterError::BadRange { lo, hi });
        }
        let c = self.max_concentrations();
        let st = |l: f32| {
            let (a, b) = self.eval(c, l);
            a + b
        };
        let mut m = st(lo).max(st(hi));
        let mut l = lo.ceil();
        while l <= hi {
            m = m.max(st(l));
            l += 1.0;
        }
        Ok(MAJORANT_MARGIN * m)
    }
}
