//! A homogeneous participating medium and spectral-MIS free-flight distance sampling.
//!
//! Water's coefficients differ by orders of magnitude across the visible range, so sampling a
//! distance from one wavelength's σt would give the others unbounded weights. Instead the
//! distance is drawn from the one-sample MIS mixture over the path's live wavelengths
//! (hero-wavelength spectral MIS, Wilkie et al. 2014; the same single-sample model that
//! pbrt-v4's majorant tracking uses): a channel c is chosen uniformly among the live ones and
//! t ~ σt_c e^{−σt_c t}, so
//!
//! * pdf(t) = (1/N) Σ_j σt_j e^{−σt_j t} for a collision at t < t_max, and
//! * P(pass) = (1/N) Σ_j e^{−σt_j t_max} for crossing the whole segment,
//!
//! with N the number of live wavelengths (`lambda.pdf[j] > 0`). The returned weights,
//! T(t)·σs/pdf(t) at a collision and T(t_max)/P(pass) on passing, make the estimator unbiased
//! for every wavelength and bounded by N (each term of the mixture dominates its own channel).

use super::phase::{PhaseFunction, ONE_MINUS_EPSILON};
use super::MediumError;
use crate::scene::{ColorSpace, MediumDesc, SpectrumDesc};
use crate::spectrum::{SampledSpectrum, SampledWavelengths, Spectrum, SpectrumKind, N_SPECTRUM};

/// Outcome of free-flight sampling along a segment of length `t_max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DistanceSample {
    /// A real scattering event at distance `t`; multiply the throughput by `weight`
    /// (= T(t)·σs / pdf(t)) and sample the phase function there.
    Scatter { t: f32, weight: SampledSpectrum },
    /// The path reaches the end of the segment; multiply the throughput by `weight`
    /// (= T(t_max) / P(pass)).
    Pass { weight: SampledSpectrum },
}

impl DistanceSample {
    /// The throughput multiplier, whichever the event.
    #[inline]
    pub fn weight(&self) -> SampledSpectrum {
        match *self {
            DistanceSample::Scatter { weight, .. } | DistanceSample::Pass { weight } => weight,
        }
    }
}

/// A medium with constant coefficients (per scene unit) and one phase function.
#[derive(Clone, Debug, PartialEq)]
pub struct HomogeneousMedium {
    pub sigma_a: Spectrum,
    pub sigma_s: Spectrum,
    pub phase: PhaseFunction,
}

/// e^{−σ t} with the limits a segment of infinite length needs: 1 where σ = 0 (also for
/// t = ∞), 0 where σ > 0 and t = ∞.
#[inline]
fn tr(sigma: f32, t: f32) -> f32 {
    if sigma <= 0.0 || t <= 0.0 {
        1.0
    } else {
        (-sigma * t).exp()
    }
}

/// Transmittance e^{−σt·t} per channel over a distance `t` (≥ 0, may be infinite).
#[inline]
pub fn transmittance_spectral(sigma_t: SampledSpectrum, t: f32) -> SampledSpectrum {
    SampledSpectrum::from_fn(|j| tr(sigma_t[j], t))
}

#[inline]
fn live_count(lambda: &SampledWavelengths) -> usize {
    lambda.pdf.iter().filter(|&&p| p > 0.0).count()
}

/// Density of the mixture over live wavelengths of sampling a collision at `t`
/// (what [`sample_distance_spectral`] uses; for MIS against other distance samplers).
pub fn distance_pdf(sigma_t: SampledSpectrum, t: f32, lambda: &SampledWavelengths) -> f32 {
    let n = live_count(lambda);
    if n == 0 {
        return 0.0;
    }
    let mut s = 0.0;
    for j in 0..N_SPECTRUM {
        if lambda.pdf[j] > 0.0 && sigma_t[j] > 0.0 {
            s += sigma_t[j] * tr(sigma_t[j], t);
        }
    }
    s / n as f32
}

/// Probability that [`sample_distance_spectral`] passes a segment of length `t_max`.
pub fn pass_probability(sigma_t: SampledSpectrum, t_max: f32, lambda: &SampledWavelengths) -> f32 {
    let n = live_count(lambda);
    if n == 0 {
        return 0.0;
    }
    let mut s = 0.0;
    for j in 0..N_SPECTRUM {
        if lambda.pdf[j] > 0.0 {
            s += tr(sigma_t[j], t_max);
        }
    }
    s / n as f32
}

/// Spectral-MIS free-flight sampling for coefficients already evaluated at `lambda`
/// (see the module documentation). `t_max` may be `f32::INFINITY`. Terminated wavelengths
/// (pdf 0) take no part in the mixture and get weight 0. When σs is zero at every live
/// wavelength no collision is sampled: the result is `Pass` with weight T(t_max).
pub fn sample_distance_spectral(
    sigma_a: SampledSpectrum,
    sigma_s: SampledSpectrum,
    t_max: f32,
    u: f32,
    lambda: &SampledWavelengths,
) -> DistanceSample {
    // terminated wavelengths are zeroed by selection (multiplying by 0 would turn ∞ into NaN)
    let keep = |s: SampledSpectrum| SampledSpectrum::from_fn(|j| if lambda.pdf[j] > 0.0 { s[j].max(0.0) } else { 0.0 });
    let live = keep(SampledSpectrum::ONE);
    let sigma_s = keep(sigma_s);
    let sigma_t = keep(sigma_a) + sigma_s;
    let n = live_count(lambda);
    if n == 0 || !(t_max > 0.0) {
        // nothing to carry, or an empty segment (t_max ≤ 0 or NaN): T = 1
        return DistanceSample::Pass { weight: live };
    }
    if sigma_s.is_black() {
        // purely absorbing: a collision could only carry weight 0, so never sample one
        return DistanceSample::Pass { weight: keep(transmittance_spectral(sigma_t, t_max)) };
    }
    // choose the live channel ⌊u·N⌋ among the live ones and reuse the remainder of u
    let scaled = u.clamp(0.0, ONE_MINUS_EPSILON) * n as f32;
    let k = (scaled as usize).min(n - 1);
    let v = (scaled - k as f32).clamp(0.0, ONE_MINUS_EPSILON);
    let c = (0..N_SPECTRUM).filter(|&j| lambda.pdf[j] > 0.0).nth(k).unwrap_or(0);
    let t = if sigma_t[c] > 0.0 { -(-v).ln_1p() / sigma_t[c] } else { f32::INFINITY };
    if t < t_max {
        let pdf = distance_pdf(sigma_t, t, lambda);
        let trans = transmittance_spectral(sigma_t, t);
        let weight = if pdf > 0.0 && pdf.is_finite() { trans * sigma_s / pdf } else { SampledSpectrum::ZERO };
        DistanceSample::Scatter { t, weight: sanitize(weight) }
    } else {
        let p_pass = pass_probability(sigma_t, t_max, lambda);
        let trans = keep(transmittance_spectral(sigma_t, t_max));
        let weight = if p_pass > 0.0 { trans / p_pass } else { SampledSpectrum::ZERO };
        DistanceSample::Pass { weight: sanitize(weight) }
    }
}

/// Replaces anything non-finite (only reachable through infinite coefficients) by 0.
#[inline]
fn sanitize(w: SampledSpectrum) -> SampledSpectrum {
    w.map(|v| if v.is_finite() { v } else { 0.0 })
}

impl HomogeneousMedium {
    pub fn new(sigma_a: Spectrum, sigma_s: Spectrum, phase: PhaseFunction) -> Self {
        HomogeneousMedium { sigma_a, sigma_s, phase }
    }

    /// Builds the medium a scene describes. `to_spectrum` turns a (validated, already
    /// `scale`d) spectrum description into a [`Spectrum`]; its error message is reported
    /// with the medium's name. Use [`HomogeneousMedium::from_desc_in`] for RGB-only media.
    pub fn from_desc(
        desc: &MediumDesc,
        mut to_spectrum: impl FnMut(&SpectrumDesc) -> Result<Spectrum, String>,
    ) -> Result<Self, MediumError> {
        let bad = |reason: String| MediumError::BadMedium { medium: desc.name.clone(), reason };
        if !desc.scale.is_finite() || desc.scale < 0.0 {
            return Err(bad(format!("scale {} must be finite and ≥ 0", desc.scale)));
        }
        let sigma_a = scaled_desc(&desc.sigma_a, desc.scale).map_err(|e| bad(format!("sigma_a: {e}")))?;
        let sigma_s = scaled_desc(&desc.sigma_s, desc.scale).map_err(|e| bad(format!("sigma_s: {e}")))?;
        let sigma_a = to_spectrum(&sigma_a).map_err(|e| bad(format!("sigma_a: {e}")))?;
        let sigma_s = to_spectrum(&sigma_s).map_err(|e| bad(format!("sigma_s: {e}")))?;
        let phase = PhaseFunction::from_desc(&desc.phase).map_err(|e| bad(format!("phase: {e}")))?;
        Ok(HomogeneousMedium { sigma_a, sigma_s, phase })
    }

    /// [`HomogeneousMedium::from_desc`] with RGB coefficients uplifted as unbounded spectra
    /// in `cs` and tabulated ones interpolated.
    pub fn from_desc_in(desc: &MediumDesc, cs: ColorSpace) -> Result<Self, MediumError> {
        Self::from_desc(desc, |s| Spectrum::from_desc(s, SpectrumKind::Unbounded, cs).map_err(|e| e.to_string()))
    }

    /// (σa, σs) at the path's wavelengths, clamped to ≥ 0. Call once per segment.
    #[inline]
    pub fn coefficients(&self, lambda: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        let clamp = |s: SampledSpectrum| s.map(|v| v.max(0.0));
        (clamp(self.sigma_a.sample(lambda)), clamp(self.sigma_s.sample(lambda)))
    }

    /// Single-scattering albedo σs/σt (0 where σt = 0).
    #[inline]
    pub fn albedo(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        let (a, s) = self.coefficients(lambda);
        s.safe_div(a + s)
    }

    /// Spectral-MIS free-flight sampling over a segment of length `t_max` (see
    /// [`sample_distance_spectral`]); `u` is one uniform number in [0, 1).
    #[inline]
    pub fn sample_distance(&self, t_max: f32, u: f32, lambda: &SampledWavelengths) -> DistanceSample {
        let (a, s) = self.coefficients(lambda);
        sample_distance_spectral(a, s, t_max, u, lambda)
    }

    /// Transmittance over a distance `t` (shadow rays), for every wavelength.
    #[inline]
    pub fn transmittance(&self, t: f32, lambda: &SampledWavelengths) -> SampledSpectrum {
        let (a, s) = self.coefficients(lambda);
        transmittance_spectral(a + s, t)
    }

    /// σt at the path's wavelengths (the majorant of a homogeneous medium).
    #[inline]
    pub fn sigma_t(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        let (a, s) = self.coefficients(lambda);
        a + s
    }
}

/// A checked copy of a spectrum description with its values multiplied by `scale`.
fn scaled_desc(s: &SpectrumDesc, scale: f32) -> Result<SpectrumDesc, String> {
    match s {
        SpectrumDesc::Rgb(rgb) => {
            if rgb.iter().any(|v| !v.is_finite() || *v < 0.0) {
                return Err(format!("RGB {rgb:?} must be finite and ≥ 0"));
            }
            Ok(SpectrumDesc::Rgb(rgb.map(|v| v * scale)))
        }
        SpectrumDesc::Tabulated { lambda, value } => {
            if lambda.is_empty() || lambda.len() != value.len() {
                return Err(format!(
                    "tabulated spectrum needs as many values as wavelengths, at least one (got {} and {})",
                    lambda.len(),
                    value.len()
                ));
            }
            if let Some(w) = lambda.windows(2).find(|w| !(w[1] > w[0])) {
                return Err(format!("wavelengths must increase ({} then {})", w[0], w[1]));
            }
            if let Some(l) = lambda.iter().find(|l| !l.is_finite()) {
                return Err(format!("wavelength {l} is not finite"));
            }
            if let Some(v) = value.iter().find(|v| !v.is_finite() || **v < 0.0) {
                return Err(format!("value {v} must be finite and ≥ 0"));
            }
            Ok(SpectrumDesc::Tabulated { lambda: lambda.clone(), value: value.iter().map(|v| v * scale).collect() })
        }
    }
}
