//! RGB → sigmoid-polynomial coefficients (Jakob & Hanika 2019, "A Low-Dimensional Function
//! Space for Efficient Spectral Upsampling"): the Gauss–Newton fit of one colour, the 3D table
//! per colour space (built offline by `examples/gen_rgb2spec.rs`, embedded from `core/data/`),
//! its binary format and its trilinear lookup.
//!
//! A spectrum is sigmoid(a·t² + b·t + c) with t = (λ − 360 nm)/470 nm and
//! sigmoid(x) = ½ + x/(2√(1+x²)); its RGB is that of the reflectance lit by the colour space's
//! white illuminant. The table is indexed by the largest channel m, its value z (on the
//! non-uniform nodes smoothstep(smoothstep(k/(res−1)))), and the two other channels divided by z.

use super::cie::{cie, node_lambda, quad_weight, N_DENSE};
use super::color::color_space;
use super::sampled::{LAMBDA_MAX, LAMBDA_MIN};
use crate::scene::ColorSpace;
use std::sync::OnceLock;

/// Magic bytes of the table files.
pub const MAGIC: &[u8; 8] = b"TRGB2SP1";

const REC709_BIN: &[u8] = include_bytes!("../../data/rgb2spec_rec709.bin");
const ACESCG_BIN: &[u8] = include_bytes!("../../data/rgb2spec_acescg.bin");

/// sigmoid(x) = ½ + x/(2√(1+x²)), with the limits at ±∞.
#[inline]
pub fn sigmoid(x: f32) -> f32 {
    if x.is_infinite() {
        return if x > 0.0 { 1.0 } else { 0.0 };
    }
    0.5 + x / (2.0 * (1.0 + x * x).sqrt())
}

/// Bound on |a|, |b|, |c| during a fit. Targets that no sigmoid spectrum reaches (the
/// gamut edges, much of the bright ACEScg cube) drive Gauss–Newton towards infinite
/// coefficients; the bound stops them at a finite, nearly box-shaped spectrum, so the table
/// stays finite in f32 and can be interpolated.
pub const COEFF_MAX: f64 = 1.0e4;

/// Quadrature nodes of the fit: the 1 nm grid, each with t and its RGB weight vector
/// (so that RGB = Σₖ s(tₖ)·wₖ for a reflectance s under the colour space's white).
pub struct Fitter {
    t: Vec<f64>,
    w: Vec<[f64; 3]>,
}

/// Outcome of one fit.
#[derive(Clone, Copy, Debug)]
pub struct Fit {
    /// (a, b, c) of a·t² + b·t + c.
    pub coeffs: [f64; 3],
    /// Largest absolute RGB error left.
    pub residual: f64,
    pub iterations: u32,
}

impl Fitter {
    pub fn new(cs: ColorSpace) -> Self {
        let c = cie();
        let space = color_space(cs);
        let white = c.white(cs);
        let m = space.xyz_to_rgb;
        let mut t = Vec::with_capacity(N_DENSE);
        let mut w = Vec::with_capacity(N_DENSE);
        for i in 0..N_DENSE {
            let cmf = c.cmf_node(i);
            let k = quad_weight(i) * white.node(i) as f64 / c.y_integral;
            let xyz = glam::DVec3::new(cmf[0] as f64 * k, cmf[1] as f64 * k, cmf[2] as f64 * k);
            let rgb = m * xyz;
            t.push((node_lambda(i) - LAMBDA_MIN as f64) / (LAMBDA_MAX - LAMBDA_MIN) as f64);
            w.push([rgb.x, rgb.y, rgb.z]);
        }
        Fitter { t, w }
    }

    /// RGB of the reflectance with coefficients `c` and its Jacobian d rgb / d c.
    pub fn eval(&self, c: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let mut rgb = [0.0; 3];
        let mut jac = [[0.0; 3]; 3];
        for (&t, w) in self.t.iter().zip(&self.w) {
            let x = (c[0] * t + c[1]) * t + c[2];
            let q = 1.0 / (1.0 + x * x).sqrt();
            let s = 0.5 + 0.5 * x * q;
            let ds = 0.5 * q * q * q;
            let d = [ds * t * t, ds * t, ds];
            for r in 0..3 {
                rgb[r] += s * w[r];
                for k in 0..3 {
                    jac[r][k] += d[k] * w[r];
                }
            }
        }
        (rgb, jac)
    }

    /// Gauss–Newton fit of `target` from the start `c`, with step halving whenever a step
    /// does not reduce the error or leaves |coefficient| ≤ [`COEFF_MAX`]. Stops at an error
    /// below 1e-9 relative to the largest channel, or when no step helps (a target outside
    /// what sigmoid spectra reach: the fit then ends at the closest point it found).
    pub fn fit(&self, target: [f64; 3], mut c: [f64; 3]) -> Fit {
        let scale = target.iter().copied().fold(0.0, f64::max).max(1e-12);
        let err = |rgb: [f64; 3]| (0..3).map(|k| (rgb[k] - target[k]).abs()).fold(0.0, f64::max);
        let (mut rgb, mut jac) = self.eval(c);
        let mut e = err(rgb);
        let mut it = 0;
        while it < 64 && e > 1e-9 * scale {
            it += 1;
            let r = [rgb[0] - target[0], rgb[1] - target[1], rgb[2] - target[2]];
            let Some(step) = solve3(jac, r) else { break };
            let mut lambda = 1.0;
            let mut improved = false;
            for _ in 0..30 {
                let cn = [c[0] - lambda * step[0], c[1] - lambda * step[1], c[2] - lambda * step[2]];
                if !cn.iter().all(|v| v.abs() <= COEFF_MAX) {
                    lambda *= 0.5;
                    continue;
                }
                let (rn, jn) = self.eval(cn);
                let en = err(rn);
                if en < e {
                    (c, rgb, jac, e) = (cn, rn, jn, en);
                    improved = true;
                    break;
                }
                lambda *= 0.5;
            }
            if !improved {
                break;
            }
        }
        Fit { coeffs: c, residual: e, iterations: it }
    }
}

/// Solves J·x = r (Cramer's rule); None when J is singular.
fn solve3(j: [[f64; 3]; 3], r: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(j);
    if !(d.abs() > 0.0) || !d.is_finite() {
        return None;
    }
    let mut x = [0.0; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        let mut m = j;
        for row in 0..3 {
            m[row][k] = r[row];
        }
        *xk = det(m) / d;
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// smoothstep(smoothstep(k/(res−1))): the brightness nodes, denser near 0 and 1.
pub fn z_nodes(res: usize) -> Vec<f32> {
    let ss = |x: f64| x * x * (3.0 - 2.0 * x);
    (0..res).map(|k| ss(ss(k as f64 / (res - 1) as f64)) as f32).collect()
}

/// The target RGB of table entry (max channel `m`, brightness `z`, ratios `x`, `y`).
pub fn entry_rgb(m: usize, z: f64, x: f64, y: f64) -> [f64; 3] {
    let mut rgb = [0.0; 3];
    rgb[m] = z;
    rgb[(m + 1) % 3] = x * z;
    rgb[(m + 2) % 3] = y * z;
    rgb
}

/// Fits the column of entries (m, ·, yi, xi) of a table of resolution `res`, in the order the
/// generator uses: from the node nearest z = 0.2 upwards, then from it downwards, each fit
/// starting from its neighbour's result. Entry 0 (black) copies entry 1. Returns (a, b, c)
/// per z node.
/// `res` must be at least 2 and `m` < 3, `yi`, `xi` < `res`.
pub fn solve_column(fitter: &Fitter, res: usize, m: usize, yi: usize, xi: usize) -> Vec<[f64; 3]> {
    let res = res.max(2);
    let m = m.min(2);
    let z = z_nodes(res);
    let x = xi as f64 / (res - 1) as f64;
    let y = yi as f64 / (res - 1) as f64;
    let mut out = vec![[0.0; 3]; res];
    let start = res / 5;
    let mut c = [0.0; 3];
    for k in start..res {
        c = fitter.fit(entry_rgb(m, z[k] as f64, x, y), c).coeffs;
        out[k] = c;
    }
    c = out[start];
    for k in (1..start).rev() {
        c = fitter.fit(entry_rgb(m, z[k] as f64, x, y), c).coeffs;
        out[k] = c;
    }
    out[0] = out[1];
    out
}

/// The coefficient table of one colour space.
#[derive(Clone, Debug, PartialEq)]
pub struct Rgb2SpecTable {
    pub res: usize,
    pub z: Vec<f32>,
    /// (a, b, c) at [m][zi][yi][xi], flattened.
    pub coeffs: Vec<[f32; 3]>,
}

impl Rgb2SpecTable {
    #[inline]
    pub fn index(&self, m: usize, zi: usize, yi: usize, xi: usize) -> usize {
        ((m * self.res + zi) * self.res + yi) * self.res + xi
    }

    /// Fits every entry (columns in parallel). `res` must be in 2..=256.
    pub fn build(cs: ColorSpace, res: usize) -> Result<Self, String> {
        use rayon::prelude::*;
        if !(2..=256).contains(&res) {
            return Err(format!("rgb2spec table: resolution {res} outside 2..=256"));
        }
        let fitter = Fitter::new(cs);
        let cols: Vec<(usize, usize, usize)> =
            (0..3).flat_map(|m| (0..res).flat_map(move |yi| (0..res).map(move |xi| (m, yi, xi)))).collect();
        let solved: Vec<Vec<[f64; 3]>> =
            cols.par_iter().map(|&(m, yi, xi)| solve_column(&fitter, res, m, yi, xi)).collect();
        let mut t = Rgb2SpecTable { res, z: z_nodes(res), coeffs: vec![[0.0; 3]; 3 * res * res * res] };
        for (&(m, yi, xi), col) in cols.iter().zip(&solved) {
            for (zi, c) in col.iter().enumerate() {
                let i = t.index(m, zi, yi, xi);
                t.coeffs[i] = c.map(|v| v as f32);
            }
        }
        Ok(t)
    }

    /// The binary file (format in `core/data/README.md`).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(12 + 4 * (self.z.len() + 3 * self.coeffs.len()));
        b.extend_from_slice(MAGIC);
        b.extend_from_slice(&(self.res as u32).to_le_bytes());
        for v in &self.z {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for c in &self.coeffs {
            for v in c {
                b.extend_from_slice(&v.to_le_bytes());
            }
        }
        b
    }

    /// Parses a table file.
    pub fn from_bytes(b: &[u8]) -> Result<Self, String> {
        if b.len() < 12 || &b[..8] != MAGIC {
            return Err("rgb2spec table: missing magic \"TRGB2SP1\"".into());
        }
        let res = u32::from_le_bytes([b[8], b[9], b[10], b[11]]) as usize;
        if !(2..=256).contains(&res) {
            return Err(format!("rgb2spec table: resolution {res} outside 2..=256"));
        }
        let n = res + 9 * res * res * res;
        if b.len() != 12 + 4 * n {
            return Err(format!("rgb2spec table: {} bytes, expected {} for resolution {res}", b.len(), 12 + 4 * n));
        }
        let f: Vec<f32> = b[12..].chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        if !f.iter().all(|v| v.is_finite()) {
            return Err("rgb2spec table: non-finite value".into());
        }
        let z = f[..res].to_vec();
        if z.windows(2).any(|w| w[1] <= w[0]) {
            return Err("rgb2spec table: brightness nodes not increasing".into());
        }
        let coeffs = f[res..].chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        Ok(Rgb2SpecTable { res, z, coeffs })
    }

    /// Trilinearly interpolated (a, b, c) (in t) for an RGB in [0,1]³ with a positive channel.
    pub fn lookup_t(&self, rgb: [f32; 3]) -> [f32; 3] {
        let m = if rgb[0] >= rgb[1] && rgb[0] >= rgb[2] {
            0
        } else if rgb[1] >= rgb[2] {
            1
        } else {
            2
        };
        let z = rgb[m].clamp(0.0, 1.0);
        if !(z > 0.0) {
            return [0.0, 0.0, f32::NEG_INFINITY];
        }
        let r1 = (self.res - 1) as f32;
        let x = (rgb[(m + 1) % 3] / z).clamp(0.0, 1.0) * r1;
        let y = (rgb[(m + 2) % 3] / z).clamp(0.0, 1.0) * r1;
        let xi = (x as usize).min(self.res - 2);
        let yi = (y as usize).min(self.res - 2);
        let zi = (self.z.partition_point(|&v| v <= z).max(1) - 1).min(self.res - 2);
        let (dx, dy) = (x - xi as f32, y - yi as f32);
        let dz = (z - self.z[zi]) / (self.z[zi + 1] - self.z[zi]);
        let mut out = [0.0f32; 3];
        for (k, wz) in [(0, 1.0 - dz), (1, dz)] {
            for (j, wy) in [(0, 1.0 - dy), (1, dy)] {
                for (i, wx) in [(0, 1.0 - dx), (1, dx)] {
                    let w = wz * wy * wx;
                    if w != 0.0 {
                        let c = self.coeffs[self.index(m, zi + k, yi + j, xi + i)];
                        for q in 0..3 {
                            out[q] += w * c[q];
                        }
                    }
                }
            }
        }
        out
    }

    /// (c0, c1, c2) of c0·λ² + c1·λ + c2 with λ in nm, for an RGB in [0,1]³.
    pub fn lookup(&self, rgb: [f32; 3]) -> [f32; 3] {
        let [a, b, c] = self.lookup_t(rgb).map(|v| v as f64);
        if c == f64::NEG_INFINITY {
            return [0.0, 0.0, f32::NEG_INFINITY];
        }
        t_to_nm([a, b, c])
    }
}

/// Converts a·t² + b·t + c, t = (λ − 360)/470, to c0·λ² + c1·λ + c2 (λ in nm).
pub fn t_to_nm([a, b, c]: [f64; 3]) -> [f32; 3] {
    let l0 = LAMBDA_MIN as f64;
    let s = 1.0 / (LAMBDA_MAX - LAMBDA_MIN) as f64;
    let c0 = a * s * s;
    let c1 = b * s - 2.0 * a * s * s * l0;
    let c2 = a * s * s * l0 * l0 - b * s * l0 + c;
    [c0 as f32, c1 as f32, c2 as f32]
}

/// The embedded table of a colour space. Rec.2020 has none: `uplift` takes its colours
/// to Rec.709 first.
pub fn table(cs: ColorSpace) -> &'static Rgb2SpecTable {
    static REC709: OnceLock<Rgb2SpecTable> = OnceLock::new();
    static ACESCG: OnceLock<Rgb2SpecTable> = OnceLock::new();
    let (cell, bytes) = match cs {
        ColorSpace::LinearRec709 => (&REC709, REC709_BIN),
        ColorSpace::AcesCg => (&ACESCG, ACESCG_BIN),
        ColorSpace::LinearRec2020 => unreachable!("uplift takes Rec.2020 colours to Rec.709"),
    };
    cell.get_or_init(|| {
        Rgb2SpecTable::from_bytes(bytes).unwrap_or_else(|e| {
            panic!("embedded {cs:?} table is corrupt (regenerate it with examples/gen_rgb2spec.rs): {e}")
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_tables_parse_and_have_enough_resolution() {
        for cs in [ColorSpace::LinearRec709, ColorSpace::AcesCg] {
            let t = table(cs);
            assert!(t.res >= 32);
            assert_eq!(t.z, z_nodes(t.res));
        }
    }

    #[test]
    fn optimiser_reproduces_stored_columns() {
        // Re-runs the generator's fit on a few columns; the fit is deterministic f64 and
        // stored as f32, so agreement to f32 rounding (1e-6 relative, plus 1e-6 absolute for
        // coefficients near 0) shows the files are what this code generates.
        for cs in [ColorSpace::LinearRec709, ColorSpace::AcesCg] {
            let t = table(cs);
            let f = Fitter::new(cs);
            let r = t.res;
            for &(m, yi, xi) in &[(0, r / 3, r / 2), (1, r - 1, 0), (2, 1, r - 2), (1, r / 2, r / 2)] {
                let col = solve_column(&f, r, m, yi, xi);
                for (zi, c) in col.iter().enumerate() {
                    let s = t.coeffs[t.index(m, zi, yi, xi)];
                    for q in 0..3 {
                        let tol = 1e-6 * c[q].abs().max(1.0);
                        assert!((s[q] as f64 - c[q]).abs() <= tol, "{cs:?} ({m},{zi},{yi},{xi}): {s:?} vs {c:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn fits_reach_their_targets_inside_the_gamut() {
        // A target away from the gamut boundary is reachable exactly, so Gauss–Newton must
        // converge to its 1e-9 relative stopping error.
        for cs in [ColorSpace::LinearRec709, ColorSpace::AcesCg] {
            let f = Fitter::new(cs);
            for target in [[0.5, 0.3, 0.2], [0.1, 0.6, 0.4], [0.05, 0.05, 0.2], [0.8, 0.8, 0.7]] {
                let fit = f.fit(target, [0.0; 3]);
                assert!(fit.residual <= 1e-9 * 0.8, "{cs:?} {target:?}: {fit:?}");
            }
        }
    }

    #[test]
    fn bad_table_bytes_are_rejected_with_a_reason() {
        assert!(Rgb2SpecTable::build(ColorSpace::LinearRec709, 1).unwrap_err().contains("resolution 1"));
        assert!(Rgb2SpecTable::from_bytes(b"nonsense").unwrap_err().contains("magic"));
        let mut b = table(ColorSpace::LinearRec709).to_bytes();
        b.pop();
        assert!(Rgb2SpecTable::from_bytes(&b).unwrap_err().contains("bytes"));
    }

    #[test]
    fn nm_conversion_preserves_the_polynomial() {
        let abc = [3.0, -2.0, 0.5];
        let c = t_to_nm(abc);
        for l in [360.0f64, 500.0, 830.0] {
            let t = (l - 360.0) / 470.0;
            let want = abc[0] * t * t + abc[1] * t + abc[2];
            let got = (c[0] as f64 * l + c[1] as f64) * l + c[2] as f64;
            // f32 coefficients: relative 1e-7 of terms of size ~|a|·(λ/470)² ≈ 10.
            assert!((want - got).abs() < 1e-5, "{want} {got}");
        }
    }
}
