//! Wavelength sampling and the conversion of sampled spectra to colour: the hero-wavelength
//! sampler (density proportional to x̄ + ȳ + z̄), the Monte Carlo XYZ estimator, the RGB ↔ XYZ
//! matrices of the working colour spaces and blackbody colours.

use super::cie::{self, cie, DenseSpectrum, N_DENSE};
use super::sampled::{SampledSpectrum, SampledWavelengths, LAMBDA_MAX, LAMBDA_MIN, N_SPECTRUM};
use super::spectra::{Spectrum, SpectrumError};
use crate::scene::ColorSpace;
use glam::{DMat3, DVec3};
use std::sync::OnceLock;

// ---------------------------------------------------------------------------------------------
// Wavelength sampling

/// Piecewise-linear density ∝ x̄ + ȳ + z̄ on the 1 nm grid, with its CDF per bin.
struct WavelengthSampler {
    /// Unnormalised density at the grid nodes.
    f: [f32; N_DENSE],
    /// CDF at the grid nodes (cdf[0] = 0, cdf[N_DENSE − 1] = 1).
    cdf: [f32; N_DENSE],
    /// 1 / ∫ f dλ.
    inv_total: f32,
    total: f32,
}

fn sampler() -> &'static WavelengthSampler {
    static S: OnceLock<WavelengthSampler> = OnceLock::new();
    S.get_or_init(|| {
        let c = cie();
        let f64s: Vec<f64> = (0..N_DENSE).map(|i| c.cmf_node(i).iter().map(|&v| v as f64).sum()).collect();
        let mut acc = vec![0.0f64; N_DENSE];
        for i in 1..N_DENSE {
            acc[i] = acc[i - 1] + 0.5 * (f64s[i - 1] + f64s[i]);
        }
        let total = acc[N_DENSE - 1];
        let mut cdf: [f32; N_DENSE] = std::array::from_fn(|i| (acc[i] / total) as f32);
        cdf[N_DENSE - 1] = 1.0;
        WavelengthSampler {
            f: std::array::from_fn(|i| f64s[i] as f32),
            cdf,
            inv_total: (1.0 / total) as f32,
            total: total as f32,
        }
    })
}

impl WavelengthSampler {
    #[inline]
    fn pdf(&self, lambda: f32) -> f32 {
        let x = lambda - LAMBDA_MIN;
        if !(0.0..=(N_DENSE - 1) as f32).contains(&x) {
            return 0.0;
        }
        let i = (x as usize).min(N_DENSE - 2);
        let t = x - i as f32;
        (self.f[i] + t * (self.f[i + 1] - self.f[i])) * self.inv_total
    }

    /// Inverts the CDF at `u` ∈ [0, 1): returns (λ, pdf).
    #[inline]
    fn sample(&self, u: f32) -> (f32, f32) {
        let i = (self.cdf.partition_point(|&c| c <= u).max(1) - 1).min(N_DENSE - 2);
        let (f0, f1) = (self.f[i], self.f[i + 1]);
        // area left inside bin i, in units of f·nm
        let a = ((u - self.cdf[i]) * self.total).max(0.0);
        // solve f0·t + (f1 − f0)·t²/2 = a for t ∈ [0, 1] (form without cancellation)
        let disc = (f0 * f0 + 2.0 * (f1 - f0) * a).max(0.0);
        let denom = f0 + disc.sqrt();
        let t = if denom > 0.0 { (2.0 * a / denom).clamp(0.0, 1.0) } else { 0.0 };
        let lambda = (LAMBDA_MIN + i as f32 + t).min(LAMBDA_MAX);
        (lambda, (f0 + t * (f1 - f0)) * self.inv_total)
    }
}

/// Density (1/nm) with which [`sample_wavelengths`] draws each of its wavelengths:
/// proportional to x̄(λ) + ȳ(λ) + z̄(λ) on [360, 830] nm, 0 outside.
pub fn wavelength_pdf(lambda: f32) -> f32 {
    sampler().pdf(lambda)
}

/// Samples the path's wavelengths: the hero from `u` ∈ [0, 1) by inverting the CDF of
/// [`wavelength_pdf`], and three more at CDF positions u + i/4 (mod 1), each with its own pdf.
pub fn sample_wavelengths(u: f32) -> SampledWavelengths {
    let s = sampler();
    let u = if u.is_finite() { u.clamp(0.0, 1.0) } else { 0.0 };
    let mut lambda = [0.0; N_SPECTRUM];
    let mut pdf = [0.0; N_SPECTRUM];
    for i in 0..N_SPECTRUM {
        let mut ui = u + i as f32 / N_SPECTRUM as f32;
        if ui >= 1.0 {
            ui -= 1.0;
        }
        (lambda[i], pdf[i]) = s.sample(ui);
    }
    SampledWavelengths { lambda, pdf }
}

// ---------------------------------------------------------------------------------------------
// XYZ

/// Monte Carlo estimate of the CIE XYZ of a radiance sampled at `lambda`:
/// (1/N) Σᵢ Lᵢ·cmf(λᵢ)/pdfᵢ / ∫ȳ dλ, so that the spectrum constant 1, and an illuminant of RGB
/// (1,1,1), have Y = 1. Wavelengths with pdf 0 (dropped by `terminate_secondary`) are skipped.
pub fn to_xyz(l: SampledSpectrum, lambda: &SampledWavelengths) -> [f32; 3] {
    let c = cie();
    let mut xyz = [0.0f32; 3];
    for i in 0..N_SPECTRUM {
        let p = lambda.pdf[i];
        if p > 0.0 {
            let w = l[i] / p;
            let m = c.cmf(lambda.lambda[i]);
            xyz[0] += w * m[0];
            xyz[1] += w * m[1];
            xyz[2] += w * m[2];
        }
    }
    let k = (1.0 / (N_SPECTRUM as f64 * c.y_integral)) as f32;
    xyz.map(|v| v * k)
}

// ---------------------------------------------------------------------------------------------
// Colour spaces

/// Chromaticities of a colour space's primaries and white, and its matrices.
#[derive(Debug)]
pub struct ColorSpaceData {
    /// (x, y) of the red, green and blue primaries.
    pub primaries: [[f64; 2]; 3],
    /// XYZ (Y = 1) of the white illuminant, integrated from its spectrum.
    pub white_xyz: [f64; 3],
    pub rgb_to_xyz: DMat3,
    pub xyz_to_rgb: DMat3,
    rgb_to_xyz_f32: [[f32; 3]; 3],
    xyz_to_rgb_f32: [[f32; 3]; 3],
}

impl ColorSpaceData {
    fn new(primaries: [[f64; 2]; 3], white: &DenseSpectrum) -> Self {
        let c = cie();
        let white_xyz = c.integrate_xyz(|l| white.eval(l as f32) as f64);
        let col = |p: [f64; 2]| DVec3::new(p[0] / p[1], 1.0, (1.0 - p[0] - p[1]) / p[1]);
        let p = DMat3::from_cols(col(primaries[0]), col(primaries[1]), col(primaries[2]));
        let s = p.inverse() * DVec3::from(white_xyz);
        let rgb_to_xyz = p * DMat3::from_diagonal(s);
        let xyz_to_rgb = rgb_to_xyz.inverse();
        let rows =
            |m: &DMat3| -> [[f32; 3]; 3] { std::array::from_fn(|r| std::array::from_fn(|k| m.col(k)[r] as f32)) };
        ColorSpaceData {
            primaries,
            white_xyz,
            rgb_to_xyz,
            xyz_to_rgb,
            rgb_to_xyz_f32: rows(&rgb_to_xyz),
            xyz_to_rgb_f32: rows(&xyz_to_rgb),
        }
    }
}

/// Primaries of ITU-R BT.709 (linear Rec.709 / sRGB).
pub const REC709_PRIMARIES: [[f64; 2]; 3] = [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]];
/// Primaries of ACES AP1 (ACEScg).
pub const AP1_PRIMARIES: [[f64; 2]; 3] = [[0.713, 0.293], [0.165, 0.830], [0.128, 0.044]];
/// Primaries of ITU-R BT.2020.
pub const REC2020_PRIMARIES: [[f64; 2]; 3] = [[0.708, 0.292], [0.170, 0.797], [0.131, 0.046]];

/// Primaries of ACES AP0 (ACES2065-1).
pub const AP0_PRIMARIES: [[f64; 2]; 3] = [[0.7347, 0.2653], [0.0, 1.0], [0.0001, -0.0770]];
/// Primaries of Display P3 (P3-D65).
pub const P3_PRIMARIES: [[f64; 2]; 3] = [[0.680, 0.320], [0.265, 0.690], [0.150, 0.060]];
/// Primaries of Adobe RGB (1998).
pub const ADOBE_RGB_PRIMARIES: [[f64; 2]; 3] = [[0.64, 0.33], [0.21, 0.71], [0.15, 0.06]];

/// The primaries (with their white) of a colour space a texture file can be encoded in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum FilePrimaries {
    Rec709,
    /// ACES2065-1 (ACES white).
    Ap0,
    /// ACEScg (ACES white).
    Ap1,
    Rec2020,
    P3D65,
    AdobeRgb,
    /// CIE XYZ itself (D65 white).
    XyzD65,
}

/// Linear RGB with primaries `p` → linear Rec.709 (the authored colours' space), a file's ACES
/// white adapted to D65 by Bradford, as colour management converts such a file; the inverse of
/// [`xyz_to_output`]'s conversion for the spaces both know.
pub fn file_to_authored(p: FilePrimaries) -> [[f32; 3]; 3] {
    let c = cie();
    let own = |primaries, white| ColorSpaceData::new(primaries, white).rgb_to_xyz;
    let (to_xyz, aces) = match p {
        FilePrimaries::Rec709 => (color_space(ColorSpace::LinearRec709).rgb_to_xyz, false),
        FilePrimaries::Ap1 => (color_space(ColorSpace::AcesCg).rgb_to_xyz, true),
        FilePrimaries::Rec2020 => (color_space(ColorSpace::LinearRec2020).rgb_to_xyz, false),
        FilePrimaries::Ap0 => (own(AP0_PRIMARIES, &c.aces_white), true),
        FilePrimaries::P3D65 => (own(P3_PRIMARIES, &c.d65), false),
        FilePrimaries::AdobeRgb => (own(ADOBE_RGB_PRIMARIES, &c.d65), false),
        FilePrimaries::XyzD65 => (DMat3::IDENTITY, false),
    };
    let rec709 = color_space(crate::scene::AUTHORED_COLOR_SPACE);
    let adapt = if aces { bradford(DVec3::from(color_space(ColorSpace::AcesCg).white_xyz), DVec3::from(rec709.white_xyz)) } else { DMat3::IDENTITY };
    let m = rec709.xyz_to_rgb * adapt * to_xyz;
    std::array::from_fn(|r| std::array::from_fn(|k| m.col(k)[r] as f32))
}

/// Matrices and white of a working colour space (built on first use).
pub fn color_space(cs: ColorSpace) -> &'static ColorSpaceData {
    static REC709: OnceLock<ColorSpaceData> = OnceLock::new();
    static ACESCG: OnceLock<ColorSpaceData> = OnceLock::new();
    static REC2020: OnceLock<ColorSpaceData> = OnceLock::new();
    match cs {
        ColorSpace::LinearRec709 => REC709.get_or_init(|| ColorSpaceData::new(REC709_PRIMARIES, &cie().d65)),
        ColorSpace::AcesCg => ACESCG.get_or_init(|| ColorSpaceData::new(AP1_PRIMARIES, &cie().aces_white)),
        ColorSpace::LinearRec2020 => REC2020.get_or_init(|| ColorSpaceData::new(REC2020_PRIMARIES, &cie().d65)),
    }
}

/// XYZ of rendered light → RGB of the rendering colour space `cs`. Light of the authored
/// colours' white (D65, [`crate::scene::AUTHORED_COLOR_SPACE`]) is white: a space with another
/// white (ACEScg's) is reached through a Bradford adaptation, as colour management converts
/// linear Rec.709 to ACEScg, so an authored colour comes out as that conversion of it.
pub fn xyz_to_output(xyz: [f32; 3], cs: ColorSpace) -> [f32; 3] {
    static OUT: [OnceLock<[[f32; 3]; 3]>; 3] = [OnceLock::new(), OnceLock::new(), OnceLock::new()];
    let i = match cs {
        ColorSpace::LinearRec709 => 0,
        ColorSpace::AcesCg => 1,
        ColorSpace::LinearRec2020 => 2,
    };
    let m = OUT[i].get_or_init(|| {
        let white = DVec3::from(color_space(crate::scene::AUTHORED_COLOR_SPACE).white_xyz);
        let target = color_space(cs);
        let m = target.xyz_to_rgb * bradford(white, DVec3::from(target.white_xyz));
        std::array::from_fn(|r| std::array::from_fn(|k| m.col(k)[r] as f32))
    });
    mul3(m, xyz)
}

/// The Bradford chromatic adaptation of XYZ from white `from` to white `to`.
fn bradford(from: DVec3, to: DVec3) -> DMat3 {
    let mb = DMat3::from_cols(DVec3::new(0.8951, -0.7502, 0.0389), DVec3::new(0.2664, 1.7135, -0.0685), DVec3::new(-0.1614, 0.0367, 1.0296));
    let (s, d) = (mb * from, mb * to);
    mb.inverse() * DMat3::from_diagonal(d / s) * mb
}

/// The white illuminant of a colour space (normalised so that ∫ȳ·W = ∫ȳ).
pub fn white_illuminant(cs: ColorSpace) -> &'static DenseSpectrum {
    cie().white(cs)
}

#[inline]
fn mul3(m: &[[f32; 3]; 3], v: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
}

/// XYZ → linear RGB of the working colour space (no chromatic adaptation: the colour
/// space's own white maps to (1,1,1)).
pub fn xyz_to_rgb(xyz: [f32; 3], cs: ColorSpace) -> [f32; 3] {
    mul3(&color_space(cs).xyz_to_rgb_f32, xyz)
}

/// Linear RGB of the working colour space → CIE XYZ.
pub fn rgb_to_xyz(rgb: [f32; 3], cs: ColorSpace) -> [f32; 3] {
    mul3(&color_space(cs).rgb_to_xyz_f32, rgb)
}

/// Luminance (Y) of a linear RGB of the working colour space.
pub fn luminance(rgb: [f32; 3], cs: ColorSpace) -> f32 {
    let m = &color_space(cs).rgb_to_xyz_f32[1];
    m[0] * rgb[0] + m[1] * rgb[1] + m[2] * rgb[2]
}

// ---------------------------------------------------------------------------------------------
// Blackbody

/// RGB of a blackbody at `kelvin`, normalised to luminance 1 (UsdLux `colorTemperature`).
/// An invalid temperature (see [`try_blackbody_rgb`]) gives neutral (1,1,1).
pub fn blackbody_rgb(kelvin: f32, cs: ColorSpace) -> [f32; 3] {
    try_blackbody_rgb(kelvin, cs).unwrap_or([1.0; 3])
}

/// RGB of a blackbody at `kelvin` ∈ [[`Spectrum::BLACKBODY_MIN_K`],
/// [`Spectrum::BLACKBODY_MAX_K`]], normalised to luminance 1.
pub fn try_blackbody_rgb(kelvin: f32, cs: ColorSpace) -> Result<[f32; 3], SpectrumError> {
    let bb = Spectrum::blackbody(kelvin)?;
    let c = cie();
    let xyz = c.integrate_xyz(|l| bb.eval(l as f32) as f64);
    let rgb = color_space(cs).xyz_to_rgb * DVec3::from(xyz);
    let y = xyz[1];
    Ok([(rgb.x / y) as f32, (rgb.y / y) as f32, (rgb.z / y) as f32])
}

/// Chromaticity (x, y) of an XYZ.
pub fn xyz_to_xy(xyz: [f32; 3]) -> [f32; 2] {
    let v = cie::chromaticity(xyz.map(|v| v as f64));
    [v[0] as f32, v[1] as f32]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{chi2_sphere, Chi2Config, TestRng};
    use glam::Vec3;

    const SPACES: [ColorSpace; 2] = [ColorSpace::LinearRec709, ColorSpace::AcesCg];

    /// Rendered light is written in the rendering colour space as colour management converts
    /// linear Rec.709 (the authored colours' space) to it: white stays white (ACEScg through a
    /// Bradford adaptation), and colours follow the published conversion matrices.
    #[test]
    fn output_spaces_convert_authored_rec709_as_colour_management_does() {
        // lin_rec709 → ACEScg (Bradford D65 → ACES white) and → lin_rec2020, as published
        // (ACES / ITU-R BT.2087), 4 decimals
        let to_ap1 = [[0.6131, 0.3395, 0.0474], [0.0702, 0.9164, 0.0134], [0.0206, 0.1096, 0.8698]];
        let to_2020 = [[0.6274, 0.3293, 0.0433], [0.0691, 0.9195, 0.0114], [0.0164, 0.0880, 0.8956]];
        for (cs, m) in [(ColorSpace::AcesCg, to_ap1), (ColorSpace::LinearRec2020, to_2020)] {
            for rgb in [[1.0, 1.0, 1.0], [1.0, 0.5, 0.25], [0.2, 0.6, 0.9], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]] {
                let got = xyz_to_output(rgb_to_xyz(rgb, ColorSpace::LinearRec709), cs);
                let want: [f32; 3] = std::array::from_fn(|r| (0..3).map(|k| m[r][k] * rgb[k]).sum());
                for k in 0..3 {
                    assert!((got[k] - want[k]).abs() < 1.5e-3, "{cs:?} {rgb:?}: {got:?} vs {want:?}");
                }
            }
        }
        let same = xyz_to_output(rgb_to_xyz([0.3, 0.5, 0.7], ColorSpace::LinearRec709), ColorSpace::LinearRec709);
        assert!(same.iter().zip([0.3, 0.5, 0.7]).all(|(a, b)| (a - b).abs() < 1e-5), "{same:?}");
    }

    /// Files in other colour spaces reach linear Rec.709 as the textbook conversion takes them:
    /// each space's normalised primary matrix from its chromaticities and white point, a
    /// Bradford adaptation from the ACES white (computed here from the published (x, y), not
    /// from the spectra the renderer integrates), and ACEScg's as published (4 decimals).
    #[test]
    fn files_in_other_colour_spaces_convert_to_linear_rec709_as_published() {
        let npm = |p: [[f64; 2]; 3], w: [f64; 2]| {
            let col = |c: [f64; 2]| DVec3::new(c[0] / c[1], 1.0, (1.0 - c[0] - c[1]) / c[1]);
            let m = DMat3::from_cols(col(p[0]), col(p[1]), col(p[2]));
            m * DMat3::from_diagonal(m.inverse() * col(w))
        };
        let (d65, aces) = ([0.3127, 0.3290], [0.32168, 0.33767]);
        let xyz = |w: [f64; 2]| DVec3::new(w[0] / w[1], 1.0, (1.0 - w[0] - w[1]) / w[1]);
        let to_709 = npm(REC709_PRIMARIES, d65).inverse();
        let from_aces = bradford(xyz(aces), xyz(d65));
        for (p, m) in [
            (FilePrimaries::Rec709, DMat3::IDENTITY),
            (FilePrimaries::Ap1, to_709 * from_aces * npm(AP1_PRIMARIES, aces)),
            (FilePrimaries::Ap0, to_709 * from_aces * npm(AP0_PRIMARIES, aces)),
            (FilePrimaries::Rec2020, to_709 * npm(REC2020_PRIMARIES, d65)),
            (FilePrimaries::P3D65, to_709 * npm(P3_PRIMARIES, d65)),
            (FilePrimaries::AdobeRgb, to_709 * npm(ADOBE_RGB_PRIMARIES, d65)),
            (FilePrimaries::XyzD65, to_709),
        ] {
            let got = file_to_authored(p);
            for r in 0..3 {
                for k in 0..3 {
                    assert!((got[r][k] as f64 - m.col(k)[r]).abs() < 2e-3, "{p:?} [{r}][{k}]: {} vs {}", got[r][k], m.col(k)[r]);
                }
            }
        }
        let published = [[1.7051, -0.6218, -0.0833], [-0.1303, 1.1408, -0.0105], [-0.0240, -0.1290, 1.1530]];
        let got = file_to_authored(FilePrimaries::Ap1);
        for r in 0..3 {
            for k in 0..3 {
                assert!((got[r][k] - published[r][k]).abs() < 2e-3, "ACEScg [{r}][{k}]: {} vs {}", got[r][k], published[r][k]);
            }
        }
        // an ACEScg file rendered into ACEScg comes back as its own numbers
        let texel = [0.8f32, 0.3, 0.1];
        let authored: [f32; 3] = std::array::from_fn(|r| (0..3).map(|k| got[r][k] * texel[k]).sum());
        let back = xyz_to_output(rgb_to_xyz(authored, ColorSpace::LinearRec709), ColorSpace::AcesCg);
        assert!(back.iter().zip(texel).all(|(a, b)| (a - b).abs() < 1e-5), "{back:?}");
    }

    #[test]
    fn wavelength_pdf_integrates_to_one() {
        // Midpoint rule at 0.01 nm on a piecewise-linear density with 1 nm knots: the error
        // is O(h²·|f''|) within a bin and the kinks sit on cell edges, so 1e-5 is ample.
        let n = 47_000;
        let h = (LAMBDA_MAX - LAMBDA_MIN) as f64 / n as f64;
        let s: f64 = (0..n).map(|i| wavelength_pdf(LAMBDA_MIN + ((i as f64 + 0.5) * h) as f32) as f64 * h).sum();
        assert!((s - 1.0).abs() < 1e-5, "∫pdf = {s}");
        assert_eq!(wavelength_pdf(359.0), 0.0);
        assert_eq!(wavelength_pdf(831.0), 0.0);
        assert!(wavelength_pdf(LAMBDA_MIN) > 0.0 && wavelength_pdf(LAMBDA_MAX) > 0.0);
    }

    #[test]
    fn wavelength_sampler_matches_its_pdf_chi2() {
        // λ ∈ [360, 830] is mapped to z = cos θ linearly and paired with a uniform φ, so the
        // sphere harness bins wavelengths in equal 10 nm cells (47 θ cells, 1 φ cell). The
        // solid-angle density is p(λ)·|dλ/dz|/(2π). Each of the four outputs (hero and its
        // rotations) must have the same marginal density.
        let range = LAMBDA_MAX - LAMBDA_MIN;
        let to_dir = |l: f32, v: f32| {
            let z = 1.0 - 2.0 * (l - LAMBDA_MIN) / range;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * std::f32::consts::PI * v;
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        };
        let from_dir = |d: Vec3| LAMBDA_MIN + (1.0 - d.z) * 0.5 * range;
        for k in 0..N_SPECTRUM {
            let cfg =
                Chi2Config { theta_res: 47, phi_res: 1, samples: 100_000, seed: 11 + k as u64, ..Default::default() };
            let res = chi2_sphere(
                cfg,
                |rng: &mut TestRng| {
                    let w = sample_wavelengths(rng.next_f32());
                    // the stored pdf must be the density of the returned wavelength
                    let p = wavelength_pdf(w.lambda[k]);
                    assert!((w.pdf[k] - p).abs() <= 1e-5 * p, "{} vs {p}", w.pdf[k]);
                    Some(to_dir(w.lambda[k], rng.next_f32()))
                },
                |d| wavelength_pdf(from_dir(d)) * range / (4.0 * std::f32::consts::PI),
            );
            assert!(res.passed(0.01, N_SPECTRUM), "output {k}: {res:?}");
            assert!((res.pdf_integral - 1.0).abs() < 1e-3, "{res:?}");
        }
    }

    #[test]
    fn rotations_are_quarter_steps_in_cdf_space() {
        let s = sampler();
        let cdf_at = |l: f32| {
            let x = l - LAMBDA_MIN;
            let i = (x as usize).min(N_DENSE - 2);
            let t = x - i as f32;
            let (f0, f1) = (s.f[i] as f64, s.f[i + 1] as f64);
            s.cdf[i] as f64 + (f0 * t as f64 + 0.5 * (f1 - f0) * (t * t) as f64) / s.total as f64
        };
        let mut rng = TestRng::new(3);
        for _ in 0..1000 {
            let u = rng.next_f32();
            let w = sample_wavelengths(u);
            for i in 0..N_SPECTRUM {
                let want = (u as f64 + i as f64 / 4.0).fract();
                // inverse then forward CDF in f32 loses ~1e-6 (CDF steps are ≥ 1e-8 per bin)
                assert!((cdf_at(w.lambda[i]) - want).abs() < 2e-5, "u={u} i={i}");
            }
        }
    }

    #[test]
    fn to_xyz_is_unbiased_for_a_smooth_spectrum() {
        // E_u[to_xyz(L, sample(u))] = ∫ L·cmf / ∫ȳ. Integrating over u with 200k midpoints
        // (stratified, no randomness) must reproduce the 1 nm quadrature; the two differ by
        // discretisation only (both O(1e-5) here), so 2e-4 relative is the bound.
        let c = cie();
        let l = |x: f32| 0.3 + 0.7 * ((x - 400.0) / 60.0).sin().powi(2);
        let want = c.integrate_xyz(|x| l(x as f32) as f64);
        for terminated in [false, true] {
            let n = 200_000;
            let mut acc = [0.0f64; 3];
            for i in 0..n {
                let mut w = sample_wavelengths((i as f32 + 0.5) / n as f32);
                if terminated {
                    w.terminate_secondary();
                }
                let ls = SampledSpectrum::from_fn(|k| l(w.lambda[k]));
                let xyz = to_xyz(ls, &w);
                for k in 0..3 {
                    acc[k] += xyz[k] as f64 / n as f64;
                }
            }
            for k in 0..3 {
                assert!((acc[k] - want[k]).abs() < 2e-4 * want[k], "{terminated} {acc:?} vs {want:?}");
            }
        }
    }

    #[test]
    fn white_illuminant_renders_white_within_3_sigma() {
        for cs in SPACES {
            let w = crate::spectrum::uplift::illuminant([1.0; 3], cs);
            let mut rng = TestRng::new(99);
            let n = 50_000;
            let (mut sum, mut sum2) = ([0.0f64; 3], [0.0f64; 3]);
            for _ in 0..n {
                let lam = sample_wavelengths(rng.next_f32());
                let rgb = xyz_to_rgb(to_xyz(w.sample(&lam), &lam), cs);
                for k in 0..3 {
                    sum[k] += rgb[k] as f64;
                    sum2[k] += (rgb[k] as f64).powi(2);
                }
            }
            for k in 0..3 {
                let mean = sum[k] / n as f64;
                let sigma = ((sum2[k] / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
                // The estimator is unbiased up to the 1 nm quadrature used for the
                // normalisation (< 1e-5), so a 3σ band is the right test.
                assert!((mean - 1.0).abs() < 3.0 * sigma + 1e-5, "{cs:?} ch{k}: {mean} ± {sigma}");
                assert!(sigma < 0.01, "{cs:?}: σ = {sigma}");
            }
        }
    }

    #[test]
    fn rec709_matrices_map_d65_to_white() {
        let cs = color_space(ColorSpace::LinearRec709);
        let w = cs.white_xyz.map(|v| v as f32);
        let rgb = xyz_to_rgb(w, ColorSpace::LinearRec709);
        // f32 matrix product: a few ulps.
        for v in rgb {
            assert!((v - 1.0).abs() < 1e-5, "{rgb:?}");
        }
        // The standard D65 (0.3127, 0.3290) differs from the table's white by 3e-5 in xy,
        // which moves RGB by < 1e-3.
        let std_white = [0.3127 / 0.3290, 1.0, (1.0 - 0.3127 - 0.3290) / 0.3290];
        for v in xyz_to_rgb(std_white, ColorSpace::LinearRec709) {
            assert!((v - 1.0).abs() < 1e-3);
        }
        // Round trip and the familiar luminance weights (BT.709: 0.2126, 0.7152, 0.0722 to
        // the 4 digits the standard gives).
        let back = rgb_to_xyz([1.0; 3], ColorSpace::LinearRec709);
        for k in 0..3 {
            assert!((back[k] - w[k]).abs() < 1e-5);
        }
        let y = [
            luminance([1.0, 0.0, 0.0], ColorSpace::LinearRec709),
            luminance([0.0, 1.0, 0.0], ColorSpace::LinearRec709),
            luminance([0.0, 0.0, 1.0], ColorSpace::LinearRec709),
        ];
        for (a, b) in y.iter().zip([0.2126, 0.7152, 0.0722]) {
            assert!((a - b).abs() < 1e-3, "{y:?}");
        }
    }

    #[test]
    fn acescg_white_is_the_aces_white() {
        let xyz = rgb_to_xyz([1.0; 3], ColorSpace::AcesCg);
        let xy = xyz_to_xy(xyz);
        // f32 matrices: 1e-5.
        assert!(
            (xy[0] as f64 - cie::ACES_WHITE_XY[0]).abs() < 1e-5 && (xy[1] as f64 - cie::ACES_WHITE_XY[1]).abs() < 1e-5,
            "{xy:?}"
        );
        assert!((xyz[1] - 1.0).abs() < 1e-5);
        // AP1 → XYZ published matrix (S-2014-004) row Y: 0.2722287, 0.6740818, 0.0536895.
        let y = [
            luminance([1.0, 0.0, 0.0], ColorSpace::AcesCg),
            luminance([0.0, 1.0, 0.0], ColorSpace::AcesCg),
            luminance([0.0, 0.0, 1.0], ColorSpace::AcesCg),
        ];
        for (a, b) in y.iter().zip([0.2722287, 0.6740818, 0.0536895]) {
            assert!((a - b).abs() < 1e-5, "{y:?}");
        }
        let rgb = xyz_to_rgb(xyz, ColorSpace::AcesCg);
        for v in rgb {
            assert!((v - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn blackbody_6504k_is_near_neutral_and_warm_is_red() {
        let rgb = blackbody_rgb(6504.0, ColorSpace::LinearRec709);
        assert!((luminance(rgb, ColorSpace::LinearRec709) - 1.0).abs() < 1e-5);
        // D65 lies Δuv ≈ +0.003 off the Planckian locus at 6504 K, which is a few per cent
        // of RGB (mostly in green); 5 % bounds that and still rejects 5500 K or 7500 K.
        for v in rgb {
            assert!((v - 1.0).abs() < 0.05, "{rgb:?}");
        }
        let warm = blackbody_rgb(2700.0, ColorSpace::LinearRec709);
        assert!(warm[0] > warm[1] && warm[1] > warm[2], "{warm:?}");
        let cool = blackbody_rgb(12000.0, ColorSpace::AcesCg);
        assert!(cool[2] > cool[0], "{cool:?}");
        assert!(try_blackbody_rgb(f32::NAN, ColorSpace::AcesCg).is_err());
        assert!(try_blackbody_rgb(-5.0, ColorSpace::AcesCg).is_err());
        assert_eq!(blackbody_rgb(0.0, ColorSpace::AcesCg), [1.0; 3]);
    }
}
