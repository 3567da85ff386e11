//! The vendored optical tables (`core/data/`, provenance in `core/data/README.md`), parsed once
//! on first use. Each parser checks the shape it expects so that a damaged table is reported,
//! not silently misread.

use std::sync::OnceLock;

const WILLIAMSON_IOP: &str = include_str!("../../data/williamson2022_iop.csv");
const WILLIAMSON_AW: &str = include_str!("../../data/williamson2022_aw.csv");
const SOLONENKO_IOP: &str = include_str!("../../data/solonenko2015_iop.csv");
const PETZOLD_VSF: &str = include_str!("../../data/petzold1972_vsf.csv");
const PETZOLD_STATIONS: &str = include_str!("../../data/petzold1972_stations.csv");
const BRICAUD_1998: &str = include_str!("../../data/bricaud1998_aph_coefficients.csv");

/// Splits one RFC 4180 line (double-quoted fields may hold commas and doubled quotes).
pub(crate) fn split_csv_line(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            ('"', _) => quoted = !quoted,
            (',', false) => out.push(std::mem::take(&mut cur)),
            _ => cur.push(c),
        }
    }
    out.push(cur);
    out
}

/// Data rows of a CSV text (header skipped, blank lines ignored).
fn rows(text: &str) -> impl Iterator<Item = Vec<String>> + '_ {
    text.lines().skip(1).filter(|l| !l.trim().is_empty()).map(split_csv_line)
}

fn num(s: &str) -> Option<f64> {
    let s = s.trim();
    if s.is_empty() {
        None
    } else {
        s.parse().ok()
    }
}

/// One row of an IOP table: type, wavelength, quantity, value (absent when `missing`),
/// gap-fill value, status.
#[derive(Clone, Debug)]
pub(crate) struct IopRow {
    pub water_type: String,
    pub lambda: f64,
    pub quantity: String,
    pub value: Option<f64>,
    /// Williamson & Hollins' gap-fill (only in the Solonenko table, only where a row was lost).
    pub gap_fill: Option<f64>,
    pub status: String,
}

pub(crate) struct Tables {
    pub williamson: Vec<IopRow>,
    pub solonenko: Vec<IopRow>,
    /// (λ nm, a_w m⁻¹), 300–800 nm at 1 nm.
    pub aw: Vec<(f64, f64)>,
    /// (λ nm, A_φ, E_φ), 400–700 nm at 2 nm.
    pub bricaud: Vec<(f64, f64, f64)>,
    pub petzold: Vec<PetzoldRow>,
    pub stations: Vec<PetzoldStationRow>,
}

#[derive(Clone, Debug)]
pub(crate) struct PetzoldRow {
    pub station: String,
    pub angle_deg: f64,
    pub vsf: f64,
    pub normalized_integral: f64,
}

#[derive(Clone, Debug)]
pub(crate) struct PetzoldStationRow {
    pub station: String,
    pub b: f64,
    pub bb_over_b: f64,
    pub slope_below_01: f64,
}

fn parse_williamson() -> Vec<IopRow> {
    rows(WILLIAMSON_IOP)
        .map(|f| {
            assert!(f.len() >= 6, "williamson2022_iop.csv: short row {f:?}");
            IopRow {
                water_type: f[0].clone(),
                lambda: num(&f[1]).expect("williamson2022_iop.csv: wavelength"),
                quantity: f[2].clone(),
                value: num(&f[3]),
                gap_fill: None,
                status: f[5].clone(),
            }
        })
        .collect()
}

fn parse_solonenko() -> Vec<IopRow> {
    rows(SOLONENKO_IOP)
        .map(|f| {
            assert!(f.len() >= 8, "solonenko2015_iop.csv: short row {f:?}");
            IopRow {
                water_type: f[0].clone(),
                lambda: num(&f[1]).expect("solonenko2015_iop.csv: wavelength"),
                quantity: f[2].clone(),
                value: num(&f[3]),
                gap_fill: num(&f[7]),
                status: f[5].clone(),
            }
        })
        .collect()
}

fn parse() -> Tables {
    let aw = rows(WILLIAMSON_AW)
        .map(|f| (num(&f[0]).expect("aw: wavelength"), num(&f[1]).expect("aw: value")))
        .collect();
    let bricaud = rows(BRICAUD_1998)
        .map(|f| {
            let v: Vec<f64> = f.iter().map(|s| num(s).expect("bricaud1998: number")).collect();
            assert_eq!(v.len(), 5, "bricaud1998: 5 columns");
            (v[0], v[3], v[4])
        })
        .collect();
    let petzold = rows(PETZOLD_VSF)
        .map(|f| PetzoldRow {
            station: f[0].clone(),
            angle_deg: num(&f[1]).expect("petzold vsf: angle"),
            vsf: num(&f[2]).expect("petzold vsf: value"),
            normalized_integral: num(&f[4]).expect("petzold vsf: normalized integral"),
        })
        .collect();
    let stations = rows(PETZOLD_STATIONS)
        .map(|f| PetzoldStationRow {
            station: f[0].clone(),
            b: num(&f[5]).expect("petzold stations: b"),
            bb_over_b: num(&f[7]).expect("petzold stations: bb/b"),
            slope_below_01: num(&f[8]).expect("petzold stations: slope"),
        })
        .collect();
    Tables { williamson: parse_williamson(), solonenko: parse_solonenko(), aw, bricaud, petzold, stations }
}

/// The parsed tables (the vendored files are fixed at compile time; the unit tests parse them
/// all, so a parse failure here cannot reach a user).
pub(crate) fn tables() -> &'static Tables {
    static T: OnceLock<Tables> = OnceLock::new();
    T.get_or_init(parse)
}

/// Linear interpolation in a table of increasing abscissae, clamped to the end values.
pub(crate) fn lerp_table(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let n = xs.len();
    if x <= xs[0] {
        return ys[0];
    }
    if x >= xs[n - 1] {
        return ys[n - 1];
    }
    let i = xs.partition_point(|&v| v <= x) - 1;
    let t = (x - xs[i]) / (xs[i + 1] - xs[i]);
    ys[i] + t * (ys[i + 1] - ys[i])
}
