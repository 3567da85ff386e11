//! RGB → spectrum uplifting (Jakob & Hanika 2019): smooth sigmoid-polynomial spectra whose
//! colour under the working colour space's white illuminant is the given RGB.

use super::color::white_illuminant;
use super::rgb2spec::table;
use super::spectra::Spectrum;
use crate::scene::ColorSpace;

/// NaN → 0, negative → 0.
#[inline]
fn non_negative(rgb: [f32; 3]) -> [f32; 3] {
    rgb.map(|v| if v > 0.0 { v } else { 0.0 })
}

/// A colour in a space with a table: Rec.2020 (no table; the same white) is taken to Rec.709,
/// where colours outside Rec.709's gamut lose their negative part.
#[inline]
fn tabled(rgb: [f32; 3], cs: ColorSpace) -> ([f32; 3], ColorSpace) {
    match cs {
        ColorSpace::LinearRec2020 => {
            let to709 = super::color::xyz_to_rgb(super::color::rgb_to_xyz(rgb, cs), ColorSpace::LinearRec709);
            (to709, ColorSpace::LinearRec709)
        }
        _ => (rgb, cs),
    }
}

/// Coefficients (nm) and scale of an unbounded RGB: the table is read at rgb/(2·max) so the
/// fit stays well inside (0, 1), and `scale` = 2·max restores the magnitude. None for black.
fn scaled(rgb: [f32; 3], cs: ColorSpace) -> Option<([f32; 3], f32)> {
    let (rgb, cs) = tabled(rgb, cs);
    let rgb = non_negative(rgb);
    let m = rgb[0].max(rgb[1]).max(rgb[2]);
    if !(m > 0.0) || !m.is_finite() {
        return None;
    }
    let scale = 2.0 * m;
    if rgb[0] == rgb[1] && rgb[1] == rgb[2] {
        // sigmoid(0) = ½ exactly
        return Some(([0.0; 3], scale));
    }
    Some((table(cs).lookup(rgb.map(|v| v / scale)), scale))
}

/// A reflectance-like colour (each channel clamped to [0,1]) as a smooth spectrum bounded by
/// [0,1]. Greys give a constant spectrum.
pub fn albedo(rgb: [f32; 3], cs: ColorSpace) -> Spectrum {
    let (rgb, cs) = tabled(rgb, cs);
    let rgb = non_negative(rgb).map(|v| v.min(1.0));
    if rgb[0] == rgb[1] && rgb[1] == rgb[2] {
        return Spectrum::Constant(rgb[0]);
    }
    let t = table(cs);
    let m = rgb[0].max(rgb[1]).max(rgb[2]);
    // Below the first non-zero brightness node the table has no data of its own: read it at
    // that node and scale down (the scale is < 1, so the bound [0,1] holds).
    let (rgb, scale) = if m < t.z[1] { (rgb.map(|v| v * (t.z[1] / m)), m / t.z[1]) } else { (rgb, 1.0) };
    let [c0, c1, c2] = t.lookup(rgb);
    Spectrum::Sigmoid { c0, c1, c2, scale }
}

/// An unbounded non-negative quantity (e.g. a coefficient in 1/m) as a smooth spectrum
/// (negative and NaN channels count as 0).
pub fn unbounded(rgb: [f32; 3], cs: ColorSpace) -> Spectrum {
    match scaled(rgb, cs) {
        None => Spectrum::Constant(0.0),
        Some(([c0, c1, c2], scale)) if c0 == 0.0 && c1 == 0.0 && c2 == 0.0 => Spectrum::Constant(0.5 * scale),
        Some(([c0, c1, c2], scale)) => Spectrum::Sigmoid { c0, c1, c2, scale },
    }
}

/// An emitted colour: the uplifted RGB times the colour space's white illuminant, so that
/// RGB (1,1,1) emitted and seen directly renders (1,1,1) (negative and NaN channels count as 0).
pub fn illuminant(rgb: [f32; 3], cs: ColorSpace) -> Spectrum {
    match scaled(rgb, cs) {
        None => Spectrum::Constant(0.0),
        Some(([c0, c1, c2], scale)) => Spectrum::Illuminant { c0, c1, c2, scale, illuminant: white_illuminant(cs) },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::cie::cie;
    use crate::spectrum::color::{color_space, rgb_to_xyz, xyz_to_rgb};
    use crate::testing::chi2::TestRng;
    use glam::DVec3;

    const SPACES: [ColorSpace; 2] = [ColorSpace::LinearRec709, ColorSpace::AcesCg];

    /// RGB of a reflectance under the colour space's white, by 1 nm quadrature.
    fn reflectance_rgb(s: &Spectrum, cs: ColorSpace) -> [f64; 3] {
        let c = cie();
        let w = c.white(cs);
        let xyz = c.integrate_xyz(|l| s.eval(l as f32) as f64 * w.eval(l as f32) as f64);
        let v = color_space(cs).xyz_to_rgb * DVec3::from(xyz);
        [v.x, v.y, v.z]
    }

    /// RGB of an emission spectrum, by 1 nm quadrature.
    fn emission_rgb(s: &Spectrum, cs: ColorSpace) -> [f64; 3] {
        let xyz = cie().integrate_xyz(|l| s.eval(l as f32) as f64);
        let v = color_space(cs).xyz_to_rgb * DVec3::from(xyz);
        [v.x, v.y, v.z]
    }

    #[test]
    fn white_and_greys_are_constant() {
        for cs in SPACES {
            assert_eq!(albedo([1.0; 3], cs), Spectrum::Constant(1.0));
            assert_eq!(albedo([0.25; 3], cs), Spectrum::Constant(0.25));
            assert_eq!(albedo([3.0, 2.0, 7.0], cs), Spectrum::Constant(1.0));
            assert_eq!(albedo([f32::NAN, -1.0, 0.0], cs), Spectrum::Constant(0.0));
            assert_eq!(unbounded([4.0; 3], cs), Spectrum::Constant(4.0));
            assert_eq!(unbounded([0.0; 3], cs), Spectrum::Constant(0.0));
        }
    }

    /// Random colours in [lo, 1]³ (each channel), seeded.
    fn colours(seed: u64, n: usize, lo: f32) -> Vec<[f32; 3]> {
        let mut rng = TestRng::new(seed);
        (0..n).map(|_| std::array::from_fn(|_| lo + (1.0 - lo) * rng.next_f32())).collect()
    }

    /// Colours a reflectance can have in each space: random linear Rec.709 colours in
    /// [0,1]³ (every one reachable by a sigmoid spectrum under D65), and for ACEScg the same
    /// colours converted and scaled by 0.9 so that no channel needs clamping (much of the
    /// ACEScg cube lies outside the colours any reflectance can have under its white).
    fn reachable_colours(cs: ColorSpace, seed: u64, n: usize) -> Vec<[f32; 3]> {
        colours(seed, n, 0.0)
            .into_iter()
            .map(|c| match cs {
                ColorSpace::LinearRec709 => c,
                _ => xyz_to_rgb(rgb_to_xyz(c, ColorSpace::LinearRec709), cs).map(|v| (0.9 * v).clamp(0.0, 1.0)),
            })
            .collect()
    }

    #[test]
    fn albedo_round_trips_rgb() {
        // The fits at the table nodes are exact to 1e-9; what remains is the trilinear
        // interpolation of coefficients between nodes of the 32³ table. It is largest near
        // the white corner and the gamut edges, where the coefficients grow without bound
        // (white itself needs c = +∞): measured worst 1.35e-2 (Rec.709) and 3.7e-3
        // (ACEScg), mean 9e-4 and 1.1e-3, over these 3000 colours. Bounds: worst 0.02,
        // mean 2e-3.
        for cs in SPACES {
            let (mut worst, mut sum, mut n) = (0.0f64, 0.0f64, 0);
            for rgb in reachable_colours(cs, 5, 3000) {
                let got = reflectance_rgb(&albedo(rgb, cs), cs);
                let e = (0..3).map(|k| (got[k] - rgb[k] as f64).abs()).fold(0.0, f64::max);
                worst = worst.max(e);
                sum += e;
                n += 1;
            }
            let mean = sum / n as f64;
            assert!(worst < 0.02 && mean < 2e-3, "{cs:?}: worst RGB error {worst}, mean {mean}");
        }
    }

    #[test]
    fn albedo_stays_within_zero_one() {
        let mut rng = TestRng::new(8);
        for cs in SPACES {
            let mut rgbs = colours(9, 500, 0.0);
            rgbs.extend([
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
                [1.0, 1.0, 0.0],
                [1e-7, 0.0, 1e-6],
                [1.0, 0.999, 1.0],
            ]);
            for rgb in rgbs {
                let s = albedo(rgb, cs);
                assert!(s.max_value() <= 1.0, "{rgb:?}");
                for _ in 0..50 {
                    let l = 360.0 + 470.0 * rng.next_f32();
                    let v = s.eval(l);
                    assert!((0.0..=1.0).contains(&v), "{cs:?} {rgb:?} at {l}: {v}");
                }
            }
        }
    }

    #[test]
    fn unbounded_scales_and_round_trips() {
        // The table is read at max channel ½, away from the white corner, and scaled by
        // 2·max, so the error is relative to the max channel. Measured worst over these
        // colours (the whole [0.05, 1]³ cube, times 0.01, 1 or 37): 2.0e-3 (Rec.709) and
        // 4.9e-3 (ACEScg, from AP1 colours near the edge of what sigmoid spectra reach at
        // half brightness). Bound: 1e-2 of the max channel.
        for cs in SPACES {
            for (i, rgb) in colours(10, 300, 0.05).into_iter().enumerate() {
                let k = [0.01f32, 1.0, 37.0][i % 3];
                let rgb = rgb.map(|v| v * k);
                let s = unbounded(rgb, cs);
                let got = reflectance_rgb(&s, cs);
                let m = rgb.iter().copied().fold(0.0, f32::max) as f64;
                for c in 0..3 {
                    assert!((got[c] - rgb[c] as f64).abs() < 1e-2 * m, "{cs:?} {rgb:?} → {got:?}");
                }
                assert!(s.max_value() <= 2.0 * m as f32 * (1.0 + 1e-6));
            }
        }
    }

    #[test]
    fn illuminant_white_renders_white_and_colours_round_trip() {
        for cs in SPACES {
            let w = emission_rgb(&illuminant([1.0; 3], cs), cs);
            // exact sigmoid(0) = ½ times 2: only the f32 storage of W (1e-6)
            for v in w {
                assert!((v - 1.0).abs() < 1e-5, "{cs:?} {w:?}");
            }
            // coloured lights: the same lookup as unbounded; measured worst 1.8e-3 (Rec.709)
            // and 3.8e-3 (ACEScg) of the max channel; bound 1e-2 as for unbounded
            for rgb in colours(12, 200, 0.05) {
                let rgb = rgb.map(|v| v * 5.0);
                let got = emission_rgb(&illuminant(rgb, cs), cs);
                for c in 0..3 {
                    assert!((got[c] - rgb[c] as f64).abs() < 1e-2 * 5.0, "{cs:?} {rgb:?} → {got:?}");
                }
            }
            assert_eq!(illuminant([0.0; 3], cs), Spectrum::Constant(0.0));
            // luminance of the white light is Y = 1
            assert!((rgb_to_xyz([1.0; 3], cs)[1] - 1.0).abs() < 1e-5);
        }
    }
}
