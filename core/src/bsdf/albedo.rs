//! Directional-albedo tables of the single-scattering GGX lobes, used for multiple-scattering
//! energy compensation (Kulla & Conty 2017) and for energy-conserving layering. They are built
//! once per process by deterministic quasi-Monte Carlo (a Fibonacci lattice over the
//! visible-normal sampler), so no generated data is committed: the conductor's rows in parallel
//! ([`rows_in_parallel`]), started by the world's build beside the BVH's; the dielectric's per
//! relative IOR node and side when a lookup first needs it (a scene of water and glass reads a
//! few of the 48, and building them all took most of the tables' time).
//!
//! The tables live on grids over μ = |cosθo| ∈ [0, 1] (uniform in √μ, denser at grazing
//! angles), perceptual roughness r = √α ∈ [0, 1] and, for the dielectric, relative IOR η ∈
//! [1, 3] (uniform in √(η − 1)); they are interpolated (bi/tri)linearly:
//!
//! * conductor, `E1(μ, r)`: albedo with F = 1; `S(μ, r)`: albedo weighted by (1 − ωo·ωm)⁵, so
//!   that a Schlick lobe has albedo F0·E1 + (1 − F0)·S exactly;
//! * dielectric, `E(μ, r, η)` for light arriving from the less dense side (η ≥ 1) and from the
//!   denser side (relative IOR 1/η), reflection plus transmission, exact Fresnel, transmission
//!   counted without the 1/η² radiance scaling (so that a smooth interface has albedo 1).
//!
//! Hemispherical averages 2∫E(μ)μ dμ are the exact integrals of the interpolants, so a
//! compensation lobe built from them integrates exactly to the missing energy.

use super::fresnel::fresnel_dielectric;
use super::microfacet::{reflect, refract, TrowbridgeReitz};
use glam::{Vec2, Vec3};
use std::sync::OnceLock;

const COND_MU: usize = 32;
const COND_R: usize = 32;
const DIEL_MU: usize = 24;
const DIEL_R: usize = 16;
const DIEL_ETA: usize = 24;
/// Largest tabulated relative IOR (larger values are clamped to it).
pub const DIEL_ETA_MAX: f32 = 3.0;
/// Fibonacci lattices (F_k, F_(k−1)) used as sample sets.
const COND_LATTICE: (usize, usize) = (233, 144);
/// 377 points for the dielectric: the compensation of one interface is then within 0.6 % of
/// lossless (1.1 % with 89, whose error compounded over the bounces inside a rough water
/// ball to 2.4 % at its rim); a block of the table (one η node, one side) takes about 10 ms.
const DIEL_LATTICE: (usize, usize) = (377, 233);

pub struct AlbedoTables {
    cond_e1: Vec<f32>,
    cond_s: Vec<f32>,
    cond_e1_avg: Vec<f32>,
    cond_s_avg: Vec<f32>,
    /// [side][η node], built on first use; side 0: from the less dense side.
    diel: [Vec<OnceLock<DielBlock>>; 2],
}

/// The dielectric's rows of one relative IOR node on one side.
#[derive(Debug, PartialEq)]
struct DielBlock {
    /// [r * DIEL_MU + mu]
    e: Vec<f32>,
    /// [r]: hemispherical averages
    avg: Vec<f32>,
}

impl DielBlock {
    /// The rows of η node `k` on `side` (each a function of its indices alone: the same
    /// whichever thread builds it, whenever).
    fn build(side: usize, k: usize) -> DielBlock {
        let eta = if side == 0 { grid_eta(k) } else { 1.0 / grid_eta(k) };
        let rows: Vec<Vec<f32>> = (0..DIEL_R)
            .map(|j| {
                let alpha = grid_alpha(j, DIEL_R);
                (0..DIEL_MU).map(|i| dielectric_albedo(grid_mu(i, DIEL_MU), alpha, eta).min(1.0)).collect()
            })
            .collect();
        DielBlock { avg: rows.iter().map(|r| hemispherical_integral(r)).collect(), e: rows.concat() }
    }
}

impl PartialEq for AlbedoTables {
    /// Equal tables, every dielectric block built to compare it.
    fn eq(&self, other: &Self) -> bool {
        self.cond_e1 == other.cond_e1
            && self.cond_s == other.cond_s
            && self.cond_e1_avg == other.cond_e1_avg
            && self.cond_s_avg == other.cond_s_avg
            && (0..2).all(|side| (0..DIEL_ETA).all(|k| self.diel_block(side, k) == other.diel_block(side, k)))
    }
}

static TABLES: OnceLock<AlbedoTables> = OnceLock::new();

/// The tables, built on first call.
pub fn tables() -> &'static AlbedoTables {
    TABLES.get_or_init(AlbedoTables::build)
}

/// `f(0)`, …, `f(n − 1)` computed on scoped threads, one per core (rows dealt round robin),
/// returned in order. Not on rayon's pool: the tables are built inside a `OnceLock`, and a rayon
/// thread waiting there for its rows could pick up render work that asks for the same table,
/// initialising it re-entrantly (a deadlock); these threads only ever run the rows.
pub(crate) fn rows_in_parallel<T: Send>(n: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
    rows_on(std::thread::available_parallelism().map_or(1, |c| c.get()), n, f)
}

/// [`rows_in_parallel`] on `threads` threads (at least one, at most one per row).
pub(crate) fn rows_on<T: Send>(threads: usize, n: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
    let threads = threads.clamp(1, n.max(1));
    let mut done: Vec<(usize, T)> = std::thread::scope(|s| {
        let f = &f;
        let workers: Vec<_> = (0..threads).map(|t| s.spawn(move || (t..n).step_by(threads).map(|i| (i, f(i))).collect::<Vec<_>>())).collect();
        workers.into_iter().flat_map(|w| w.join().expect("a table row panicked")).collect()
    });
    done.sort_by_key(|x| x.0);
    done.into_iter().map(|x| x.1).collect()
}

/// μ of node i: nodes are uniform in x = √μ, denser at grazing angles where the albedo of a
/// rough lobe changes fastest.
#[inline]
pub(super) fn grid_mu(i: usize, n: usize) -> f32 {
    let x = i as f32 / (n - 1) as f32;
    (x * x).max(1e-4)
}

#[inline]
fn grid_alpha(j: usize, n: usize) -> f32 {
    let r = j as f32 / (n - 1) as f32;
    (r * r).max(1e-4)
}

/// η of node k: nodes are uniform in y = √((η − 1)/(η_max − 1)), denser near η = 1 where the
/// grazing-angle albedo changes fastest.
#[inline]
fn grid_eta(k: usize) -> f32 {
    let y = k as f32 / (DIEL_ETA - 1) as f32;
    1.0 + (DIEL_ETA_MAX - 1.0) * y * y
}

/// Grid coordinate y ∈ [0, 1] of a relative IOR ≥ 1.
#[inline]
fn eta_coord(eta: f32) -> f32 {
    ((eta - 1.0) / (DIEL_ETA_MAX - 1.0)).max(0.0).sqrt()
}

#[inline]
fn lattice(i: usize, (n, g): (usize, usize)) -> Vec2 {
    Vec2::new((i as f32 + 0.5) / n as f32, (((i * g) % n) as f32 + 0.5) / n as f32)
}

/// Exact ∫₀¹ 2μ E(μ) dμ of the interpolant of `e`, which is linear in x = √μ between nodes
/// uniform in x: ∫₀¹ 4x³ E(x) dx, a degree-4 polynomial per interval integrated exactly by
/// Gauss–Legendre quadrature.
fn hemispherical_integral(e: &[f32]) -> f32 {
    let h = 1.0 / (e.len() - 1) as f64;
    let mut acc = 0.0f64;
    for i in 0..e.len() - 1 {
        let (a, b) = (e[i] as f64, e[i + 1] as f64);
        for &(s, w) in GL3.iter() {
            let x = (i as f64 + s) * h;
            acc += w * h * 4.0 * x * x * x * (a + (b - a) * s);
        }
    }
    acc as f32
}

/// 3-point Gauss–Legendre on [0, 1] (exact to degree 5).
const GL3: [(f64, f64); 3] = [
    (0.5 - 0.387_298_334_620_741_7, 5.0 / 18.0),
    (0.5, 8.0 / 18.0),
    (0.5 + 0.387_298_334_620_741_7, 5.0 / 18.0),
];

/// Single-scattering albedos (F = 1, Schlick weight) of a GGX reflection lobe.
fn conductor_albedo(mu: f32, alpha: f32) -> (f32, f32) {
    let d = TrowbridgeReitz::new(alpha, alpha);
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let g1 = d.g1(wo);
    let (mut e, mut s) = (0.0f64, 0.0f64);
    for i in 0..COND_LATTICE.0 {
        let wm = d.sample_wm(wo, lattice(i, COND_LATTICE));
        let wi = reflect(wo, wm);
        if wi.z <= 0.0 {
            continue;
        }
        let w = d.g2(wo, wi) / g1;
        e += w as f64;
        s += (w * (1.0 - wo.dot(wm).clamp(0.0, 1.0)).powi(5)) as f64;
    }
    let n = COND_LATTICE.0 as f64;
    ((e / n) as f32, (s / n) as f32)
}

/// Single-scattering albedo (reflection + transmission, no η² scaling) of a rough dielectric
/// seen from above, `eta` = n_below / n_above.
pub(crate) fn dielectric_albedo(mu: f32, alpha: f32, eta: f32) -> f32 {
    let d = TrowbridgeReitz::new(alpha, alpha);
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let g1 = d.g1(wo);
    let mut e = 0.0f64;
    for i in 0..DIEL_LATTICE.0 {
        let wm = d.sample_wm(wo, lattice(i, DIEL_LATTICE));
        let c = wo.dot(wm);
        if c <= 0.0 {
            continue;
        }
        let f = fresnel_dielectric(c, eta);
        let wr = reflect(wo, wm);
        if wr.z > 0.0 {
            e += (f * d.g2(wo, wr) / g1) as f64;
        }
        if f < 1.0 {
            if let Some((wt, _)) = refract(wo, wm, eta) {
                if wt.z < 0.0 {
                    e += ((1.0 - f) * d.g2(wo, wt) / g1) as f64;
                }
            }
        }
    }
    (e / DIEL_LATTICE.0 as f64) as f32
}

impl AlbedoTables {
    /// Builds the conductor's tables, rows in parallel, and readies the dielectric's blocks to
    /// be built on first use (each row's values do not depend on the others, so the tables are
    /// the same whatever the thread count and the order of use).
    pub(crate) fn build() -> Self {
        let cond_rows: Vec<(Vec<f32>, Vec<f32>)> = rows_in_parallel(COND_R, |j| {
            let alpha = grid_alpha(j, COND_R);
            (0..COND_MU)
                .map(|i| {
                    let (e, s) = conductor_albedo(grid_mu(i, COND_MU), alpha);
                    (e.min(1.0), s.min(1.0))
                })
                .unzip()
        });
        let cond_e1: Vec<f32> = cond_rows.iter().flat_map(|r| r.0.iter().copied()).collect();
        let cond_s: Vec<f32> = cond_rows.iter().flat_map(|r| r.1.iter().copied()).collect();
        let cond_e1_avg = cond_rows.iter().map(|r| hemispherical_integral(&r.0)).collect();
        let cond_s_avg = cond_rows.iter().map(|r| hemispherical_integral(&r.1)).collect();
        let diel = [0, 1].map(|_| (0..DIEL_ETA).map(|_| OnceLock::new()).collect());
        AlbedoTables { cond_e1, cond_s, cond_e1_avg, cond_s_avg, diel }
    }

    #[inline]
    fn diel_block(&self, side: usize, k: usize) -> &DielBlock {
        self.diel[side][k].get_or_init(|| DielBlock::build(side, k))
    }

    /// How many dielectric blocks (η node and side) have been built.
    #[cfg(test)]
    pub(crate) fn diel_blocks_built(&self) -> usize {
        self.diel.iter().flatten().filter(|b| b.get().is_some()).count()
    }

    /// Conductor albedos (E1, S) at μ = |cosθo| and perceptual roughness r.
    #[inline]
    pub fn conductor(&self, mu: f32, r: f32) -> (f32, f32) {
        let (i0, i1, ti) = coord(mu.max(0.0).sqrt(), COND_MU);
        let (j0, j1, tj) = coord(r, COND_R);
        let at = |t: &[f32]| {
            let a = lerp(ti, t[j0 * COND_MU + i0], t[j0 * COND_MU + i1]);
            let b = lerp(ti, t[j1 * COND_MU + i0], t[j1 * COND_MU + i1]);
            lerp(tj, a, b)
        };
        (at(&self.cond_e1), at(&self.cond_s))
    }

    /// Hemispherical averages (E1_avg, S_avg) at perceptual roughness r.
    #[inline]
    pub fn conductor_avg(&self, r: f32) -> (f32, f32) {
        let (j0, j1, tj) = coord(r, COND_R);
        (lerp(tj, self.cond_e1_avg[j0], self.cond_e1_avg[j1]), lerp(tj, self.cond_s_avg[j0], self.cond_s_avg[j1]))
    }

    #[inline]
    fn diel_side(eta: f32) -> (usize, f32) {
        if eta >= 1.0 {
            (0, eta)
        } else {
            (1, 1.0 / eta)
        }
    }

    /// Dielectric albedo for light arriving at μ on the side where the relative IOR across the
    /// interface is `eta` (n_other / n_this).
    #[inline]
    pub fn dielectric(&self, mu: f32, r: f32, eta: f32) -> f32 {
        let (side, e) = Self::diel_side(eta);
        let (i0, i1, ti) = coord(mu.max(0.0).sqrt(), DIEL_MU);
        let (j0, j1, tj) = coord(r, DIEL_R);
        let (k0, k1, tk) = coord(eta_coord(e), DIEL_ETA);
        let at = |k: usize, j: usize| {
            let t = &self.diel_block(side, k).e;
            lerp(ti, t[j * DIEL_MU + i0], t[j * DIEL_MU + i1])
        };
        let a = lerp(tj, at(k0, j0), at(k0, j1));
        let b = lerp(tj, at(k1, j0), at(k1, j1));
        lerp(tk, a, b)
    }

    /// Hemispherical average of [`Self::dielectric`].
    #[inline]
    pub fn dielectric_avg(&self, r: f32, eta: f32) -> f32 {
        let (side, e) = Self::diel_side(eta);
        let (j0, j1, tj) = coord(r, DIEL_R);
        let (k0, k1, tk) = coord(eta_coord(e), DIEL_ETA);
        let (t0, t1) = (&self.diel_block(side, k0).avg, &self.diel_block(side, k1).avg);
        let a = lerp(tj, t0[j0], t0[j1]);
        let b = lerp(tj, t1[j0], t1[j1]);
        lerp(tk, a, b)
    }
}

#[inline]
pub(super) fn lerp(t: f32, a: f32, b: f32) -> f32 {
    a + (b - a) * t
}

/// Cell indices and weight of x ∈ [0, 1] (clamped; non-finite reads 0) on a uniform grid of n
/// nodes.
#[inline]
pub(super) fn coord(x: f32, n: usize) -> (usize, usize, f32) {
    let x = if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 } * (n - 1) as f32;
    let i0 = (x as usize).min(n - 2);
    (i0, i0 + 1, x - i0 as f32)
}
