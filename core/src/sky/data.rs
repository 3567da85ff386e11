//! The Hošek–Wilkie coefficient tables compiled into the renderer (`core/data/hosek-wilkie/`,
//! BSD-3-Clause, see `core/data/README.md`), parsed once into flat `f64` arrays in the tables'
//! own row-major order. Every row's key columns are checked against the layout, so a reordered
//! or truncated table is reported instead of silently misread.

use std::sync::OnceLock;

/// Number of spectral bands (320, 360, …, 720 nm).
pub const N_BANDS: usize = 11;
/// Wavelength of the first band (nm).
pub const BAND_FIRST_NM: f64 = 320.0;
/// Spacing of the bands (nm).
pub const BAND_STEP_NM: f64 = 40.0;
/// Parameters per (band, albedo, turbidity, control point): A, B, C, D, E, F, G, I, H.
pub const N_PARAMS: usize = 9;
/// Control points of the quintic Bézier curve in solar elevation.
pub const N_CTRL: usize = 6;
/// Integer turbidities 1..=10.
pub const N_TURBIDITY: usize = 10;
/// Cubic pieces of the solar-radiance curve in elevation.
pub const N_SOLAR_SEGMENTS: usize = 45;
/// Coefficients of the limb-darkening polynomial.
pub const N_LIMB: usize = 6;

const SKY_PARAMS_CSV: &str = include_str!("../../data/hosek-wilkie/hw_spectral_sky_params.csv");
const SKY_RADIANCE_CSV: &str = include_str!("../../data/hosek-wilkie/hw_spectral_sky_radiance.csv");
const SOLAR_CSV: &str = include_str!("../../data/hosek-wilkie/hw_spectral_solar_radiance.csv");
const LIMB_CSV: &str = include_str!("../../data/hosek-wilkie/hw_spectral_limb_darkening.csv");

/// The spectral tables.
#[derive(Debug)]
pub struct Tables {
    /// `[band][albedo][turbidity − 1][ctrl][param]`, params in stored order A..G, I, H.
    pub sky_params: Vec<f64>,
    /// `[band][albedo][turbidity − 1][ctrl]`: the radiance scale L_M (W m⁻² sr⁻¹ nm⁻¹).
    pub sky_radiance: Vec<f64>,
    /// `[band][turbidity − 1][segment][4]`, coefficients of x³, x², x, 1.
    pub solar: Vec<f64>,
    /// `[band][k]`: coefficient of μᵏ.
    pub limb: [[f64; N_LIMB]; N_BANDS],
}

impl Tables {
    /// The 9 parameters of one (band, albedo ∈ {0,1}, turbidity index 0..10, control point).
    #[inline]
    pub fn params(&self, band: usize, albedo: usize, turb: usize, ctrl: usize) -> &[f64] {
        let i = (((band * 2 + albedo) * N_TURBIDITY + turb) * N_CTRL + ctrl) * N_PARAMS;
        &self.sky_params[i..i + N_PARAMS]
    }
    #[inline]
    pub fn radiance(&self, band: usize, albedo: usize, turb: usize, ctrl: usize) -> f64 {
        self.sky_radiance[((band * 2 + albedo) * N_TURBIDITY + turb) * N_CTRL + ctrl]
    }
    /// The 4 coefficients (x³ first) of one solar segment.
    #[inline]
    pub fn solar_segment(&self, band: usize, turb: usize, segment: usize) -> &[f64] {
        let i = ((band * N_TURBIDITY + turb) * N_SOLAR_SEGMENTS + segment) * 4;
        &self.solar[i..i + 4]
    }
}

/// One key column: its values run `first, first + step, …` (`count` values).
#[derive(Clone, Copy)]
pub(crate) struct Axis {
    pub first: f64,
    pub step: f64,
    pub count: usize,
}

/// Parses a table with one header line, key columns laid out by `axes` (leftmost slowest) and
/// `n_values` value columns; returns the values in row order.
pub(crate) fn parse_table(name: &str, text: &str, axes: &[Axis], n_values: usize) -> Result<Vec<f64>, String> {
    let n_rows: usize = axes.iter().map(|a| a.count).product();
    let mut out = Vec::with_capacity(n_rows * n_values);
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    lines.next().ok_or_else(|| format!("{name}: empty table"))?;
    let mut row = 0usize;
    for line in lines {
        if row >= n_rows {
            return Err(format!("{name}: more than the {n_rows} rows expected"));
        }
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != axes.len() + n_values {
            return Err(format!("{name}: row {} has {} columns, {} expected", row + 1, fields.len(), axes.len() + n_values));
        }
        // key of this row from its flat index
        let mut rem = row;
        for (k, axis) in axes.iter().enumerate().rev() {
            let idx = rem % axis.count;
            rem /= axis.count;
            let want = axis.first + axis.step * idx as f64;
            let got: f64 = fields[k].trim().parse().map_err(|_| format!("{name}: row {}: key '{}' is not a number", row + 1, fields[k]))?;
            if got != want {
                return Err(format!("{name}: row {}: key column {k} is {got}, {want} expected", row + 1));
            }
        }
        for f in &fields[axes.len()..] {
            let v: f64 = f.trim().parse().map_err(|_| format!("{name}: row {}: value '{f}' is not a number", row + 1))?;
            if !v.is_finite() {
                return Err(format!("{name}: row {}: value {v} is not finite", row + 1));
            }
            out.push(v);
        }
        row += 1;
    }
    if row != n_rows {
        return Err(format!("{name}: {row} rows, {n_rows} expected"));
    }
    Ok(out)
}

pub(crate) const BAND_AXIS: Axis = Axis { first: BAND_FIRST_NM, step: BAND_STEP_NM, count: N_BANDS };
pub(crate) const ALBEDO_AXIS: Axis = Axis { first: 0.0, step: 1.0, count: 2 };
pub(crate) const TURBIDITY_AXIS: Axis = Axis { first: 1.0, step: 1.0, count: N_TURBIDITY };
pub(crate) const CTRL_AXIS: Axis = Axis { first: 0.0, step: 1.0, count: N_CTRL };

fn build() -> Result<Tables, String> {
    let sky_params = parse_table("hw_spectral_sky_params.csv", SKY_PARAMS_CSV, &[BAND_AXIS, ALBEDO_AXIS, TURBIDITY_AXIS, CTRL_AXIS], N_PARAMS)?;
    let sky_radiance = parse_table("hw_spectral_sky_radiance.csv", SKY_RADIANCE_CSV, &[BAND_AXIS, ALBEDO_AXIS, TURBIDITY_AXIS, CTRL_AXIS], 1)?;
    let seg_axis = Axis { first: 0.0, step: 1.0, count: N_SOLAR_SEGMENTS };
    let solar = parse_table("hw_spectral_solar_radiance.csv", SOLAR_CSV, &[BAND_AXIS, TURBIDITY_AXIS, seg_axis], 4)?;
    let limb_flat = parse_table("hw_spectral_limb_darkening.csv", LIMB_CSV, &[BAND_AXIS], N_LIMB)?;
    let limb = std::array::from_fn(|b| std::array::from_fn(|k| limb_flat[b * N_LIMB + k]));
    Ok(Tables { sky_params, sky_radiance, solar, limb })
}

/// The shared tables, parsed on first use; `Err` names the table and row that failed.
pub fn tables() -> Result<&'static Tables, String> {
    static T: OnceLock<Result<Tables, String>> = OnceLock::new();
    T.get_or_init(build).as_ref().map_err(|e| e.clone())
}
