//! The CIE 1931 2° standard observer and the white illuminants of the working colour spaces
//! (D65 for linear Rec.709, the ACES white for ACEScg), resampled once to a dense 1 nm grid
//! over [`LAMBDA_MIN`], [`LAMBDA_MAX`], plus the 1 nm trapezoid quadrature all colour
//! integrals use. Source tables and their provenance: `core/data/README.md`.

use super::sampled::LAMBDA_MIN;
use crate::scene::ColorSpace;
use std::sync::OnceLock;

/// Number of samples of the dense grid: one per nm from 360 to 830 inclusive.
pub const N_DENSE: usize = 471;

const CMF_CSV: &str = include_str!("../../data/cie1931_2deg_cmf.csv");
const D65_CSV: &str = include_str!("../../data/cie_d65.csv");

/// Chromaticity of the ACES white (SMPTE ST 2065-1).
pub const ACES_WHITE_XY: [f64; 2] = [0.32168, 0.33767];

/// A spectrum sampled every nm over [360, 830] nm, linearly interpolated, clamped at the ends.
#[derive(Clone, PartialEq)]
pub struct DenseSpectrum {
    values: [f32; N_DENSE],
    max: f32,
}

impl std::fmt::Debug for DenseSpectrum {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "DenseSpectrum {{ 360 nm: {}, 560 nm: {}, 830 nm: {}, max: {} }}",
            self.values[0],
            self.values[200],
            self.values[N_DENSE - 1],
            self.max
        )
    }
}

impl DenseSpectrum {
    /// From the values at 360, 361, …, 830 nm.
    pub fn new(values: [f32; N_DENSE]) -> Self {
        let max = values.iter().copied().fold(0.0, f32::max);
        DenseSpectrum { values, max }
    }
    /// Value at `lambda` nm.
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        let x = (lambda - LAMBDA_MIN).clamp(0.0, (N_DENSE - 1) as f32);
        let i = (x as usize).min(N_DENSE - 2);
        let f = x - i as f32;
        let (a, b) = (self.values[i], self.values[i + 1]);
        a + f * (b - a)
    }
    /// The value at grid node `i` (λ = 360 + i nm).
    #[inline]
    pub fn node(&self, i: usize) -> f32 {
        self.values[i]
    }
    /// Largest value (an upper bound of [`DenseSpectrum::eval`]).
    pub fn max_value(&self) -> f32 {
        self.max
    }
}

/// The observer and the white illuminants.
#[derive(Debug)]
pub struct Cie {
    /// (x̄, ȳ, z̄) at each grid node.
    cmf: [[f32; 3]; N_DENSE],
    /// ∫ ȳ dλ over [360, 830] nm (1 nm trapezoid rule).
    pub y_integral: f64,
    /// D65, scaled so that ∫ ȳ·W dλ = ∫ ȳ dλ.
    pub d65: DenseSpectrum,
    /// The ACES white (D60-like), scaled likewise.
    pub aces_white: DenseSpectrum,
}

/// Wavelength (nm) of grid node `i`.
#[inline]
pub fn node_lambda(i: usize) -> f64 {
    LAMBDA_MIN as f64 + i as f64
}

/// Weight of grid node `i` in the 1 nm trapezoid rule over [360, 830] nm.
#[inline]
pub fn quad_weight(i: usize) -> f64 {
    if i == 0 || i == N_DENSE - 1 {
        0.5
    } else {
        1.0
    }
}

impl Cie {
    /// Colour matching functions at `lambda` nm, linearly interpolated (0 outside the grid).
    #[inline]
    pub fn cmf(&self, lambda: f32) -> [f32; 3] {
        let x = lambda - LAMBDA_MIN;
        if !(0.0..=(N_DENSE - 1) as f32).contains(&x) {
            return [0.0; 3];
        }
        let i = (x as usize).min(N_DENSE - 2);
        let f = x - i as f32;
        let (a, b) = (self.cmf[i], self.cmf[i + 1]);
        [a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2])]
    }
    /// Colour matching functions at grid node `i`.
    #[inline]
    pub fn cmf_node(&self, i: usize) -> [f32; 3] {
        self.cmf[i]
    }
    /// The white illuminant of a colour space.
    pub fn white(&self, cs: ColorSpace) -> &DenseSpectrum {
        match cs {
            ColorSpace::LinearRec709 | ColorSpace::LinearRec2020 => &self.d65,
            ColorSpace::AcesCg => &self.aces_white,
        }
    }
    /// ∫ f·(x̄, ȳ, z̄) dλ / ∫ ȳ dλ by the 1 nm trapezoid rule: the XYZ of a spectrum `f(λ)`,
    /// normalised so that the constant 1 has Y = 1.
    pub fn integrate_xyz(&self, f: impl Fn(f64) -> f64) -> [f64; 3] {
        let mut s = [0.0; 3];
        for i in 0..N_DENSE {
            let w = quad_weight(i) * f(node_lambda(i));
            for (c, acc) in s.iter_mut().enumerate() {
                *acc += w * self.cmf[i][c] as f64;
            }
        }
        s.map(|v| v / self.y_integral)
    }
}

/// The shared observer data (parsed on first use).
pub fn cie() -> &'static Cie {
    static CIE: OnceLock<Cie> = OnceLock::new();
    CIE.get_or_init(build)
}

/// Rows of a numeric CSV with one header line.
fn parse_csv(text: &str, cols: usize) -> Vec<Vec<f64>> {
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let row: Vec<f64> = l.split(',').map(|f| f.trim().parse::<f64>().unwrap_or(f64::NAN)).collect();
            assert!(row.len() == cols && row.iter().all(|v| v.is_finite()), "malformed embedded CIE table row: {l}");
            row
        })
        .collect()
}

fn build() -> Cie {
    let rows = parse_csv(CMF_CSV, 4);
    assert_eq!(rows.len(), N_DENSE, "embedded CMF table must cover 360..=830 nm at 1 nm");
    let mut cmf = [[0f32; 3]; N_DENSE];
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r[0], node_lambda(i), "embedded CMF table must be on the 1 nm grid");
        cmf[i] = [r[1] as f32, r[2] as f32, r[3] as f32];
    }
    let y_integral: f64 = (0..N_DENSE).map(|i| quad_weight(i) * cmf[i][1] as f64).sum();

    // D65: 5 nm table → 1 nm grid (linear), held at its last value beyond 780 nm.
    let d65_rows = parse_csv(D65_CSV, 2);
    let d65_at = |l: f64| -> f64 {
        let last = d65_rows.len() - 1;
        if l <= d65_rows[0][0] {
            return d65_rows[0][1];
        }
        if l >= d65_rows[last][0] {
            return d65_rows[last][1];
        }
        let k = d65_rows.partition_point(|r| r[0] <= l) - 1;
        let (a, b) = (&d65_rows[k], &d65_rows[k + 1]);
        a[1] + (l - a[0]) / (b[0] - a[0]) * (b[1] - a[1])
    };
    let d65_raw: Vec<f64> = (0..N_DENSE).map(|i| d65_at(node_lambda(i))).collect();

    let xyz_of = |w: &dyn Fn(usize) -> f64| -> [f64; 3] {
        let mut s = [0.0; 3];
        for (i, m) in cmf.iter().enumerate() {
            let k = quad_weight(i) * w(i);
            for c in 0..3 {
                s[c] += k * m[c] as f64;
            }
        }
        s
    };
    let normalise = |w: &dyn Fn(usize) -> f64| -> DenseSpectrum {
        let y = xyz_of(w)[1];
        DenseSpectrum::new(std::array::from_fn(|i| (w(i) * y_integral / y) as f32))
    };

    // ACES white: D65 tilted by exp(a t + b t²) with (a, b) solved (Newton, numerical
    // Jacobian) so that the chromaticity is exactly ACES_WHITE_XY.
    let tilt = |a: f64, b: f64, i: usize| {
        let t = (node_lambda(i) - 560.0) / 100.0;
        d65_raw[i] * (a * t + b * t * t).exp()
    };
    let xy_err = |a: f64, b: f64| -> [f64; 2] {
        let s = xyz_of(&|i| tilt(a, b, i));
        let n = s[0] + s[1] + s[2];
        [s[0] / n - ACES_WHITE_XY[0], s[1] / n - ACES_WHITE_XY[1]]
    };
    let (mut a, mut b) = (0.0, 0.0);
    for _ in 0..20 {
        let e = xy_err(a, b);
        if e[0].abs().max(e[1].abs()) < 1e-12 {
            break;
        }
        let h = 1e-6;
        let ea = xy_err(a + h, b);
        let eb = xy_err(a, b + h);
        let j = [[(ea[0] - e[0]) / h, (eb[0] - e[0]) / h], [(ea[1] - e[1]) / h, (eb[1] - e[1]) / h]];
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        a -= (j[1][1] * e[0] - j[0][1] * e[1]) / det;
        b -= (-j[1][0] * e[0] + j[0][0] * e[1]) / det;
    }

    Cie { cmf, y_integral, d65: normalise(&|i| d65_raw[i]), aces_white: normalise(&|i| tilt(a, b, i)) }
}

/// Chromaticity (x, y) of an XYZ.
pub fn chromaticity(xyz: [f64; 3]) -> [f64; 2] {
    let n = xyz[0] + xyz[1] + xyz[2];
    [xyz[0] / n, xyz[1] / n]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_parse_and_match_their_documented_shape() {
        let c = cie();
        // ȳ peaks at exactly 1.0 at 555 nm in the CIE table.
        assert_eq!(c.cmf_node(555 - 360)[1], 1.0);
        // ∫ȳ over 360–830 nm of the CIE 1931 observer is 106.857 (1 nm sum); the
        // trapezoid rule differs from the sum by half the end values (< 1e-5).
        assert!((c.y_integral - 106.857).abs() < 1e-3, "{}", c.y_integral);
        assert!(c.d65.max_value() > 0.0 && c.aces_white.max_value() > 0.0);
    }

    #[test]
    fn whites_have_their_chromaticities_and_unit_luminance() {
        let c = cie();
        let d65 = c.integrate_xyz(|l| c.d65.eval(l as f32) as f64);
        let aces = c.integrate_xyz(|l| c.aces_white.eval(l as f32) as f64);
        // Normalisation is done in f64 and stored in f32: 1e-6 covers the rounding.
        assert!((d65[1] - 1.0).abs() < 1e-6 && (aces[1] - 1.0).abs() < 1e-6);
        // D65 from the 5 nm CIE table under the 1931 observer: (0.31272, 0.32903) to 5
        // digits; the standard's rounded (0.3127, 0.3290) is 3e-5 away.
        let xy = chromaticity(d65);
        assert!((xy[0] - 0.31272).abs() < 1e-5 && (xy[1] - 0.32903).abs() < 1e-5, "{xy:?}");
        // The ACES white is solved to 1e-12; f32 storage of the spectrum leaves < 1e-6.
        let xy = chromaticity(aces);
        assert!((xy[0] - ACES_WHITE_XY[0]).abs() < 1e-6 && (xy[1] - ACES_WHITE_XY[1]).abs() < 1e-6, "{xy:?}");
    }

    #[test]
    fn dense_interpolation_is_linear_and_clamped() {
        let s = DenseSpectrum::new(std::array::from_fn(|i| i as f32));
        assert_eq!(s.eval(360.0), 0.0);
        assert!((s.eval(400.25) - 40.25).abs() < 1e-4);
        assert_eq!(s.eval(100.0), 0.0);
        assert_eq!(s.eval(900.0), 470.0);
        assert_eq!(s.eval(830.0), 470.0);
        assert_eq!(s.max_value(), 470.0);
    }
}
