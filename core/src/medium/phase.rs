//! Phase functions of participating media: isotropic, Henyey–Greenstein, a two-lobe HG mixture
//! and a tabulated p(cosθ) (for measured functions such as Petzold's or Fournier–Forand).
//!
//! Direction convention (as in pbrt-v4): `wo` points *away* from the scattering point, back
//! towards where the path came from; `wi` is the direction the path continues in (also pointing
//! away from the point). The light/path therefore propagates along `-wo` before the event, the
//! scattering angle θ is the angle between `-wo` and `wi`, and forward scattering means
//! `wi ≈ -wo`. With μ = cosθ = dot(-wo, wi), a positive HG `g` favours μ → 1.
//!
//! Every phase function here is sampled exactly, so `eval(wo, wi) == pdf(wo, wi)` and the
//! sampling weight value/pdf is 1. Values are densities per steradian and integrate to 1.
//!
//! Near-forward and near-backward directions are handled through the quantities 1 − μ and
//! 1 + μ computed as |wo + wi|²/2 and |wi − wo|²/2, which keep their relative precision for
//! nearly (anti)parallel vectors where `1 − dot` would cancel; this matters for very peaked
//! lobes (g → 1, measured ocean phase functions).

use super::MediumError;
use crate::math::{safe_sqrt, spherical_direction, Frame, INV_4PI, PI};
use crate::scene::PhaseDesc;
use glam::{Vec2, Vec3};

/// Largest |g| used by Henyey–Greenstein: |g| in (G_MAX, 1] is clamped to it. At |g| = 1 HG
/// degenerates to a Dirac delta, which has no density; 0.9999 keeps the peak value (≈1.6e7 sr⁻¹)
/// and every intermediate of the sampling formula finite in f32.
pub const G_MAX: f32 = 0.9999;

/// A phase function. Cheap to evaluate; `Tabulated` owns its table.
#[derive(Clone, Debug, PartialEq)]
pub enum PhaseFunction {
    /// p = 1/(4π).
    Isotropic,
    /// Henyey–Greenstein with mean cosine `g` (construct with [`PhaseFunction::hg`]).
    HenyeyGreenstein { g: f32 },
    /// w·HG(g1) + (1−w)·HG(g2) (construct with [`PhaseFunction::dual_hg`]).
    DualHg { g1: f32, g2: f32, w: f32 },
    /// A tabulated p(cosθ), linearly interpolated in cosθ.
    Tabulated(TabulatedPhase),
}

/// The two measures of the angle between `-wo` and `wi` that stay precise near the poles:
/// `fwd` = 1 − μ and `back` = 1 + μ, both in [0, 2].
#[derive(Clone, Copy, Debug)]
struct Angle {
    fwd: f32,
    back: f32,
}

impl Angle {
    #[inline]
    fn between(wo: Vec3, wi: Vec3) -> Angle {
        let fwd = (0.5 * (wo + wi).length_squared()).clamp(0.0, 2.0);
        let back = (0.5 * (wi - wo).length_squared()).clamp(0.0, 2.0);
        Angle { fwd, back }
    }
}

/// HG density as a function of the angle.
#[inline]
fn hg_pdf(g: f32, a: Angle) -> f32 {
    let g = g.clamp(-G_MAX, G_MAX);
    // 1 + g² − 2gμ = (1 − |g|)² + 2|g|·(1 ∓ μ): no cancellation near the lobe's peak.
    let (ga, x) = if g >= 0.0 { (g, a.fwd) } else { (-g, a.back) };
    let one_minus = 1.0 - ga;
    let denom = one_minus * one_minus + 2.0 * ga * x;
    INV_4PI * one_minus * (1.0 + ga) / (denom * denom.sqrt())
}

/// Samples HG exactly: returns the angle of the sampled direction. For |g| the distance from
/// the lobe's axis, a = 1 − cos(angle to axis), is
///   d = (1−u)(1+|g|) + u(1−|g|),   a = u (1−|g|)² (1+|g|+d) / d²,
/// an algebraic rearrangement of the textbook inverse CDF that needs no division by g (so it
/// is exact at g = 0, where it gives a = 2u) and never subtracts nearly equal numbers.
#[inline]
fn hg_sample(g: f32, u: f32) -> Angle {
    let g = g.clamp(-G_MAX, G_MAX);
    let ga = g.abs();
    let d = (1.0 - u) * (1.0 + ga) + u * (1.0 - ga);
    let om = 1.0 - ga;
    let a = (u * om * om * (1.0 + ga + d) / (d * d)).clamp(0.0, 2.0);
    if g >= 0.0 {
        Angle { fwd: a, back: 2.0 - a }
    } else {
        Angle { fwd: 2.0 - a, back: a }
    }
}

/// Direction at the given angle from the forward axis `-wo`, azimuth 2π·v.
#[inline]
fn direction_at(wo: Vec3, a: Angle, v: f32) -> Vec3 {
    let frame = Frame::from_normal(-wo);
    let cos_theta = if a.fwd <= a.back { 1.0 - a.fwd } else { a.back - 1.0 };
    let sin_theta = safe_sqrt(a.fwd * a.back);
    frame.to_world(spherical_direction(sin_theta, cos_theta, 2.0 * PI * v))
}

/// `u` remapped after a discrete choice of probability `p` taken by `u < p`, kept below 1.
#[inline]
fn remap(u: f32, lo: f32, p: f32) -> f32 {
    ((u - lo) / p).clamp(0.0, ONE_MINUS_EPSILON)
}

/// Largest f32 below 1.
pub(crate) const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

impl PhaseFunction {
    /// Henyey–Greenstein. |g| > 1 or a non-finite g is an error; |g| in (G_MAX, 1] is clamped.
    pub fn hg(g: f32) -> Result<Self, MediumError> {
        Ok(PhaseFunction::HenyeyGreenstein { g: check_g("g", g)? })
    }

    /// w·HG(g1) + (1−w)·HG(g2); w must lie in [0, 1].
    pub fn dual_hg(g1: f32, g2: f32, w: f32) -> Result<Self, MediumError> {
        let g1 = check_g("g1", g1)?;
        let g2 = check_g("g2", g2)?;
        if !(0.0..=1.0).contains(&w) {
            return Err(MediumError::BadParameter { name: "w (lobe weight)", value: w, expected: "a weight in [0, 1]" });
        }
        Ok(PhaseFunction::DualHg { g1, g2, w })
    }

    /// Builds the phase function a scene describes, validating its parameters.
    pub fn from_desc(desc: &PhaseDesc) -> Result<Self, MediumError> {
        match desc {
            PhaseDesc::Isotropic => Ok(PhaseFunction::Isotropic),
            PhaseDesc::HenyeyGreenstein { g } => Self::hg(*g),
            PhaseDesc::DualHg { g1, g2, w } => Self::dual_hg(*g1, *g2, *w),
            PhaseDesc::Tabulated { theta, value } => {
                if theta.len() != value.len() {
                    return Err(MediumError::BadTable(format!("{} angles but {} values", theta.len(), value.len())));
                }
                let pts: Vec<(f32, f32)> = theta.iter().copied().zip(value.iter().copied()).collect();
                Ok(PhaseFunction::Tabulated(TabulatedPhase::from_angles(&pts)?))
            }
        }
    }

    /// Density of scattering from `-wo` into `wi` per steradian (both unit vectors).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            PhaseFunction::Isotropic => INV_4PI,
            PhaseFunction::HenyeyGreenstein { g } => hg_pdf(*g, Angle::between(wo, wi)),
            PhaseFunction::DualHg { g1, g2, w } => {
                let a = Angle::between(wo, wi);
                w * hg_pdf(*g1, a) + (1.0 - w) * hg_pdf(*g2, a)
            }
            PhaseFunction::Tabulated(t) => t.density(Angle::between(wo, wi).fwd),
        }
    }

    /// Solid-angle pdf of [`PhaseFunction::sample`] producing `wi` (equal to `eval`).
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval(wo, wi)
    }

    /// Samples an outgoing path direction for a path that arrived along `-wo`.
    /// Returns (wi, value, pdf); value == pdf for every variant.
    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> (Vec3, f32, f32) {
        let (a, p) = match self {
            PhaseFunction::Isotropic => {
                let fwd = 2.0 * u.x;
                (Angle { fwd, back: 2.0 - fwd }, INV_4PI)
            }
            PhaseFunction::HenyeyGreenstein { g } => {
                let a = hg_sample(*g, u.x);
                (a, hg_pdf(*g, a))
            }
            PhaseFunction::DualHg { g1, g2, w } => {
                let a = if u.x < *w { hg_sample(*g1, remap(u.x, 0.0, *w)) } else { hg_sample(*g2, remap(u.x, *w, 1.0 - w)) };
                (a, w * hg_pdf(*g1, a) + (1.0 - w) * hg_pdf(*g2, a))
            }
            PhaseFunction::Tabulated(t) => {
                let (fwd, p) = t.sample_fwd(u.x);
                (Angle { fwd, back: 2.0 - fwd }, p)
            }
        };
        (direction_at(wo, a, u.y), p, p)
    }

    /// Mean cosine ∫ μ p dω of the scattering angle (0 isotropic, g for HG).
    pub fn mean_cosine(&self) -> f32 {
        match self {
            PhaseFunction::Isotropic => 0.0,
            PhaseFunction::HenyeyGreenstein { g } => g.clamp(-G_MAX, G_MAX),
            PhaseFunction::DualHg { g1, g2, w } => w * g1.clamp(-G_MAX, G_MAX) + (1.0 - w) * g2.clamp(-G_MAX, G_MAX),
            PhaseFunction::Tabulated(t) => t.mean_cosine(),
        }
    }
}

fn check_g(name: &'static str, g: f32) -> Result<f32, MediumError> {
    if !g.is_finite() || g.abs() > 1.0 {
        return Err(MediumError::BadParameter { name, value: g, expected: "an HG mean cosine in [-1, 1]" });
    }
    Ok(g.clamp(-G_MAX, G_MAX))
}

/// A measured phase function p(μ), μ = cosθ, piecewise linear in μ between its nodes and
/// normalised to integrate to 1 over the sphere. Internally the abscissa is x = 1 − μ ∈ [0, 2]
/// so that nodes a fraction of a degree from the forward direction stay distinct in f32.
/// Sampling inverts the CDF exactly: a segment is picked from the tabulated CDF, then the
/// linear density within it is inverted in closed form.
#[derive(Clone, Debug, PartialEq)]
pub struct TabulatedPhase {
    /// Node abscissae x = 1 − μ, strictly increasing from 0 to 2.
    x: Vec<f32>,
    /// Density per steradian at the nodes.
    p: Vec<f32>,
    /// CDF at the nodes (cdf[0] = 0, last = 1).
    cdf: Vec<f32>,
    /// Last segment with non-zero probability (where u ≈ 1 lands).
    last_segment: usize,
    mean_cosine: f32,
}

impl TabulatedPhase {
    /// From (μ = cosθ, value) samples, in any order. Values need only be proportional to the
    /// phase function; the table is normalised. Outside the sampled range of μ the end values
    /// are held constant.
    pub fn from_cosines(samples: &[(f32, f32)]) -> Result<Self, MediumError> {
        let mut pts = Vec::with_capacity(samples.len() + 2);
        for &(mu, v) in samples {
            if !mu.is_finite() || mu.abs() > 1.0 {
                return Err(MediumError::BadTable(format!("cosθ = {mu} is outside [-1, 1]")));
            }
            pts.push((1.0 - mu, v));
        }
        Self::from_fwd(pts)
    }

    /// From (θ in radians, value) samples, in any order; as [`TabulatedPhase::from_cosines`].
    pub fn from_angles(samples: &[(f32, f32)]) -> Result<Self, MediumError> {
        let mut pts = Vec::with_capacity(samples.len() + 2);
        for &(theta, v) in samples {
            if !theta.is_finite() || !(0.0..=PI + 1e-6).contains(&theta) {
                return Err(MediumError::BadTable(format!("angle θ = {theta} rad is outside [0, π]")));
            }
            // 1 − cosθ = 2 sin²(θ/2): exact for small angles
            let s = (0.5 * theta.min(PI)).sin();
            pts.push((2.0 * s * s, v));
        }
        Self::from_fwd(pts)
    }

    fn from_fwd(mut pts: Vec<(f32, f32)>) -> Result<Self, MediumError> {
        if pts.is_empty() {
            return Err(MediumError::BadTable("no samples".into()));
        }
        if let Some(&(x, v)) = pts.iter().find(|(_, v)| !v.is_finite() || *v < 0.0) {
            return Err(MediumError::BadTable(format!("value {v} at cosθ = {} is negative or not finite", 1.0 - x)));
        }
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        if let Some(w) = pts.windows(2).find(|w| w[0].0 == w[1].0) {
            return Err(MediumError::BadTable(format!("cosθ = {} appears twice", 1.0 - w[0].0)));
        }
        let first = pts[0];
        if first.0 > 0.0 {
            pts.insert(0, (0.0, first.1));
        }
        let last = pts[pts.len() - 1];
        if last.0 < 2.0 {
            pts.push((2.0, last.1));
        }
        // trapezoid rule is exact for the piecewise-linear density; accumulate in f64
        let mut cum = Vec::with_capacity(pts.len());
        let mut acc = 0f64;
        let mut first_moment = 0f64;
        cum.push(0.0);
        for w in pts.windows(2) {
            let ((x0, p0), (x1, p1)) = (w[0], w[1]);
            let (x0, p0, x1, p1) = (x0 as f64, p0 as f64, x1 as f64, p1 as f64);
            let h = x1 - x0;
            acc += 0.5 * h * (p0 + p1);
            // ∫ (1 − x) p(x) dx over the segment
            first_moment += h * ((1.0 - x0) * 0.5 * (p0 + p1) - h * (p0 / 6.0 + p1 / 3.0));
            cum.push(acc);
        }
        if !(acc > 0.0) || !acc.is_finite() {
            return Err(MediumError::BadTable("the values integrate to zero (or overflow)".into()));
        }
        let norm = 1.0 / (2.0 * std::f64::consts::PI * acc);
        let x: Vec<f32> = pts.iter().map(|q| q.0).collect();
        let p: Vec<f32> = pts.iter().map(|q| (q.1 as f64 * norm) as f32).collect();
        let mut cdf: Vec<f32> = cum.iter().map(|c| (c / acc) as f32).collect();
        let n = cdf.len();
        cdf[n - 1] = 1.0;
        let last_segment = (0..n - 1).rev().find(|&i| cdf[i + 1] > cdf[i]).unwrap_or(0);
        Ok(TabulatedPhase { x, p, cdf, last_segment, mean_cosine: (first_moment / acc) as f32 })
    }

    /// Density per steradian at x = 1 − μ.
    #[inline]
    fn density(&self, x: f32) -> f32 {
        let n = self.x.len();
        let i = self.x.partition_point(|&v| v <= x).saturating_sub(1).min(n - 2);
        let (x0, x1) = (self.x[i], self.x[i + 1]);
        let t = ((x - x0) / (x1 - x0)).clamp(0.0, 1.0);
        (1.0 - t) * self.p[i] + t * self.p[i + 1]
    }

    /// Samples x = 1 − μ; returns (x, density).
    #[inline]
    fn sample_fwd(&self, u: f32) -> (f32, f32) {
        let n = self.cdf.len();
        let mut i = self.cdf.partition_point(|&c| c <= u).saturating_sub(1).min(n - 2);
        if self.cdf[i + 1] <= self.cdf[i] {
            i = self.last_segment;
        }
        let v = remap(u, self.cdf[i], self.cdf[i + 1] - self.cdf[i]);
        let (p0, p1) = (self.p[i], self.p[i + 1]);
        // root in [0,1] of ((p1−p0)/2) t² + p0 t = v (p0+p1)/2, in the form without cancellation
        let disc = (1.0 - v) * p0 * p0 + v * p1 * p1;
        let den = p0 + disc.sqrt();
        let t = if den > 0.0 { (v * (p0 + p1) / den).clamp(0.0, 1.0) } else { 0.0 };
        let x = (self.x[i] + t * (self.x[i + 1] - self.x[i])).clamp(0.0, 2.0);
        (x, (1.0 - t) * p0 + t * p1)
    }

    /// Mean cosine of the tabulated function (exact for its piecewise-linear form).
    pub fn mean_cosine(&self) -> f32 {
        self.mean_cosine
    }

    /// Number of nodes (including the ones added at μ = ±1).
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Always false: a table has at least its two end nodes.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }
}
