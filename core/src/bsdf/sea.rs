//! The wind-driven sea-surface BSDF: a rough air–water interface whose microfacet slopes follow
//! the Cox–Munk (1954) statistics for a given wind speed and direction.
//!
//! * **Slopes.** The surface slopes ζ = (∂h/∂u, ∂h/∂c) along the wind (u, the direction the wind
//!   blows towards) and across it (c) are Gaussian with the Cox–Munk clean-surface variances
//!   σ²_up = 3.16·10⁻³ U and σ²_cross = 0.003 + 1.92·10⁻³ U (U: wind speed at 10 m in m/s; both
//!   floored at [`MIN_SLOPE_VARIANCE`] so that U = 0 stays a valid, very narrow lobe). A
//!   microfacet with slope ζ has the normal m = (−ζ, 1)/√(1 + |ζ|²), and the slope density p(ζ)
//!   is the normal distribution D(m) = p(ζ)/cos⁴θm (normalised over projected area:
//!   ∫D cosθm dωm = 1).
//! * **Gram–Charlier correction.** Evaluation multiplies the Gaussian by Cox and Munk's
//!   skewness/kurtosis series in ξ = ζ_c/σ_c, η = ζ_u/σ_u:
//!   1 − ½c₂₁(ξ²−1)η − ⅙c₀₃(η³−3η) + c₄₀/24 (ξ⁴−6ξ²+3) + ¼c₂₂(ξ²−1)(η²−1) + c₀₄/24 (η⁴−6η²+3),
//!   c₂₁ = 0.01 − 0.0086U, c₀₃ = 0.04 − 0.033U, c₄₀ = 0.40, c₂₂ = 0.12, c₀₄ = 0.23, with U
//!   capped at [`GRAM_CHARLIER_MAX_WIND`] in c₂₁ and c₀₃. The series is negative far in the
//!   tails for strong winds; it is clamped at zero there (the clamped mass is below 10⁻³). The
//!   correction only reshapes the lobe: it has zero mean and integrates to one against the
//!   Gaussian, so it is *not* sampled (slopes are drawn from the Gaussian and the correction
//!   rides in `f`), and masking uses the Smith Λ of the corrected density (closed form, see
//!   [`CoxMunk::lambda`]) so that the masking and the distribution stay consistent.
//! * **Reflection** (Ross, Dion & Potvin 2005): perfect-mirror facets,
//!   f_r = F(ωo·m) D(m) G₂(ωo, ωi) / (4 |cosθo| |cosθi|), with exact dielectric Fresnel and the
//!   height-correlated Smith term G₂ = 1/(1 + Λ(ωo) + Λ(ωi)), where for the Gaussian
//!   Λ(ω) = (φ(a) − a Q(a))/a, a = |cotθ|/σ(φ), σ²(φ) the slope variance along ω's azimuth,
//!   φ the standard normal density and Q its upper tail (plus the Gram–Charlier terms).
//! * **Transmission** (Ma et al. 2016): refraction through the same facets, written with the
//!   Walter et al. (2007) half-vector Jacobian so that it is reciprocal and lossless for a smooth
//!   surface: f_t = (1 − F) D G₂ |ωi·m||ωo·m| / (|cosθi||cosθo| (ωi·m + ωo·m/η')²), divided by
//!   η'² in [`TransportMode::Radiance`].
//! * **Sampling.** Normals visible from ωo are drawn exactly from the Gaussian (the Beckmann
//!   distribution with α = √2σ): the slope along the stretched view azimuth by numerically
//!   inverting its closed-form CDF, the other slope from a normal law. Reflection or refraction
//!   is then chosen with probability F(ωo·m) and 1 − F. The pdf is
//!   G₁(ωo)/|cosθo| · D(m) |ωo·m| times the reflection or refraction Jacobian.
//! * **Energy.** Single scattering loses the light that the Smith term masks out: its
//!   directional albedo E = ∫(f_r + f_t)|cosθi| (without the η² radiance scaling) is 1 at
//!   normal incidence on both sides; from the air it drops to 0.94–0.96 between 80° and 89°
//!   (the lowest, ≈0.935, at U = 2 m/s and 85° or at U = 0 and 89°); from the water, where rays
//!   beyond the critical angle bounce under total internal reflection, to 0.92 (U = 5), 0.89
//!   (U = 10), 0.85 (U = 15), 0.80 (U = 25) and 0.73 (U = 40) at 75° from the nadir, and it
//!   depends strongly on the azimuth to the wind (0.70 to 0.82 at U = 40, 15° below the
//!   horizon). The clamped Gram–Charlier tail gains at most 10⁻³.
//!
//!   A **multiple-scattering compensation** (Kulla & Conty 2017, dielectric form) adds the
//!   missing energy back: a cosine lobe on each side,
//!   f_ms(ωo, ωi) = s · (1 − E(ωo))(1 − E(ωi)) / (π (1 − E_avg,i)), with E the tabulated
//!   single-scattering albedo of this lobe ([`super::sea_albedo`]: per side, over μ, the azimuth
//!   to the wind, the total slope σ and η), E_avg,i its hemispherical average on ωi's side, and
//!   s the share of the side ωi lies on: seen from the air the transmitted share is
//!   1 − F_avg(η) (the light a smooth surface passes), seen from the water it follows from
//!   reciprocity with the η² factor, t_water = t_air (1 − E_avg,air) / (η² (1 − E_avg,water)).
//!   f_ms is symmetric (reflection) and obeys f_radiance(ωo, ωi) = f_importance(ωi, ωo)
//!   (transmission), and ∫f_ms|cosθi| = 1 − E(ωo) exactly for the tabulated E. It is sampled
//!   with probability 1 − E(ωo) (cosine-distributed on the side chosen by s), and the pdf is
//!   the mixture. Evaluation costs three table look-ups (bench `sea_bsdf`, U = 10 m/s: `f` +
//!   `pdf` 141 → 278 ns, `sample_f` 850 → 982 ns, construction 40 → 104 ns; the first lobe of
//!   a new wind builds its 8 table nodes, 1.1 s on two cores). The tables hold the
//!   albedo raised by their own error bound (`sea_albedo::TABLE_MARGIN`, 6.5·10⁻³), so the
//!   compensation never adds more than is missing: compensated, the white furnace never reads
//!   above 1 and reads 1 − 6.5·10⁻³ within the tables' error, ±3.3·10⁻³ for U ≥ 5 m/s (both
//!   sides, every azimuth, normal to 89°) and up to 6.1·10⁻³ for calm water (U ≤ 2) within 6°
//!   of the horizon, where the albedo changes faster with the azimuth than the 10° nodes
//!   follow (`cargo test -p tide-core --lib report_table_error -- --ignored --nocapture`;
//!   `report_compensated_furnace`: the full sampler reads 0.991–0.996 ± 8·10⁻⁴ at U = 5–40,
//!   e.g. 0.995 at U = 40 seen from the water 10° below the horizon, where single scattering
//!   gives 0.876; without the margin it read 0.998–1.003).
//!   A lobe whose slope variances are scaled (`slopeVarianceScale`) is looked up by its total
//!   σ, which stands in the node's up/cross ratio and Gram–Charlier coefficients for its own:
//!   its furnace reads 1 within 7·10⁻³ at scales 0.4–0.5, but within only 4·10⁻² (either way)
//!   for a tiny share (0.02 at 15 m/s, whose slopes are nearly isotropic while the nodes of
//!   that σ are the strongly anisotropic calm lobe), grazing views only
//!   (`report_scaled_furnace`). Relative IORs outside [`COMPENSATED_ETA`] are not compensated.
//!
//! Use through [`super::Bsdf::sea`] (`eta` = n_water / n_air at the hero wavelength, the water on
//! the −Z side; `wind_speed` in m/s; `wind_direction` in radians in the local tangent plane,
//! measured from +X towards +Y). [`CoxMunk`] exposes the slope distribution itself.

use super::sea_albedo::{self, SeaAlbedoKey};
use super::{flags, BsdfError, BsdfSample, TransportMode};
use crate::math::{sample_cosine_hemisphere, INV_PI};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3};

/// Smallest slope variance used, so that calm water (σ²_up = 0 at U = 0) stays a proper lobe.
pub const MIN_SLOPE_VARIANCE: f64 = 1e-4;

/// Largest accepted wind speed in m/s: the Cox–Munk fits were measured up to about 14 m/s and
/// their Gram–Charlier coefficients grow without bound; beyond this they stop describing a sea.
pub const MAX_WIND_SPEED: f32 = 40.0;

/// Wind speed beyond which the Gram–Charlier coefficients are held fixed: about the top of
/// Cox and Munk's measurements, and the speed up to which the clamped negative tail of the
/// series stays below 10⁻³ of the density (it grows to 2·10⁻³ at 20 m/s and to percents at
/// 40 m/s, where the series would add energy).
pub const GRAM_CHARLIER_MAX_WIND: f32 = 15.0;

const SQRT_2PI: f64 = 2.506_628_274_631_000_7;
const FRAC_1_SQRT_2: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// Complementary error function, uniformly within 1.2·10⁻⁷ relative error (the Chebyshev fit of
/// Press et al., Numerical Recipes §6.2), accurate in the far tails where 1 − erf is not.
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// Standard normal density φ(x).
#[inline]
fn npdf(x: f64) -> f64 {
    (-0.5 * x * x).exp() / SQRT_2PI
}

/// Standard normal distribution function Φ(x).
#[inline]
fn ncdf(x: f64) -> f64 {
    0.5 * erfc(-x * FRAC_1_SQRT_2)
}

/// Solves H(x) = target for x ≤ `hi`, where H is increasing with derivative `dh`, by Newton
/// steps kept inside a shrinking bracket (bisection when a step leaves it).
fn invert_monotone(h: impl Fn(f64) -> f64, dh: impl Fn(f64) -> f64, target: f64, lo: f64, hi: f64, x0: f64) -> f64 {
    let (mut lo, mut hi) = (lo, hi);
    let mut x = x0.clamp(lo, hi);
    for _ in 0..64 {
        let g = h(x) - target;
        if g > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let d = dh(x);
        let mut next = if d > 0.0 { x - g / d } else { f64::NAN };
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        if (next - x).abs() <= 1e-9 * (1.0 + x.abs()) || hi - lo <= 1e-12 {
            return next;
        }
        x = next;
    }
    x
}

/// Rough starting point for Φ⁻¹(u) (logistic approximation of Φ), refined by Newton.
#[inline]
fn probit_guess(u: f64) -> f64 {
    let u = u.clamp(1e-12, 1.0 - 1e-12);
    (u / (1.0 - u)).ln() / 1.702
}

/// Φ⁻¹(u) for u ∈ (0, 1), to about 10⁻⁹ in x.
fn probit(u: f64) -> f64 {
    invert_monotone(ncdf, npdf, u, -9.0, 9.0, probit_guess(u))
}

/// The Cox–Munk wind-driven distribution of sea-surface slopes in a local frame (z up), with
/// the wind along the tangent direction at angle `wind_direction` from +X towards +Y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoxMunk {
    /// Slope standard deviations along and across the wind.
    pub sigma_up: f32,
    pub sigma_cross: f32,
    /// Wind direction (cos, sin) in the tangent plane.
    cos_w: f32,
    sin_w: f32,
    /// Gram–Charlier skewness coefficients c₂₁ and c₀₃ (kurtosis ones are constants).
    c21: f32,
    c03: f32,
}

const C40: f32 = 0.40;
const C22: f32 = 0.12;
const C04: f32 = 0.23;

impl super::lobes::Microfacets for CoxMunk {
    #[inline]
    fn d(&self, wm: Vec3) -> f32 {
        CoxMunk::d(self, wm)
    }
    #[inline]
    fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        CoxMunk::g2(self, wo, wi)
    }
    #[inline]
    fn pdf_visible(&self, w: Vec3, wm: Vec3) -> f32 {
        CoxMunk::pdf_visible(self, w, wm)
    }
}

impl CoxMunk {
    /// The Cox–Munk clean-surface slope variances (σ²_up, σ²_cross) for wind speed `u` m/s,
    /// before flooring.
    pub fn variances(u: f32) -> (f32, f32) {
        (3.16e-3 * u, 0.003 + 1.92e-3 * u)
    }

    /// Distribution for wind speed `wind_speed` (m/s at 10 m, in [0, [`MAX_WIND_SPEED`]]) and
    /// direction `wind_direction` (radians in the tangent plane, from +X towards +Y).
    pub fn new(wind_speed: f32, wind_direction: f32) -> Result<CoxMunk, BsdfError> {
        Self::with_variance_scale(wind_speed, wind_direction, 1.0)
    }

    /// As [`CoxMunk::new`], with both slope variances multiplied by `variance_scale` (finite,
    /// ≥ 0) before flooring: the part of the Cox–Munk slopes this facet distribution carries when
    /// the rest is resolved by geometry (a wave mesh whose own slopes hold 1 − `variance_scale`
    /// of them). The Gram–Charlier coefficients are in units of σ and stay those of the wind.
    pub fn with_variance_scale(wind_speed: f32, wind_direction: f32, variance_scale: f32) -> Result<CoxMunk, BsdfError> {
        if !variance_scale.is_finite() {
            return Err(BsdfError::NotFinite { parameter: "slopeVarianceScale" });
        }
        if variance_scale < 0.0 {
            return Err(BsdfError::OutOfRange { parameter: "slopeVarianceScale", value: variance_scale, expected: ">= 0" });
        }
        if !wind_speed.is_finite() {
            return Err(BsdfError::NotFinite { parameter: "windSpeed" });
        }
        if !wind_direction.is_finite() {
            return Err(BsdfError::NotFinite { parameter: "windDirection" });
        }
        if !(0.0..=MAX_WIND_SPEED).contains(&wind_speed) {
            return Err(BsdfError::OutOfRange { parameter: "windSpeed", value: wind_speed, expected: "in [0, 40] m/s" });
        }
        let (vu, vc) = Self::variances(wind_speed);
        let (vu, vc) = (vu as f64 * variance_scale as f64, vc as f64 * variance_scale as f64);
        let (sin_w, cos_w) = wind_direction.sin_cos();
        Ok(CoxMunk {
            sigma_up: vu.max(MIN_SLOPE_VARIANCE).sqrt() as f32,
            sigma_cross: vc.max(MIN_SLOPE_VARIANCE).sqrt() as f32,
            cos_w,
            sin_w,
            c21: 0.01 - 0.0086 * wind_speed.min(GRAM_CHARLIER_MAX_WIND),
            c03: 0.04 - 0.033 * wind_speed.min(GRAM_CHARLIER_MAX_WIND),
        })
    }

    /// Components of a tangent-plane vector along and across the wind.
    #[inline]
    fn to_wind(&self, x: f32, y: f32) -> (f32, f32) {
        (x * self.cos_w + y * self.sin_w, -x * self.sin_w + y * self.cos_w)
    }

    /// Components of ω's tangent part along and across the wind.
    #[inline]
    pub(crate) fn wind_components(&self, w: Vec3) -> (f32, f32) {
        self.to_wind(w.x, w.y)
    }

    #[inline]
    fn from_wind(&self, u: f32, c: f32) -> (f32, f32) {
        (u * self.cos_w - c * self.sin_w, u * self.sin_w + c * self.cos_w)
    }

    /// Slopes (along, across the wind) of the facet with normal m (m.z > 0).
    #[inline]
    pub fn slopes(&self, m: Vec3) -> (f32, f32) {
        let (u, c) = self.to_wind(m.x, m.y);
        (-u / m.z, -c / m.z)
    }

    /// Normal of the facet with slopes (along, across the wind).
    #[inline]
    pub fn normal(&self, zeta_up: f32, zeta_cross: f32) -> Vec3 {
        let (x, y) = self.from_wind(-zeta_up, -zeta_cross);
        Vec3::new(x, y, 1.0).normalize()
    }

    /// The Gram–Charlier factor at standardised slopes (ξ across, η along the wind), clamped
    /// at zero.
    #[inline]
    pub fn gram_charlier(&self, xi: f32, eta: f32) -> f32 {
        let (x2, e2) = (xi * xi, eta * eta);
        let g = 1.0 - 0.5 * self.c21 * (x2 - 1.0) * eta - self.c03 / 6.0 * (e2 * eta - 3.0 * eta)
            + C40 / 24.0 * (x2 * x2 - 6.0 * x2 + 3.0)
            + 0.25 * C22 * (x2 - 1.0) * (e2 - 1.0)
            + C04 / 24.0 * (e2 * e2 - 6.0 * e2 + 3.0);
        g.max(0.0)
    }

    /// Gaussian slope density p(ζ) and the standardised slopes (ξ, η).
    #[inline]
    fn gauss(&self, m: Vec3) -> (f32, f32, f32) {
        let (zu, zc) = self.slopes(m);
        let (eta, xi) = (zu / self.sigma_up, zc / self.sigma_cross);
        let p = (-0.5 * (xi * xi + eta * eta)).exp() / (2.0 * std::f32::consts::PI * self.sigma_up * self.sigma_cross);
        (p, xi, eta)
    }

    /// Gaussian normal distribution D(m) = p(ζ)/cos⁴θm (what the sampler draws from).
    #[inline]
    pub fn d_gauss(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let c2 = m.z * m.z;
        self.gauss(m).0 / (c2 * c2)
    }

    /// Normal distribution with the Gram–Charlier correction (what the BSDF evaluates).
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let (p, xi, eta) = self.gauss(m);
        let c2 = m.z * m.z;
        p * self.gram_charlier(xi, eta) / (c2 * c2)
    }

    /// Slope standard deviation along the azimuth of ω times sinθ: |σ ⊙ ω_t| in wind axes.
    #[inline]
    fn stretched_tangent(&self, w: Vec3) -> (f64, f64) {
        let (u, c) = self.to_wind(w.x, w.y);
        ((self.sigma_up * u) as f64, (self.sigma_cross * c) as f64)
    }

    /// Standardised view geometry: a = cosθ/|σ ⊙ ω_t| and the unit stretched azimuth (A, B)
    /// along and across the wind, for ω taken on the upper side; None at normal incidence.
    #[inline]
    fn view(&self, w: Vec3) -> Option<(f64, f64, f64)> {
        let w = if w.z < 0.0 { -w } else { w };
        let (su, sc) = self.stretched_tangent(w);
        let r = (su * su + sc * sc).sqrt();
        if r == 0.0 {
            return None;
        }
        Some((w.z as f64 / r, su / r, sc / r))
    }

    /// Smith Λ of the Gaussian slopes (what the sampler's pdf uses): (φ(a) − a Q(a))/a.
    pub fn lambda_gauss(&self, w: Vec3) -> f32 {
        if w.z == 0.0 {
            return f32::INFINITY;
        }
        let Some((a, _, _)) = self.view(w) else { return 0.0 };
        if a > 30.0 {
            return 0.0;
        }
        let q = 0.5 * erfc(a * FRAC_1_SQRT_2);
        ((npdf(a) - a * q) / a).max(0.0) as f32
    }

    /// Smith Λ(ω) of the Gram–Charlier-corrected slopes, so that masking matches [`Self::d`].
    /// The standardised slope x along ω's azimuth has the density φ(x)(1 + κ₃/6 He₃(x) +
    /// κ₄/24 He₄(x)), with κ₃ = −(A³c₀₃ + 3AB²c₂₁) and κ₄ = A⁴c₀₄ + 6A²B²c₂₂ + B⁴c₄₀, and
    /// Λ = (1/a)∫ₐ^∞ (x − a) p(x) dx = (φ(a)(1 + κ₃a/6 + κ₄(a² − 1)/24) − a Q(a))/a, using
    /// ∫ₐ^∞ (x − a) Heₙ(x) φ(x) dx = Heₙ₋₂(a) φ(a). ω below the surface is seen from −ω (so Λ
    /// is not even in ω: upwind and downwind views differ). Clamped at zero where the series'
    /// negative tail would make it negative.
    pub fn lambda(&self, w: Vec3) -> f32 {
        if w.z == 0.0 {
            return f32::INFINITY;
        }
        let Some((a, ca, cb)) = self.view(w) else { return 0.0 };
        if a > 30.0 {
            return 0.0;
        }
        let (c03, c21) = (self.c03 as f64, self.c21 as f64);
        let k3 = -(ca * ca * ca * c03 + 3.0 * ca * cb * cb * c21);
        let (a2, b2) = (ca * ca, cb * cb);
        let k4 = a2 * a2 * C04 as f64 + 6.0 * a2 * b2 * C22 as f64 + b2 * b2 * C40 as f64;
        let q = 0.5 * erfc(a * FRAC_1_SQRT_2);
        let series = npdf(a) * (1.0 + k3 * a / 6.0 + k4 * (a * a - 1.0) / 24.0);
        ((series - a * q) / a).max(0.0) as f32
    }

    /// Masking G₁(ω) of the corrected slopes.
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Masking G₁(ω) of the Gaussian slopes.
    #[inline]
    pub fn g1_gauss(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda_gauss(w))
    }

    /// Height-correlated masking–shadowing G₂(ωo, ωi) of the corrected slopes.
    #[inline]
    pub fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Density of the Gaussian normals visible from ω (either side; seen from −ω when below):
    /// G₁(ω)/|cosθ| · D(m) · max(0, ±ω·m). The pdf of [`Self::sample_visible`].
    #[inline]
    pub fn pdf_visible(&self, w: Vec3, m: Vec3) -> f32 {
        let c = w.z.abs();
        if c == 0.0 {
            return 0.0;
        }
        self.g1_gauss(w) / c * self.d_gauss(m) * (w.dot(m) * w.z.signum()).max(0.0)
    }

    /// Samples a Gaussian normal visible from ω (ω on either side; the normal is upward). In
    /// slopes standardised by σ the visible density is ∝ (a − s₁)⁺ φ(s₁) φ(s₂) with s₁ along
    /// the stretched view azimuth and a = cosθ/|σ ⊙ ω_t|; s₁ inverts the CDF
    /// (Φ(s₁) + φ(s₁)/a) / (Φ(a) + φ(a)/a), s₂ = Φ⁻¹(u₂).
    pub fn sample_visible(&self, w: Vec3, u: Vec2) -> Vec3 {
        let w = if w.z < 0.0 { -w } else { w };
        let (su, sc) = self.stretched_tangent(w);
        let r = (su * su + sc * sc).sqrt();
        let z = w.z as f64;
        let u1 = (u.x as f64).clamp(1e-12, 1.0 - 1e-12);
        let u2 = (u.y as f64).clamp(1e-12, 1.0 - 1e-12);
        let (e_u, e_c, s1) = if r <= 1e-12 * z {
            (1.0, 0.0, probit(u1))
        } else {
            let a = z / r;
            let s1 = if a > 30.0 {
                probit(u1)
            } else {
                let inv_a = 1.0 / a;
                let h = |x: f64| ncdf(x) + npdf(x) * inv_a;
                let dh = |x: f64| npdf(x) * (a - x) * inv_a;
                let target = u1 * h(a);
                invert_monotone(h, dh, target, -9.0, a.min(9.0), probit_guess(u1).min(a))
            };
            (su / r, sc / r, s1)
        };
        let s2 = probit(u2);
        // standardised slopes in wind axes, then physical slopes
        let eta = s1 * e_u - s2 * e_c;
        let xi = s1 * e_c + s2 * e_u;
        self.normal((eta * self.sigma_up as f64) as f32, (xi * self.sigma_cross as f64) as f32)
    }
}

/// Relative IORs (n_water / n_air) for which the lobe carries its multiple-scattering
/// compensation: the tabulated water range widened by what clamping to it misstates by less
/// than the tables' own accuracy; outside it (a sea surface under some other medium) the lobe
/// stays single scattering rather than compensate by a loss it does not have.
pub const COMPENSATED_ETA: (f32, f32) = (1.25, 1.45);

/// Multiple-scattering compensation of the sea lobe (Kulla & Conty 2017, dielectric form): a
/// cosine lobe on each side whose value factors as (1 − E(ωo))(1 − E(ωi)), E the tabulated
/// single-scattering albedo, so that it is symmetric and integrates to the missing 1 − E(ωo).
#[derive(Clone, Copy, Debug)]
struct SeaMs {
    key: SeaAlbedoKey,
    /// Fractions of the missing energy that are transmitted, seen from the air and the water.
    t_above: f32,
    t_below: f32,
    /// 1 − E_avg on each side.
    loss_above: f32,
    loss_below: f32,
}

/// The sea-surface BSDF lobe; `eta` = n_below / n_above.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SeaSurface {
    pub eta: f32,
    pub slopes: CoxMunk,
    ms: Option<SeaMs>,
}

impl SeaSurface {
    pub fn new(eta: f32, slopes: CoxMunk) -> Self {
        let mut s = SeaSurface { eta, slopes, ms: None };
        if !s.is_index_matched() && (COMPENSATED_ETA.0..=COMPENSATED_ETA.1).contains(&eta) {
            let key = sea_albedo::key(&slopes, eta);
            let loss_above = 1.0 - sea_albedo::albedo_avg(&key, true);
            let loss_below = 1.0 - sea_albedo::albedo_avg(&key, false);
            if loss_above > 1e-6 && loss_below > 1e-6 {
                // Seen from the air, the missing energy splits like the light a smooth surface
                // passes (1 − F_avg). The transmitted parts must be reciprocal with the η²
                // factor: t_above / (η² loss_below) = t_below / loss_above, which fixes the
                // share seen from the water (there, total internal reflection keeps most of it
                // on the water side).
                let ratio = loss_above / (eta * eta * loss_below);
                let mut t_above = 1.0 - sea_albedo::fresnel_avg(&key);
                let mut t_below = t_above * ratio;
                if t_below > 1.0 {
                    t_below = 1.0;
                    t_above = 1.0 / ratio;
                }
                s.ms = Some(SeaMs { key, t_above, t_below, loss_above, loss_below });
            }
        }
        s
    }

    /// An index-matched interface does not bend light: it is a specular pass-through.
    #[inline]
    pub fn is_index_matched(&self) -> bool {
        (self.eta - 1.0).abs() < 1e-4
    }

    #[inline]
    pub fn lobe_flags(&self) -> u8 {
        if self.is_index_matched() {
            flags::SPECULAR_TRANSMISSION
        } else {
            flags::REFLECTION | flags::TRANSMISSION | flags::GLOSSY
        }
    }

    fn f_ss(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> f32 {
        super::lobes::rough_dielectric_f(&self.slopes, self.eta, wo, wi, mode)
    }

    fn pdf_ss(&self, wo: Vec3, wi: Vec3) -> f32 {
        super::lobes::rough_dielectric_pdf(&self.slopes, self.eta, wo, wi)
    }

    /// Tabulated single-scattering albedo seen from ω.
    #[inline]
    fn albedo_ss(&self, key: &SeaAlbedoKey, w: Vec3) -> f32 {
        let (u, c) = self.slopes.wind_components(w);
        sea_albedo::albedo(key, w.z > 0.0, w.z.abs(), c.abs().atan2(u))
    }

    /// The compensation lobe's value (no cosine).
    fn f_ms(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> f32 {
        match &self.ms {
            Some(ms) => self.f_ms_with(ms, self.p_ms(wo), wo, wi, mode),
            None => 0.0,
        }
    }

    /// [`Self::f_ms`] given the missing energy `lo` = 1 − E(ωo).
    #[inline]
    fn f_ms_with(&self, ms: &SeaMs, lo: f32, wo: Vec3, wi: Vec3, mode: TransportMode) -> f32 {
        if wo.z == 0.0 || wi.z == 0.0 {
            return 0.0;
        }
        let (above_o, above_i) = (wo.z > 0.0, wi.z > 0.0);
        let li = (1.0 - self.albedo_ss(&ms.key, wi)).clamp(0.0, 1.0);
        let loss_i = if above_i { ms.loss_above } else { ms.loss_below };
        let t = if above_o { ms.t_above } else { ms.t_below };
        let base = lo * li * INV_PI / loss_i;
        if above_o == above_i {
            (1.0 - t) * base
        } else {
            let etap = if above_o { self.eta } else { 1.0 / self.eta };
            match mode {
                TransportMode::Radiance => t * base / (etap * etap),
                TransportMode::Importance => t * base,
            }
        }
    }

    /// Probability of sampling the compensation lobe: its share 1 − E(ωo) of the energy.
    #[inline]
    fn p_ms(&self, wo: Vec3) -> f32 {
        match &self.ms {
            Some(ms) => (1.0 - self.albedo_ss(&ms.key, wo)).clamp(0.0, 1.0),
            None => 0.0,
        }
    }

    pub fn f(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> SampledSpectrum {
        if self.is_index_matched() {
            return SampledSpectrum::ZERO;
        }
        SampledSpectrum::splat(self.f_ss(wo, wi, mode) + self.f_ms(wo, wi, mode))
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.is_index_matched() || wo.z == 0.0 || wi.z == 0.0 {
            return 0.0;
        }
        let Some(ms) = &self.ms else { return self.pdf_ss(wo, wi) };
        self.pdf_with(ms, self.p_ms(wo), wo, wi)
    }

    /// [`Self::pdf`] of the compensated lobe given p_ms(ωo).
    #[inline]
    fn pdf_with(&self, ms: &SeaMs, p_ms: f32, wo: Vec3, wi: Vec3) -> f32 {
        let t = if wo.z > 0.0 { ms.t_above } else { ms.t_below };
        let side = if wo.z * wi.z > 0.0 { 1.0 - t } else { t };
        (1.0 - p_ms) * self.pdf_ss(wo, wi) + p_ms * side * wi.z.abs() * INV_PI
    }

    pub fn sample_f(&self, wo: Vec3, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        if self.is_index_matched() {
            let wi = -wo;
            return Some(BsdfSample {
                f: SampledSpectrum::splat(1.0 / wi.z.abs()),
                wi,
                pdf: 1.0,
                flags: flags::SPECULAR_TRANSMISSION,
                eta: 1.0,
            });
        }
        let p_ms = self.p_ms(wo);
        let wi = if uc < p_ms {
            // the compensation lobe: cosine-distributed on the side chosen by its split
            let ms = self.ms.as_ref()?;
            let t = if wo.z > 0.0 { ms.t_above } else { ms.t_below };
            let d = sample_cosine_hemisphere(u);
            let reflect = uc / p_ms >= t;
            let z = if reflect == (wo.z > 0.0) { d.z } else { -d.z };
            Vec3::new(d.x, d.y, z)
        } else {
            let uc = ((uc - p_ms) / (1.0 - p_ms)).min(1.0 - f32::EPSILON);
            super::lobes::scatter_at_facet(wo, self.slopes.sample_visible(wo, u), self.eta, uc)?
        };
        if wi.z == 0.0 {
            return None;
        }
        // E(ωo) is looked up once for the pdf and the value
        let Some(ms) = &self.ms else {
            return super::lobes::glossy_dielectric_sample(wo, wi, self.eta, self.pdf_ss(wo, wi), || self.f(wo, wi, mode));
        };
        let pdf = self.pdf_with(ms, p_ms, wo, wi);
        super::lobes::glossy_dielectric_sample(wo, wi, self.eta, pdf, || {
            SampledSpectrum::splat(self.f_ss(wo, wi, mode) + self.f_ms_with(ms, p_ms, wo, wi, mode))
        })
    }
}

#[cfg(test)]
mod tests {
    //! χ² of the sampler against its pdf, slope statistics against Cox–Munk, reciprocity,
    //! white furnace (single scattering and compensated), the compensation's normalisation and
    //! the calm-water Fresnel limit.

    use super::*;
    use crate::bsdf::{fresnel_dielectric, Bsdf, Model};
    use crate::math;
    use crate::testing::chi2::{chi2_sphere, Chi2Config, TestRng};

    /// Number of χ² tests in this module, for the Šidák correction of the significance level.
    const N_CHI2: usize = 44;
    /// Family-wise significance of the χ² tests.
    const ALPHA: f64 = 0.01;
    const WINDS: [f32; 4] = [2.0, 5.0, 10.0, 15.0];
    /// Wind direction used in most tests: oblique to the plane of incidence (xz).
    const WIND_DIR: f32 = 0.5;
    const WATER: f32 = 1.333;

    fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
        let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
        Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
    }

    fn rng_u(rng: &mut TestRng) -> (f32, Vec2) {
        (rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32()))
    }

    /// The χ² harness bins in (cosθ, φ) about its own pole; the sea lobes are narrow and lie
    /// near the local ±Z poles and in the plane of incidence (xz), so the harness is given
    /// directions rotated to put its pole on the local +Y axis: the lobes then lie on its
    /// equator, where its cells and quadrature are finest in angle.
    #[inline]
    fn to_harness(d: Vec3) -> Vec3 {
        Vec3::new(d.x, d.z, -d.y)
    }
    #[inline]
    fn from_harness(d: Vec3) -> Vec3 {
        Vec3::new(d.x, -d.z, d.y)
    }

    /// 20×40 cells; 32² quadrature points per cell resolve the narrowest lobe tested (the
    /// transmitted lobe at U = 2 m/s, about 0.02 rad wide) with at least 3 points per σ.
    fn chi2_cfg() -> Chi2Config {
        Chi2Config { theta_res: 20, phi_res: 40, samples: 100_000, quad_res: 32, ..Chi2Config::default() }
    }

    fn check_chi2(b: &Bsdf, wo: Vec3, mode: TransportMode, name: &str) {
        let r = chi2_sphere(
            chi2_cfg(),
            |rng| {
                let (uc, u) = rng_u(rng);
                b.sample_f(wo, uc, u, mode).map(|s| to_harness(s.wi))
            },
            |d| b.pdf(wo, from_harness(d), mode),
        );
        assert!(r.passed(ALPHA, N_CHI2), "{name}: wo {wo:?}: {r:?}");
        // The success rate is a binomial proportion over 1e5 trials (σ ≤ 1.6e-3) and the
        // quadrature of the pdf is accurate to about 1e-4: 6e-3 is about 4σ.
        assert!(
            (r.pdf_integral - r.success_rate).abs() < 6e-3,
            "{name}: wo {wo:?}: ∫pdf = {} but success rate = {}",
            r.pdf_integral,
            r.success_rate
        );
    }

    fn chi2_wind(wind: f32) {
        let b = Bsdf::sea(WATER, wind, WIND_DIR).unwrap();
        let mut k = 0;
        for (theta, mode) in [(0.0, TransportMode::Radiance), (45.0, TransportMode::Importance), (80.0, TransportMode::Radiance), (88.0, TransportMode::Radiance)] {
            for wo in [dir(theta, 0.0), dir(180.0 - theta, 0.0)] {
                check_chi2(&b, wo, mode, &format!("U {wind} θ {theta} #{k}"));
                k += 1;
            }
        }
    }

    #[test]
    fn chi2_wind_2() {
        chi2_wind(2.0);
    }
    #[test]
    fn chi2_wind_5() {
        chi2_wind(5.0);
    }
    #[test]
    fn chi2_wind_10() {
        chi2_wind(10.0);
    }
    #[test]
    fn chi2_wind_15() {
        chi2_wind(15.0);
    }

    /// The visible-normal sampler alone against its pdf, at grazing and oblique views.
    #[test]
    fn chi2_visible_normals() {
        for (wind, theta) in [(5.0f32, 60.0f32), (15.0, 89.0), (2.0, 120.0), (10.0, 95.0)] {
            let cm = CoxMunk::new(wind, WIND_DIR).unwrap();
            let w = dir(theta, 20.0);
            let r = chi2_sphere(
                chi2_cfg(),
                |rng| Some(to_harness(cm.sample_visible(w, Vec2::new(rng.next_f32(), rng.next_f32())))),
                |d| cm.pdf_visible(w, from_harness(d)),
            );
            assert!(r.passed(ALPHA, N_CHI2), "U {wind} θ {theta}: {r:?}");
            // the sampler never fails: ∫pdf = 1 up to the quadrature error (about 1e-4; the
            // density integrated is G₁/cosθ·D·(ω·m)⁺, so this also checks Λ against D)
            assert!((r.pdf_integral - 1.0).abs() < 2e-3, "U {wind} θ {theta}: ∫pdf = {}", r.pdf_integral);
        }
    }

    /// Sampled directions return exactly what f() and pdf() give.
    #[test]
    fn sample_matches_eval() {
        let mut rng = TestRng::new(11);
        for wind in WINDS {
            let b = Bsdf::sea(WATER, wind, WIND_DIR).unwrap();
            for wo in [dir(30.0, 10.0), dir(85.0, 100.0), dir(150.0, 40.0), dir(93.0, 0.0)] {
                for mode in [TransportMode::Radiance, TransportMode::Importance] {
                    for _ in 0..500 {
                        let (uc, u) = rng_u(&mut rng);
                        let Some(s) = b.sample_f(wo, uc, u, mode) else { continue };
                        assert!(s.f.is_finite() && s.pdf.is_finite() && s.pdf > 0.0, "{s:?}");
                        let (f, pdf) = (b.f(wo, s.wi, mode), b.pdf(wo, s.wi, mode));
                        // the same code on both paths, up to the order of float operations
                        assert!((pdf - s.pdf).abs() <= 1e-4 * pdf.max(1.0), "pdf {pdf} vs sampled {}", s.pdf);
                        assert!((f[0] - s.f[0]).abs() <= 1e-4 * f[0].max(1.0), "f {f:?} vs sampled {:?}", s.f);
                        let refl = s.wi.z * wo.z > 0.0;
                        assert_eq!(s.is_transmission(), !refl);
                    }
                }
            }
        }
    }

    /// Normals sampled as seen from the zenith follow the projected-area slope distribution
    /// itself, so their slope variances must be Cox–Munk's; from an oblique view, weighting each
    /// normal by cosθm cosθo / (G₁ ωo·m) undoes the visibility and must give the same (and a
    /// mean weight of 1).
    #[test]
    fn sampled_slope_variance_is_cox_munk() {
        let n = 100_000;
        for wind in WINDS {
            let cm = CoxMunk::new(wind, WIND_DIR).unwrap();
            let (vu, vc) = CoxMunk::variances(wind);
            for wo in [Vec3::Z, dir(60.0, 70.0)] {
                let g1 = cm.g1_gauss(wo);
                let mut rng = TestRng::new(5);
                let (mut sw, mut su, mut sc, mut su2, mut sc2, mut sw2) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
                for _ in 0..n {
                    let m = cm.sample_visible(wo, Vec2::new(rng.next_f32(), rng.next_f32()));
                    let (zu, zc) = cm.slopes(m);
                    let w = (m.z * wo.z / (g1 * wo.dot(m))) as f64;
                    let (a, c) = (w * (zu * zu) as f64, w * (zc * zc) as f64);
                    sw += w;
                    sw2 += w * w;
                    su += a;
                    sc += c;
                    su2 += a * a;
                    sc2 += c * c;
                }
                let nf = n as f64;
                let se = |s: f64, s2: f64| ((s2 / nf - (s / nf).powi(2)).max(0.0) / nf).sqrt();
                let (mu, mc, mw) = (su / nf, sc / nf, sw / nf);
                // 3 standard errors of each Monte Carlo mean
                assert!((mw - 1.0).abs() <= 3.0 * se(sw, sw2) + 1e-6, "U {wind} wo {wo:?}: mean weight {mw}");
                assert!((mu - vu as f64).abs() <= 3.0 * se(su, su2), "U {wind} wo {wo:?}: σ²_up {mu} vs {vu}");
                assert!((mc - vc as f64).abs() <= 3.0 * se(sc, sc2), "U {wind} wo {wo:?}: σ²_cross {mc} vs {vc}");
            }
        }
    }

    /// A variance scale multiplies both slope variances of the evaluated (Gram–Charlier
    /// corrected) density — the second moments the BSDF carries are scale·Cox–Munk — until the
    /// floor; the lobe keeps its shape and the sampler still matches the pdf; scale 1 is `new`.
    #[test]
    fn variance_scale_scales_the_slope_variances() {
        for wind in [2.0f32, 5.0, 10.0] {
            let (vu, vc) = CoxMunk::variances(wind);
            let full = CoxMunk::new(wind, WIND_DIR).unwrap();
            assert_eq!(CoxMunk::with_variance_scale(wind, WIND_DIR, 1.0).unwrap(), full);
            for scale in [0.6f32, 0.35] {
                let cm = CoxMunk::with_variance_scale(wind, WIND_DIR, scale).unwrap();
                // second moments of the density with the unclamped series (the clamped tail,
                // < 1e-3 of the mass, is bounded in gram_charlier_density_and_smith_lambda_agree)
                let (mu, _) = slope_quadrature(&cm, |u, _| u * u);
                let (mc, _) = slope_quadrature(&cm, |_, c| c * c);
                let (mu, mc) = (mu - clamp_moment(&cm, |u, _| u * u), mc - clamp_moment(&cm, |_, c| c * c));
                // the Gram–Charlier terms have no second moment, so these are the Gaussian's
                // σ², stored as f32 σ (2.4e-7 relative), by a quadrature exact to ~1e-12
                let tol = |v: f64| v * 1e-5;
                let (eu, ec) = (scale as f64 * vu as f64, scale as f64 * vc as f64);
                assert!((mu - eu).abs() <= tol(eu), "U {wind} scale {scale}: σ²_up {mu} vs {eu}");
                assert!((mc - ec).abs() <= tol(ec), "U {wind} scale {scale}: σ²_cross {mc} vs {ec}");
                assert_eq!((cm.c21, cm.c03), (full.c21, full.c03));
            }
        }
        // a vanishing share floors at the calm-water lobe
        let calm = CoxMunk::with_variance_scale(10.0, 0.0, 0.0).unwrap();
        assert_eq!((calm.sigma_up, calm.sigma_cross), (MIN_SLOPE_VARIANCE.sqrt() as f32, MIN_SLOPE_VARIANCE.sqrt() as f32));
        // the scaled BSDF still samples what it evaluates
        let b = Bsdf::sea_scaled(WATER, 10.0, WIND_DIR, 0.4).unwrap();
        check_chi2(&b, dir(45.0, 0.0), TransportMode::Radiance, "U 10 scale 0.4");
        assert_eq!(Bsdf::sea_scaled(WATER, 5.0, 0.0, f32::NAN).unwrap_err(), BsdfError::NotFinite { parameter: "slopeVarianceScale" });
        assert!(matches!(Bsdf::sea_scaled(WATER, 5.0, 0.0, -0.1), Err(BsdfError::OutOfRange { parameter: "slopeVarianceScale", .. })));
    }

    /// Midpoint quadrature over standardised slopes (ξ, η) ∈ [−10, 10]² of g(ζ_up, ζ_cross)
    /// times the clamped Gram–Charlier density; and the mass the clamping added.
    fn slope_quadrature(cm: &CoxMunk, g: impl Fn(f64, f64) -> f64) -> (f64, f64) {
        let n = 800;
        let h = 20.0 / n as f64;
        let (mut acc, mut clamped) = (0.0, 0.0);
        for i in 0..n {
            let eta = -10.0 + (i as f64 + 0.5) * h;
            for j in 0..n {
                let xi = -10.0 + (j as f64 + 0.5) * h;
                let phi = (-0.5 * (xi * xi + eta * eta)).exp() / (2.0 * std::f64::consts::PI);
                let gc = cm.gram_charlier(xi as f32, eta as f32) as f64;
                let raw = phi * h * h;
                acc += raw * gc * g(eta * cm.sigma_up as f64, xi * cm.sigma_cross as f64);
                // the unclamped series is linear in the coefficients: recover its value where
                // the clamp acted from the (zero-mean) series itself
                if gc == 0.0 {
                    clamped -= raw * gc_raw(cm, xi, eta);
                }
            }
        }
        (acc, clamped)
    }

    /// What the clamp adds to ∫ g p: the quadrature of g times the clamped-away negative series.
    fn clamp_moment(cm: &CoxMunk, g: impl Fn(f64, f64) -> f64) -> f64 {
        let n = 800;
        let h = 20.0 / n as f64;
        let mut acc = 0.0;
        for i in 0..n {
            let eta = -10.0 + (i as f64 + 0.5) * h;
            for j in 0..n {
                let xi = -10.0 + (j as f64 + 0.5) * h;
                if cm.gram_charlier(xi as f32, eta as f32) == 0.0 {
                    let phi = (-0.5 * (xi * xi + eta * eta)).exp() / (2.0 * std::f64::consts::PI);
                    acc -= phi * h * h * gc_raw(cm, xi, eta) * g(eta * cm.sigma_up as f64, xi * cm.sigma_cross as f64);
                }
            }
        }
        acc
    }

    fn gc_raw(cm: &CoxMunk, xi: f64, eta: f64) -> f64 {
        let (x2, e2) = (xi * xi, eta * eta);
        let (c21, c03) = (cm.c21 as f64, cm.c03 as f64);
        1.0 - 0.5 * c21 * (x2 - 1.0) * eta - c03 / 6.0 * (e2 * eta - 3.0 * eta)
            + C40 as f64 / 24.0 * (x2 * x2 - 6.0 * x2 + 3.0)
            + 0.25 * C22 as f64 * (x2 - 1.0) * (e2 - 1.0)
            + C04 as f64 / 24.0 * (e2 * e2 - 6.0 * e2 + 3.0)
    }

    /// The corrected slope density integrates to one with zero mean, the clamped mass stays
    /// below the documented 10⁻³, and the closed-form Λ matches its definition
    /// ∫ (ζ·ω_t − cosθ)⁺ p(ζ) dζ = cosθ Λ(ω) by brute-force quadrature, from either side and
    /// for up-, down- and cross-wind views.
    #[test]
    fn gram_charlier_density_and_smith_lambda_agree() {
        for wind in [0.0f32, 5.0, 15.0, 40.0] {
            let cm = CoxMunk::new(wind, WIND_DIR).unwrap();
            let (norm, clamped) = slope_quadrature(&cm, |_, _| 1.0);
            // midpoint quadrature of a Gaussian times a polynomial with 40 points per σ is
            // exact to ~1e-12; the clamp adds exactly `clamped`
            assert!((norm - 1.0 - clamped).abs() < 1e-6, "U {wind}: ∫p = {norm}, clamped {clamped}");
            assert!(clamped < 1e-3, "U {wind}: clamped mass {clamped}");
            let (mean_up, _) = slope_quadrature(&cm, |u, _| u);
            assert!(mean_up.abs() < 1e-3 * cm.sigma_up as f64 + clamped, "U {wind}: mean slope {mean_up}");
            for theta in [20.0f32, 60.0, 80.0, 88.0, 100.0, 150.0] {
                for phi in [0.0f32, 28.6, 90.0, 180.0, 250.0] {
                    let w = dir(theta, phi);
                    let v = if w.z < 0.0 { -w } else { w };
                    let (tu, tc) = cm.to_wind(v.x, v.y);
                    let (tu, tc, z) = (tu as f64, tc as f64, v.z as f64);
                    let (q, _) = slope_quadrature(&cm, |u, c| (u * tu + c * tc - z).max(0.0));
                    let lam = cm.lambda(w) as f64;
                    // the closed form neglects only the clamped mass (weighted by a slope
                    // difference below 10σ ≈ 2.2) and f32 rounding
                    let tol = 1e-4 * (1.0 + lam) + 3.0 * clamped / z;
                    assert!((q / z - lam).abs() < tol, "U {wind} θ {theta} φ {phi}: quadrature {} vs Λ {lam}", q / z);
                }
            }
        }
    }

    #[test]
    fn reflection_is_reciprocal() {
        let mut rng = TestRng::new(3);
        for wind in WINDS {
            let b = Bsdf::sea(WATER, wind, WIND_DIR).unwrap();
            let mut checked = 0;
            for _ in 0..2000 {
                let wo = math::sample_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                // directions near the mirror direction, where f is not negligible
                let d = math::sample_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let wi = (Vec3::new(-wo.x, -wo.y, wo.z) + 0.3 * d).normalize();
                if wi.z * wo.z <= 0.0 {
                    continue;
                }
                let a = b.f(wo, wi, TransportMode::Radiance)[0];
                let c = b.f(wi, wo, TransportMode::Radiance)[0];
                // the same expression with arguments swapped: float rounding only
                assert!((a - c).abs() <= 1e-4 * a.abs().max(1e-3), "U {wind}: {a} vs {c}");
                checked += (a > 1e-3) as usize;
            }
            assert!(checked > 200, "U {wind}: only {checked} nonzero pairs");
        }
    }

    /// f_radiance(ωo, ωi) = f_importance(ωi, ωo) for transmission.
    #[test]
    fn transmission_is_adjoint_reciprocal() {
        let mut rng = TestRng::new(4);
        for wind in WINDS {
            let b = Bsdf::sea(WATER, wind, WIND_DIR).unwrap();
            let mut checked = 0;
            for _ in 0..4000 {
                let wo = math::sample_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let (uc, u) = rng_u(&mut rng);
                // a transmitted direction from the sampler, jittered
                let Some(s) = b.sample_f(wo, uc, u, TransportMode::Radiance) else { continue };
                if !s.is_transmission() {
                    continue;
                }
                let wi = s.wi;
                let a = b.f(wo, wi, TransportMode::Radiance)[0];
                let c = b.f(wi, wo, TransportMode::Importance)[0];
                // the two directions use different (cancelling) half-vector denominators:
                // relative rounding of a few 1e-4 in f32 at grazing angles
                assert!((a - c).abs() <= 1e-3 * a.abs().max(1e-3), "U {wind} wo {wo:?} wi {wi:?}: {a} vs {c}");
                checked += (a > 0.0) as usize;
            }
            assert!(checked > 1000, "U {wind}: only {checked} transmitted pairs");
        }
    }

    /// Monte Carlo directional albedo ∫(f_r + f_t)|cosθi| dωi in importance mode (no η²
    /// radiance scaling, so a lossless interface gives 1), with its standard error; also the
    /// reflected part alone.
    fn furnace(b: &Bsdf, wo: Vec3, n: usize) -> (f64, f64, f64) {
        furnace_seeded(b, wo, n, 1234)
    }

    /// [`furnace`] with the random sequence of `seed`.
    fn furnace_seeded(b: &Bsdf, wo: Vec3, n: usize, seed: u64) -> (f64, f64, f64) {
        let mut rng = TestRng::new(seed);
        let (mut sum, mut sum2, mut refl) = (0.0f64, 0.0f64, 0.0f64);
        for _ in 0..n {
            let (uc, u) = rng_u(&mut rng);
            if let Some(s) = b.sample_f(wo, uc, u, TransportMode::Importance) {
                let w = (s.f[0] * s.wi.z.abs() / s.pdf) as f64;
                sum += w;
                sum2 += w * w;
                if !s.is_transmission() {
                    refl += w;
                }
            }
        }
        let nf = n as f64;
        let mean = sum / nf;
        (mean, ((sum2 / nf - mean * mean).max(0.0) / nf).sqrt(), refl / nf)
    }

    /// The sea lobe without its compensation.
    fn single_scattering(wind: f32) -> Bsdf {
        let lobe = SeaSurface { eta: WATER, slopes: CoxMunk::new(wind, WIND_DIR).unwrap(), ms: None };
        Bsdf { model: crate::bsdf::Model::Sea(lobe) }
    }

    /// The single-scattering lobe never gains: ∫(f_r + f_t)|cosθi| ≤ 1 + 3σ, for every wind (up
    /// to the largest accepted), both sides, normal to grazing views and two azimuths to the wind.
    fn white_furnace_never_gains(winds: &[f32]) {
        for &wind in winds {
            let b = single_scattering(wind);
            for t in [0.0f32, 45.0, 75.0, 85.0, 89.0] {
                for phi in [0.0f32, 200.0] {
                    for wo in [dir(t, phi), dir(180.0 - t, phi)] {
                        let (m, s, _) = furnace(&b, wo, 20_000);
                        assert!(m <= 1.0 + 3.0 * s, "U {wind} wo {wo:?}: albedo {m} ± {s}");
                        // and the loss stays within what the module documents (the largest, 27%,
                        // is seen from the water at U = 40 m/s)
                        assert!(m > 0.70, "U {wind} wo {wo:?}: albedo {m} ± {s}");
                    }
                }
            }
        }
    }

    #[test]
    fn white_furnace_calm_to_moderate() {
        white_furnace_never_gains(&[0.0, 2.0, 5.0]);
    }
    #[test]
    fn white_furnace_strong_wind() {
        white_furnace_never_gains(&[10.0, 15.0, 40.0]);
    }

    /// Reflected energy ∫f_r|cosθi| by sampling visible normals and always reflecting (the
    /// weight is then F·G₂/G₁ times the Gram–Charlier factor: low variance), with its standard
    /// error.
    fn reflected_energy(wind: f32, wo: Vec3, n: usize) -> (f64, f64) {
        let b = Bsdf::sea(WATER, wind, WIND_DIR).unwrap();
        let cm = CoxMunk::new(wind, WIND_DIR).unwrap();
        let mut rng = TestRng::new(77);
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let m = cm.sample_visible(wo, Vec2::new(rng.next_f32(), rng.next_f32()));
            let wr = crate::bsdf::microfacet::reflect(wo, m);
            if wr.z <= 0.0 {
                continue;
            }
            let pdf = cm.pdf_visible(wo, m) / (4.0 * wo.dot(m));
            let w = (b.f(wo, wr, TransportMode::Radiance)[0] * wr.z / pdf) as f64;
            sum += w;
            sum2 += w * w;
        }
        let mean = sum / n as f64;
        (mean, ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt())
    }

    /// Calm water approaches the smooth interface: the reflected energy tends to the Fresnel
    /// reflectance as the wind drops. U = 0 keeps Cox–Munk's residual σ² = 0.003 across the
    /// wind, so the limit is approached, not reached: within 1% of F (a spread of facet angles
    /// of 0.055 rad changes F by a few 1e-3 relative up to 70°), and the error shrinks with
    /// the wind wherever roughness matters (60°, 70°).
    #[test]
    fn calm_sea_reflects_like_fresnel() {
        for t in [0.0f32, 30.0, 60.0, 70.0] {
            let wo = dir(t, 0.0);
            let fresnel = fresnel_dielectric(wo.z, WATER) as f64;
            let mut errs = Vec::new();
            for wind in [10.0f32, 2.0, 0.0] {
                let (r, s) = reflected_energy(wind, wo, 50_000);
                errs.push(((r - fresnel).abs(), s));
            }
            let (e0, s0) = errs[2];
            assert!(e0 <= 0.01 * fresnel + 3.0 * s0, "θ {t}: calm R off Fresnel by {e0} (F {fresnel})");
            if t >= 60.0 {
                assert!(errs[0].0 > errs[1].0 && errs[1].0 > errs[2].0, "θ {t}: {errs:?}");
            }
        }
    }

    /// With the compensation the white furnace never reads above 1 and reads 1 within the
    /// tables' error from both sides, every wind, normal to grazing: the compensated albedo is
    /// E(ωo) + 1 − E_table(ωo), E_table the quadrature's albedo plus `TABLE_MARGIN`, so it reads
    /// 1 − TABLE_MARGIN − (E_quadrature − E). `report_table_error` measures that last error
    /// against a 2·10⁵-sample Monte Carlo furnace of the lobe (σ ≤ 10⁻³) over 7 winds × 16 polar
    /// angles × 4 azimuths: within ±3.3·10⁻³ for U ≥ 5 (the quadrature near the critical angle
    /// and the multilinear interpolation), so 6·10⁻³ here; calm water (U ≤ 2) within 6° of the
    /// horizon, where the albedo changes by 0.06 over 20° of azimuth between the 10° φ nodes,
    /// reaches 6.1·10⁻³, so 8·10⁻³ there. It never exceeds TABLE_MARGIN, hence no gain. Each
    /// Monte Carlo mean adds 3σ.
    fn white_furnace_reads_one(winds: &[f32]) {
        for &wind in winds {
            let b = Bsdf::sea(WATER, wind, WIND_DIR).unwrap();
            for t in [0.0f32, 45.0, 75.0, 85.0, 89.0] {
                for phi in [0.0f32, 200.0] {
                    for wo in [dir(t, phi), dir(180.0 - t, phi)] {
                        let (m, s, _) = furnace(&b, wo, 20_000);
                        let table = if wind <= 2.0 && t >= 84.0 { 8e-3 } else { 6e-3 };
                        let margin = sea_albedo::TABLE_MARGIN;
                        assert!(m <= 1.0 + 3.0 * s, "U {wind} wo {wo:?}: albedo {m} ± {s} gains");
                        assert!((m - (1.0 - margin)).abs() <= table + 3.0 * s, "U {wind} wo {wo:?}: albedo {m} ± {s}");
                    }
                }
            }
        }
    }

    #[test]
    fn compensated_furnace_calm_to_moderate() {
        white_furnace_reads_one(&[0.0, 2.0, 5.0]);
    }
    #[test]
    fn compensated_furnace_strong_wind() {
        white_furnace_reads_one(&[10.0, 15.0, 25.0, 40.0]);
    }

    /// A lobe with scaled slope variances is compensated from the nodes of its total σ, whose
    /// up/cross ratio and Gram–Charlier coefficients are those of another wind: the furnace
    /// (single-scattering Monte Carlo plus the compensation's exact 1 − E_table) then reads 1
    /// within 1.2·10⁻² at moderate scales — `report_scaled_furnace` measures at most 7·10⁻³ for
    /// scale 0.4 at 10 m/s and 3.4·10⁻³ for 0.5 at 40 m/s — plus 3σ of the Monte Carlo.
    #[test]
    fn scaled_lobe_is_compensated_from_its_total_sigma() {
        for (wind, scale) in [(10.0f32, 0.4f32), (40.0, 0.5)] {
            let b = Bsdf::sea_scaled(WATER, wind, WIND_DIR, scale).unwrap();
            let Model::Sea(lobe) = &b.model else { unreachable!() };
            for t in [60.0f32, 85.0] {
                for wo in [dir(t, 0.0), dir(180.0 - t, 200.0)] {
                    let (ss, s) = furnace_ss(WATER, lobe.slopes, wo, 20_000);
                    let total = ss + lobe.p_ms(wo) as f64;
                    let centre = 1.0 - sea_albedo::TABLE_MARGIN;
                    assert!((total - centre).abs() <= 1.2e-2 + 3.0 * s, "U {wind} scale {scale} wo {wo:?}: {total} ± {s}");
                }
            }
        }
    }

    /// The compensated sampler against its pdf at the strongest wind, grazing, from both sides
    /// (where the compensation lobe carries up to 30% of the energy).
    #[test]
    fn chi2_compensated_strong_wind() {
        let b = Bsdf::sea(WATER, 40.0, WIND_DIR).unwrap();
        for (k, wo) in [dir(75.0, 0.0), dir(105.0, 0.0), dir(85.0, 120.0), dir(93.0, 300.0)].into_iter().enumerate() {
            let Model::Sea(lobe) = &b.model else { unreachable!() };
            assert!(lobe.p_ms(wo) > 0.02, "#{k}: compensation share {}", lobe.p_ms(wo));
            check_chi2(&b, wo, TransportMode::Radiance, &format!("U 40 compensated #{k}"));
        }
    }

    /// The compensated f is reciprocal: reflection symmetric, transmission with the η² factor
    /// (f_radiance(ωo, ωi) = f_importance(ωi, ωo)), for direction pairs spread over the sphere
    /// (where the compensation lobe is most of f).
    #[test]
    fn compensation_is_reciprocal() {
        let mut rng = TestRng::new(21);
        for wind in [5.0f32, 40.0] {
            let b = Bsdf::sea(WATER, wind, WIND_DIR).unwrap();
            let Model::Sea(lobe) = &b.model else { unreachable!() };
            let mut checked = 0;
            for _ in 0..400 {
                let wo = math::sample_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let wi = math::sample_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                let ms = lobe.f_ms(wo, wi, TransportMode::Radiance);
                let reflect = wo.z * wi.z > 0.0;
                let (a, c) = if reflect {
                    (b.f(wo, wi, TransportMode::Radiance)[0], b.f(wi, wo, TransportMode::Radiance)[0])
                } else {
                    (b.f(wo, wi, TransportMode::Radiance)[0], b.f(wi, wo, TransportMode::Importance)[0])
                };
                // the compensation is the same products in another order; the single-scattering
                // transmission uses different (cancelling) half-vector denominators, a few 1e-4
                // relative in f32 (as in transmission_is_adjoint_reciprocal)
                let tol = if reflect { 1e-4 } else { 1e-3 };
                assert!((a - c).abs() <= tol * a.abs().max(1e-4), "U {wind} wo {wo:?} wi {wi:?}: {a} vs {c}");
                checked += (ms > 1e-4) as usize;
            }
            assert!(checked > 100, "U {wind}: only {checked} pairs with compensation");
        }
    }

    /// The compensation lobe carries exactly the energy the tables say is missing:
    /// ∫ f_ms(ωo, ωi)|cosθi| dωi = 1 − E(ωo) (importance mode), by a midpoint quadrature over
    /// both hemispheres in (√μ, φ) fine enough (a few 10⁻⁵) to check the tables' averages.
    #[test]
    fn compensation_integrates_to_the_missing_energy() {
        for wind in [2.0f32, 15.0, 40.0] {
            let b = Bsdf::sea(WATER, wind, WIND_DIR).unwrap();
            let Model::Sea(lobe) = &b.model else { unreachable!() };
            for wo in [dir(30.0, 10.0), dir(85.0, 200.0), dir(100.0, 70.0), dir(150.0, 300.0)] {
                let (nx, np) = (400, 256);
                let mut acc = 0.0f64;
                for i in 0..nx {
                    let x = (i as f64 + 0.5) / nx as f64;
                    let mu = x * x;
                    let st = (1.0 - mu * mu).sqrt();
                    for p in 0..np {
                        let phi = (p as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
                        for z in [mu, -mu] {
                            let wi = Vec3::new((st * phi.cos()) as f32, (st * phi.sin()) as f32, z as f32);
                            // dω = dμ dφ = 2x dx dφ
                            let dw = 2.0 * x / nx as f64 * std::f64::consts::TAU / np as f64;
                            acc += lobe.f_ms(wo, wi, TransportMode::Importance) as f64 * mu * dw;
                        }
                    }
                }
                let missing = lobe.p_ms(wo) as f64;
                assert!((acc - missing).abs() < 2e-4 * missing.max(0.01) + 1e-5, "U {wind} wo {wo:?}: ∫f_ms = {acc} vs 1 − E = {missing}");
            }
        }
    }

    /// The compensated white furnace of the full sampler (three seeds, 4·10⁵ samples each)
    /// against the single-scattering furnace plus the compensation's exact 1 − E_table(ωo).
    #[test]
    #[ignore]
    fn report_compensated_furnace() {
        for (wind, t, phi) in [(5.0f32, 85.0f32, 0.0f32), (5.0, 105.0, 0.0), (15.0, 135.0, 0.0), (40.0, 100.0, 200.0)] {
            let b = Bsdf::sea(WATER, wind, WIND_DIR).unwrap();
            let Model::Sea(lobe) = &b.model else { unreachable!() };
            let wo = dir(t, phi);
            let (ss, sss) = furnace_ss(WATER, lobe.slopes, wo, 400_000);
            let mut line = format!("U {wind} θ {t} φ {phi}: ss {ss:.4}±{sss:.4} + ms {:.4} = {:.4};", lobe.p_ms(wo), ss + lobe.p_ms(wo) as f64);
            for seed in [1u64, 2, 3] {
                let (m, se, _) = furnace_seeded(&b, wo, 400_000, seed);
                line += &format!(" full {m:.4}±{se:.4}");
            }
            println!("{line}");
        }
    }

    #[test]
    #[ignore]
    fn report_scaled_furnace() {
        let mut worst = (0.0f64, 0.0f64);
        for (wind, scale) in [(10.0f32, 0.4f32), (40.0, 0.1), (40.0, 0.5), (15.0, 0.02), (5.0, 0.7)] {
            let b = Bsdf::sea_scaled(WATER, wind, WIND_DIR, scale).unwrap();
            let Model::Sea(lobe) = &b.model else { unreachable!() };
            report_sweep(&format!("U {wind} scale {scale}:"), &[0.0, 60.0, 75.0, 85.0, 89.0], &[0.0, 90.0, 200.0], 3e-3, &mut worst, |wo| {
                let (ss, sss) = furnace_ss(WATER, lobe.slopes, wo, 100_000);
                (ss + lobe.p_ms(wo) as f64 - 1.0, sss)
            });
        }
        println!("compensated − 1: max {:+.4}, min {:+.4}", worst.0, worst.1);
    }

    /// Prints, after `label`, the deviations d of `measure(ωo)` = (d, its standard error) larger
    /// than `shown` over the polar angles `thetas` (and their mirror below the surface) and the
    /// azimuths `phis`, and widens `worst` = (max d, min d) by them all.
    fn report_sweep(label: &str, thetas: &[f32], phis: &[f32], shown: f64, worst: &mut (f64, f64), mut measure: impl FnMut(Vec3) -> (f64, f64)) {
        let mut line = label.to_string();
        for &t in thetas {
            for &phi in phis {
                for wo in [dir(t, phi), dir(180.0 - t, phi)] {
                    let (d, s) = measure(wo);
                    *worst = (worst.0.max(d), worst.1.min(d));
                    if d.abs() > shown {
                        line += &format!(" [{:.0} {phi}]:{d:+.4}±{s:.4}", wo.z.acos().to_degrees());
                    }
                }
            }
        }
        println!("{line}");
    }

    /// Tabulated single-scattering albedo against a Monte Carlo furnace of the lobe.
    #[test]
    #[ignore]
    fn report_table_error() {
        let mut worst = (0.0f64, 0.0f64);
        for wind in [0.0f32, 2.0, 5.0, 10.0, 15.0, 25.0, 40.0] {
            let cm = CoxMunk::new(wind, WIND_DIR).unwrap();
            let lobe = SeaSurface::new(WATER, cm);
            let Some(ms) = &lobe.ms else { continue };
            report_sweep(&format!("U {wind:4}:"), &[0.0, 45.0, 60.0, 75.0, 80.0, 85.0, 87.0, 89.0], &[0.0, 45.0, 90.0, 200.0], 1.5e-3, &mut worst, |wo| {
                let (m, s) = furnace_ss(WATER, cm, wo, 200_000);
                // the quadrature's albedo: the table less its margin (where below 1)
                let e = lobe.albedo_ss(&ms.key, wo) as f64;
                (m - if e < 1.0 { e - sea_albedo::TABLE_MARGIN } else { e }, s)
            });
        }
        println!("E_mc − E_table: max {:+.4}, min {:+.4}", worst.0, worst.1);
    }

    /// Calm water keeps its single-scattering lobe: at U = 0 the compensation carries less than
    /// 3·10⁻³ of the energy up to 60° from the normal on either side (the smooth interface is
    /// lossless there), and [`calm_sea_reflects_like_fresnel`] holds for the compensated lobe.
    #[test]
    fn calm_water_is_barely_compensated() {
        let b = Bsdf::sea(WATER, 0.0, WIND_DIR).unwrap();
        let Model::Sea(lobe) = &b.model else { unreachable!() };
        for t in [0.0f32, 30.0, 60.0] {
            for phi in [0.0f32, 45.0, 90.0, 180.0, 300.0] {
                for wo in [dir(t, phi), dir(180.0 - t, phi)] {
                    assert!(lobe.p_ms(wo) < 3e-3, "wo {wo:?}: share {}", lobe.p_ms(wo));
                }
            }
        }
        // no compensation outside water's IOR range, nor when index-matched
        let Model::Sea(l) = &Bsdf::sea(1.6, 10.0, 0.0).unwrap().model else { unreachable!() };
        assert!(l.ms.is_none());
    }

    #[test]
    fn bad_input_is_an_error() {
        assert_eq!(Bsdf::sea(f32::NAN, 5.0, 0.0).unwrap_err(), BsdfError::NotFinite { parameter: "eta" });
        assert!(matches!(Bsdf::sea(-1.0, 5.0, 0.0), Err(BsdfError::OutOfRange { parameter: "eta", .. })));
        assert_eq!(Bsdf::sea(1.33, f32::INFINITY, 0.0).unwrap_err(), BsdfError::NotFinite { parameter: "windSpeed" });
        assert!(matches!(Bsdf::sea(1.33, -1.0, 0.0), Err(BsdfError::OutOfRange { parameter: "windSpeed", .. })));
        assert!(matches!(Bsdf::sea(1.33, 41.0, 0.0), Err(BsdfError::OutOfRange { parameter: "windSpeed", .. })));
        assert_eq!(Bsdf::sea(1.33, 5.0, f32::NAN).unwrap_err(), BsdfError::NotFinite { parameter: "windDirection" });
        assert!(Bsdf::sea(1.33, 0.0, 7.0).is_ok());
        assert!(Bsdf::sea(1.33, MAX_WIND_SPEED, -3.0).is_ok());
    }

    #[test]
    fn index_matched_sea_passes_light_straight_through() {
        let b = Bsdf::sea(1.0, 10.0, 0.0).unwrap();
        assert_eq!(b.flags(), flags::SPECULAR_TRANSMISSION);
        let wo = dir(40.0, 30.0);
        let s = b.sample_f(wo, 0.5, Vec2::new(0.3, 0.7), TransportMode::Radiance).unwrap();
        assert!(s.is_specular() && (s.wi + wo).length() < 1e-6);
        assert!((s.f[0] * s.wi.z.abs() / s.pdf - 1.0).abs() < 1e-6);
        let b = Bsdf::sea(1.333, 10.0, 0.0).unwrap();
        assert_eq!(b.flags(), flags::REFLECTION | flags::TRANSMISSION | flags::GLOSSY);
        assert!(!b.is_specular());
    }

    /// Monte Carlo albedo of the single-scattering lobe alone (importance mode), ± its error.
    fn furnace_ss(eta: f32, cm: CoxMunk, wo: Vec3, n: usize) -> (f64, f64) {
        let lobe = SeaSurface { eta, slopes: cm, ms: None };
        let mut rng = TestRng::new(99);
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let (uc, u) = rng_u(&mut rng);
            if let Some(s) = lobe.sample_f(wo, uc, u, TransportMode::Importance) {
                let w = (s.f[0] * s.wi.z.abs() / s.pdf) as f64;
                sum += w;
                sum2 += w * w;
            }
        }
        let nf = n as f64;
        let mean = sum / nf;
        (mean, ((sum2 / nf - mean * mean).max(0.0) / nf).sqrt())
    }

    /// Albedo tables' quadrature against finer ones and Monte Carlo (what the furnace
    /// tolerance rests on).
    #[test]
    #[ignore]
    fn report_quadrature_convergence() {
        for (wind, t, phi) in [(15.0f32, 120.0f32, 180.0f32), (5.0, 120.0, 0.0), (40.0, 95.0, 0.0), (0.0, 85.0, 50.0), (15.0, 105.0, 180.0), (2.0, 89.0, 30.0), (25.0, 135.0, 60.0), (10.0, 0.0, 0.0), (10.0, 80.0, 90.0)] {
            let cm = CoxMunk::new(wind, 0.0).unwrap();
            let wo = dir(t, phi);
            let (m, s) = furnace_ss(WATER, cm, wo, 400_000);
            let mut line = format!("U {wind} θ {t} φ {phi}: mc {m:.4}±{s:.4}");
            for (p1, p2) in [(0, 7), (0, 6), (12, 8), (48, 32)] {
                let q = crate::bsdf::sea_albedo::sea_albedo_quadrature(&cm, WATER, wo, p1, p2);
                line += &format!(" {p1}x{p2}: {q:.5}");
            }
            println!("{line}");
        }
    }

    /// The single-scattering albedos the module documents.
    #[test]
    #[ignore]
    fn report_albedo() {
        for wind in [0.0f32, 2.0, 5.0, 10.0, 15.0, 25.0, 40.0] {
            let b = single_scattering(wind);
            let mut line = format!("U {wind:4}:");
            for t in [0.0f32, 60.0, 75.0, 85.0, 89.0, 180.0, 120.0, 105.0, 95.0, 91.0] {
                let (m, s, _) = furnace(&b, dir(t, 0.0), 100_000);
                line += &format!(" {t}:{m:.4}±{s:.4}");
            }
            println!("{line}");
        }
    }
}
