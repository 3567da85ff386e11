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
    /// Cumulative optical depth over depth (None: not built; transmittance is then tracked).
    pub optical_depth: Option<Box<OpticalDepthTable>>,
}

/// The optical depth of depth-varying water in closed form along any straight segment: since
/// σt depends on depth z alone and z is linear along a ray, `∫σt dt = (C(z₁) − C(z₀)) / |d_y|`
/// with `C(λ, z) = ∫σt(λ, z') dz'`. C is tabulated at every whole nanometre on a depth grid
/// over the span where the profiles vary (σt is constant on either side of it), integrated by
/// Simpson's rule on each cell, and interpolated linearly in depth and wavelength. Segments
/// spanning less than a quarter cell in depth use σt at their middle depth times their length
/// (a nearly horizontal ray would otherwise divide a tiny difference by a tiny |d_y|).
/// Transmittance is then exact up to the table's interpolation, and costs no random numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct OpticalDepthTable {
    z0: f32,
    dz: f32,
    /// Depth cells (nodes: nz + 1).
    nz: usize,
    /// C at the nodes, `[nm][node]`.
    c: Vec<f32>,
    /// σt at the nodes, `[nm][node]`.
    st: Vec<f32>,
    /// σs at the nodes, `[nm][node]`.
    ss: Vec<f32>,
}

/// Wavelength rows of the table: whole nanometres over the visible range.
const OD_ROWS: usize = (crate::spectrum::LAMBDA_MAX - crate::spectrum::LAMBDA_MIN) as usize + 1;

impl OpticalDepthTable {
    /// The table of `coefficients(z, λ) = (σa, σs)` over depths `[z0, z1]` with cells at most
    /// `max_dz` deep.
    pub fn build(z0: f32, z1: f32, max_dz: f32, coefficients: impl Fn(f32, f32) -> (f32, f32)) -> Option<OpticalDepthTable> {
        if !(z1 > z0 && max_dz > 0.0) {
            return None;
        }
        let nz = (((z1 - z0) / max_dz).ceil() as usize).clamp(16, 2048);
        let dz = (z1 - z0) / nz as f32;
        let mut c = vec![0.0f32; OD_ROWS * (nz + 1)];
        let mut st = vec![0.0f32; OD_ROWS * (nz + 1)];
        let mut ss = vec![0.0f32; OD_ROWS * (nz + 1)];
        let sigma_t = |z: f32, l: f32| {
            let (a, b) = coefficients(z, l);
            (a + b) as f64
        };
        for r in 0..OD_ROWS {
            let l = crate::spectrum::LAMBDA_MIN + r as f32;
            let row = r * (nz + 1);
            let mut acc = 0.0f64;
            let mut prev = sigma_t(z0, l);
            st[row] = prev as f32;
            ss[row] = coefficients(z0, l).1;
            for k in 0..nz {
                let za = z0 + dz * k as f32;
                let mid = sigma_t(za + 0.5 * dz, l);
                let next = sigma_t(za + dz, l);
                acc += dz as f64 / 6.0 * (prev + 4.0 * mid + next);
                c[row + k + 1] = acc as f32;
                st[row + k + 1] = next as f32;
                ss[row + k + 1] = coefficients(za + dz, l).1;
                prev = next;
            }
        }
        Some(OpticalDepthTable { z0, dz, nz, c, st, ss })
    }

    /// C and σt of row `r` at depth `z` (C extended linearly with the end σt beyond the span).
    #[inline]
    fn row_at(&self, r: usize, z: f32) -> (f32, f32) {
        let row = r * (self.nz + 1);
        let u = (z - self.z0) / self.dz;
        if u <= 0.0 {
            let s = self.st[row];
            return (u * self.dz * s, s);
        }
        if u >= self.nz as f32 {
            let s = self.st[row + self.nz];
            return (self.c[row + self.nz] + (z - (self.z0 + self.dz * self.nz as f32)) * s, s);
        }
        let k = (u as usize).min(self.nz - 1);
        let f = u - k as f32;
        let (s0, s1) = (self.st[row + k], self.st[row + k + 1]);
        // C between nodes: the integral of σt interpolated linearly over the cell
        let c = self.c[row + k] + self.dz * f * (s0 + 0.5 * f * (s1 - s0));
        (c, s0 + f * (s1 - s0))
    }

    /// (σa, σs) at wavelength `l` (nm) and depth `z`, interpolated linearly in both.
    #[inline]
    pub fn coefficients(&self, l: f32, z: f32) -> (f32, f32) {
        let x = (l - crate::spectrum::LAMBDA_MIN).clamp(0.0, (OD_ROWS - 1) as f32);
        let r = (x as usize).min(OD_ROWS - 2);
        let w = x - r as f32;
        let u = ((z - self.z0) / self.dz).clamp(0.0, self.nz as f32);
        let k = (u as usize).min(self.nz - 1);
        let f = u - k as f32;
        let at = |v: &[f32], r: usize| {
            let row = r * (self.nz + 1) + k;
            v[row] + f * (v[row + 1] - v[row])
        };
        let st = at(&self.st, r) + w * (at(&self.st, r + 1) - at(&self.st, r));
        let ss = at(&self.ss, r) + w * (at(&self.ss, r + 1) - at(&self.ss, r));
        ((st - ss).max(0.0), ss.max(0.0))
    }

    /// Optical depth at wavelength `l` (nm) from depth `za` to `zb` along a segment of length
    /// `t`.
    #[inline]
    pub fn optical_depth(&self, l: f32, za: f32, zb: f32, t: f32) -> f32 {
        let x = (l - crate::spectrum::LAMBDA_MIN).clamp(0.0, (OD_ROWS - 1) as f32);
        let r = (x as usize).min(OD_ROWS - 2);
        let w = x - r as f32;
        let eval = |r: usize| {
            if (zb - za).abs() < 0.25 * self.dz {
                self.row_at(r, 0.5 * (za + zb)).1 * t
            } else {
                let (ca, _) = self.row_at(r, za);
                let (cb, _) = self.row_at(r, zb);
                (cb - ca).abs() * t / (zb - za).abs()
            }
        };
        let (a, b) = (eval(r), eval(r + 1));
        (a + w * (b - a)).max(0.0)
    }
}

impl BioOpticalMedium {
    /// The medium, with the optical-depth table of its profiles when the water varies.
    pub fn new(water: BioOptical, extra_a: Spectrum, extra_s: Spectrum, scale: f32, phase: PhaseFunction, top: f32) -> BioOpticalMedium {
        let optical_depth = water.varying_span().and_then(|(z0, z1, width)| {
            let (ea, es) = (&extra_a, &extra_s);
            // cells a twentieth of the narrowest profile's width: the linear interpolation of σt
            // is then within ~10⁻⁴ of a Gaussian's curvature
            OpticalDepthTable::build(z0, z1, width / 20.0, |z, l| {
                let (a, b) = water.coefficients_at(z, l);
                ((a + ea.eval(l).max(0.0)) * scale, (b + es.eval(l).max(0.0)) * scale)
            })
            .map(Box::new)
        });
        BioOpticalMedium { water, extra_a, extra_s, scale, phase, top, optical_depth }
    }

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

    /// (σa, σs) at world point `p`, at the path's wavelengths (from the table when there is
    /// one).
    pub fn coefficients_at(&self, p: Vec3, lambda: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        match &self.optical_depth {
            Some(od) => Self::from_table(od, self.depth(p), lambda),
            None => self.with_concentrations(self.water.concentrations(self.depth(p)), self.extra(lambda), lambda),
        }
    }

    #[inline]
    fn from_table(od: &OpticalDepthTable, z: f32, lambda: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        let (mut a, mut s) = (SampledSpectrum::ZERO, SampledSpectrum::ZERO);
        for j in 0..a.0.len() {
            let (x, y) = od.coefficients(lambda.lambda[j], z);
            a.0[j] = x;
            s.0[j] = y;
        }
        (a, s)
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
        if let Some(od) = &self.optical_depth {
            // the table's σt interpolates the model linearly over cells a twentieth of a
            // profile's width, so it exceeds the model's bound by under 10⁻³ where the profile
            // is convex: the majorant is raised by that much
            return sample_distance_tracking(maj * 1.001, t_max, rng, lambda, |t| Self::from_table(od, z0 - dir.y * t, lambda));
        }
        let extra = self.extra(lambda);
        sample_distance_tracking(maj, t_max, rng, lambda, |t| self.with_concentrations(self.water.concentrations(z0 - dir.y * t), extra, lambda))
    }

    /// Transmittance over [0, t]: from the optical-depth table when there is one (exact up to
    /// its interpolation, drawing nothing), else residual ratio tracking (exact and drawing
    /// nothing without a profile).
    pub fn transmittance(&self, origin: Vec3, dir: Vec3, t: f32, rng: &mut impl FnMut() -> f32, lambda: &SampledWavelengths) -> SampledSpectrum {
        let (z0, z1) = self.depth_span(origin, dir, t);
        if let Some(od) = &self.optical_depth {
            if t.is_finite() {
                let mut tr = SampledSpectrum::ZERO;
                for j in 0..tr.0.len() {
                    tr.0[j] = (-od.optical_depth(lambda.lambda[j], z0, z1, t)).exp();
                }
                return tr;
            }
        }
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
