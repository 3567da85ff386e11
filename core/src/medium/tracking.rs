//! Unbiased free-flight sampling and transmittance where the coefficients vary along the ray,
//! given a per-wavelength majorant σ̄_j ≥ σt_j(t) on the segment.
//!
//! # Collisions: delta tracking with spectral MIS
//!
//! Tentative collisions are drawn with the majorant of one channel c, chosen uniformly among
//! the live wavelengths (as in the homogeneous case, [`super::sample_distance_spectral`]); at a
//! tentative collision at t the event is real with probability σt_c(t)/σ̄_c and null
//! otherwise. Writing the transmittance of every channel j in its null-collision expansion with
//! its own majorant σ̄_j (Galtier et al. 2013; Miller et al. 2019),
//!
//! T_j(t) σs_j(t) = Σ_k ∫…∫ e^{−σ̄_j t} Π_i σn_j(t_i) · σs_j(t) dt_1…dt_k,  σn = σ̄ − σt,
//!
//! the tracking strategy of channel c has, for a sequence of nulls t_1 < … < t_k followed by a
//! real collision at t, the density p_c = e^{−σ̄_c t} Π_i σn_c(t_i) · σt_c(t) (and for passing
//! the segment, e^{−σ̄_c t_max} Π_i σn_c(t_i)). Choosing c uniformly is a one-sample mixture of
//! these strategies, so the per-wavelength weight
//!
//! w_j = f_j / ((1/N) Σ_c p_c),  f_j = e^{−σ̄_j t} Π_i σn_j(t_i) · σs_j(t)  (or without σs on passing),
//!
//! is unbiased for every wavelength and, as each strategy dominates its own channel, bounded by
//! N·σs_j/σt_j ≤ N. This is pbrt-v4's majorant-tracking estimator with its path-level pdf
//! ratios (r_u) resolved within the segment. Where σ̄ = σt everywhere no null collision can
//! happen and the result is exactly the homogeneous estimator. The products are kept in the
//! log domain so that long segments do not underflow.
//!
//! # Shadow rays: residual ratio tracking
//!
//! With a control σc_j ≤ σt_j(t) and a scalar rate μ ≥ σt_j(t) − σc_j for all live j,
//! T_j = e^{−σc_j t} Π_i (1 − (σt_j(t_i) − σc_j)/μ) over a Poisson process of rate μ is
//! unbiased for every wavelength at once (Novák et al. 2014); each factor lies in [0, 1]. A
//! medium whose coefficients do not vary along the ray has μ = 0 and gets the exact value.

use super::homogeneous::DistanceSample;
use super::phase::ONE_MINUS_EPSILON;
use crate::spectrum::{SampledSpectrum, SampledWavelengths, N_SPECTRUM};

/// Ratio tracking's Russian roulette: once every wavelength's estimate is below
/// [`ROULETTE_BELOW`], the estimate ends (0) with probability [`ROULETTE_END`] and is otherwise
/// divided by 1 − [`ROULETTE_END`]. The expectation is unchanged; in a dense medium a shadow
/// ray then takes a few points instead of walking on until its estimate underflows (or, at a
/// density of 10⁹ m⁻¹, until [`MAX_TRACKING_STEPS`]). A number is drawn only below the threshold.
pub const ROULETTE_BELOW: f32 = 0.05;
pub const ROULETTE_END: f32 = 0.75;

/// Applies the roulette to `tr` (see [`ROULETTE_BELOW`]); false when the estimate ended.
#[inline]
pub fn roulette(tr: &mut SampledSpectrum, rng: &mut impl FnMut() -> f32) -> bool {
    if tr.max_component() >= ROULETTE_BELOW {
        return true;
    }
    if unit(rng) < ROULETTE_END {
        *tr = SampledSpectrum::ZERO;
        return false;
    }
    *tr = *tr * (1.0 / (1.0 - ROULETTE_END));
    true
}

/// Tentative collisions (or ratio-tracking points) allowed per call. Reaching it needs a
/// segment some 6.5·10⁴ majorant free paths long (1.3 cm of a grid whose densest voxel is
/// 5·10⁶ m⁻¹, 65 km of water of 1 m⁻¹); the call then ends the path (weight 0), which is the
/// only bias and only there. It bounds a call's time (about a millisecond) in a medium
/// absurdly dense for its voxels, where null collisions would otherwise run on.
pub const MAX_TRACKING_STEPS: u32 = 1 << 16;

#[inline]
fn unit(rng: &mut impl FnMut() -> f32) -> f32 {
    rng().clamp(0.0, ONE_MINUS_EPSILON)
}

/// Exponential step with rate `rate` (∞ when the rate is 0).
#[inline]
fn step(rate: f32, u: f32) -> f32 {
    if rate > 0.0 {
        -(-u).ln_1p() / rate
    } else {
        f32::INFINITY
    }
}

/// −σ̄ t with the limits of 0·∞ (= 0: a clear channel transmits an infinite segment).
#[inline]
fn neg_optical(sigma: f32, t: f32) -> f32 {
    if sigma > 0.0 {
        -sigma * t
    } else {
        0.0
    }
}

/// Delta tracking with spectral MIS (see the module docs). `majorant[j]` must bound
/// σt_j(t) = σa_j(t) + σs_j(t) on [0, t_max); `coeffs(t)` returns (σa, σs) at distance t.
/// The first number drawn from `rng` chooses the channel (and the first step), as the
/// homogeneous sampler does with its single number.
pub fn sample_distance_tracking(
    majorant: SampledSpectrum,
    t_max: f32,
    rng: &mut impl FnMut() -> f32,
    lambda: &SampledWavelengths,
    mut coeffs: impl FnMut(f32) -> (SampledSpectrum, SampledSpectrum),
) -> DistanceSample {
    let live = |j: usize| lambda.pdf[j] > 0.0;
    let keep = |s: SampledSpectrum| SampledSpectrum::from_fn(|j| if live(j) && s[j] > 0.0 { s[j] } else { 0.0 });
    let n = (0..N_SPECTRUM).filter(|&j| live(j)).count();
    let all_live = keep(SampledSpectrum::ONE);
    if n == 0 || !(t_max > 0.0) {
        return DistanceSample::Pass { weight: all_live };
    }
    let maj = majorant.map(|v| if v.is_finite() { v } else { f32::MAX });
    let maj = keep(maj);
    let scaled = unit(rng) * n as f32;
    let k = (scaled as usize).min(n - 1);
    let mut v = (scaled - k as f32).clamp(0.0, ONE_MINUS_EPSILON);
    let c = (0..N_SPECTRUM).filter(|&j| live(j)).nth(k).unwrap_or(0);
    // Σ ln σn_j over the null collisions so far
    let mut log_null = [0f32; N_SPECTRUM];
    let mut t = 0.0f32;
    for _ in 0..MAX_TRACKING_STEPS {
        t += step(maj[c], v);
        if !(t < t_max) {
            let logs: [f32; N_SPECTRUM] = std::array::from_fn(|j| log_null[j] + neg_optical(maj[j], t_max));
            return DistanceSample::Pass { weight: mis_weight(&logs, SampledSpectrum::ONE, SampledSpectrum::ONE, lambda, n) };
        }
        let (a, s) = coeffs(t);
        let (a, s) = (keep(a), keep(s));
        let st = a + s;
        if unit(rng) * maj[c] < st[c] {
            let logs: [f32; N_SPECTRUM] = std::array::from_fn(|j| log_null[j] + neg_optical(maj[j], t));
            return DistanceSample::Scatter { t, weight: mis_weight(&logs, s, st, lambda, n) };
        }
        for j in 0..N_SPECTRUM {
            // σ̄ ≥ σt up to rounding; a negative difference would be rounding only
            log_null[j] += (maj[j] - st[j]).max(0.0).ln();
        }
        v = unit(rng);
    }
    DistanceSample::Pass { weight: SampledSpectrum::ZERO }
}

/// w_j = e^{L_j} num_j / ((1/N) Σ_c e^{L_c} den_c) over the live channels, in the log domain.
pub(crate) fn mis_weight(logs: &[f32; N_SPECTRUM], num: SampledSpectrum, den: SampledSpectrum, lambda: &SampledWavelengths, n: usize) -> SampledSpectrum {
    let live = |j: usize| lambda.pdf[j] > 0.0;
    let d: [f32; N_SPECTRUM] = std::array::from_fn(|j| if live(j) { logs[j] + den[j].ln() } else { f32::NEG_INFINITY });
    let m = d.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    if !m.is_finite() {
        return SampledSpectrum::ZERO;
    }
    let denom: f32 = d.iter().map(|&x| (x - m).exp()).sum::<f32>() / n as f32;
    SampledSpectrum::from_fn(|j| {
        if !live(j) || num[j] <= 0.0 {
            return 0.0;
        }
        let w = (logs[j] + num[j].ln() - m).exp() / denom;
        if w.is_finite() {
            w
        } else {
            0.0
        }
    })
}

/// Residual ratio tracking (see the module docs): transmittance over [0, t] of every live
/// wavelength. `control[j]` ≤ σt_j on the segment, `residual_rate` ≥ σt_j − control[j]
/// for every live j; `sigma_t(s)` is σt at distance s. Draws nothing when `residual_rate` is 0.
pub fn transmittance_ratio_tracking(
    control: SampledSpectrum,
    residual_rate: f32,
    t: f32,
    rng: &mut impl FnMut() -> f32,
    lambda: &SampledWavelengths,
    mut sigma_t: impl FnMut(f32) -> SampledSpectrum,
) -> SampledSpectrum {
    let live = |j: usize| lambda.pdf[j] > 0.0;
    if !(t > 0.0) {
        return SampledSpectrum::from_fn(|j| if live(j) { 1.0 } else { 0.0 });
    }
    let mut tr = SampledSpectrum::from_fn(|j| if live(j) { neg_optical(control[j].max(0.0), t).exp() } else { 0.0 });
    if !(residual_rate > 0.0) || !residual_rate.is_finite() {
        return tr;
    }
    let mut s = 0.0f32;
    for _ in 0..MAX_TRACKING_STEPS {
        if tr.is_black() {
            return tr;
        }
        s += step(residual_rate, unit(rng));
        if !(s < t) {
            return tr;
        }
        let st = sigma_t(s);
        for j in 0..N_SPECTRUM {
            if live(j) {
                tr.0[j] *= (1.0 - (st[j].max(0.0) - control[j].max(0.0)) / residual_rate).max(0.0);
            }
        }
        if !roulette(&mut tr, rng) {
            return tr;
        }
    }
    SampledSpectrum::ZERO
}
