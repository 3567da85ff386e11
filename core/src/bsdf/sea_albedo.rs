//! Directional-albedo tables of the single-scattering sea-surface lobe (`sea.rs`), for its
//! multiple-scattering energy compensation (Kulla & Conty 2017, dielectric form). Each node is
//! built once, the first time a lobe needs it, by deterministic quadrature; no generated data is
//! committed.
//!
//! `E(ωo) = ∫(f_r + f_t)|cosθi| dωi` (transmission without the 1/η² radiance scaling, so that a
//! lossless interface has albedo 1) is tabulated for light arriving from the air (relative IOR
//! η) and from the water (1/η), over
//!
//! * μ = |cosθo| ∈ [0, 1], uniform in √μ (denser at grazing angles);
//! * the azimuth φ ∈ [0, π] of ωo relative to the wind (the lobe is anisotropic and, through
//!   the Gram–Charlier skewness, differs upwind and downwind, but it is symmetric about the
//!   wind axis, so φ and −φ share a node); the azimuth is tabulated rather than averaged
//!   because the albedo varies strongly with it: seen from the water 15° below the horizon at
//!   U = 40 m/s it is 0.70 along the wind (φ = 0), 0.82 across it and 0.79 at φ = π, so an
//!   azimuthal average (or an effective isotropic variance) would misstate the loss by up to
//!   0.07 and push some views that far above 1. Nodes every 10°;
//! * the total slope standard deviation σ = √(σ²_up + σ²_cross), uniform in σ from the floored
//!   minimum to the Cox–Munk value at 40 m/s. Each node is the Cox–Munk lobe of the wind whose
//!   total variance is σ² (below the calm-water value, the calm lobe with scaled variances). A
//!   lobe whose variances were scaled (`slopeVarianceScale` ≠ 1) is looked up by its own σ: its
//!   up/cross ratio and Gram–Charlier coefficients then differ from the node's (approximate);
//! * η ∈ [[`ETA_LO`], [`ETA_HI`]] (n_water/n_air over 360–830 nm, salinity and temperature
//!   included, for Quan–Fry n = 1.31–1.36), three nodes (two left errors of 4·10⁻³ from the
//!   water at strong wind, where the critical angle moves with η), clamped outside.
//!
//! Grid: 24 μ × 19 φ × 12 σ × 3 η × 2 sides. A node (one side, η and σ: 456 albedos) is built
//! the first time a lobe needs it, so a scene pays only for its own winds and IORs (about
//! 0.25 s of one core per node; a lobe needs 8). Measured against Monte Carlo furnaces of the
//! lobe, the tabulated albedo is within ±3.3·10⁻³ for U ≥ 5 m/s and within 6.1·10⁻³ for calm
//! water (U ≤ 2) within 6° of the horizon (`cargo test -p tide-core --lib report_table_error
//! -- --ignored --nocapture`).
//!
//! The stored albedo is the quadrature's plus [`TABLE_MARGIN`] (at most 1): an upper bound of
//! the lobe's albedo, so that the compensation, 1 − E, never exceeds the energy actually
//! missing and a white furnace never reads above 1 (it reads 1 − 2·10⁻³ … 1 − 1.3·10⁻²).
//!
//! Each entry is a product Gauss–Legendre quadrature over the slopes standardised along the
//! stretched view azimuth (s₁) and across it (s₂), where the visible projected area is
//! (a − s₁)⁺/a exactly; the region s₁ > a is cut off rather than integrated through. Lookups
//! are multilinear. The hemispherical averages are the exact integrals of the interpolants, so
//! a compensation lobe built from them carries exactly the missing energy.

use super::albedo::{coord, lerp};
use super::fresnel::fresnel_dielectric;

/// Added to every tabulated albedo: the largest difference measured between the quadrature's
/// interpolated albedo and a Monte Carlo furnace of the lobe (6.1·10⁻³, calm water within 6° of
/// the horizon; 3.3·10⁻³ at U ≥ 5 m/s), rounded up.
pub const TABLE_MARGIN: f64 = 6.5e-3;
use super::microfacet::{reflect, refract};
use super::sea::{CoxMunk, MAX_WIND_SPEED};
use glam::Vec3;
use std::sync::OnceLock;

const N_MU: usize = 24;
const N_PHI: usize = 19;
const N_SIGMA: usize = 12;
const N_ETA: usize = 3;
/// Relative IORs of the first and last η nodes.
pub const ETA_LO: f32 = 1.30;
pub const ETA_HI: f32 = 1.37;
/// Composite Gauss–Legendre panels (8 nodes each): along the view azimuth one per
/// [`PANEL_WIDTH_S1`] of the visible range, across it a fixed number. Panels of about one
/// standard deviation resolve the kink where facets reach the critical angle to within
/// 4·10⁻³ of the converged quadrature, mostly within 5·10⁻⁴ (checked against 48 × 32 panels
/// and Monte Carlo: `report_quadrature_convergence` in `sea.rs`).
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

/// The albedos of one (side, η, σ) node over μ and φ, and their hemispherical average.
#[derive(Debug)]
pub struct Block {
    /// [phi · N_MU + mu]
    e: Vec<f32>,
    avg: f32,
}

const N_BLOCKS: usize = 2 * N_ETA * N_SIGMA;

/// Each node is built the first time a lobe needs it, so a scene pays only for the winds and
/// IORs it uses.
static BLOCKS: [OnceLock<Block>; N_BLOCKS] = [const { OnceLock::new() }; N_BLOCKS];
static FRESNEL_AVG: OnceLock<[f32; N_ETA]> = OnceLock::new();

#[inline]
fn block_index(above: bool, k: usize, j: usize) -> usize {
    ((if above { 0 } else { 1 }) * N_ETA + k) * N_SIGMA + j
}

#[inline]
fn block(n: usize) -> &'static Block {
    BLOCKS[n].get_or_init(|| {
        let (side, k, j) = (n / (N_ETA * N_SIGMA), (n / N_SIGMA) % N_ETA, n % N_SIGMA);
        Block::build(&node_lobe(grid_sigma(j, sigma_range())), grid_eta(k), side == 0)
    })
}

/// Hemispherical average Fresnel reflectance from the air at the η nodes.
fn fresnel_avg_nodes() -> &'static [f32; N_ETA] {
    FRESNEL_AVG.get_or_init(|| {
        std::array::from_fn(|k| {
            let eta = grid_eta(k);
            let mut acc = 0.0f64;
            // 2∫F(μ)μ dμ from the air (smooth in μ): composite Gauss–Legendre
            gauss_legendre(0.0, 1.0, 4, |mu, w| acc += w * 2.0 * mu * fresnel_dielectric(mu as f32, eta) as f64);
            acc as f32
        })
    })
}

/// Where a lobe sits on the (σ, η) axes: the four surrounding (σ, η) nodes of each side and
/// the weights between them, found once per lobe, so that a lookup only interpolates in μ and
/// φ.
#[derive(Clone, Copy, Debug)]
pub struct SeaAlbedoKey {
    /// [side][(k − k0) · 2 + (j − j0)]; side 0: the air side.
    nodes: [[&'static Block; 4]; 2],
    tj: f32,
    tk: f32,
    /// Hemispherical average Fresnel reflectance from the air at this η.
    fresnel_avg: f32,
}

#[inline]
fn grid_mu(i: usize) -> f32 {
    super::albedo::grid_mu(i, N_MU)
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
    static RANGE: OnceLock<(f64, f64)> = OnceLock::new();
    *RANGE.get_or_init(|| {
        let lo = total_variance(&CoxMunk::with_variance_scale(0.0, 0.0, 0.0).expect("calm lobe")).sqrt();
        let hi = total_variance(&CoxMunk::new(MAX_WIND_SPEED, 0.0).expect("strongest wind")).sqrt();
        (lo, hi)
    })
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
            // nodes far in the tails (below 10⁻¹² of the mass each) are skipped
            if w1 * w2 * dens < 1e-12 {
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

impl Block {
    fn build(cm: &CoxMunk, eta: f32, above: bool) -> Block {
        let mut e = Vec::with_capacity(N_PHI * N_MU);
        for p in 0..N_PHI {
            let (sp, cp) = grid_phi(p).sin_cos();
            for i in 0..N_MU {
                let mu = grid_mu(i);
                let s = (1.0 - mu * mu).max(0.0).sqrt();
                let z = if above { mu } else { -mu };
                // raised by the tables' error bound so that the compensation never adds more
                // than is missing; clamped at 1 (the clamped Gram–Charlier tail gains up to
                // 10⁻³ at strong wind)
                e.push((sea_albedo(cm, eta, Vec3::new(s * cp, s * sp, z)) + TABLE_MARGIN).min(1.0) as f32);
            }
        }
        // trapezoid weights in φ: the exact mean of the piecewise-linear interpolant
        let over_phi: Vec<f64> = (0..N_MU)
            .map(|i| {
                let sum: f64 = (0..N_PHI).map(|p| if p == 0 || p == N_PHI - 1 { 0.5 } else { 1.0 } * e[p * N_MU + i] as f64).sum();
                sum / (N_PHI - 1) as f64
            })
            .collect();
        Block { avg: hemispherical_integral(&over_phi) as f32, e }
    }

    #[inline]
    fn at(&self, i0: usize, ti: f32, p0: usize, tp: f32) -> f32 {
        let (r0, r1) = (p0 * N_MU, (p0 + 1) * N_MU);
        lerp(tp, lerp(ti, self.e[r0 + i0], self.e[r0 + i0 + 1]), lerp(ti, self.e[r1 + i0], self.e[r1 + i0 + 1]))
    }
}

/// The table coordinates of a lobe with slopes `cm` and relative IOR `eta` (clamped to the
/// tabulated ranges); builds the nodes it needs that are not built yet, in parallel on plain
/// scoped threads (no work stealing, so no other task can run inside this initialisation).
pub fn key(cm: &CoxMunk, eta: f32) -> SeaAlbedoKey {
    let (lo, hi) = sigma_range();
    let sigma = total_variance(cm).sqrt();
    let (j0, _, tj) = coord(((sigma - lo) / (hi - lo)) as f32, N_SIGMA);
    let (k0, _, tk) = coord((eta - ETA_LO) / (ETA_HI - ETA_LO), N_ETA);
    let index = |side: usize, c: usize| block_index(side == 0, k0 + c / 2, j0 + c % 2);
    if (0..8).any(|n| BLOCKS[index(n / 4, n % 4)].get().is_none()) {
        let needed: Vec<usize> = (0..8).map(|n| index(n / 4, n % 4)).collect();
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).clamp(1, needed.len());
        let next = std::sync::atomic::AtomicUsize::new(0);
        std::thread::scope(|scope| {
            for _ in 0..threads {
                scope.spawn(|| {
                    while let Some(&n) = needed.get(next.fetch_add(1, std::sync::atomic::Ordering::Relaxed)) {
                        block(n);
                    }
                });
            }
        });
    }
    let f = fresnel_avg_nodes();
    let fresnel_avg = lerp(tk, f[k0], f[k0 + 1]);
    SeaAlbedoKey { nodes: std::array::from_fn(|side| std::array::from_fn(|c| block(index(side, c)))), tj, tk, fresnel_avg }
}

/// Single-scattering albedo for a view on the air side (`above`) or the water side, at
/// μ = |cosθo| and azimuth `phi` ∈ [0, π] from the wind.
#[inline]
pub fn albedo(key: &SeaAlbedoKey, above: bool, mu: f32, phi: f32) -> f32 {
    let (i0, _, ti) = coord(mu.max(0.0).sqrt(), N_MU);
    let (p0, _, tp) = coord(phi * std::f32::consts::FRAC_1_PI, N_PHI);
    let n = &key.nodes[if above { 0 } else { 1 }];
    let at = |c: usize| n[c].at(i0, ti, p0, tp);
    lerp(key.tk, lerp(key.tj, at(0), at(1)), lerp(key.tj, at(2), at(3)))
}

/// Hemispherical average of [`albedo`] on one side.
pub fn albedo_avg(key: &SeaAlbedoKey, above: bool) -> f32 {
    let n = &key.nodes[if above { 0 } else { 1 }];
    lerp(key.tk, lerp(key.tj, n[0].avg, n[1].avg), lerp(key.tj, n[2].avg, n[3].avg))
}

/// Hemispherical average Fresnel reflectance for light from the air.
pub fn fresnel_avg(key: &SeaAlbedoKey) -> f32 {
    key.fresnel_avg
}

