//! χ² goodness-of-fit test of a sampler of directions against its own pdf, in the manner of
//! Mitsuba 3's `ChiSquareTest`: the sphere is cut into cells of equal (cosθ, φ) extent, the
//! expected count of each cell is the pdf integrated over it by dense quadrature, cells with
//! too few expected samples are pooled, and the p-value of Pearson's statistic decides.

use glam::Vec3;

/// Outcome of one χ² run.
#[derive(Debug, Clone)]
pub struct Chi2Result {
    pub p_value: f64,
    pub statistic: f64,
    pub dof: usize,
    /// ∫ pdf dω over the sphere (1 for a sampler that never fails).
    pub pdf_integral: f64,
    /// Fraction of sample attempts that produced a direction.
    pub success_rate: f64,
    /// Samples whose direction had pdf(ω) == 0 (must be 0 for a correct pair).
    pub samples_outside_support: usize,
    pub message: String,
}

impl Chi2Result {
    /// Passes at significance `alpha`, Šidák-corrected for `n_tests` tests in the suite.
    pub fn passed(&self, alpha: f64, n_tests: usize) -> bool {
        let a = 1.0 - (1.0 - alpha).powf(1.0 / n_tests.max(1) as f64);
        self.p_value > a && self.samples_outside_support == 0
    }
}

/// Settings of the test.
#[derive(Debug, Clone, Copy)]
pub struct Chi2Config {
    pub theta_res: usize,
    pub phi_res: usize,
    pub samples: usize,
    /// Quadrature points per cell and axis for the expected counts.
    pub quad_res: usize,
    /// Minimum expected count per pooled cell.
    pub min_expected: f64,
    pub seed: u64,
}

impl Default for Chi2Config {
    fn default() -> Self {
        Chi2Config { theta_res: 10, phi_res: 20, samples: 200_000, quad_res: 24, min_expected: 5.0, seed: 7 }
    }
}

/// A tiny deterministic generator for tests (SplitMix64 → floats in [0,1)).
#[derive(Clone)]
pub struct TestRng(u64);

impl TestRng {
    pub fn new(seed: u64) -> Self {
        TestRng(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E3779B97F4A7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        z ^ (z >> 31)
    }
    pub fn next_f32(&mut self) -> f32 {
        ((self.next_u64() >> 40) as f32) * (1.0 / (1u64 << 24) as f32)
    }
}

fn cell_of(d: Vec3, cfg: &Chi2Config) -> usize {
    let z = d.z.clamp(-1.0, 1.0);
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += 2.0 * std::f32::consts::PI;
    }
    let ti = (((1.0 - z) * 0.5) * cfg.theta_res as f32) as usize;
    let pi = ((phi / (2.0 * std::f32::consts::PI)) * cfg.phi_res as f32) as usize;
    ti.min(cfg.theta_res - 1) * cfg.phi_res + pi.min(cfg.phi_res - 1)
}

/// Runs the test. `sample(rng)` returns a unit direction or None (a failed sample, which is
/// allowed: the pdf then integrates to the success rate). `pdf(ω)` is the solid-angle density.
pub fn chi2_sphere(
    cfg: Chi2Config,
    mut sample: impl FnMut(&mut TestRng) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f32,
) -> Chi2Result {
    let n_cells = cfg.theta_res * cfg.phi_res;
    let mut observed = vec![0f64; n_cells];
    let mut rng = TestRng::new(cfg.seed);
    let mut ok = 0usize;
    let mut outside = 0usize;
    for _ in 0..cfg.samples {
        if let Some(d) = sample(&mut rng) {
            if !d.is_finite() || (d.length() - 1.0).abs() > 1e-3 {
                outside += 1;
                continue;
            }
            ok += 1;
            if !(pdf(d) > 0.0) {
                outside += 1;
            }
            observed[cell_of(d, &cfg)] += 1.0;
        }
    }
    // expected counts: midpoint quadrature in (z, φ), where dω = dz dφ
    let mut expected = vec![0f64; n_cells];
    let dz = 2.0 / cfg.theta_res as f64;
    let dphi = 2.0 * std::f64::consts::PI / cfg.phi_res as f64;
    let q = cfg.quad_res;
    let mut integral = 0.0;
    for ti in 0..cfg.theta_res {
        for pi in 0..cfg.phi_res {
            let mut acc = 0.0;
            for a in 0..q {
                let z = 1.0 - (ti as f64 + (a as f64 + 0.5) / q as f64) * dz;
                let r = (1.0 - z * z).max(0.0).sqrt();
                for b in 0..q {
                    let phi = (pi as f64 + (b as f64 + 0.5) / q as f64) * dphi;
                    let d = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                    let p = pdf(d) as f64;
                    if p.is_finite() {
                        acc += p;
                    }
                }
            }
            let cell_integral = acc * dz * dphi / (q * q) as f64;
            integral += cell_integral;
            expected[ti * cfg.phi_res + pi] = cell_integral * cfg.samples as f64;
        }
    }
    // pool cells in increasing order of expected count until each pool reaches min_expected
    let mut order: Vec<usize> = (0..n_cells).collect();
    order.sort_by(|&a, &b| expected[a].partial_cmp(&expected[b]).unwrap());
    let mut stat = 0.0;
    let mut dof = 0usize;
    let (mut pool_e, mut pool_o) = (0.0, 0.0);
    let mut message = String::new();
    for &c in &order {
        if expected[c] == 0.0 {
            if observed[c] > 0.0 {
                message += &format!("cell {c}: {} samples where the pdf integrates to 0\n", observed[c]);
                stat = f64::INFINITY;
            }
            continue;
        }
        if expected[c] < cfg.min_expected {
            pool_e += expected[c];
            pool_o += observed[c];
            if pool_e >= cfg.min_expected {
                stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
                dof += 1;
                pool_e = 0.0;
                pool_o = 0.0;
            }
            continue;
        }
        stat += (observed[c] - expected[c]).powi(2) / expected[c];
        dof += 1;
    }
    if pool_e > 0.0 {
        stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        dof += 1;
    }
    let dof = dof.saturating_sub(1).max(1);
    let p_value = if stat.is_finite() { gamma_q(dof as f64 / 2.0, stat / 2.0) } else { 0.0 };
    if outside > 0 {
        message += &format!("{outside} samples fell where pdf(ω) = 0 or were not unit vectors\n");
    }
    Chi2Result {
        p_value,
        statistic: stat,
        dof,
        pdf_integral: integral,
        success_rate: ok as f64 / cfg.samples as f64,
        samples_outside_support: outside,
        message,
    }
}

fn ln_gamma(x: f64) -> f64 {
    // Lanczos approximation (g = 7, n = 9)
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        return (std::f64::consts::PI / (std::f64::consts::PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, &c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma function Q(a, x) = Γ(a, x) / Γ(a).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    if x < a + 1.0 {
        // series for P
        let mut sum = 1.0 / a;
        let mut del = sum;
        let mut ap = a;
        for _ in 0..10_000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        let p = sum * (-x + a * x.ln() - ln_gamma(a)).exp();
        (1.0 - p).clamp(0.0, 1.0)
    } else {
        // Lentz continued fraction for Q
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (h * (-x + a * x.ln() - ln_gamma(a)).exp()).clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{sample_cosine_hemisphere, sample_uniform_sphere, INV_PI};
    use glam::Vec2;

    #[test]
    fn gamma_q_matches_known_values() {
        // Q(1, x) = e^{-x}; χ² with 2 dof at statistic 2x
        assert!((gamma_q(1.0, 2.0) - (-2.0f64).exp()).abs() < 1e-12);
        // Q(k/2, x/2) for k = 10, x = 18.307 (95th percentile of χ²_10) = 0.05
        assert!((gamma_q(5.0, 18.307 / 2.0) - 0.05).abs() < 1e-4);
    }

    #[test]
    fn accepts_a_correct_cosine_sampler() {
        let r = chi2_sphere(
            Chi2Config::default(),
            |rng| Some(sample_cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()))),
            |d| d.z.max(0.0) * INV_PI,
        );
        assert!(r.passed(0.01, 1), "{r:?}");
        assert!((r.pdf_integral - 1.0).abs() < 1e-3);
    }

    #[test]
    fn rejects_a_sampler_that_disagrees_with_its_pdf() {
        // uniform sphere samples tested against the cosine pdf: must fail
        let r = chi2_sphere(
            Chi2Config::default(),
            |rng| {
                let d = sample_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                Some(Vec3::new(d.x, d.y, d.z.abs()))
            },
            |d| d.z.max(0.0) * INV_PI,
        );
        assert!(!r.passed(0.01, 1), "{r:?}");
    }
}
