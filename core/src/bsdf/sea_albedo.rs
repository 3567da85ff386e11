//! Directional-albedo tables of the single-scattering sea-surface lobe (`sea.rs`), for its
//! multiple-scattering energy compensation (Kulla & Conty 2017, dielectric form). Built once, at
//! first use, by deterministic quadrature; no generated data is committed.
//!
//! `E(ωo) = ∫(f_r + f_t)|cosθi| dωi` (transmission without the 1/η² radiance scaling, so that a
//! lossless interface has albedo 1) is tabulated for light arriving from the air (relative IOR
//! η) and from the water (1/η), over
//!
//! * μ = |cosθo| ∈ [0, 1], uniform in √μ (denser at grazing angles);
//! * the azimuth φ ∈ [0, π] of ωo relative to the wind (the lobe is anisotropic and, through
//!   the Gram–Charlier skewness, differs upwind and downwind, but it is symmetric about the
//!   wind axis, so φ and −φ share a node); the azimuth is tabulated rather than averaged
//!   because the albedo seen from the water varies by up to ±0.03 with it at strong wind, and
//!   an azimuthal average would push some views above 1;
//! * the total slope standard deviation σ = √(σ²_up + σ²_cross), uniform in σ from the floored
//!   minimum to the Cox–Munk value at 40 m/s. Each node is the Cox–Munk lobe of the wind whose
//!   total variance is σ² (below the calm-water value, the calm lobe with scaled variances). A
//!   lobe whose variances were scaled (`slopeVarianceScale` ≠ 1) is looked up by its own σ: its
//!   up/cross ratio and Gram–Charlier coefficients then differ from the node's (approximate);
//! * η ∈ [[`ETA_LO`], [`ETA_HI`]] (n_water/n_air over 360–830 nm, salinity and temperature
//!   included, for Quan–Fry n = 1.31–1.36), two nodes, clamped outside.
//!
//! Each entry is a product Gauss–Legendre quadrature over the slopes standardised along the
//! stretched view azimuth (s₁) and across it (s₂), where the visible projected area is
//! (a − s₁)⁺/a exactly; the region s₁ > a is cut off rather than integrated through. Lookups
//! are multilinear. The hemispherical averages are the exact integrals of the interpolants, so
//! a compensation lobe built from them carries exactly the missing energy.

use super::fresnel::fresnel_dielectric;
use super::microfacet::{reflect, refract};
use super::sea::{CoxMunk, MAX_WIND_SPEED};
use glam::Vec3;
use std::sync::OnceLock;

const N_MU: usize = 16;
const N_PHI: usize = 9;
const N_SIGMA: usize = 12;
const N_ETA: usize = 2;
/// Relative IORs of the two η nodes.
pub const ETA_LO: f32 = 1.30;
pub const ETA_HI: f32 = 1.37;
/// Composite Gauss–Legendre panels (8 nodes each): along the view azimuth one per
/// [`PANEL_WIDTH_S1`] of the visible range, across it a fixed number. Panels of about one
/// standard deviation resolve the kink where facets reach the critical angle to within
/// about 3·10⁻³ of the converged quadrature (checked against 48 × 32 panels and Monte Carlo),
/// mostly within 5·10⁻⁴.
const PANEL_WIDTH_S1: f64 = 1.1;
const PANELS_S2: usize = 6;
/// Standardised slopes beyond this carry less than 10⁻⁶ of the (Gram–Charlier) mass.
const SLOPE_RANGE: f64 = 5.5;

/// 8-point Gauss–Legendre nodes and weights on [−1, 1] (positive half).
const GL8: [(f64, f64); 4] = [
    (0.183_434_642_495_649_8, 0.362_683_783_378_362_0),
    (0.525_532_409_916_329_0, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_5),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_3),
];

/// Calls `f(x, w)` for the nodes and weights of a composite 8-point Gauss–Legendre rule of
/// `panels` panels on [lo, hi].
fn gauss_legendre(lo: f64, hi: f64, panels: usize, mut f: impl FnMut(f64, f64)) {
    let h = (hi - lo) / panels as f64;
    for p in 0..panels {
        let mid = lo + (p as f64 + 0.5) * h;
        for &(x, w) in GL8.iter() {
            f(mid - 0.5 * h * x, 0.5 * h * w);
            f(mid + 0.5 * h * x, 0.5 * h * w);
        }
    }
}

pub struct SeaAlbedoTables {
    /// [side][((eta · N_SIGMA + sigma) · N_PHI + phi) · N_MU + mu]; side 0: ωo in the air.
    e: [Vec<f32>; 2],
    /// [side][eta · N_SIGMA + sigma]: hemispherical averages of the interpolant.
    avg: [Vec<f32>; 2],
    /// Hemispherical average Fresnel reflectance from the air at the η nodes.
    fresnel_avg: [f32; N_ETA],
}

static TABLES: OnceLock<SeaAlbedoTables> = OnceLock::new();

/// The tables, built on first call.
pub fn tables() -> &'static SeaAlbedoTables {
    TABLES.get_or_init(SeaAlbedoTables::build)
}

/// Where a lobe sits on the (σ, η) axes: precomputed once per lobe, so that a lookup only
/// interpolates in μ and φ at the four surrounding (σ, η) nodes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeaAlbedoKey {
    j0: u8,
    k0: u8,
    tj: f32,
    tk: f32,
}

#[inline]
fn grid_mu(i: usize) -> f32 {
    let x = i as f32 / (N_MU - 1) as f32;
    (x * x).max(1e-4)
}

#[inline]
fn grid_phi(p: usize) -> f32 {
    std::f32::consts::PI * p as f32 / (N_PHI - 1) as f32
}

#[inline]
fn grid_eta(k: usize) -> f32 {
    ETA_LO + (ETA_HI - ETA_LO) * k as f32 / (N_ETA - 1) as f32
}

/// Total slope variance σ²_up + σ²_cross of a distribution.
#[inline]
fn total_variance(cm: &CoxMunk) -> f64 {
    let (u, c) = (cm.sigma_up as f64, cm.sigma_cross as f64);
    u * u + c * c
}

/// The smallest and largest total slope standard deviations: both variances floored, and the
/// Cox–Munk lobe at the strongest accepted wind.
fn sigma_range() -> (f64, f64) {
    let lo = total_variance(&CoxMunk::with_variance_scale(0.0, 0.0, 0.0).expect("calm lobe")).sqrt();
    let hi = total_variance(&CoxMunk::new(MAX_WIND_SPEED, 0.0).expect("strongest wind")).sqrt();
    (lo, hi)
}

#[inline]
fn grid_sigma(j: usize, (lo, hi): (f64, f64)) -> f64 {
    lo + (hi - lo) * j as f64 / (N_SIGMA - 1) as f64
}

/// Increasing `g` on [0, hi]: x with g(x) = target, by bisection (table build only).
fn bisect(g: impl Fn(f64) -> f64, target: f64, hi: f64) -> f64 {
    let (mut a, mut b) = (0.0, hi);
    for _ in 0..60 {
        let m = 0.5 * (a + b);
        if g(m) < target {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

/// The node lobe of total slope standard deviation `sigma`, wind along +X: the Cox–Munk lobe
/// of the wind with that total variance, or below calm water the calm lobe scaled down.
fn node_lobe(sigma: f64) -> CoxMunk {
    let v = sigma * sigma;
    let calm = total_variance(&CoxMunk::new(0.0, 0.0).expect("calm lobe"));
    if v >= calm {
        let u = bisect(|u| total_variance(&CoxMunk::new(u as f32, 0.0).expect("wind")), v, MAX_WIND_SPEED as f64);
        CoxMunk::new((u as f32).min(MAX_WIND_SPEED), 0.0).expect("wind")
    } else {
        let s = bisect(|s| total_variance(&CoxMunk::with_variance_scale(0.0, 0.0, s as f32).expect("scale")), v, 1.0);
        CoxMunk::with_variance_scale(0.0, 0.0, s as f32).expect("scale")
    }
}

/// Single-scattering albedo of the sea lobe `cm` (relative IOR `eta` = n_below / n_above) for
/// the view `wo` (either side; no η² scaling), by quadrature over the visible slopes:
/// E = ∫ p(ζ) (a − s₁)⁺/a · [F G₂(ωo, ωr) + (1 − F) G₂(ωo, ωt)] dζ, with G₂ zero where the
/// scattered direction leaves on the wrong side.
pub(crate) fn sea_albedo(cm: &CoxMunk, eta: f32, wo: Vec3) -> f64 {
    sea_albedo_quadrature(cm, eta, wo, 0, PANELS_S2)
}

/// [`sea_albedo`] with `panels_s1` panels along the view azimuth (0: one per
/// [`PANEL_WIDTH_S1`]) and `panels_s2` across.
pub(crate) fn sea_albedo_quadrature(cm: &CoxMunk, eta: f32, wo: Vec3, panels_s1: usize, panels_s2: usize) -> f64 {
    let v = if wo.z < 0.0 { -wo } else { wo };
    let (tu, tc) = cm.wind_components(v);
    let (su, sc) = ((cm.sigma_up * tu) as f64, (cm.sigma_cross * tc) as f64);
    let r = (su * su + sc * sc).sqrt();
    let z = v.z as f64;
    // unit stretched view azimuth (along, across the wind) and a = cosθ/r
    let (ea, eb, a) = if r <= 1e-12 * z { (1.0, 0.0, f64::INFINITY) } else { (su / r, sc / r, z / r) };
    let lam_o = cm.lambda(wo);
    let top = a.min(SLOPE_RANGE);
    let panels_s1 = if panels_s1 > 0 { panels_s1 } else { ((top + SLOPE_RANGE) / PANEL_WIDTH_S1).ceil().max(1.0) as usize };
    let mut acc = 0.0f64;
    gauss_legendre(-SLOPE_RANGE, top, panels_s1, |s1, w1| {
        let vis = if a.is_finite() { (a - s1) / a } else { 1.0 };
        let g1 = (-0.5 * s1 * s1).exp();
        gauss_legendre(-SLOPE_RANGE, SLOPE_RANGE, panels_s2, |s2, w2| {
            let h = s1 * ea - s2 * eb; // standardised slope along the wind
            let x = s1 * eb + s2 * ea; // across
            let dens = g1 * (-0.5 * s2 * s2).exp() / (2.0 * std::f64::consts::PI)
                * cm.gram_charlier(x as f32, h as f32) as f64;
            if dens == 0.0 {
                return;
            }
            let m = cm.normal((h * cm.sigma_up as f64) as f32, (x * cm.sigma_cross as f64) as f32);
            let c = wo.dot(m);
            let f = fresnel_dielectric(c, eta);
            let mut wsum = 0.0f32;
            let wr = reflect(wo, m);
            if wr.z * wo.z > 0.0 {
                wsum += f / (1.0 + lam_o + cm.lambda(wr));
            }
            if f < 1.0 {
                if let Some((wt, _)) = refract(wo, m, eta) {
                    if wt.z * wo.z < 0.0 {
                        wsum += (1.0 - f) / (1.0 + lam_o + cm.lambda(wt));
                    }
                }
            }
            acc += w1 * w2 * dens * vis * wsum as f64;
        });
    });
    acc
}

/// The N_PHI · N_MU albedos of one (side, η, σ) node, clamped at 1 (the clamped Gram–Charlier
/// tail gains up to 10⁻³ at strong wind).
fn albedo_block(cm: &CoxMunk, eta: f32, above: bool) -> Vec<f32> {
    let mut b = Vec::with_capacity(N_PHI * N_MU);
    for p in 0..N_PHI {
        let (sp, cp) = grid_phi(p).sin_cos();
        for i in 0..N_MU {
            let mu = grid_mu(i);
            let s = (1.0 - mu * mu).max(0.0).sqrt();
            let z = if above { mu } else { -mu };
            b.push(sea_albedo(cm, eta, Vec3::new(s * cp, s * sp, z)).min(1.0) as f32);
        }
    }
    b
}

/// Exact ∫₀¹ 2μ E(μ) dμ of an interpolant linear in x = √μ between nodes uniform in x:
/// ∫₀¹ 4x³ E(x) dx, a quartic per interval, integrated by 3-point Gauss–Legendre.
fn hemispherical_integral(e: &[f64]) -> f64 {
    const GL3: [(f64, f64); 3] = [
        (0.5 - 0.387_298_334_620_741_7, 5.0 / 18.0),
        (0.5, 8.0 / 18.0),
        (0.5 + 0.387_298_334_620_741_7, 5.0 / 18.0),
    ];
    let h = 1.0 / (e.len() - 1) as f64;
    let mut acc = 0.0;
    for i in 0..e.len() - 1 {
        for &(s, w) in GL3.iter() {
            let x = (i as f64 + s) * h;
            acc += w * h * 4.0 * x * x * x * (e[i] + (e[i + 1] - e[i]) * s);
        }
    }
    acc
}

impl SeaAlbedoTables {
    fn build() -> Self {
        let range = sigma_range();
        let lobes: Vec<CoxMunk> = (0..N_SIGMA).map(|j| node_lobe(grid_sigma(j, range))).collect();
        // one block of N_PHI · N_MU entries per (side, η, σ), computed on plain scoped threads
        // (no work stealing, so no other task can run inside this one-time initialisation)
        let jobs: Vec<(usize, usize, usize)> =
            (0..2).flat_map(|side| (0..N_ETA).flat_map(move |k| (0..N_SIGMA).map(move |j| (side, k, j)))).collect();
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).clamp(1, 16);
        let next = std::sync::atomic::AtomicUsize::new(0);
        let mut blocks: Vec<Vec<f32>> = vec![Vec::new(); jobs.len()];
        let done: Vec<Vec<(usize, Vec<f32>)>> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..threads)
                .map(|_| {
                    scope.spawn(|| {
                        let mut out = Vec::new();
                        loop {
                            let n = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                            let Some(&(side, k, j)) = jobs.get(n) else { break };
                            out.push((n, albedo_block(&lobes[j], grid_eta(k), side == 0)));
                        }
                        out
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().expect("sea albedo table thread")).collect()
        });
        for (n, b) in done.into_iter().flatten() {
            blocks[n] = b;
        }
        let per_side = N_ETA * N_SIGMA * N_PHI * N_MU;
        let mut e = [Vec::with_capacity(per_side), Vec::with_capacity(per_side)];
        let mut avg = [vec![0.0f32; N_ETA * N_SIGMA], vec![0.0f32; N_ETA * N_SIGMA]];
        for (&(side, k, j), b) in jobs.iter().zip(&blocks) {
            e[side].extend_from_slice(b);
            // trapezoid weights in φ: the exact mean of the piecewise-linear interpolant
            let over_phi: Vec<f64> = (0..N_MU)
                .map(|i| {
                    (0..N_PHI)
                        .map(|p| {
                            let w = if p == 0 || p == N_PHI - 1 { 0.5 } else { 1.0 };
                            w * b[p * N_MU + i] as f64
                        })
                        .sum::<f64>()
                        / (N_PHI - 1) as f64
                })
                .collect();
            avg[side][k * N_SIGMA + j] = hemispherical_integral(&over_phi) as f32;
        }
        let fresnel_avg = std::array::from_fn(|k| {
            let eta = grid_eta(k);
            let mut acc = 0.0f64;
            // 2∫F(μ)μ dμ from the air (smooth in μ): composite Gauss–Legendre
            gauss_legendre(0.0, 1.0, 4, |mu, w| acc += w * 2.0 * mu * fresnel_dielectric(mu as f32, eta) as f64);
            acc as f32
        });
        SeaAlbedoTables { e, avg, fresnel_avg }
    }

    /// The table coordinates of a lobe with slopes `cm` and relative IOR `eta` (clamped to the
    /// tabulated ranges).
    pub fn key(&self, cm: &CoxMunk, eta: f32) -> SeaAlbedoKey {
        let (lo, hi) = sigma_range();
        let sigma = total_variance(cm).sqrt();
        let (j0, _, tj) = coord(((sigma - lo) / (hi - lo)) as f32, N_SIGMA);
        let (k0, _, tk) = coord((eta - ETA_LO) / (ETA_HI - ETA_LO), N_ETA);
        SeaAlbedoKey { j0: j0 as u8, k0: k0 as u8, tj, tk }
    }

    /// Single-scattering albedo for a view on the air side (`above`) or the water side, at
    /// μ = |cosθo| and azimuth `phi` ∈ [0, π] from the wind.
    #[inline]
    pub fn albedo(&self, key: &SeaAlbedoKey, above: bool, mu: f32, phi: f32) -> f32 {
        let t = &self.e[if above { 0 } else { 1 }];
        let (i0, i1, ti) = coord(mu.max(0.0).sqrt(), N_MU);
        let (p0, p1, tp) = coord(phi * std::f32::consts::FRAC_1_PI, N_PHI);
        let at = |k: usize, j: usize| {
            let base = (k * N_SIGMA + j) * N_PHI;
            let r0 = (base + p0) * N_MU;
            let r1 = (base + p1) * N_MU;
            lerp(tp, lerp(ti, t[r0 + i0], t[r0 + i1]), lerp(ti, t[r1 + i0], t[r1 + i1]))
        };
        let (j0, k0) = (key.j0 as usize, key.k0 as usize);
        let a = lerp(key.tj, at(k0, j0), at(k0, j0 + 1));
        let b = lerp(key.tj, at(k0 + 1, j0), at(k0 + 1, j0 + 1));
        lerp(key.tk, a, b)
    }

    /// Hemispherical average of [`Self::albedo`] on one side.
    pub fn albedo_avg(&self, key: &SeaAlbedoKey, above: bool) -> f32 {
        let t = &self.avg[if above { 0 } else { 1 }];
        let (j0, k0) = (key.j0 as usize, key.k0 as usize);
        let a = lerp(key.tj, t[k0 * N_SIGMA + j0], t[k0 * N_SIGMA + j0 + 1]);
        let b = lerp(key.tj, t[(k0 + 1) * N_SIGMA + j0], t[(k0 + 1) * N_SIGMA + j0 + 1]);
        lerp(key.tk, a, b)
    }

    /// Hemispherical average Fresnel reflectance for light from the air.
    pub fn fresnel_avg(&self, key: &SeaAlbedoKey) -> f32 {
        lerp(key.tk, self.fresnel_avg[key.k0 as usize], self.fresnel_avg[key.k0 as usize + 1])
    }
}

#[inline]
fn lerp(t: f32, a: f32, b: f32) -> f32 {
    a + (b - a) * t
}

/// Cell indices and weight of x ∈ [0, 1] (clamped) on a uniform grid of n nodes.
#[inline]
fn coord(x: f32, n: usize) -> (usize, usize, f32) {
    let x = if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 } * (n - 1) as f32;
    let i0 = (x as usize).min(n - 2);
    (i0, i0 + 1, x - i0 as f32)
}
