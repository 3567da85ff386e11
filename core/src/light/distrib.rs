//! Piecewise-constant distributions in one and two dimensions over [0,1) and [0,1)², used to
//! importance-sample the dome light's lat-long map.

/// A piecewise-constant density over [0,1) with `n` equal cells.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution1D {
    /// Non-negative cell values (the function, not normalised).
    func: Vec<f32>,
    /// n + 1 entries, cdf[0] = 0, cdf[n] = 1.
    cdf: Vec<f32>,
    /// ∫ func over [0,1) (= mean of the cells).
    integral: f32,
}

impl Distribution1D {
    /// `func` must be non-empty; negative or non-finite values count as 0. An all-zero function
    /// becomes uniform for sampling, while `integral()` stays 0.
    pub fn new(func: &[f32]) -> Self {
        let n = func.len().max(1);
        let func: Vec<f32> = (0..n).map(|i| func.get(i).copied().filter(|v| v.is_finite() && *v > 0.0).unwrap_or(0.0)).collect();
        let mut cdf = Vec::with_capacity(n + 1);
        cdf.push(0.0f32);
        let mut acc = 0.0f64;
        for &f in &func {
            acc += f as f64 / n as f64;
            cdf.push(acc as f32);
        }
        let integral = acc as f32;
        if acc > 0.0 {
            for c in cdf.iter_mut() {
                *c = (*c as f64 / acc) as f32;
            }
        } else {
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = i as f32 / n as f32;
            }
        }
        cdf[n] = 1.0;
        Distribution1D { func, cdf, integral }
    }

    pub fn len(&self) -> usize {
        self.func.len()
    }

    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// Density at cell `i` (with respect to the unit interval).
    #[inline]
    pub fn pdf_cell(&self, i: usize) -> f32 {
        if self.integral > 0.0 {
            self.func[i] / self.integral
        } else {
            1.0
        }
    }

    /// Samples x in [0,1); returns (x, density, cell).
    #[inline]
    pub fn sample(&self, u: f32) -> (f32, f32, usize) {
        let n = self.func.len();
        // last index with cdf[i] <= u: never a zero-width cell, since its successor shares its cdf
        let i = self.cdf.partition_point(|&c| c <= u).saturating_sub(1).min(n - 1);
        let lo = self.cdf[i];
        let w = self.cdf[i + 1] - lo;
        let du = if w > 0.0 { ((u - lo) / w).clamp(0.0, 1.0) } else { 0.5 };
        let x = ((i as f32 + du) / n as f32).min(1.0 - f32::EPSILON * 0.5);
        (x, self.pdf_cell(i), i)
    }
}

/// A piecewise-constant density over [0,1)² on a `nu` × `nv` grid: the marginal picks a row
/// (v), the row's conditional picks a column (u).
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution2D {
    rows: Vec<Distribution1D>,
    marginal: Distribution1D,
}

impl Distribution2D {
    /// `func` is row-major, `nv` rows of `nu` values.
    pub fn new(func: &[f32], nu: usize, nv: usize) -> Self {
        let rows: Vec<Distribution1D> = (0..nv).map(|v| Distribution1D::new(&func[v * nu..(v + 1) * nu])).collect();
        let marg: Vec<f32> = rows.iter().map(|r| r.integral()).collect();
        Distribution2D { marginal: Distribution1D::new(&marg), rows }
    }

    pub fn integral(&self) -> f32 {
        self.marginal.integral()
    }

    /// Samples (u, v) in [0,1)²; returns it with its density on the unit square.
    #[inline]
    pub fn sample(&self, u: [f32; 2]) -> ([f32; 2], f32) {
        let (v, pv, iv) = self.marginal.sample(u[1]);
        let (x, pu, _) = self.rows[iv].sample(u[0]);
        ([x, v], pu * pv)
    }

    /// Density at (u, v) on the unit square.
    #[inline]
    pub fn pdf(&self, uv: [f32; 2]) -> f32 {
        let nv = self.rows.len();
        let nu = self.rows[0].len();
        let iv = ((uv[1] * nv as f32) as usize).min(nv - 1);
        let iu = ((uv[0] * nu as f32) as usize).min(nu - 1);
        if self.marginal.integral() <= 0.0 {
            return 1.0;
        }
        // p(u,v) = f(u,v) / ∫f ; rows[iv].pdf_cell(iu) · marginal.pdf_cell(iv) equals it
        self.rows[iv].pdf_cell(iu) * self.marginal.pdf_cell(iv)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{gamma_q, TestRng};

    #[test]
    fn one_d_sampling_matches_the_cell_weights() {
        let f = [1.0, 0.0, 3.0, 0.5, 0.0, 2.0];
        let d = Distribution1D::new(&f);
        let total: f32 = f.iter().sum();
        let mut counts = [0f64; 6];
        let mut rng = TestRng::new(3);
        let n = 60_000;
        for _ in 0..n {
            let (x, p, i) = d.sample(rng.next_f32());
            assert!((0.0..1.0).contains(&x) && i == (x * 6.0) as usize);
            assert!((p - f[i] * 6.0 / total).abs() < 1e-4, "density {p} at cell {i}");
            counts[i] += 1.0;
        }
        let mut stat = 0.0;
        let mut dof = 0;
        for i in 0..6 {
            let e = n as f64 * f[i] as f64 / total as f64;
            if e == 0.0 {
                assert_eq!(counts[i], 0.0, "zero cell {i} was sampled");
                continue;
            }
            stat += (counts[i] - e).powi(2) / e;
            dof += 1;
        }
        // seeded: a correct sampler gives p ≫ 0.001; a wrong one (e.g. off-by-one cells) p ≈ 0
        assert!(gamma_q((dof - 1) as f64 / 2.0, stat / 2.0) > 1e-3, "χ² = {stat}");
    }

    #[test]
    fn two_d_density_integrates_to_one() {
        let (nu, nv) = (7, 5);
        let f: Vec<f32> = (0..nu * nv).map(|i| ((i * 37) % 11) as f32).collect();
        let d = Distribution2D::new(&f, nu, nv);
        let mut s = 0.0f64;
        for v in 0..nv {
            for u in 0..nu {
                s += d.pdf([(u as f32 + 0.5) / nu as f32, (v as f32 + 0.5) / nv as f32]) as f64 / (nu * nv) as f64;
            }
        }
        // exact up to f32 rounding of the cell densities
        assert!((s - 1.0).abs() < 1e-5, "{s}");
        let mut rng = TestRng::new(5);
        for _ in 0..1000 {
            let (uv, p) = d.sample([rng.next_f32(), rng.next_f32()]);
            assert!((p - d.pdf(uv)).abs() <= 1e-4 * p.max(1.0) && p > 0.0);
        }
    }
}
