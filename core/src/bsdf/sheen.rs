//! Sheen: the retro-reflective fuzz of cloth and dusty surfaces, as MaterialX's `sheen_bsdf` in
//! its default `conty_kulla` mode (Autodesk Standard Surface `sheen`): the "Charlie" microfacet
//! distribution of Estevez & Kulla, "Production Friendly Microfacet Sheen BRDF" (Imageworks,
//! 2017), with the smooth visibility term of Neubelt & Pettineo (2013),
//!
//! f = D(ωh) / (4 (μi + μo − μi μo)),  D(ωh) = (2 + 1/r) sin^{1/r}θh / (2π),
//!
//! times the sheen colour, where ωh is the half vector, μ the cosines to the normal and r the
//! sheen roughness as given (MaterialX does not square it) clamped to [0.005, 1] (MaterialX
//! clamps below at 0.005; Standard Surface's range ends at 1). D is normalised
//! (∫D cosθh dω = 1) and puts the microfacet normals close to the tangent plane, the more so
//! the smaller r is (fibres standing up from the surface), so the lobe reflects towards grazing
//! angles. (OpenPBR's `fuzz` selects the `zeltner` mode, a
//! linearly-transformed-cosine fit of a volumetric fibre layer, which is not this lobe.)
//!
//! Energy. The visibility term is not a masking-shadowing function, and for r ≲ 0.2 this lobe
//! reflects more than it receives at grazing views: its white directional albedo E(μ) reaches
//! 1.02 at r = 0.2, 1.35 at r = 0.1 and 5.6 at r = 0.005 as μ → 0 (MaterialX clamps the albedo
//! it uses for layering to 1 but leaves the lobe as it is). Here the lobe is divided by
//! max(N(μo), N(μi)), N = max(1, 1.01·E): symmetric in the two directions (so reciprocity
//! holds), and bounding the albedo by 1 (∫f μi dωi / max(N(μo), …) ≤ E(μo)/N(μo) ≤ 1; the 1%
//! margin covers the interpolation error of the tabulated E, so the bound holds between nodes
//! too: the largest albedo found between nodes is 0.995). Where 1.01·E ≤ 1 at both directions,
//! which is everywhere for r ≥ 0.25 and away from grazing angles below, the value is
//! MaterialX's unchanged. White sheen at small roughness then reflects 0.99 at grazing views
//! instead of several times the incident light.
//!
//! Albedo. The white directional albedo of the lobe actually used, E′(μ, r), is tabulated
//! once, at first use ([`OnceLock`], about 0.1 s), by deterministic product Gauss–Legendre
//! quadrature of f·cosθi (converged to 2·10⁻⁴ relative), on 64 nodes in μ (uniform in √μ) by
//! 32 in r (uniform in ln r), and interpolated bilinearly; the raw E used for the divisor is
//! tabulated alike (interpolation error ≤ 0.6% relative). E′ is stored multiplied by the
//! divisor N(μo) and divided after interpolation, so that the kink N puts into E′ where 1.01·E
//! crosses 1 is not interpolated across; the largest interpolation error of E′ found at cell
//! centres is 6.7·10⁻³ (r ≈ 0.006, μ ≈ 0.09, where E′ falls steeply). A layer above a base lets
//! through 1 − weight·E′(μ) of the light ([`Sheen::albedo`]). MaterialX's own rational fit of
//! E deviates from this table by up to 0.09 (at μ = 0, r = 1).
//!
//! Sampling is uniform over the hemisphere (pdf 1/(2π)). The lobe's mass lies towards grazing
//! directions, where a cosine-weighted sampler puts few samples: measured on the white
//! directional albedo, the relative variance per sample of uniform sampling is 2–7 times lower
//! than cosine-weighted sampling for r ≤ 0.3 (15.9 → 2.4 at r = 0.02, μo = 0.05; 1.48 → 0.22 at
//! r = 0.3, μo = 0.05) and within 1.5× of it elsewhere.

use super::albedo::{coord, lerp};
use super::thin_film::gauss_legendre;
use super::{flags, BsdfSample};
use crate::math::INV_2PI;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3};
use std::sync::OnceLock;

/// Smallest sheen roughness (MaterialX's clamp).
pub const MIN_ROUGHNESS: f32 = 0.005;

const N_MU: usize = 64;
const N_R: usize = 32;
/// Relative margin of the energy bound over the tabulated raw albedo: more than the largest
/// relative interpolation error of that table (5.7·10⁻³, at r = 0.005 within 10⁻⁴ of grazing),
/// so that the bound holds between nodes too.
const BOUND_MARGIN: f32 = 0.01;
/// Quadrature per table entry: panels × Gauss–Legendre order, in x = √μi and in φi ∈ [0, π].
const QUAD_PANELS_X: usize = 4;
const QUAD_PANELS_PHI: usize = 2;
const QUAD_ORDER: usize = 8;

/// Sheen roughness clamped to [MIN_ROUGHNESS, 1] (non-finite reads the maximum).
#[inline]
fn clamp_roughness(r: f32) -> f32 {
    if r.is_finite() {
        r.clamp(MIN_ROUGHNESS, 1.0)
    } else {
        1.0
    }
}

/// μ of node i: uniform in √μ, floored above 0 (the lobe is zero exactly at the horizon).
#[inline]
fn grid_mu(i: usize) -> f32 {
    super::albedo::grid_mu(i, N_MU)
}

/// r of node j: uniform in ln r (the exponent 1/r of the distribution changes fastest at small
/// roughness).
#[inline]
fn grid_r(j: usize) -> f32 {
    let t = j as f32 / (N_R - 1) as f32;
    MIN_ROUGHNESS * (1.0 / MIN_ROUGHNESS).powf(t)
}

/// Grid coordinate in [0, 1] of a (clamped) roughness.
#[inline]
fn r_coord(r: f32) -> f32 {
    ((r / MIN_ROUGHNESS).ln() / (1.0 / MIN_ROUGHNESS).ln()).clamp(0.0, 1.0)
}

/// The divisor N = max(1, (1 + margin) Ê) of a direction whose tabulated raw albedo is Ê.
#[inline]
fn bound(raw_albedo: f32) -> f32 {
    ((1.0 + BOUND_MARGIN) * raw_albedo).max(1.0)
}

/// MaterialX's white sheen value (no colour, no energy bound) for 1/r = `inv_r`, both
/// directions above the surface.
#[inline]
fn sheen_raw(wo: Vec3, wi: Vec3, inv_r: f32) -> f32 {
    let h = wo + wi;
    let hxy2 = h.x * h.x + h.y * h.y;
    let h2 = hxy2 + h.z * h.z;
    if h2 == 0.0 {
        return 0.0;
    }
    // sin²θh, from the unnormalised half vector
    let sin2 = hxy2 / h2;
    let d = (2.0 + inv_r) * sin2.powf(0.5 * inv_r) * INV_2PI;
    d / (4.0 * (wi.z + wo.z - wi.z * wo.z))
}

/// Value at μ of a table row, linear in √μ between nodes.
#[inline]
fn row_at(row: &[f32], mu: f32) -> f32 {
    let (i0, i1, t) = coord(mu.max(0.0).sqrt(), N_MU);
    lerp(t, row[i0], row[i1])
}

/// ∫₀¹ 2μ E(μ) dμ = ∫₀¹ 4x³ E(x²) dx of a function given in x = √μ, by 4-point Gauss–Legendre
/// on each table interval.
fn hemispherical_integral(e_of_x: impl Fn(f32) -> f32) -> f32 {
    let gl = gauss_legendre(4);
    let h = 1.0 / (N_MU - 1) as f64;
    let mut acc = 0.0f64;
    for i in 0..N_MU - 1 {
        for &(s, w) in &gl {
            let x = (i as f64 + s) * h;
            acc += w * h * 4.0 * x * x * x * e_of_x(x as f32) as f64;
        }
    }
    acc as f32
}

/// Directional-albedo tables of the sheen lobe.
#[derive(PartialEq)]
pub struct SheenTables {
    /// White albedo of MaterialX's lobe, E(μ, r): [j * N_MU + i].
    raw: Vec<f32>,
    /// White albedo of the energy-bounded lobe times the divisor of ωo, E′(μ, r) N(μ, r): the
    /// division by N (steep where E crosses 1/(1 + margin)) is applied after interpolation, so
    /// that the kink it puts into E′ is not interpolated across.
    scaled: Vec<f32>,
    /// Hemispherical averages of E′ per r node.
    bounded_avg: Vec<f32>,
    /// Per r node: whether the energy bound divides anywhere in its row (a blend of two rows
    /// where neither does never needs it).
    row_bounded: Vec<bool>,
}

static TABLES: OnceLock<SheenTables> = OnceLock::new();

/// The tables, built on first call.
pub fn tables() -> &'static SheenTables {
    TABLES.get_or_init(SheenTables::build)
}

impl SheenTables {
    /// Builds the tables (about 4·10⁶ evaluations of the lobe).
    pub fn build() -> SheenTables {
        let gl = gauss_legendre(QUAD_ORDER);
        // rows of roughness in parallel (each depends on nothing but its own: the same tables
        // whatever the thread count)
        let rows: Vec<(Vec<f32>, Vec<f32>, f32)> = super::albedo::rows_in_parallel(N_R, |j| {
            let inv_r = 1.0 / grid_r(j);
            let raw_row: Vec<f32> = (0..N_MU).map(|i| integrate(grid_mu(i), &gl, |wo, wi| sheen_raw(wo, wi, inv_r)) as f32).collect();
            let scaled_row: Vec<f32> = (0..N_MU)
                .map(|i| {
                    let n_o = bound(raw_row[i]);
                    let e = integrate(grid_mu(i), &gl, |wo, wi| sheen_raw(wo, wi, inv_r) / n_o.max(bound(row_at(&raw_row, wi.z))));
                    (e * n_o as f64) as f32
                })
                .collect();
            let avg = hemispherical_integral(|x| bounded_albedo(row_at(&scaled_row, x * x), row_at(&raw_row, x * x)));
            (raw_row, scaled_row, avg)
        });
        let raw: Vec<f32> = rows.iter().flat_map(|r| r.0.iter().copied()).collect();
        let scaled: Vec<f32> = rows.iter().flat_map(|r| r.1.iter().copied()).collect();
        let bounded_avg: Vec<f32> = rows.iter().map(|r| r.2).collect();
        let row_bounded = (0..N_R).map(|j| raw[j * N_MU..(j + 1) * N_MU].iter().any(|&e| bound(e) > 1.0)).collect();
        SheenTables { raw, scaled, bounded_avg, row_bounded }
    }

    /// White albedo E′(μ, r) of the energy-bounded lobe at μ = cosθo and sheen roughness r.
    pub fn albedo(&self, mu: f32, roughness: f32) -> f32 {
        let b = RowBlend::new(roughness);
        bounded_albedo(b.at(&self.scaled, mu), b.at(&self.raw, mu))
    }

    /// Hemispherical average 2∫E′(μ)μ dμ at sheen roughness r.
    pub fn albedo_avg(&self, roughness: f32) -> f32 {
        let b = RowBlend::new(roughness);
        lerp(b.t, self.bounded_avg[b.j0], self.bounded_avg[b.j1])
    }

    /// White albedo E(μ, r) of MaterialX's lobe (unbounded; exceeds 1 at grazing for r ≲ 0.2).
    pub fn raw_albedo(&self, mu: f32, roughness: f32) -> f32 {
        RowBlend::new(roughness).at(&self.raw, mu)
    }
}

/// E′ from the interpolated E′N and raw albedo (at most 1: the bound holds exactly at the nodes
/// and, by the margin, between them).
#[inline]
fn bounded_albedo(scaled: f32, raw: f32) -> f32 {
    (scaled / bound(raw)).min(1.0)
}

/// Interpolation between the two table rows around a roughness.
#[derive(Clone, Copy, Debug, PartialEq)]
struct RowBlend {
    j0: usize,
    j1: usize,
    t: f32,
}

impl RowBlend {
    #[inline]
    fn new(roughness: f32) -> RowBlend {
        let (j0, j1, t) = coord(r_coord(clamp_roughness(roughness)), N_R);
        RowBlend { j0, j1, t }
    }
    #[inline]
    fn at(&self, table: &[f32], mu: f32) -> f32 {
        let a = row_at(&table[self.j0 * N_MU..(self.j0 + 1) * N_MU], mu);
        let b = row_at(&table[self.j1 * N_MU..(self.j1 + 1) * N_MU], mu);
        lerp(self.t, a, b)
    }
}

/// ∫ g(ωo, ωi) μi dωi over the upper hemisphere for ωo at μo (in the xz-plane), g symmetric in
/// φi: product Gauss–Legendre in x = √μi (dμi = 2x dx, resolving the grazing directions where
/// the lobe concentrates) and φi ∈ [0, π], doubled.
fn integrate(mu_o: f32, gl: &[(f64, f64)], g: impl Fn(Vec3, Vec3) -> f32) -> f64 {
    let wo = Vec3::new((1.0 - mu_o * mu_o).max(0.0).sqrt(), 0.0, mu_o);
    let mut acc = 0.0f64;
    for px in 0..QUAD_PANELS_X {
        for &(sx, wx) in gl {
            let x = (px as f64 + sx) / QUAD_PANELS_X as f64;
            let mu_i = x * x;
            let sin_i = (1.0 - mu_i * mu_i).max(0.0).sqrt();
            let wx = wx / QUAD_PANELS_X as f64;
            for pp in 0..QUAD_PANELS_PHI {
                for &(sp, wp) in gl {
                    let phi = (pp as f64 + sp) / QUAD_PANELS_PHI as f64 * std::f64::consts::PI;
                    let wp = wp / QUAD_PANELS_PHI as f64 * std::f64::consts::PI;
                    let wi = Vec3::new((sin_i * phi.cos()) as f32, (sin_i * phi.sin()) as f32, mu_i as f32);
                    acc += 2.0 * wx * wp * 2.0 * x * mu_i * g(wo, wi) as f64;
                }
            }
        }
    }
    acc
}

/// The sheen lobe (see the module documentation), written for ωo in the upper hemisphere (zero
/// below).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sheen {
    color: SampledSpectrum,
    roughness: f32,
    inv_r: f32,
    rows: RowBlend,
    /// Whether the divisor may exceed 1 at this roughness (else the lobe is MaterialX's
    /// everywhere and no lookup is needed).
    bounded: bool,
}

impl Sheen {
    /// Sheen of colour `color` (multiplies the lobe) and sheen roughness (clamped to
    /// [[`MIN_ROUGHNESS`], 1]; non-finite reads 1).
    pub fn new(color: SampledSpectrum, roughness: f32) -> Sheen {
        let roughness = clamp_roughness(roughness);
        let rows = RowBlend::new(roughness);
        let t = tables();
        let bounded = t.row_bounded[rows.j0] || t.row_bounded[rows.j1];
        Sheen { color, roughness, inv_r: 1.0 / roughness, rows, bounded }
    }

    /// The clamped sheen roughness.
    #[inline]
    pub fn roughness(&self) -> f32 {
        self.roughness
    }

    /// The white lobe's value (no colour).
    #[inline]
    fn white(&self, wo: Vec3, wi: Vec3) -> f32 {
        let v = sheen_raw(wo, wi, self.inv_r);
        if !self.bounded {
            return v;
        }
        let t = &tables().raw;
        let n = bound(self.rows.at(t, wo.z).max(self.rows.at(t, wi.z)));
        if n > 1.0 {
            v / n
        } else {
            v
        }
    }

    /// BSDF value (cosine excluded).
    pub fn f(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        self.color * self.white(wo, wi)
    }

    /// Uniform-hemisphere density 1/(2π).
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z > 0.0 && wi.z > 0.0 {
            INV_2PI
        } else {
            0.0
        }
    }

    /// Samples ωi uniformly over the upper hemisphere.
    pub fn sample_f(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let z = 1.0 - u.x;
        let s = (1.0 - z * z).max(0.0).sqrt();
        let (sp, cp) = (2.0 * std::f32::consts::PI * u.y).sin_cos();
        let wi = Vec3::new(s * cp, s * sp, z);
        if wi.z <= 0.0 {
            return None;
        }
        Some(BsdfSample { f: self.f(wo, wi), wi, pdf: INV_2PI, flags: flags::GLOSSY_REFLECTION, eta: 1.0 })
    }

    /// White directional albedo E′(μ) (colour excluded) at μ = cosθo: what the lobe reflects of
    /// white light, so that a layer of weight w over a base lets 1 − w·E′(μ) through. In [0, 1].
    #[inline]
    pub fn albedo(&self, mu: f32) -> f32 {
        let t = tables();
        bounded_albedo(self.rows.at(&t.scaled, mu), self.rows.at(&t.raw, mu))
    }

    /// Hemispherical average 2∫E′(μ)μ dμ of [`Self::albedo`].
    #[inline]
    pub fn albedo_avg(&self) -> f32 {
        let t = tables();
        lerp(self.rows.t, t.bounded_avg[self.rows.j0], t.bounded_avg[self.rows.j1])
    }

    /// Directional albedo including the colour.
    #[inline]
    pub fn reflectance(&self, mu: f32) -> SampledSpectrum {
        self.color * self.albedo(mu)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{dir_mu, random_upper};
    use crate::testing::chi2::{chi2_sphere, Chi2Config, TestRng};


    /// MaterialX's `mx_imageworks_sheen_brdf` transcribed independently (D from NdotH, the
    /// visibility 1/(4(NdotL + NdotV − NdotL·NdotV))), in double precision: 1 − NdotH² loses
    /// most of its digits in single precision near θh = 0.
    fn materialx(wo: Vec3, wi: Vec3, roughness: f32) -> f64 {
        let (wo, wi) = (wo.as_dvec3(), wi.as_dvec3());
        let h = (wo + wi).normalize();
        let inv_r = 1.0 / (roughness as f64).max(0.005);
        let sin2 = 1.0 - h.z * h.z;
        let d = (2.0 + inv_r) * sin2.powf(inv_r * 0.5) / (2.0 * std::f64::consts::PI);
        d / (4.0 * (wi.z + wo.z - wi.z * wo.z))
    }

    #[test]
    fn value_is_materialx_where_it_conserves_energy() {
        let c = SampledSpectrum([1.0, 0.6, 0.3, 0.8]);
        let mut rng = TestRng::new(5);
        for r in [0.3f32, 0.5, 0.8, 1.0] {
            let s = Sheen::new(c, r);
            for _ in 0..1000 {
                let (wo, wi) = (random_upper(&mut rng), random_upper(&mut rng));
                let m = materialx(wo, wi, r);
                let f = s.f(wo, wi);
                for i in 0..4 {
                    // single against double precision: a few ulps of each factor
                    let expect = c[i] as f64 * m;
                    assert!((f[i] as f64 - expect).abs() <= 2e-6 * expect + 1e-12, "r {r}: {f:?} vs {m}");
                }
            }
        }
        // small roughness away from grazing angles: also unchanged
        let s = Sheen::new(SampledSpectrum::ONE, 0.05);
        let (wo, wi) = (dir_mu(0.6, 0.0), dir_mu(0.5, 2.0));
        assert!(bound(tables().raw_albedo(0.5, 0.05).max(tables().raw_albedo(0.6, 0.05))) == 1.0);
        let m = materialx(wo, wi, 0.05);
        assert!(m > 0.0 && (s.f(wo, wi)[0] as f64 - m).abs() <= 2e-5 * m, "{m}");
        // and divided where the raw albedo exceeds 1
        let (wo, wi) = (dir_mu(0.01, 0.0), dir_mu(0.02, 0.5));
        let m = materialx(wo, wi, 0.05);
        let n = bound(tables().raw_albedo(0.01, 0.05).max(tables().raw_albedo(0.02, 0.05)));
        assert!(n > 1.5 && (s.f(wo, wi)[0] as f64 - m / n as f64).abs() <= 2e-5 * m, "{m} / {n}");
    }

    #[test]
    fn zero_below_the_horizon() {
        let s = Sheen::new(SampledSpectrum::ONE, 0.3);
        let (up, down) = (dir_mu(0.5, 0.3), dir_mu(-0.5, 1.0));
        assert_eq!(s.f(up, down), SampledSpectrum::ZERO);
        assert_eq!(s.f(down, up), SampledSpectrum::ZERO);
        assert_eq!(s.pdf(up, down), 0.0);
        assert!(s.sample_f(down, Vec2::new(0.3, 0.3)).is_none());
    }

    #[test]
    fn reciprocity() {
        let mut rng = TestRng::new(6);
        for r in [0.005f32, 0.05, 0.15, 0.4, 1.0] {
            let s = Sheen::new(SampledSpectrum::ONE, r);
            for _ in 0..2000 {
                let (wo, wi) = (random_upper(&mut rng), random_upper(&mut rng));
                let (a, b) = (s.f(wo, wi)[0], s.f(wi, wo)[0]);
                // the half vector is formed as wo + wi vs wi + wo: identical up to rounding
                assert!((a - b).abs() <= 1e-5 * a.max(1e-3), "r {r}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn chi2_of_sampling() {
        // 2 roughnesses × 3 directions; 1% family-wise, Šidák-corrected
        for r in [0.1f32, 0.7] {
            let s = Sheen::new(SampledSpectrum::ONE, r);
            for wo in [dir_mu(1.0, 0.0), dir_mu(0.4, 1.0), dir_mu(0.03, 2.0)] {
                let res = chi2_sphere(
                    Chi2Config { samples: 50_000, ..Chi2Config::default() },
                    |rng| s.sample_f(wo, Vec2::new(rng.next_f32(), rng.next_f32())).map(|b| b.wi),
                    |wi| s.pdf(wo, wi),
                );
                assert!(res.passed(0.01, 6), "r {r} wo {wo:?}: {res:?}");
                assert!((res.pdf_integral - 1.0).abs() < 1e-3 && res.success_rate == 1.0, "{res:?}");
                let mut rng = TestRng::new(8);
                for _ in 0..200 {
                    let b = s.sample_f(wo, Vec2::new(rng.next_f32(), rng.next_f32())).unwrap();
                    assert_eq!(b.f, s.f(wo, b.wi));
                    assert_eq!(b.pdf, s.pdf(wo, b.wi));
                }
            }
        }
    }

    /// Monte Carlo estimate (uniform hemisphere, `n` samples) of ∫ g μi dωi and its standard
    /// error.
    fn monte_carlo(wo: Vec3, n: usize, seed: u64, g: impl Fn(Vec3, Vec3) -> f32) -> (f64, f64) {
        let mut rng = TestRng::new(seed);
        let (mut s1, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let z = 1.0 - rng.next_f32();
            let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
            let s = (1.0 - z * z).max(0.0).sqrt();
            let wi = Vec3::new(s * phi.cos(), s * phi.sin(), z);
            let v = (g(wo, wi) * wi.z) as f64 * 2.0 * std::f64::consts::PI;
            s1 += v;
            s2 += v * v;
        }
        let m = s1 / n as f64;
        (m, ((s2 / n as f64 - m * m) / n as f64).sqrt())
    }

    /// Allowance for the error of the bilinear lookups between nodes: the largest found at cell
    /// centres by `report_sheen_table_accuracy` is 6.7·10⁻³.
    const INTERPOLATION_TOL: f64 = 1e-2;

    /// The tabulated albedo against brute-force Monte Carlo of f·cos, on and between nodes.
    #[test]
    fn table_matches_monte_carlo() {
        for &(mu, r) in &[(0.02f32, 0.02f32), (0.1, 0.1), (0.5, 0.1), (0.05, 0.3), (0.33, 0.45), (0.8, 0.7), (1.0, 1.0), (0.2, 0.93)] {
            let s = Sheen::new(SampledSpectrum::ONE, r);
            let wo = dir_mu(mu, 0.0);
            let (m, se) = monte_carlo(wo, 200_000, 31, |a, b| s.f(a, b)[0]);
            let e = s.albedo(mu) as f64;
            assert!((m - e).abs() < 4.0 * se + INTERPOLATION_TOL, "μ {mu} r {r}: MC {m} ± {se}, table {e}");
        }
    }

    /// A white sheen never reflects more than it receives: the tabulated albedo (every node,
    /// and lookups between them) and brute-force estimates of the lobe's albedo at the worst
    /// places (grazing views at small roughness, between nodes) stay at or below 1; the latter
    /// within 4 standard errors of the Monte Carlo estimate, with no allowance for the table.
    #[test]
    fn white_sheen_never_creates_energy() {
        let t = tables();
        assert!(t.scaled.iter().zip(&t.raw).all(|(&s, &r)| s >= 0.0 && s <= bound(r)));
        assert!(t.bounded_avg.iter().all(|&e| e <= 1.0 && e >= 0.0));
        for j in 0..=200 {
            let r = j as f32 / 200.0;
            for i in 0..=100 {
                let mu = i as f32 / 100.0;
                assert!(t.albedo(mu, r) <= 1.0);
            }
        }
        // MaterialX's lobe does exceed 1 there
        assert!(t.raw_albedo(0.001, 0.05) > 1.5);
        for &(mu, r) in &[(0.0005f32, 0.005f32), (0.003, 0.011), (0.02, 0.03), (0.0025, 0.1), (0.01, 0.17)] {
            let s = Sheen::new(SampledSpectrum::ONE, r);
            let (m, se) = monte_carlo(dir_mu(mu, 0.0), 200_000, 41, |a, b| s.f(a, b)[0]);
            assert!(m < 1.0 + 4.0 * se, "μ {mu} r {r}: {m} ± {se}");
        }
    }

    /// The tables are deterministic: a rebuild reproduces the shared copy bit for bit (the build
    /// time is reported).
    #[test]
    fn tables_are_deterministic() {
        let t = std::time::Instant::now();
        let fresh = SheenTables::build();
        eprintln!("sheen tables built in {:?}", t.elapsed());
        assert!(fresh == *tables());
    }

    #[test]
    fn average_is_the_integral_of_the_albedo() {
        let gl = gauss_legendre(64);
        for r in [0.01f32, 0.2, 0.6, 1.0] {
            let s = Sheen::new(SampledSpectrum::ONE, r);
            // the interpolant is piecewise linear in √μ: 64 Gauss points per cell-sized piece
            // would be exact; over the whole interval they leave ~1e-4
            let q: f64 = gl.iter().map(|&(x, w)| 2.0 * w * x * s.albedo(x as f32) as f64).sum();
            assert!((q - s.albedo_avg() as f64).abs() < 1e-3, "r {r}: {q} vs {}", s.albedo_avg());
        }
    }

    /// Accuracy report of the tables: quadrature convergence (order doubled) at every node and
    /// interpolation error at cell centres, against direct quadrature. Run with
    /// `cargo test --release -p tide-core --lib report_sheen_table -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn report_sheen_table_accuracy() {
        let t = tables();
        let gl2 = gauss_legendre(2 * QUAD_ORDER);
        let mut worst_quad: (f64, f32, f32) = (0.0, 0.0, 0.0);
        for j in 0..N_R {
            let r = grid_r(j);
            let inv_r = 1.0 / r;
            for i in 0..N_MU {
                let q = integrate(grid_mu(i), &gl2, |wo, wi| sheen_raw(wo, wi, inv_r));
                let d = (q - t.raw[j * N_MU + i] as f64).abs() / q.max(1e-3);
                if d > worst_quad.0 {
                    worst_quad = (d, grid_mu(i), r);
                }
            }
        }
        eprintln!("raw quadrature: worst relative change with doubled order {worst_quad:?}");
        let gl = gauss_legendre(2 * QUAD_ORDER);
        let (mut worst_raw, mut worst_b): ((f64, f32, f32), (f64, f32, f32)) = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0));
        let mut max_b = 0.0f64;
        for j in 0..N_R - 1 {
            let tr = (j as f32 + 0.5) / (N_R - 1) as f32;
            let r = MIN_ROUGHNESS * (1.0 / MIN_ROUGHNESS).powf(tr);
            let s = Sheen::new(SampledSpectrum::ONE, r);
            for i in 0..N_MU - 1 {
                let x = (i as f32 + 0.5) / (N_MU - 1) as f32;
                let mu = x * x;
                let raw = integrate(mu, &gl, |wo, wi| sheen_raw(wo, wi, 1.0 / r));
                let b = integrate(mu, &gl, |wo, wi| s.f(wo, wi)[0]);
                let dr = (raw - t.raw_albedo(mu, r) as f64).abs() / raw.max(1.0);
                let db = (b - s.albedo(mu) as f64).abs();
                max_b = max_b.max(b);
                if dr > worst_raw.0 {
                    worst_raw = (dr, mu, r);
                }
                if db > worst_b.0 {
                    worst_b = (db, mu, r);
                }
            }
        }
        eprintln!("raw interpolation: worst relative error {worst_raw:?}");
        eprintln!("bounded interpolation: worst absolute error {worst_b:?}, largest true albedo {max_b}");
        // MaterialX's rational fit of the raw albedo, where it is below 1
        let mut worst_fit: (f64, f32, f32) = (0.0, 0.0, 0.0);
        for j in 0..=20 {
            let r = (j as f32 / 20.0).max(0.01);
            for i in 0..=20 {
                let mu = i as f32 / 20.0;
                let (x, y) = (
                    13.67300 - 68.78018 * mu + 799.08825 * r - 905.00061 * mu * r + 60.28956 * mu * mu + 1086.96473 * r * r,
                    1.0 + 61.57746 * mu + 442.78211 * r + 2597.49308 * mu * r + 121.81241 * mu * mu + 3045.55075 * r * r,
                );
                let fit = (x / y).clamp(0.0, 1.0) as f64;
                let e = (t.raw_albedo(mu, r) as f64).min(1.0);
                if (fit - e).abs() > worst_fit.0 {
                    worst_fit = ((fit - e).abs(), mu, r);
                }
            }
        }
        eprintln!("MaterialX's rational fit vs table (both clamped to 1): worst {worst_fit:?}");
    }
}
