//! Wind-sea spectra: Pierson–Moskowitz and JONSWAP frequency spectra, the Hasselmann et al.
//! directional spreading, their conversion to a wavenumber spectrum under deep-water
//! dispersion, spectral moments, and the Cox–Munk slope statistics they are compared with.
//!
//! Conventions: angular frequency ω in rad/s, wavenumber k in rad/m, `S(ω)` in m²·s (variance per
//! unit ω, one-sided), the directional spectrum `S(ω)·D(ω, θ)` with `∫D dθ = 1` over the full
//! circle, and the wavenumber spectrum `Ψ(k)` in m⁴ with `∫Ψ d²k = ∫S dω = m₀`, the variance
//! of the elevation. All arithmetic is f64 through the `libm` crate so that results are the same
//! bits on every IEEE-754 machine.

/// Standard gravity (m/s²).
pub const GRAVITY: f64 = 9.81;
/// The Phillips constant α of the equilibrium range.
pub const PHILLIPS_ALPHA: f64 = 0.0081;
/// Peak of the Pierson–Moskowitz spectrum: ω_p = `PM_PEAK` · g / U. With it the spectrum's
/// significant wave height is 4·√m₀ = 0.2093 U²/g, the Sverdrup–Munk / Pierson–Moskowitz
/// relation H_s ≈ 0.21 U²/g for a fully developed sea. (The peak written as f_m = 0.13 g/U,
/// ω_p = 0.817 g/U, would give 0.241 U²/g.)
pub const PM_PEAK: f64 = 0.877;
/// JONSWAP peak enhancement γ (mean of the JONSWAP experiment).
pub const JONSWAP_GAMMA: f64 = 3.3;
/// JONSWAP peak widths σ below and above the peak.
pub const JONSWAP_SIGMA: (f64, f64) = (0.07, 0.09);

/// Which frequency spectrum shapes the sea.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SpectrumKind {
    /// Pierson & Moskowitz (1964), fully developed sea.
    #[default]
    PiersonMoskowitz,
    /// JONSWAP (Hasselmann et al. 1973) with γ = 3.3 about the Pierson–Moskowitz peak,
    /// normalised by A_γ = 1 − 0.287 ln γ (Goda) so that its significant wave height and peak
    /// stay those of the fully developed sea: a sharper, younger-looking peak at the same energy.
    /// (The prim has no fetch, so JONSWAP's fetch-dependent α and ω_p are not used.)
    Jonswap,
}

impl SpectrumKind {
    /// Parses the USD token (`piersonMoskowitz` | `jonswap`).
    pub fn from_token(token: &str) -> Option<Self> {
        match token {
            "piersonMoskowitz" => Some(SpectrumKind::PiersonMoskowitz),
            "jonswap" => Some(SpectrumKind::Jonswap),
            _ => None,
        }
    }

    /// The USD token.
    pub fn token(self) -> &'static str {
        match self {
            SpectrumKind::PiersonMoskowitz => "piersonMoskowitz",
            SpectrumKind::Jonswap => "jonswap",
        }
    }
}

/// Peak angular frequency ω_p (rad/s) for wind speed `u` (m/s); infinite for no wind.
pub fn peak_frequency(u: f64) -> f64 {
    PM_PEAK * GRAVITY / u
}

/// Peak wavelength 2π g / ω_p² (m): a patch should be a few of these wide to hold the
/// energetic waves (0.83 U² metres).
pub fn peak_wavelength(u: f64) -> f64 {
    let wp = peak_frequency(u);
    2.0 * std::f64::consts::PI * GRAVITY / (wp * wp)
}

/// The one-sided frequency spectrum S(ω) in m²·s.
pub fn frequency_spectrum(kind: SpectrumKind, u: f64, omega: f64) -> f64 {
    if u.is_nan() || omega.is_nan() || u <= 0.0 || omega <= 0.0 {
        return 0.0;
    }
    let wp = peak_frequency(u);
    let r = wp / omega;
    let r4 = (r * r) * (r * r);
    let o2 = omega * omega;
    let pm = PHILLIPS_ALPHA * GRAVITY * GRAVITY / (o2 * o2 * omega) * libm::exp(-1.25 * r4);
    match kind {
        SpectrumKind::PiersonMoskowitz => pm,
        SpectrumKind::Jonswap => {
            let sigma = if omega <= wp { JONSWAP_SIGMA.0 } else { JONSWAP_SIGMA.1 };
            let d = (omega - wp) / (sigma * wp);
            let peak = libm::pow(JONSWAP_GAMMA, libm::exp(-0.5 * d * d));
            (1.0 - 0.287 * libm::log(JONSWAP_GAMMA)) * pm * peak
        }
    }
}

/// Spreading exponent p(ω) of Hasselmann et al. (1980): 9.77 (ω/ω_p)^μ, μ = 4.06 below the
/// peak and −2.34 above.
pub fn spreading_exponent(omega_over_peak: f64) -> f64 {
    let mu = if omega_over_peak < 1.0 { 4.06 } else { -2.34 };
    9.77 * libm::pow(omega_over_peak, mu)
}

/// Directional spreading D = cos^{2p}(θ/2) / N_p (1/rad) of a wave whose direction makes
/// `cos_theta` with the downwind direction; ∫D dθ over (−π, π] is 1.
pub fn spreading(omega_over_peak: f64, cos_theta: f64) -> f64 {
    let p = spreading_exponent(omega_over_peak);
    // N_p = 2^{1−2p} π Γ(2p+1) / Γ(p+1)²
    let ln_np = (1.0 - 2.0 * p) * std::f64::consts::LN_2 + libm::log(std::f64::consts::PI) + libm::lgamma(2.0 * p + 1.0)
        - 2.0 * libm::lgamma(p + 1.0);
    // cos²(θ/2) = (1 + cos θ)/2
    let c2 = (0.5 * (1.0 + cos_theta)).clamp(0.0, 1.0);
    if c2 == 0.0 {
        return 0.0;
    }
    libm::exp(p * libm::log(c2) - ln_np)
}

/// Deep-water dispersion ω = √(g k).
pub fn dispersion(k: f64) -> f64 {
    libm::sqrt(GRAVITY * k)
}

/// The wavenumber spectrum Ψ(k) in m⁴ at wavevector (`kx`, `kz`) (rad/m, on the XZ plane) for
/// wind speed `u` blowing towards the unit vector `wind` = (x, z):
/// Ψ = S(ω) D(ω, θ) (dω/dk) / k with ω² = g k.
pub fn wavenumber_spectrum(kind: SpectrumKind, u: f64, wind: [f64; 2], kx: f64, kz: f64) -> f64 {
    let k = libm::sqrt(kx * kx + kz * kz);
    if k.is_nan() || u.is_nan() || k <= 0.0 || u <= 0.0 {
        return 0.0;
    }
    let omega = dispersion(k);
    let cos_theta = (kx * wind[0] + kz * wind[1]) / k;
    let dw_dk = 0.5 * GRAVITY / omega;
    frequency_spectrum(kind, u, omega) * spreading(omega / peak_frequency(u), cos_theta) * dw_dk / k
}

/// ∫ ω^n S(ω) dω from 0 to `omega_max` (may be infinite) by Simpson's rule in ln ω over the
/// range where the integrand is not negligible, plus the analytic ω⁻⁵ tail beyond it.
pub fn spectral_moment(kind: SpectrumKind, u: f64, n: i32, omega_max: f64) -> f64 {
    if u.is_nan() || omega_max.is_nan() || u <= 0.0 || omega_max <= 0.0 {
        return 0.0;
    }
    let wp = peak_frequency(u);
    // below ω_p/8 the factor exp(−1.25 (ω_p/ω)⁴) is < e^{−5000}
    let lo = wp / 8.0;
    let hi_cap = wp * 2000.0;
    let hi = omega_max.min(hi_cap);
    if hi <= lo {
        return 0.0;
    }
    let steps = 20_000usize;
    let (a, b) = (libm::log(lo), libm::log(hi));
    let h = (b - a) / steps as f64;
    let f = |x: f64| {
        let w = libm::exp(x);
        libm::pow(w, n as f64 + 1.0) * frequency_spectrum(kind, u, w)
    };
    let mut sum = f(a) + f(b);
    for i in 1..steps {
        sum += f(a + h * i as f64) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    let mut total = sum * h / 3.0;
    if omega_max > hi_cap {
        // far above the peak S = α g² ω⁻⁵ (the JONSWAP factor is A_γ there)
        let scale = match kind {
            SpectrumKind::PiersonMoskowitz => 1.0,
            SpectrumKind::Jonswap => 1.0 - 0.287 * libm::log(JONSWAP_GAMMA),
        };
        let c = scale * PHILLIPS_ALPHA * GRAVITY * GRAVITY;
        total += if n == 4 {
            c * (libm::log(omega_max) - libm::log(hi_cap))
        } else {
            let e = (n - 4) as f64;
            let term = |w: f64| if w.is_finite() { libm::pow(w, e) } else if e < 0.0 { 0.0 } else { f64::INFINITY };
            c * (term(omega_max) - term(hi_cap)) / e
        };
    }
    total
}

/// Significant wave height 4·√m₀ (m) of the whole spectrum.
pub fn significant_wave_height(kind: SpectrumKind, u: f64) -> f64 {
    4.0 * libm::sqrt(spectral_moment(kind, u, 0, f64::INFINITY))
}

/// Mean-square slope ∫ k² Ψ d²k (both directions together) of the waves with wavenumber below
/// `k_max`: ∫ ω⁴/g² S(ω) dω up to ω = √(g k_max). It grows without bound (logarithmically) as
/// `k_max` grows: the ω⁻⁵ tail of these spectra does not describe the capillary range.
pub fn slope_variance_below(kind: SpectrumKind, u: f64, k_max: f64) -> f64 {
    spectral_moment(kind, u, 4, dispersion(k_max)) / (GRAVITY * GRAVITY)
}

/// Cox & Munk (1954) mean-square slope of a clean sea, upwind plus crosswind:
/// σ² = 0.003 + 5.12·10⁻³ U (U in m/s at 12.5 m).
pub fn cox_munk_mss(u: f64) -> f64 {
    0.003 + 5.12e-3 * u
}
