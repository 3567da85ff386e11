//! IES photometric profiles (ANSI/IES LM-63, the `.ies` files of `shaping:ies:file`).
//!
//! [`IesProfile::parse`] reads the text of an LM-63 file (1986, 1991, 1995, 2002 and 2019
//! layouts: an optional `IESNA` first line, keyword lines, `TILT=`, then the numbers).
//! [`IesProfile::eval`] gives the luminous intensity in candela (values × the file's candela
//! multiplier, ballast factor and ballast-lamp factor; `TILT` data is read and ignored) at a
//! vertical angle `v` (0 = nadir, the light's primary axis) and horizontal angle `h` (radians,
//! 0 along the light's +X, 90° along its +Y), interpolating bilinearly in the file's own
//! angles.
//!
//! Photometric type C (1), the type of nearly every architectural and theatrical profile,
//! measures in vertical planes about the axis: its angles are `v` and `h` themselves, and the
//! file's symmetry is unfolded:
//!
//! | horizontal angles | symmetry |
//! |---|---|
//! | one angle | about the vertical axis |
//! | 0 to 90° | in each quadrant |
//! | 0 to 180° | about the 0–180° plane |
//! | 90 to 270° | about the 90–270° plane |
//! | anything else starting at 0° | none; between the last angle and 360° the values go back to those at 0° |
//!
//! Types B (2, floodlights) and A (3, automotive lamps) aim their photometric zero (0°, 0°)
//! along the axis. Type B's planes share the axis through the light's ±Y: a direction's
//! horizontal angle is its turn about ±Y, from the axis towards +X (−90° to 90°), and its
//! vertical angle its elevation out of the axis–X plane towards +Y (tan H = cos h tan v,
//! sin V = sin h sin v). Type A's planes share the axis through ±X: the horizontal angle
//! turns from the axis towards +Y, the vertical angle rises towards +X. Horizontal angles
//! from 0° to 90° are mirrored (the same at −H); both kinds light at most the hemisphere in
//! front of the light.
//!
//! Directions outside the file's range (e.g. above the horizon for a type C 0–90° file, or
//! behind a type B light) have zero intensity. [`IesProfile::mean_intensity`] is the intensity averaged over the
//! sphere, or over the hemisphere for type C files whose vertical angles span at most a
//! hemisphere and for types A and B (as UsdLux's `shaping:ies:normalize` divides by).

use std::f64::consts::PI;

#[derive(Clone, Debug, PartialEq)]
pub struct IesProfile {
    /// Vertical angles (radians, increasing).
    v: Vec<f32>,
    /// Horizontal angles (radians, increasing).
    h: Vec<f32>,
    /// Candela, `h.len()` rows of `v.len()` values.
    cd: Vec<f32>,
    symmetry: Symmetry,
    kind: Kind,
    mean: f32,
}

/// The photometric type: how a file's angles lie about the light.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    C,
    B,
    A,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Symmetry {
    Axial,
    Quadrant,
    Bilateral0,
    Bilateral90,
    Full,
}

/// Whitespace- or comma-separated numbers after the `TILT=` line.
struct Numbers<'a> {
    it: std::iter::Peekable<Box<dyn Iterator<Item = &'a str> + 'a>>,
    read: usize,
}

impl<'a> Numbers<'a> {
    fn next(&mut self, what: &str) -> Result<f64, String> {
        let tok = self.it.next().ok_or_else(|| format!("the file ends before {what} (after {} numbers)", self.read))?;
        self.read += 1;
        let v: f64 = tok.parse().map_err(|_| format!("'{tok}' is not a number ({what})"))?;
        if !v.is_finite() {
            return Err(format!("{what} is not finite"));
        }
        Ok(v)
    }

    fn count(&mut self, what: &str, max: usize) -> Result<usize, String> {
        let v = self.next(what)?;
        if v < 1.0 || v.fract() != 0.0 || v > max as f64 {
            return Err(format!("{what} must be a whole number from 1 to {max} (got {v})"));
        }
        Ok(v as usize)
    }
}

impl IesProfile {
    /// Parses an LM-63 file's text. Errors say what is wrong ("photometric type 2 (B) is not
    /// supported", "the file ends before the candela values", ...).
    pub fn parse(text: &str) -> Result<IesProfile, String> {
        let mut lines = text.lines();
        let mut tilt = None;
        for line in lines.by_ref() {
            let t = line.trim();
            if let Some(rest) = t.strip_prefix("TILT=").or_else(|| t.strip_prefix("TILT =")) {
                tilt = Some(rest.trim().to_string());
                break;
            }
        }
        let tilt = tilt.ok_or("no TILT= line: not an IES (LM-63) file")?;
        let rest: Vec<&str> = lines.collect();
        let words: Box<dyn Iterator<Item = &str>> = Box::new(rest.into_iter().flat_map(|l| l.split(|c: char| c.is_whitespace() || c == ',')).filter(|w| !w.is_empty()));
        let mut n = Numbers { it: words.peekable(), read: 0 };
        if tilt.eq_ignore_ascii_case("INCLUDE") {
            n.next("the lamp-to-luminaire geometry")?;
            let k = n.count("the number of tilt angles", 100_000)?;
            for _ in 0..2 * k {
                n.next("the tilt table")?;
            }
        }
        n.next("the number of lamps")?;
        n.next("the lumens per lamp")?;
        let multiplier = n.next("the candela multiplier")?;
        let nv = n.count("the number of vertical angles", 100_000)?;
        let nh = n.count("the number of horizontal angles", 100_000)?;
        let kind = match n.next("the photometric type")? {
            1.0 => Kind::C,
            2.0 => Kind::B,
            3.0 => Kind::A,
            k => return Err(format!("photometric type {k} is none of 1 (C), 2 (B) and 3 (A)")),
        };
        for what in ["the units type", "the width", "the length", "the height"] {
            n.next(what)?;
        }
        let ballast = n.next("the ballast factor")?;
        let lamp_factor = n.next("the ballast-lamp photometric factor")?;
        n.next("the input watts")?;
        let scale = multiplier * ballast * lamp_factor;
        let read_angles = |n: &mut Numbers, count: usize, what: &str| -> Result<Vec<f64>, String> {
            let a = (0..count).map(|_| n.next(what)).collect::<Result<Vec<f64>, String>>()?;
            if a.windows(2).any(|w| !(w[1] > w[0])) {
                return Err(format!("{what} must increase"));
            }
            Ok(a)
        };
        let v = read_angles(&mut n, nv, "the vertical angles")?;
        let h = read_angles(&mut n, nh, "the horizontal angles")?;
        let (t, v_range, h_range) = match kind {
            Kind::C => ("C", (0.0, 180.0), (0.0, 360.0)),
            Kind::B => ("B", (-90.0, 90.0), (-90.0, 90.0)),
            Kind::A => ("A", (-90.0, 90.0), (-90.0, 90.0)),
        };
        if v[0] < v_range.0 || v[nv - 1] > v_range.1 {
            return Err(format!("vertical angles must lie in [{}, {}] degrees for type {t} (got {} to {})", v_range.0, v_range.1, v[0], v[nv - 1]));
        }
        if h[0] < h_range.0 || h[nh - 1] > h_range.1 {
            return Err(format!("horizontal angles must lie in [{}, {}] degrees for type {t} (got {} to {})", h_range.0, h_range.1, h[0], h[nh - 1]));
        }
        let mut cd = Vec::with_capacity(nv * nh);
        for _ in 0..nv * nh {
            let c = n.next("the candela values")? * scale;
            cd.push(c.max(0.0) as f32);
        }
        let symmetry = match (h[0], h[nh - 1]) {
            _ if kind != Kind::C => {
                if h[0] == 0.0 {
                    Symmetry::Bilateral0
                } else {
                    Symmetry::Full
                }
            }
            _ if nh == 1 => Symmetry::Axial,
            (a, b) if a == 0.0 && b == 90.0 => Symmetry::Quadrant,
            (a, b) if a == 0.0 && b == 180.0 => Symmetry::Bilateral0,
            (a, b) if a == 90.0 && b == 270.0 => Symmetry::Bilateral90,
            (a, _) if a == 0.0 => Symmetry::Full,
            (a, b) => return Err(format!("horizontal angles from {a} to {b} degrees are not an LM-63 type C layout")),
        };
        let rad = |a: &Vec<f64>| a.iter().map(|d| d.to_radians() as f32).collect::<Vec<f32>>();
        let mut p = IesProfile { v: rad(&v), h: rad(&h), cd, symmetry, kind, mean: 0.0 };
        p.mean = p.integrate_mean() as f32;
        Ok(p)
    }

    /// Candela at vertical angle `v` from the nadir and horizontal angle `h` (radians).
    pub fn eval(&self, v: f32, h: f32) -> f32 {
        if self.kind != Kind::C {
            return self.eval_ab(v, h);
        }
        let nv = self.v.len();
        if !(v >= self.v[0] && v <= self.v[nv - 1]) {
            // a single vertical angle is a ring of measure zero; outside the range: dark
            return 0.0;
        }
        let deg90 = std::f32::consts::FRAC_PI_2;
        let two_pi = 2.0 * std::f32::consts::PI;
        let h = h.rem_euclid(two_pi);
        let h = match self.symmetry {
            Symmetry::Axial => 0.0,
            Symmetry::Quadrant => {
                let a = h % std::f32::consts::PI;
                if a > deg90 {
                    std::f32::consts::PI - a
                } else {
                    a
                }
            }
            Symmetry::Bilateral0 => {
                if h > std::f32::consts::PI {
                    two_pi - h
                } else {
                    h
                }
            }
            Symmetry::Bilateral90 => {
                if h < deg90 {
                    std::f32::consts::PI - h
                } else if h > 3.0 * deg90 {
                    3.0 * std::f32::consts::PI - h
                } else {
                    h
                }
            }
            Symmetry::Full => h,
        };
        let nh = self.h.len();
        if matches!(self.symmetry, Symmetry::Axial) {
            return self.row(0, bracket(&self.v, v));
        }
        if matches!(self.symmetry, Symmetry::Full) && nh > 1 && h > self.h[nh - 1] {
            // from the last angle back round to 360° = the first row
            let span = two_pi - self.h[nh - 1];
            let t = if span > 0.0 { (h - self.h[nh - 1]) / span } else { 0.0 };
            let bv = bracket(&self.v, v);
            return self.row(nh - 1, bv) * (1.0 - t) + self.row(0, bv) * t;
        }
        self.bilinear(v, h.clamp(self.h[0], self.h[nh - 1]))
    }

    /// Candela of horizontal row `j` at the vertical bracket (`iv`, `tv`).
    #[inline]
    fn row(&self, j: usize, (iv, tv): (usize, f32)) -> f32 {
        let nv = self.v.len();
        let r = &self.cd[j * nv..(j + 1) * nv];
        if tv == 0.0 || iv + 1 >= nv {
            r[iv]
        } else {
            r[iv] * (1.0 - tv) + r[iv + 1] * tv
        }
    }

    /// Bilinear in the file's own angles (radians), `v` and `h` within their ranges.
    fn bilinear(&self, v: f32, h: f32) -> f32 {
        let nh = self.h.len();
        let bv = bracket(&self.v, v);
        let (ih, th) = bracket(&self.h, h);
        if th == 0.0 || ih + 1 >= nh {
            self.row(ih, bv)
        } else {
            self.row(ih, bv) * (1.0 - th) + self.row(ih + 1, bv) * th
        }
    }

    /// Type A or B: the direction at (`v`, `h`) in the file's angles, then bilinear.
    fn eval_ab(&self, v: f32, h: f32) -> f32 {
        let (sv, cv) = v.sin_cos();
        let (sh, ch) = h.sin_cos();
        // along the axis, +X and +Y
        let (a, x, y) = (cv, sv * ch, sv * sh);
        let (across, along) = if self.kind == Kind::B { (x, y) } else { (y, x) };
        let mut hh = across.atan2(a);
        let vv = along.clamp(-1.0, 1.0).asin();
        if self.symmetry == Symmetry::Bilateral0 {
            hh = hh.abs();
        }
        let (nv, nh) = (self.v.len(), self.h.len());
        if !(vv >= self.v[0] && vv <= self.v[nv - 1] && hh >= self.h[0] && hh <= self.h[nh - 1]) {
            return 0.0;
        }
        self.bilinear(vv, hh)
    }

    /// Mean candela over the sphere, or over the hemisphere when the vertical angles of a type
    /// C file span at most 90° (plus a 0.1 rad margin) and for types A and B.
    pub fn mean_intensity(&self) -> f32 {
        self.mean
    }

    /// The angles from the axis (radians) where the profile has kinks: a type C file's
    /// vertical angles (none are known for types A and B, whose kinks are not cones).
    pub fn vertical_angles(&self) -> &[f32] {
        if self.kind == Kind::C {
            &self.v
        } else {
            &[]
        }
    }

    /// Whether the profile depends on the horizontal angle.
    pub fn is_axial(&self) -> bool {
        matches!(self.symmetry, Symmetry::Axial)
    }

    fn integrate_mean(&self) -> f64 {
        // midpoint rule on a grid fine against the file's own angles
        let (nv, nh) = (2048, if self.is_axial() { 1 } else { 1024 });
        let mut acc = 0.0;
        for i in 0..nv {
            let v = (i as f64 + 0.5) * PI / nv as f64;
            let ring: f64 = (0..nh).map(|j| self.eval(v as f32, ((j as f64 + 0.5) * 2.0 * PI / nh as f64) as f32) as f64).sum::<f64>() / nh as f64;
            acc += ring * v.sin() * (PI / nv as f64) * 2.0 * PI;
        }
        let span = (self.v[self.v.len() - 1] - self.v[0]) as f64;
        acc / if self.kind == Kind::C && span > PI / 2.0 + 0.1 { 4.0 * PI } else { 2.0 * PI }
    }
}

/// Index `i` and fraction `t` with `a[i] ≤ x ≤ a[i + 1]` (x within `a`'s range).
#[inline]
fn bracket(a: &[f32], x: f32) -> (usize, f32) {
    let n = a.len();
    if n == 1 {
        return (0, 0.0);
    }
    let i = (a.partition_point(|&y| y <= x).max(1) - 1).min(n - 2);
    let d = a[i + 1] - a[i];
    let t = if d > 0.0 { ((x - a[i]) / d).clamp(0.0, 1.0) } else { 0.0 };
    (i, t)
}

#[cfg(test)]
#[path = "ies/tests.rs"]
pub(crate) mod tests;
