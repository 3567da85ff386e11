//! Ocean phase functions as `PhaseFunction::Tabulated` (built with
//! `TabulatedPhase::from_angles`): Fournier–Forand, Petzold's measured VSFs, the molecular
//! (Rayleigh-like) phase function of water, HG lobes, and the mixture
//! p = w·p_molecular + (1 − w)·p_particle of the Weta course notes (their Eq. 4.2).
//!
//! Everything is first built as a [`PhaseTable`]: nodes in x = 1 − cosθ (f64, increasing from 0
//! to 2), the density per steradian piecewise linear in x — the same form `TabulatedPhase`
//! interpolates and samples exactly — so mean cosine, backscatter fraction and mixtures computed
//! here are those of the phase function the renderer samples.
//!
//! * **Fournier–Forand** (Fournier & Forand 1994, in the closed form of Mobley, Sundman & Boss
//!   2002, Appl. Opt. 41:1035, Eq. 2) from (n, μ): real relative index of the particles `n` and
//!   Junge slope `μ` (3 < μ ≤ 5). [`FournierForand::from_backscatter`] fixes n = 1.10 and solves
//!   for μ so that the backscatter fraction equals B (Mobley et al. 2002, Eq. 4); B = 0.0183,
//!   the Petzold average-particle value, gives μ ≈ 3.5835 and is the contract's default.
//! * **Petzold** (SIO Ref. 72-78, 1972): the eight stations' total VSFs at 530 nm. Below the
//!   first tabulated angle (0.1°) the VSF is extended with the report's log-log slope of each
//!   station down to 10⁻⁷° (what lies below is < 0.5 % of that part), which carries the 3–15 %
//!   of b the report assigns there. The default
//!   [`PetzoldStation::AverageParticle`] is the "average particle" phase function of Mobley et
//!   al. (1993): the three San Diego harbour stations (NUC 2200, 2040, 2240), pure-seawater
//!   scattering (Morel 1974 at 530 nm, S = 35 PSU) subtracted from each, each normalised by its
//!   particle b, then averaged (mean cosine ≈ 0.924, B ≈ 0.018).
//! * **Molecular water** (Morel 1974): p(θ) = 3/(4π(3 + p))·(1 + p·cos²θ), p = (1 − δ)/(1 + δ)
//!   with depolarisation δ = 0.09 (p = 0.835); mean cosine 0, backscatter fraction ½.

use super::bio::seawater_beta90;
use super::data::tables;
use super::WaterError;
use crate::medium::{PhaseFunction, TabulatedPhase};
use std::f64::consts::PI;

/// Depolarisation ratio of pure water (Morel 1974).
pub const WATER_DEPOLARISATION: f64 = 0.09;

/// Salinity assumed for the pure-seawater part removed from Petzold's harbour VSFs (PSU).
const PETZOLD_SALINITY: f64 = 35.0;

/// A normalised phase function p(x), x = 1 − cosθ, piecewise linear between its nodes.
#[derive(Clone, Debug, PartialEq)]
pub struct PhaseTable {
    x: Vec<f64>,
    p: Vec<f64>,
}

/// Number of nodes of the generic grid analytic phase functions are tabulated on.
const GRID_NODES: usize = 640;
/// Smallest non-zero x of the generic grid (θ ≈ 1.4·10⁻⁶ rad).
const GRID_X_MIN: f64 = 1e-12;

/// Uniform x nodes added to the geometric ones (step 2/256), for the wide part of the sphere.
const GRID_UNIFORM: usize = 256;

/// x nodes: 0, geometric from [`GRID_X_MIN`] to 2 (consecutive nodes ≈ 4.5 % apart), merged
/// with a uniform grid of step 2/256. Linear interpolation of HG (g ≤ 0.9999), FF or the
/// molecular function between them is within ≈ 0.1 % of the analytic value.
fn grid() -> Vec<f64> {
    let r = (2.0 / GRID_X_MIN).powf(1.0 / (GRID_NODES - 2) as f64);
    let mut x = vec![0.0];
    let mut v = GRID_X_MIN;
    for _ in 0..GRID_NODES - 1 {
        x.push(v.min(2.0));
        v *= r;
    }
    x.extend((1..=GRID_UNIFORM).map(|i| 2.0 * i as f64 / GRID_UNIFORM as f64));
    x.sort_by(f64::total_cmp);
    x.dedup_by(|a, b| (*a - *b).abs() <= 1e-6 * b.abs());
    *x.last_mut().unwrap() = 2.0;
    x
}

impl PhaseTable {
    /// From (x, value) nodes, x strictly increasing over [0, 2] and including both ends;
    /// values proportional to the phase function (normalised here).
    fn from_nodes(x: Vec<f64>, v: Vec<f64>) -> Result<PhaseTable, WaterError> {
        if x.len() < 2 || x.len() != v.len() || x[0] != 0.0 || *x.last().unwrap() != 2.0 {
            return Err(WaterError::BadPhaseTable("nodes must span x = 1 − cosθ from 0 to 2".into()));
        }
        if x.windows(2).any(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater)) || v.iter().any(|p| !(p.is_finite() && *p >= 0.0)) {
            return Err(WaterError::BadPhaseTable("nodes not increasing or values negative/non-finite".into()));
        }
        let mut t = PhaseTable { x, p: v };
        let total = t.integral_x(0.0, 2.0);
        if !(total > 0.0 && total.is_finite()) {
            return Err(WaterError::BadPhaseTable("values integrate to zero".into()));
        }
        let k = 1.0 / (2.0 * PI * total);
        t.p.iter_mut().for_each(|p| *p *= k);
        Ok(t)
    }

    /// Tabulates `f(x)` (proportional to a phase function) on the generic grid.
    fn from_fn(f: impl Fn(f64) -> f64) -> Result<PhaseTable, WaterError> {
        let x = grid();
        let v = x.iter().map(|&x| f(x)).collect();
        Self::from_nodes(x, v)
    }

    /// Density per steradian at cosθ = 1 − x.
    pub fn eval_x(&self, x: f64) -> f64 {
        super::data::lerp_table(&self.x, &self.p, x)
    }

    /// Density per steradian at scattering angle θ (radians).
    pub fn eval_theta(&self, theta: f64) -> f64 {
        let s = (0.5 * theta).sin();
        self.eval_x(2.0 * s * s)
    }

    /// ∫ p dx over [x0, x1] (exact for the piecewise-linear form). The solid angle is 2π dx.
    fn integral_x(&self, x0: f64, x1: f64) -> f64 {
        let mut acc = 0.0;
        for i in 0..self.x.len() - 1 {
            let (a, b) = (self.x[i].max(x0), self.x[i + 1].min(x1));
            if b > a {
                acc += 0.5 * (b - a) * (self.eval_x(a) + self.eval_x(b));
            }
        }
        acc
    }

    /// Probability of scattering by an angle of at most θ (radians).
    pub fn cdf_theta(&self, theta: f64) -> f64 {
        let s = (0.5 * theta.clamp(0.0, PI)).sin();
        2.0 * PI * self.integral_x(0.0, 2.0 * s * s)
    }

    /// ∫ p dω over the sphere (1 up to rounding).
    pub fn integral(&self) -> f64 {
        2.0 * PI * self.integral_x(0.0, 2.0)
    }

    /// Mean cosine ∫ cosθ p dω (exact for the piecewise-linear form).
    pub fn mean_cosine(&self) -> f64 {
        let mut acc = 0.0;
        for i in 0..self.x.len() - 1 {
            let (x0, x1, p0, p1) = (self.x[i], self.x[i + 1], self.p[i], self.p[i + 1]);
            let h = x1 - x0;
            acc += h * ((1.0 - x0) * 0.5 * (p0 + p1) - h * (p0 / 6.0 + p1 / 3.0));
        }
        2.0 * PI * acc
    }

    /// Backscatter fraction B = ∫ over θ > 90° of p dω.
    pub fn backscatter_fraction(&self) -> f64 {
        2.0 * PI * self.integral_x(1.0, 2.0)
    }

    /// The nodes as (θ radians, density) pairs.
    pub fn angles(&self) -> Vec<(f64, f64)> {
        self.x.iter().zip(&self.p).map(|(&x, &p)| (2.0 * (0.5 * x).sqrt().min(1.0).asin(), p)).collect()
    }

    /// w·molecular + (1 − w)·self, on the union of both node sets.
    pub fn mix_molecular(&self, w: f64) -> Result<PhaseTable, WaterError> {
        if !(0.0..=1.0).contains(&w) {
            return Err(WaterError::OutOfRange { name: "molecularWeight", value: w as f32, min: 0.0, max: 1.0, unit: "" });
        }
        let mut x: Vec<f64> = self.x.iter().copied().chain(grid()).collect();
        x.sort_by(f64::total_cmp);
        x.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * b.abs());
        let v = x.iter().map(|&x| w * molecular_density(1.0 - x) + (1.0 - w) * self.eval_x(x)).collect();
        Self::from_nodes(x, v)
    }

    /// The renderer's phase function: `PhaseFunction::Tabulated` through
    /// `TabulatedPhase::from_angles`.
    pub fn to_phase_function(&self) -> Result<PhaseFunction, WaterError> {
        Ok(PhaseFunction::Tabulated(TabulatedPhase::from_angles(&self.f32_nodes())?))
    }

    /// The table as a scene description (`PhaseDesc::Tabulated`, the nodes
    /// [`PhaseTable::to_phase_function`] uses).
    pub fn to_phase_desc(&self) -> crate::scene::PhaseDesc {
        let (theta, value) = self.f32_nodes().into_iter().unzip();
        crate::scene::PhaseDesc::Tabulated { theta, value }
    }

    fn f32_nodes(&self) -> Vec<(f32, f32)> {
        let pts: Vec<(f32, f32)> = self.angles().into_iter().map(|(t, p)| (t as f32, p as f32)).collect();
        // nodes closer than f32 resolves in x would be duplicates there; keep the first
        let mut kept: Vec<(f32, f32)> = Vec::with_capacity(pts.len());
        let fx = |t: f32| {
            let s = (0.5 * t).sin();
            2.0 * s * s
        };
        for p in pts {
            if kept.last().is_none_or(|q| fx(p.0) > fx(q.0)) {
                kept.push(p);
            }
        }
        kept
    }
}

/// Molecular scattering phase function of water (depolarisation 0.09) at cosθ = `mu`.
pub fn molecular_density(mu: f64) -> f64 {
    let p = (1.0 - WATER_DEPOLARISATION) / (1.0 + WATER_DEPOLARISATION);
    3.0 / (4.0 * PI * (3.0 + p)) * (1.0 + p * mu * mu)
}

/// The molecular phase function as a table.
pub fn molecular() -> Result<PhaseTable, WaterError> {
    PhaseTable::from_fn(|x| molecular_density(1.0 - x))
}

/// Henyey–Greenstein with mean cosine g (|g| ≤ 1) as a table; |g| is clamped to
/// `medium::G_MAX` as `PhaseFunction::hg` does.
pub fn hg_table(g: f64) -> Result<PhaseTable, WaterError> {
    if !(g.is_finite() && g.abs() <= 1.0) {
        return Err(WaterError::OutOfRange { name: "g", value: g as f32, min: -1.0, max: 1.0, unit: "" });
    }
    let gm = crate::medium::G_MAX as f64;
    let g = g.clamp(-gm, gm);
    // 1 + g² − 2gμ = (1 − g)² + 2g·x
    PhaseTable::from_fn(|x| (1.0 - g * g) / ((1.0 - g) * (1.0 - g) + 2.0 * g * x).powf(1.5))
}

/// w·HG(g1) + (1 − w)·HG(g2) as a table.
pub fn dual_hg_table(g1: f64, g2: f64, w: f64) -> Result<PhaseTable, WaterError> {
    if !(0.0..=1.0).contains(&w) {
        return Err(WaterError::OutOfRange { name: "lobeMix", value: w as f32, min: 0.0, max: 1.0, unit: "" });
    }
    let (a, b) = (hg_table(g1)?, hg_table(g2)?);
    PhaseTable::from_nodes(a.x.clone(), a.x.iter().map(|&x| w * a.eval_x(x) + (1.0 - w) * b.eval_x(x)).collect())
}

/// Fournier–Forand parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FournierForand {
    /// Real index of refraction of the particles relative to water (1 < n ≤ 1.35).
    pub n: f64,
    /// Slope of the Junge (hyperbolic) particle size distribution (3 < μ ≤ 5).
    pub mu: f64,
}

/// n used by [`FournierForand::from_backscatter`] (Mobley et al. 2002).
pub const FF_DEFAULT_N: f64 = 1.10;
/// Backscatter fraction of the Petzold average-particle phase function, the contract default.
pub const FF_DEFAULT_BACKSCATTER: f64 = 0.0183;

impl FournierForand {
    /// Checked parameters.
    pub fn new(n: f64, mu: f64) -> Result<Self, WaterError> {
        if !(n.is_finite() && n > 1.0 && n <= 1.35) {
            return Err(WaterError::OutOfRange { name: "Fournier–Forand n", value: n as f32, min: 1.0, max: 1.35, unit: "" });
        }
        if !(mu.is_finite() && mu > 3.0 && mu <= 5.0) {
            return Err(WaterError::OutOfRange { name: "Fournier–Forand μ (Junge slope)", value: mu as f32, min: 3.0, max: 5.0, unit: "" });
        }
        Ok(FournierForand { n, mu })
    }

    fn delta(&self, x: f64) -> f64 {
        // δ = 4 sin²(θ/2) / (3 (n−1)²) and sin²(θ/2) = x/2
        2.0 * x / (3.0 * (self.n - 1.0) * (self.n - 1.0))
    }

    /// The normalised FF density per steradian at x = 1 − cosθ (x > 0; the forward
    /// singularity is integrable).
    pub fn density_x(&self, x: f64) -> f64 {
        let nu = 0.5 * (3.0 - self.mu);
        let d = self.delta(x);
        let d180 = self.delta(2.0);
        let dn = d.powf(nu);
        let s2 = 0.5 * x;
        let mu = 1.0 - x;
        let main = (nu * (1.0 - d) - (1.0 - dn) + (d * (1.0 - dn) - nu * (1.0 - d)) / s2)
            / (4.0 * PI * (1.0 - d) * (1.0 - d) * dn);
        let d180n = d180.powf(nu);
        main + (1.0 - d180n) / (16.0 * PI * (d180 - 1.0) * d180n) * (3.0 * mu * mu - 1.0)
    }

    /// Closed-form backscatter fraction (Mobley et al. 2002, Eq. 4).
    pub fn backscatter_fraction(&self) -> f64 {
        let nu = 0.5 * (3.0 - self.mu);
        let d90 = self.delta(1.0);
        1.0 - (1.0 - d90.powf(nu + 1.0) - 0.5 * (1.0 - d90.powf(nu))) / ((1.0 - d90) * d90.powf(nu))
    }

    /// n = 1.10 and the μ whose backscatter fraction is `b` (found by bisection; B grows with μ).
    pub fn from_backscatter(b: f64) -> Result<Self, WaterError> {
        let (lo_b, hi_b) = (Self { n: FF_DEFAULT_N, mu: 3.001 }.backscatter_fraction(), Self { n: FF_DEFAULT_N, mu: 5.0 }.backscatter_fraction());
        if !(b.is_finite() && b >= lo_b && b <= hi_b) {
            return Err(WaterError::OutOfRange { name: "Fournier–Forand backscatter fraction", value: b as f32, min: lo_b as f32, max: hi_b as f32, unit: "" });
        }
        let (mut lo, mut hi) = (3.001, 5.0);
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            if (Self { n: FF_DEFAULT_N, mu: mid }).backscatter_fraction() < b {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Self::new(FF_DEFAULT_N, 0.5 * (lo + hi))
    }

    /// The table (the forward node x = 0 takes the value at the first grid node). The density's
    /// probability below x is ∝ x^((μ−3)/2); what lies below the first grid node (x = 10⁻¹²) is
    /// dropped by normalisation: < 0.1 % for μ ≥ 3.5, but several % as μ → 3.
    pub fn table(&self) -> Result<PhaseTable, WaterError> {
        PhaseTable::from_fn(|x| self.density_x(x.max(GRID_X_MIN)))
    }
}

/// Petzold's eight stations and the average-particle phase function derived from them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum PetzoldStation {
    /// Mean of the three San Diego harbour stations with pure seawater removed (default).
    #[default]
    AverageParticle,
    Autec7,
    Autec8,
    Autec9,
    Haoce5,
    Haoce11,
    Nuc2200,
    Nuc2040,
    Nuc2240,
}

impl PetzoldStation {
    /// The station name in the table (None for the average).
    pub fn table_name(self) -> Option<&'static str> {
        Some(match self {
            PetzoldStation::AverageParticle => return None,
            PetzoldStation::Autec7 => "AUTEC 7",
            PetzoldStation::Autec8 => "AUTEC 8",
            PetzoldStation::Autec9 => "AUTEC 9",
            PetzoldStation::Haoce5 => "HAOCE 5",
            PetzoldStation::Haoce11 => "HAOCE 11",
            PetzoldStation::Nuc2200 => "NUC 2200",
            PetzoldStation::Nuc2040 => "NUC 2040",
            PetzoldStation::Nuc2240 => "NUC 2240",
        })
    }
}

/// Values the Petzold report prints for a station (530 nm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PetzoldPublished {
    /// Scattering coefficient b, m⁻¹.
    pub b: f64,
    /// Backscatter fraction B.
    pub bb_over_b: f64,
    /// Fraction of b scattered by less than 0.1° (the table's normalised integral at 0.1°).
    pub fraction_below_01deg: f64,
}

impl PetzoldStation {
    /// The report's numbers for a measured station (None for the average-particle function).
    pub fn published(self) -> Option<PetzoldPublished> {
        let name = self.table_name()?;
        let t = tables();
        let st = t.stations.iter().find(|s| s.station == name)?;
        let first = t.petzold.iter().find(|r| r.station == name)?;
        Some(PetzoldPublished { b: st.b, bb_over_b: st.bb_over_b, fraction_below_01deg: first.normalized_integral })
    }
}

/// Decades below 0.1° covered by the power-law extension, and nodes per decade (the table's
/// own spacing).
const PETZOLD_EXT_DECADES: i32 = 6;
const PETZOLD_EXT_PER_DECADE: i32 = 10;

/// (θ radians, β m⁻¹ sr⁻¹) of one station including the power-law extension, increasing θ;
/// and the station's b.
fn petzold_station_vsf(name: &str, subtract_water: bool) -> Result<(Vec<(f64, f64)>, f64), WaterError> {
    let t = tables();
    let st = t
        .stations
        .iter()
        .find(|s| s.station == name)
        .ok_or_else(|| WaterError::NoData { what: format!("Petzold station '{name}'") })?;
    let rows: Vec<_> = t.petzold.iter().filter(|r| r.station == name).collect();
    if rows.is_empty() {
        return Err(WaterError::NoData { what: format!("Petzold VSF of '{name}'") });
    }
    let (th0, b0) = (rows[0].angle_deg, rows[0].vsf);
    let mut pts = Vec::new();
    for k in (1..=PETZOLD_EXT_DECADES * PETZOLD_EXT_PER_DECADE).rev() {
        let th = th0 * 10f64.powf(-(k as f64) / PETZOLD_EXT_PER_DECADE as f64);
        pts.push((th, b0 * (th / th0).powf(st.slope_below_01)));
    }
    pts.extend(rows.iter().map(|r| (r.angle_deg, r.vsf)));
    let (bw90, bw) = seawater_beta90(530.0, PETZOLD_SALINITY);
    let pol = (1.0 - WATER_DEPOLARISATION) / (1.0 + WATER_DEPOLARISATION);
    let mut b = st.b;
    let out = pts
        .into_iter()
        .map(|(deg, beta)| {
            let th = deg.to_radians();
            let beta = if subtract_water {
                let c = th.cos();
                (beta - bw90 * (1.0 + pol * c * c)).max(0.0)
            } else {
                beta
            };
            (th, beta)
        })
        .collect();
    if subtract_water {
        b -= bw;
    }
    Ok((out, b))
}

/// Petzold's normalised phase function of `station`.
pub fn petzold(station: PetzoldStation) -> Result<PhaseTable, WaterError> {
    let to_x = |th: f64| {
        let s = (0.5 * th).sin();
        2.0 * s * s
    };
    let finish = |pts: Vec<(f64, f64)>| -> Result<PhaseTable, WaterError> {
        let mut x = vec![0.0];
        let mut v = vec![pts[0].1];
        for (th, p) in pts {
            let xx = if th >= PI - 1e-12 { 2.0 } else { to_x(th) };
            x.push(xx);
            v.push(p);
        }
        PhaseTable::from_nodes(x, v)
    };
    match station.table_name() {
        Some(name) => finish(petzold_station_vsf(name, false)?.0),
        None => {
            let mut acc: Vec<(f64, f64)> = Vec::new();
            let names = ["NUC 2200", "NUC 2040", "NUC 2240"];
            for name in names {
                let (pts, b) = petzold_station_vsf(name, true)?;
                if acc.is_empty() {
                    acc = pts.iter().map(|&(t, _)| (t, 0.0)).collect();
                }
                for (a, (t, beta)) in acc.iter_mut().zip(pts) {
                    // the three stations share the angle grid except in the extension, whose
                    // angles are also common (same first angle and spacing)
                    debug_assert!((a.0 - t).abs() < 1e-12);
                    a.1 += beta / b / names.len() as f64;
                }
            }
            finish(acc)
        }
    }
}

/// The particle part of a contract phase choice.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ParticlePhase {
    Hg { g: f64 },
    DualHg { g1: f64, g2: f64, w: f64 },
    FournierForand(FournierForand),
    Petzold(PetzoldStation),
}

impl ParticlePhase {
    /// From the contract's `phase` token and `g`, `g2`, `lobeMix`: `fournierForand` uses
    /// B = 0.0183 (n = 1.10), `petzold` the average-particle function.
    pub fn from_contract(phase: &str, g: f32, g2: f32, lobe_mix: f32) -> Result<Self, WaterError> {
        match phase {
            "hg" => Ok(ParticlePhase::Hg { g: g as f64 }),
            "dualHG" => Ok(ParticlePhase::DualHg { g1: g as f64, g2: g2 as f64, w: lobe_mix as f64 }),
            "fournierForand" => Ok(ParticlePhase::FournierForand(FournierForand::from_backscatter(FF_DEFAULT_BACKSCATTER)?)),
            "petzold" => Ok(ParticlePhase::Petzold(PetzoldStation::AverageParticle)),
            _ => Err(WaterError::UnknownToken { attribute: "phase", token: phase.to_string() }),
        }
    }

    /// The particle phase function as a table.
    pub fn table(&self) -> Result<PhaseTable, WaterError> {
        match *self {
            ParticlePhase::Hg { g } => hg_table(g),
            ParticlePhase::DualHg { g1, g2, w } => dual_hg_table(g1, g2, w),
            ParticlePhase::FournierForand(ff) => ff.table(),
            ParticlePhase::Petzold(s) => petzold(s),
        }
    }
}

/// The scene description of [`phase_function`]`(particle, molecular_weight)`: analytic HG /
/// dual HG when there is no molecular part, `PhaseDesc::Tabulated` otherwise.
pub fn phase_desc(particle: ParticlePhase, molecular_weight: f32) -> Result<crate::scene::PhaseDesc, WaterError> {
    use crate::scene::PhaseDesc;
    let w = molecular_weight as f64;
    if !(w.is_finite() && (0.0..=1.0).contains(&w)) {
        return Err(WaterError::OutOfRange { name: "molecularWeight", value: molecular_weight, min: 0.0, max: 1.0, unit: "" });
    }
    if w == 0.0 {
        match particle {
            ParticlePhase::Hg { g } => return Ok(PhaseDesc::HenyeyGreenstein { g: g as f32 }),
            ParticlePhase::DualHg { g1, g2, w } => return Ok(PhaseDesc::DualHg { g1: g1 as f32, g2: g2 as f32, w: w as f32 }),
            _ => {}
        }
    }
    let t = particle.table()?;
    let t = if w > 0.0 { t.mix_molecular(w)? } else { t };
    Ok(t.to_phase_desc())
}

/// The renderer's phase function for particle phase `particle` mixed with the molecular one
/// at weight `molecular_weight` ∈ [0, 1]. HG and dual HG without molecular part stay analytic
/// (`PhaseFunction::HenyeyGreenstein` / `DualHg`); everything else is `Tabulated`.
pub fn phase_function(particle: ParticlePhase, molecular_weight: f32) -> Result<PhaseFunction, WaterError> {
    let w = molecular_weight as f64;
    if !(w.is_finite() && (0.0..=1.0).contains(&w)) {
        return Err(WaterError::OutOfRange { name: "molecularWeight", value: molecular_weight, min: 0.0, max: 1.0, unit: "" });
    }
    if w == 0.0 {
        match particle {
            ParticlePhase::Hg { g } => return Ok(PhaseFunction::hg(g as f32)?),
            ParticlePhase::DualHg { g1, g2, w } => return Ok(PhaseFunction::dual_hg(g1 as f32, g2 as f32, w as f32)?),
            _ => {}
        }
    }
    let t = particle.table()?;
    let t = if w > 0.0 { t.mix_molecular(w)? } else { t };
    t.to_phase_function()
}
