//! Natural water whose coefficients vary with depth: the bio-optical model (Jerlov IOPs or pure
//! seawater, chlorophyll with a Gaussian depth profile, CDOM, SPM) plus constant RGB
//! coefficients, all times a density scale. Depth is z = `top` − y (the scene's up axis is +Y).
//!
//! Where the water varies, the model is tabulated once over depth and wavelength
//! ([`OpticalDepthTable`]: σt and σs at every nanometre on cells a twentieth of the narrowest
//! profile's width, within 5·10⁻⁴ of the model, and C(z) = ∫σt dz in closed form). Since depth
//! is linear along a ray, the optical depth of any segment is a difference of C, so
//! transmittance is exact and draws nothing, and free-flight distances are drawn by inverting
//! it ([`BioOpticalMedium::sample_distance_table`]): one number per call, no majorant and no
//! null collisions, with the spectral-MIS weights of a homogeneous medium.
//!
//! Without a table (only when it cannot be built), along a ray the concentrations over a
//! segment lie between their values at the depth in the segment farthest from and nearest to
//! each profile's peak ([`BioOptical::concentration_range`]); every coefficient is
//! non-decreasing in every concentration, so σt evaluated there bounds σt on the segment per
//! wavelength from below and above: the upper bound is the majorant of delta tracking, the
//! lower one the control of residual ratio tracking ([`super::tracking`]). Without a profile
//! both bounds equal σt and the medium behaves exactly as a homogeneous one.

use super::homogeneous::DistanceSample;
use super::phase::{PhaseFunction, ONE_MINUS_EPSILON};
use super::tracking::{sample_distance_tracking, transmittance_ratio_tracking};
use crate::spectrum::{SampledSpectrum, SampledWavelengths, Spectrum, N_SPECTRUM};
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
    /// Height (along `up`) of depth 0.
    pub top: f32,
    /// The scene's up direction (unit): depth is measured down it.
    pub up: Vec3,
    /// Cumulative optical depth over depth (None: not built; transmittance is then tracked).
    pub optical_depth: Option<Box<OpticalDepthTable>>,
}

/// The optical depth of depth-varying water in closed form along any straight segment: since
/// σt depends on depth z alone and z is linear along a ray, `∫σt dt = (C(z₁) − C(z₀)) / |d_y|`
/// with `C(λ, z) = ∫σt(λ, z') dz'`. σt is tabulated at every whole nanometre on a depth grid
/// over the span where the profiles vary (it is constant on either side of it) and
/// interpolated linearly in depth and wavelength; C is the exact integral of that interpolant.
/// Segments spanning less than a quarter cell in depth use σt at their middle depth times
/// their length (exact for a linear σt; a nearly horizontal ray would otherwise divide a tiny
/// difference by a tiny |d_y|). Transmittance is then exact for the tabulated medium, and costs
/// no random numbers; free-flight distances are drawn by inverting the same optical depth
/// ([`OpticalDepthTable::invert`]), so they need no majorant and no null collisions.
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
    /// The largest σt of each row (σt is constant beyond the span, so this bounds it at every
    /// depth).
    row_max: Vec<f32>,
}

/// Cells walked in distance before distance sampling inverts C directly (see
/// [`OpticalDepthTable::invert`]).
const WALK_PIECES: usize = 4;

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
        let mut row_max = vec![0.0f32; OD_ROWS];
        for r in 0..OD_ROWS {
            let l = crate::spectrum::LAMBDA_MIN + r as f32;
            let row = r * (nz + 1);
            for k in 0..=nz {
                let (a, b) = coefficients(z0 + dz * k as f32, l);
                st[row + k] = (a.max(0.0) + b.max(0.0)).max(0.0);
                ss[row + k] = b.max(0.0);
            }
            // C is the exact integral of the linear interpolant of σt (the trapezoid rule on
            // each cell), so that dC/dz is the tabulated σt everywhere: distance sampling by
            // inverting C then has exactly the density its weights assume
            let mut acc = 0.0f64;
            for k in 0..nz {
                acc += 0.5 * dz as f64 * (st[row + k] as f64 + st[row + k + 1] as f64);
                c[row + k + 1] = acc as f32;
            }
            row_max[r] = st[row..row + nz + 1].iter().copied().fold(0.0, f32::max);
        }
        Some(OpticalDepthTable { z0, dz, nz, c, st, ss, row_max })
    }

    /// Where depth `z` falls in the table, shared by every row.
    #[inline]
    fn cell(&self, z: f32) -> Cell {
        let u = (z - self.z0) / self.dz;
        if u <= 0.0 {
            return Cell { k: 0, f: 0.0, ext: z - self.z0 };
        }
        if u >= self.nz as f32 {
            return Cell { k: self.nz, f: 0.0, ext: z - (self.z0 + self.dz * self.nz as f32) };
        }
        let k = (u as usize).min(self.nz - 1);
        Cell { k, f: u - k as f32, ext: 0.0 }
    }

    /// C and σt of row `r` at a depth's cell (C extended linearly with the end σt beyond the
    /// span; between nodes the integral of σt interpolated linearly over the cell).
    #[inline]
    fn row_at(&self, r: usize, cell: Cell) -> (f32, f32) {
        let i = r * (self.nz + 1) + cell.k;
        let s0 = self.st[i];
        if cell.f == 0.0 {
            return (self.c[i] + cell.ext * s0, s0);
        }
        let s1 = self.st[i + 1];
        (self.c[i] + self.dz * cell.f * (s0 + 0.5 * cell.f * (s1 - s0)), s0 + cell.f * (s1 - s0))
    }

    /// Row and weight of wavelength `l` (nm): rows r and r + 1, mixed (1 − w) : w.
    #[inline]
    fn rows(l: f32) -> (usize, f32) {
        let x = (l - crate::spectrum::LAMBDA_MIN).clamp(0.0, (OD_ROWS - 1) as f32);
        let r = (x as usize).min(OD_ROWS - 2);
        (r, x - r as f32)
    }

    /// C and σt at depth `z` of rows r, r + 1 mixed by w.
    #[inline]
    fn mixed_at(&self, (r, w): (usize, f32), z: f32) -> (f32, f32) {
        let cell = self.cell(z);
        let (c0, s0) = self.row_at(r, cell);
        let (c1, s1) = self.row_at(r + 1, cell);
        (c0 + w * (c1 - c0), s0 + w * (s1 - s0))
    }

    /// C and σt at node `k` of rows r, r + 1 mixed by w.
    #[inline]
    fn mixed_node(&self, (r, w): (usize, f32), k: usize) -> (f32, f32) {
        let (i0, i1) = (r * (self.nz + 1) + k, (r + 1) * (self.nz + 1) + k);
        (self.c[i0] + w * (self.c[i1] - self.c[i0]), self.st[i0] + w * (self.st[i1] - self.st[i0]))
    }

    /// Upper bound of σt at wavelength `l` over all depths.
    #[inline]
    pub fn max_sigma_t(&self, l: f32) -> f32 {
        let (r, _) = Self::rows(l);
        self.row_max[r].max(self.row_max[r + 1])
    }

    /// The distance t ∈ [0, t_max) along a ray that starts at depth `z0` with dz/dt = `q` at
    /// which the optical depth at wavelength `l` reaches `tau` (None when it stays below `tau`
    /// up to `t_max`, which may be infinite). The optical depth is the integral of the
    /// tabulated σt, piecewise linear in t between the depth nodes: the first
    /// `WALK_PIECES` pieces are walked in t and the crossing solved in closed form within its
    /// piece (exact for any |q|, horizontal rays included); beyond them the crossing depth is
    /// found by a binary search of C and solved within its cell, z* with C(z*) = C(z) + τ q.
    pub fn invert(&self, l: f32, z0: f32, q: f32, tau: f32, t_max: f32) -> Option<f32> {
        if !(tau >= 0.0) {
            return None;
        }
        let rw = Self::rows(l);
        let node_z = |k: usize| self.z0 + self.dz * k as f32;
        let (mut t, mut z, mut acc) = (0.0f32, z0, 0.0f32);
        let (_, mut sa) = self.mixed_at(rw, z);
        for _ in 0..WALK_PIECES {
            // the next depth node in the direction of travel (none beyond the span's far end:
            // σt is constant there)
            let u = (z - self.z0) / self.dz;
            let next = if q > 0.0 {
                let k = if u < 0.0 { 0.0 } else { (u + 1e-4).floor() + 1.0 };
                (k <= self.nz as f32).then(|| (node_z(k as usize) - z) / q)
            } else if q < 0.0 {
                let k = if u > self.nz as f32 { self.nz as f32 } else { (u - 1e-4).ceil() - 1.0 };
                (k >= 0.0).then(|| (node_z(k as usize) - z) / q)
            } else {
                None
            };
            let t_end = next.map_or(t_max, |d| (t + d.max(0.0)).min(t_max));
            // (beyond the last node σt is constant: an infinite piece keeps its depth)
            let z_end = if t_end.is_finite() { z0 + q * t_end } else { z };
            let (_, sb) = self.mixed_at(rw, z_end);
            let len = t_end - t;
            let piece = if len.is_finite() { 0.5 * (sa + sb) * len } else if sa > 0.0 || sb > 0.0 { f32::INFINITY } else { 0.0 };
            if acc + piece >= tau {
                // σ(x) = sa + k x on the piece: solve sa x + k x²/2 = tau − acc
                let rem = (tau - acc).max(0.0);
                let k = if len.is_finite() && len > 0.0 { (sb - sa) / len } else { 0.0 };
                let disc = (sa * sa + 2.0 * k * rem).max(0.0);
                let den = sa + disc.sqrt();
                let x = if den > 0.0 { 2.0 * rem / den } else { 0.0 };
                return Some((t + x.min(len)).min(t_max * ONE_MINUS_EPSILON).max(0.0));
            }
            acc += piece;
            t = t_end;
            z = z_end;
            sa = sb;
            if !(t < t_max) {
                return None;
            }
        }
        // several cells crossed: |q| is not small, so invert C in depth
        let (cz, _) = self.mixed_at(rw, z);
        let target = cz + (tau - acc) * q;
        let z_star = self.depth_of(rw, target)?;
        let t_star = t + (z_star - z) / q;
        (t_star < t_max).then(|| t_star.max(t))
    }

    /// The depth at which C (rows mixed by `rw`) takes the value `target`, None where σt = 0
    /// makes it unreachable.
    fn depth_of(&self, rw: (usize, f32), target: f32) -> Option<f32> {
        let (c_first, s_first) = self.mixed_node(rw, 0);
        if target <= c_first {
            return (s_first > 0.0).then(|| self.z0 + (target - c_first) / s_first);
        }
        let (c_last, s_last) = self.mixed_node(rw, self.nz);
        if target >= c_last {
            return (s_last > 0.0).then(|| self.z0 + self.dz * self.nz as f32 + (target - c_last) / s_last);
        }
        // the cell k with C(k) ≤ target < C(k + 1)
        let (mut lo, mut hi) = (0usize, self.nz);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if self.mixed_node(rw, mid).0 <= target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let (ck, s0) = self.mixed_node(rw, lo);
        let (_, s1) = self.mixed_node(rw, lo + 1);
        // C(z_k + x) = ck + s0 x + (s1 − s0) x² / (2 dz)
        let rem = target - ck;
        let disc = (s0 * s0 + 2.0 * (s1 - s0) / self.dz * rem).max(0.0);
        let den = s0 + disc.sqrt();
        let x = if den > 0.0 { (2.0 * rem / den).clamp(0.0, self.dz) } else { 0.0 };
        Some(self.z0 + self.dz * lo as f32 + x)
    }

    /// (σa, σs) at wavelength `l` (nm) in depth cell `cell`, interpolated linearly in depth and
    /// wavelength.
    #[inline]
    fn coefficients_in(&self, l: f32, cell: Cell) -> (f32, f32) {
        let (r, w) = Self::rows(l);
        let at = |v: &[f32], r: usize| {
            let i = r * (self.nz + 1) + cell.k;
            if cell.f == 0.0 {
                v[i]
            } else {
                v[i] + cell.f * (v[i + 1] - v[i])
            }
        };
        let (st0, st1) = (at(&self.st, r), at(&self.st, r + 1));
        let (ss0, ss1) = (at(&self.ss, r), at(&self.ss, r + 1));
        let st = st0 + w * (st1 - st0);
        let ss = ss0 + w * (ss1 - ss0);
        ((st - ss).max(0.0), ss.max(0.0))
    }

    /// (σa, σs) at the path's wavelengths and depth `z`.
    #[inline]
    pub fn coefficients_all(&self, lambda: &SampledWavelengths, z: f32) -> (SampledSpectrum, SampledSpectrum) {
        let cell = self.cell(z);
        let (mut a, mut s) = (SampledSpectrum::ZERO, SampledSpectrum::ZERO);
        for j in 0..N_SPECTRUM {
            (a.0[j], s.0[j]) = self.coefficients_in(lambda.lambda[j], cell);
        }
        (a, s)
    }

    /// The cells a segment from depth `za` to `zb` needs: its middle when it spans under a
    /// quarter cell, else its two ends.
    #[inline]
    fn segment(&self, za: f32, zb: f32) -> Segment {
        if (zb - za).abs() < 0.25 * self.dz {
            Segment::Short(self.cell(0.5 * (za + zb)))
        } else {
            Segment::Long(self.cell(za), self.cell(zb), (zb - za).abs())
        }
    }

    #[inline]
    fn optical_depth_in(&self, l: f32, seg: &Segment, t: f32) -> f32 {
        let (r, w) = Self::rows(l);
        let eval = |r: usize| match *seg {
            Segment::Short(m) => self.row_at(r, m).1 * t,
            Segment::Long(a, b, span) => (self.row_at(r, b).0 - self.row_at(r, a).0).abs() * t / span,
        };
        let (a, b) = (eval(r), eval(r + 1));
        (a + w * (b - a)).max(0.0)
    }

    /// Transmittance at the path's wavelengths from depth `za` to `zb` along a segment of
    /// length `t` (finite).
    #[inline]
    pub fn transmittance_all(&self, lambda: &SampledWavelengths, za: f32, zb: f32, t: f32) -> SampledSpectrum {
        let seg = self.segment(za, zb);
        SampledSpectrum::from_fn(|j| (-self.optical_depth_in(lambda.lambda[j], &seg, t)).exp())
    }
}

/// A depth's place in the table: node `k`, fraction `f` of the cell after it, and the distance
/// `ext` beyond the span's end (0 inside).
#[derive(Clone, Copy, Debug)]
struct Cell {
    k: usize,
    f: f32,
    ext: f32,
}

/// What the optical depth of a segment is read from.
#[derive(Clone, Copy, Debug)]
enum Segment {
    /// Under a quarter cell deep: σt at the middle times the length.
    Short(Cell),
    /// The ends' cells and the depth spanned: |C(b) − C(a)| · t / span.
    Long(Cell, Cell, f32),
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
        BioOpticalMedium { water, extra_a, extra_s, scale, phase, top, up: Vec3::Y, optical_depth }
    }

    /// The medium with depth measured down `up` (a unit vector; +Y unless the stage is Z-up).
    pub fn facing_up(self, up: Vec3) -> BioOpticalMedium {
        BioOpticalMedium { up, ..self }
    }

    /// Depth below the water's top of a world point.
    #[inline]
    pub fn depth(&self, p: Vec3) -> f32 {
        self.top - p.dot(self.up)
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
        od.coefficients_all(lambda, z)
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

    /// Depths at the ends of `origin + t·dir`, t ∈ [0, t_max], and the rise of `dir` (its
    /// component up: depth changes by −rise per unit of t).
    fn depth_span(&self, origin: Vec3, dir: Vec3, t_max: f32) -> (f32, f32, f32) {
        let z0 = self.depth(origin);
        let rise = dir.dot(self.up);
        let dz = if rise == 0.0 { 0.0 } else { -rise * t_max };
        (z0, z0 + dz, rise)
    }

    /// Free-flight sampling with spectral MIS: with the optical-depth table, by inverting the
    /// chosen wavelength's optical depth along the ray (one number drawn, as in a homogeneous
    /// medium; see [`Self::sample_distance_table`]); without it, delta tracking against the
    /// segment's majorant.
    pub fn sample_distance(&self, origin: Vec3, dir: Vec3, t_max: f32, rng: &mut impl FnMut() -> f32, lambda: &SampledWavelengths) -> DistanceSample {
        let (z0, z1, rise) = self.depth_span(origin, dir, t_max);
        if let Some(od) = &self.optical_depth {
            return Self::sample_distance_table(od, z0, -rise, t_max, rng(), lambda);
        }
        let (_, maj) = self.sigma_t_bounds(z0, z1, lambda);
        let extra = self.extra(lambda);
        sample_distance_tracking(maj, t_max, rng, lambda, |t| self.with_concentrations(self.water.concentrations(z0 - rise * t), extra, lambda))
    }

    /// The one-sample spectral-MIS free-flight estimator of a homogeneous medium
    /// ([`super::sample_distance_spectral`]) with the optical depth τ_j(t) of the table in
    /// place of σt_j·t: a live channel c is chosen with the first part of `u`, τ* = −ln(1 − v)
    /// with the rest, and the collision lies where τ_c(t) = τ* ([`OpticalDepthTable::invert`]);
    /// so pdf(t) = (1/N) Σ_j σt_j(t) e^{−τ_j(t)} and P(pass) = (1/N) Σ_j e^{−τ_j(t_max)}, and the
    /// weights T·σs/pdf and T/P(pass) are unbiased for every wavelength and bounded by N.
    /// `q` is dz/dt along the ray (depth grows downwards).
    pub fn sample_distance_table(od: &OpticalDepthTable, z0: f32, q: f32, t_max: f32, u: f32, lambda: &SampledWavelengths) -> DistanceSample {
        let live = |j: usize| lambda.pdf[j] > 0.0;
        let n = (0..N_SPECTRUM).filter(|&j| live(j)).count();
        let all_live = SampledSpectrum::from_fn(|j| if live(j) { 1.0 } else { 0.0 });
        if n == 0 || !(t_max > 0.0) {
            return DistanceSample::Pass { weight: all_live };
        }
        let scaled = u.clamp(0.0, ONE_MINUS_EPSILON) * n as f32;
        let k = (scaled as usize).min(n - 1);
        let v = (scaled - k as f32).clamp(0.0, ONE_MINUS_EPSILON);
        let c = (0..N_SPECTRUM).filter(|&j| live(j)).nth(k).unwrap_or(0);
        let tau_star = -(-v).ln_1p();
        // transmittance over [0, t], zero at the live wavelengths that are not
        let tr_to = |t: f32| {
            let tr = if t.is_finite() {
                od.transmittance_all(lambda, z0, z0 + q * t, t)
            } else {
                SampledSpectrum::from_fn(|j| if od.max_sigma_t(lambda.lambda[j]) > 0.0 { 0.0 } else { 1.0 })
            };
            SampledSpectrum::from_fn(|j| if live(j) { tr[j] } else { 0.0 })
        };
        let sane = |w: SampledSpectrum| w.map(|x| if x.is_finite() { x } else { 0.0 });
        match od.invert(lambda.lambda[c], z0, q, tau_star, t_max) {
            Some(t) => {
                let tr = tr_to(t);
                let (a, s) = od.coefficients_all(lambda, z0 + q * t);
                let pdf = (tr * (a + s)).0.iter().sum::<f32>() / n as f32;
                DistanceSample::Scatter { t, weight: if pdf > 0.0 { sane(tr * s / pdf) } else { SampledSpectrum::ZERO } }
            }
            None => {
                let tr = tr_to(t_max);
                let p = tr.0.iter().sum::<f32>() / n as f32;
                DistanceSample::Pass { weight: if p > 0.0 { sane(tr / p) } else { SampledSpectrum::ZERO } }
            }
        }
    }

    /// Transmittance over [0, t]: from the optical-depth table when there is one (exact up to
    /// its interpolation, drawing nothing), else residual ratio tracking (exact and drawing
    /// nothing without a profile).
    pub fn transmittance(&self, origin: Vec3, dir: Vec3, t: f32, rng: &mut impl FnMut() -> f32, lambda: &SampledWavelengths) -> SampledSpectrum {
        let (z0, z1, rise) = self.depth_span(origin, dir, t);
        if let Some(od) = &self.optical_depth {
            if t.is_finite() {
                return od.transmittance_all(lambda, z0, z1, t);
            }
        }
        let (lo, hi) = self.sigma_t_bounds(z0, z1, lambda);
        let rate = (0..lo.0.len()).filter(|&j| lambda.pdf[j] > 0.0).map(|j| hi[j] - lo[j]).fold(0.0f32, f32::max);
        let extra = self.extra(lambda);
        transmittance_ratio_tracking(lo, rate, t, rng, lambda, |s| {
            let (a, b) = self.with_concentrations(self.water.concentrations(z0 - rise * s), extra, lambda);
            a + b
        })
    }

    /// σt bound over all depths.
    pub fn majorant(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        match &self.optical_depth {
            Some(od) => SampledSpectrum::from_fn(|j| od.max_sigma_t(lambda.lambda[j])),
            None => self.sigma_t_bounds(f32::NEG_INFINITY, f32::INFINITY, lambda).1,
        }
    }
}
