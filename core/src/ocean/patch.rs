//! One periodic patch of ocean at one time: random spectral amplitudes from the seed, their
//! evolution under ω² = g k, and the inverse FFTs that give heights, choppy horizontal
//! displacements and exact normals on the N×N grid.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::fft::{Fft, C64};
use super::rng::gaussian_pair;
use super::spectrum::{cox_munk_mss, dispersion, wavenumber_spectrum};
use super::{OceanError, OceanParams};

/// The surface at one point of the patch, evaluated exactly from the Fourier series.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// Elevation η (m).
    pub height: f64,
    /// Horizontal displacement λ·D (x, z) in metres.
    pub displacement: [f64; 2],
    /// Height gradient (∂η/∂x, ∂η/∂z) with respect to the undisplaced coordinates.
    pub slope: [f64; 2],
    /// Unit normal of the displaced surface.
    pub normal: [f64; 3],
}

/// The synthesised patch. Grid arrays are row-major with `index = q * N + p`, p along X and
/// q along Z; sample (p, q) sits at (p, q)·L/N before displacement.
#[derive(Clone, Debug)]
pub struct OceanPatch {
    params: OceanParams,
    time: f64,
    n: usize,
    heights: Vec<f32>,
    displacements: Vec<Vec2>,
    normals: Vec<Vec3>,
    /// h(k, t) at `[n_index * N + m_index]`, m along kx.
    coefficients: Vec<C64>,
}

/// Signed frequency index of FFT bin `i` of `n`: 0..n/2−1, then −n/2..−1.
#[inline]
pub(crate) fn signed_index(i: usize, n: usize) -> i64 {
    if i < n / 2 {
        i as i64
    } else {
        i as i64 - n as i64
    }
}

/// The random amplitudes a(k) of the params' sea, `[n_index * N + m_index]`.
pub(crate) fn amplitudes(params: &OceanParams) -> Vec<C64> {
    let n = params.resolution as usize;
    let l = params.patch_size as f64;
    let dk = 2.0 * std::f64::consts::PI / l;
    let u = params.wind_speed as f64;
    let wind = params.wind_vector();
    let kind = params.spectrum;
    let seed = params.seed;
    let mut a = vec![C64::ZERO; n * n];
    a.par_chunks_mut(n).enumerate().for_each(|(ni, row)| {
        let nn = signed_index(ni, n);
        for (mi, out) in row.iter_mut().enumerate() {
            let mm = signed_index(mi, n);
            if mm == -(n as i64 / 2) || nn == -(n as i64 / 2) || (mm == 0 && nn == 0) {
                continue;
            }
            let psi = wavenumber_spectrum(kind, u, wind, mm as f64 * dk, nn as f64 * dk);
            if psi > 0.0 {
                let (g1, g2) = gaussian_pair(seed, mm as i32, nn as i32);
                let s = 0.5 * libm::sqrt(psi) * dk;
                *out = C64::new(g1 * s, g2 * s);
            }
        }
    });
    a
}

/// The exact expectation over seeds of the patch's spatial variance of η (m²) and of its
/// mean-square slope, Σ Ψ(k) Δk² and Σ |k|² Ψ(k) Δk² over the grid's wavevectors, with the
/// variances of those two sample statistics (each h(k) is circular Gaussian, h(−k) its conjugate).
pub(crate) fn resolved_moments(params: &OceanParams) -> ResolvedMoments {
    let n = params.resolution as usize;
    let dk = 2.0 * std::f64::consts::PI / params.patch_size as f64;
    let u = params.wind_speed as f64;
    let wind = params.wind_vector();
    let half = n as i64 / 2;
    let mut m = ResolvedMoments::default();
    for nn in -half + 1..half {
        for mm in -half + 1..half {
            if mm == 0 && nn == 0 {
                continue;
            }
            let (kx, kz) = (mm as f64 * dk, nn as f64 * dk);
            let psi = wavenumber_spectrum(params.spectrum, u, wind, kx, kz) * dk * dk;
            let k2 = kx * kx + kz * kz;
            m.height_variance += psi;
            m.slope_variance += k2 * psi;
            // count each ± pair once: V = Σ_pairs 2|h|², |h|² exponential with mean s
            if (nn, mm) > (0, 0) {
                let psi_neg = wavenumber_spectrum(params.spectrum, u, wind, -kx, -kz) * dk * dk;
                let s = 0.5 * (psi + psi_neg);
                m.height_variance_var += 4.0 * s * s;
                m.slope_variance_var += 4.0 * k2 * k2 * s * s;
            }
        }
    }
    m
}

#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct ResolvedMoments {
    pub height_variance: f64,
    pub slope_variance: f64,
    pub height_variance_var: f64,
    pub slope_variance_var: f64,
}

impl OceanPatch {
    /// Synthesises the patch of `params` at `time` seconds.
    pub fn new(params: &OceanParams, time: f64) -> Result<Self, OceanError> {
        params.validate()?;
        if !time.is_finite() {
            return Err(OceanError { parameter: "time", message: format!("must be a finite time in seconds, got {time}") });
        }
        Ok(Self::from_amplitudes(params, &amplitudes(params), time))
    }

    /// Synthesis from given amplitudes a(k) (`[n_index * N + m_index]`); `params` valid.
    pub(crate) fn from_amplitudes(params: &OceanParams, a: &[C64], time: f64) -> Self {
        let n = params.resolution as usize;
        let dk = 2.0 * std::f64::consts::PI / params.patch_size as f64;
        let lambda = params.choppiness as f64;
        let mut coefficients = vec![C64::ZERO; n * n];
        // four packed spectra: each pair of real fields f, g travels as F + iG
        let mut packed: [Vec<C64>; 4] = std::array::from_fn(|_| vec![C64::ZERO; n * n]);
        for ni in 0..n {
            let nn = signed_index(ni, n);
            for mi in 0..n {
                let mm = signed_index(mi, n);
                let i = ni * n + mi;
                let j = ((n - ni) % n) * n + (n - mi) % n;
                if a[i] == C64::ZERO && a[j] == C64::ZERO {
                    continue;
                }
                let (kx, kz) = (mm as f64 * dk, nn as f64 * dk);
                let k = libm::sqrt(kx * kx + kz * kz);
                let wt = dispersion(k) * time;
                let rot = C64::cis(-wt);
                let h = a[i] * rot + a[j].conj() * rot.conj();
                coefficients[i] = h;
                let ih = h.times_i();
                let eta = h;
                let dx = ih.scale(lambda * kx / k);
                let dz = ih.scale(lambda * kz / k);
                let sx = ih.scale(kx);
                let sz = ih.scale(kz);
                let jxx = h.scale(-lambda * kx * kx / k);
                let jxz = h.scale(-lambda * kx * kz / k);
                let jzz = h.scale(-lambda * kz * kz / k);
                packed[0][i] = eta + dx.times_i();
                packed[1][i] = sx + sz.times_i();
                packed[2][i] = dz + jxx.times_i();
                packed[3][i] = jxz + jzz.times_i();
            }
        }
        let fft = Fft::new(n);
        packed.par_iter_mut().for_each(|f| fft.inverse_2d(f));
        let mut heights = vec![0.0f32; n * n];
        let mut displacements = vec![Vec2::ZERO; n * n];
        let mut normals = vec![Vec3::Y; n * n];
        for i in 0..n * n {
            let (eta, dx) = (packed[0][i].re, packed[0][i].im);
            let (sx, sz) = (packed[1][i].re, packed[1][i].im);
            let (dz, jxx) = (packed[2][i].re, packed[2][i].im);
            let (jxz, jzz) = (packed[3][i].re, packed[3][i].im);
            heights[i] = eta as f32;
            displacements[i] = Vec2::new(dx as f32, dz as f32);
            let nrm = surface_normal(sx, sz, jxx, jxz, jzz);
            normals[i] = Vec3::new(nrm[0] as f32, nrm[1] as f32, nrm[2] as f32);
        }
        OceanPatch { params: params.clone(), time, n, heights, displacements, normals, coefficients }
    }

    pub fn params(&self) -> &OceanParams {
        &self.params
    }
    pub fn time(&self) -> f64 {
        self.time
    }
    /// Samples N per side.
    pub fn resolution(&self) -> usize {
        self.n
    }
    /// Side L (m).
    pub fn patch_size(&self) -> f32 {
        self.params.patch_size
    }
    /// Elevations η, `[q * N + p]`.
    pub fn heights(&self) -> &[f32] {
        &self.heights
    }
    /// Horizontal displacements λ·D (x, z), `[q * N + p]`.
    pub fn displacements(&self) -> &[Vec2] {
        &self.displacements
    }
    /// Unit normals of the displaced surface, `[q * N + p]`.
    pub fn normals(&self) -> &[Vec3] {
        &self.normals
    }
    /// Elevation at grid sample (p, q), indices taken modulo N (the patch is periodic).
    pub fn height(&self, p: i64, q: i64) -> f32 {
        self.heights[self.index(p, q)]
    }
    /// Unit normal at grid sample (p, q), modulo N.
    pub fn normal(&self, p: i64, q: i64) -> Vec3 {
        self.normals[self.index(p, q)]
    }
    /// Horizontal displacement at grid sample (p, q), modulo N.
    pub fn displacement(&self, p: i64, q: i64) -> Vec2 {
        self.displacements[self.index(p, q)]
    }
    /// Displaced position of grid sample (p, q) (not wrapped: p = N lies one patch over).
    pub fn position(&self, p: i64, q: i64) -> Vec3 {
        let d = self.params.patch_size as f64 / self.n as f64;
        let disp = self.displacement(p, q);
        Vec3::new((p as f64 * d) as f32 + disp.x, self.height(p, q), (q as f64 * d) as f32 + disp.y)
    }

    #[inline]
    fn index(&self, p: i64, q: i64) -> usize {
        let n = self.n as i64;
        (q.rem_euclid(n) * n + p.rem_euclid(n)) as usize
    }

    /// Spatial variance of the heights (m²); their mean is 0 by construction.
    pub fn height_variance(&self) -> f64 {
        self.heights.iter().map(|&h| (h as f64) * (h as f64)).sum::<f64>() / self.heights.len() as f64
    }

    /// The patch's significant wave height 4·√(variance) (m).
    pub fn significant_wave_height(&self) -> f64 {
        4.0 * self.height_variance().sqrt()
    }

    /// Mean over the grid of the squared slope (∂y/∂x)² + (∂y/∂z)² of the displaced surface,
    /// from its normals.
    pub fn slope_variance(&self) -> f64 {
        self.normals
            .iter()
            .map(|n| {
                let (sx, sz) = (-n.x as f64 / n.y as f64, -n.z as f64 / n.y as f64);
                sx * sx + sz * sz
            })
            .sum::<f64>()
            / self.normals.len() as f64
    }

    /// Expected mean-square slope of the waves this grid resolves, Σ |k|² Ψ(k) Δk².
    pub fn resolved_slope_variance(&self) -> f64 {
        resolved_moments(&self.params).slope_variance
    }

    /// Cox–Munk mean-square slope at this wind minus what the grid resolves (never below 0):
    /// the sub-grid roughness left for the sea-surface BSDF.
    pub fn subgrid_slope_variance(&self) -> f64 {
        (cox_munk_mss(self.params.wind_speed as f64) - self.resolved_slope_variance()).max(0.0)
    }

    /// The surface at undisplaced point (x, z), summed exactly from the Fourier series:
    /// O(N²) per call, for checks and single queries.
    pub fn evaluate(&self, x: f64, z: f64) -> SurfacePoint {
        let n = self.n;
        let dk = 2.0 * std::f64::consts::PI / self.params.patch_size as f64;
        let lambda = self.params.choppiness as f64;
        let (mut eta, mut dx, mut dz, mut sx, mut sz, mut jxx, mut jxz, mut jzz) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for ni in 0..n {
            let kz = signed_index(ni, n) as f64 * dk;
            for mi in 0..n {
                let h = self.coefficients[ni * n + mi];
                if h == C64::ZERO {
                    continue;
                }
                let kx = signed_index(mi, n) as f64 * dk;
                let k = libm::sqrt(kx * kx + kz * kz);
                let e = h * C64::cis(kx * x + kz * z);
                // Re(i e) = −Im(e)
                eta += e.re;
                dx -= lambda * kx / k * e.im;
                dz -= lambda * kz / k * e.im;
                sx -= kx * e.im;
                sz -= kz * e.im;
                jxx -= lambda * kx * kx / k * e.re;
                jxz -= lambda * kx * kz / k * e.re;
                jzz -= lambda * kz * kz / k * e.re;
            }
        }
        SurfacePoint { height: eta, displacement: [dx, dz], slope: [sx, sz], normal: surface_normal(sx, sz, jxx, jxz, jzz) }
    }
}

/// Unit normal ∂P/∂z × ∂P/∂x of P(x, z) = (x + Dx, η, z + Dz), from the slopes and the
/// displacement gradients (Jxx = ∂Dx/∂x, Jxz = ∂Dx/∂z = ∂Dz/∂x, Jzz = ∂Dz/∂z).
fn surface_normal(sx: f64, sz: f64, jxx: f64, jxz: f64, jzz: f64) -> [f64; 3] {
    let tx = [1.0 + jxx, sx, jxz];
    let tz = [jxz, sz, 1.0 + jzz];
    let c = [tz[1] * tx[2] - tz[2] * tx[1], tz[2] * tx[0] - tz[0] * tx[2], tz[0] * tx[1] - tz[1] * tx[0]];
    let len = libm::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    if len > 0.0 && len.is_finite() {
        [c[0] / len, c[1] / len, c[2] / len]
    } else {
        [0.0, 1.0, 0.0]
    }
}
