//! Continuous spectra: what materials, media and lights store, sampled at a path's
//! wavelengths. Every variant evaluates in a few flops per wavelength without allocation.

use super::cie::DenseSpectrum;
use super::rgb2spec::sigmoid;
use super::sampled::{SampledSpectrum, SampledWavelengths, LAMBDA_MAX, LAMBDA_MIN};
use super::uplift;
use crate::scene::{ColorSpace, SpectrumDesc};
use std::fmt;
use std::sync::Arc;

/// A spectrum over wavelength λ in nm.
#[derive(Clone, Debug, PartialEq)]
pub enum Spectrum {
    /// The same value at every wavelength.
    Constant(f32),
    /// scale · sigmoid(c0·λ² + c1·λ + c2) (Jakob & Hanika 2019), λ in nm; see
    /// [`super::rgb2spec::sigmoid`]. Bounded by `scale`.
    Sigmoid { c0: f32, c1: f32, c2: f32, scale: f32 },
    /// scale · sigmoid(c0·λ² + c1·λ + c2) · W(λ): a colour of emitted light, W being the
    /// working colour space's white illuminant (normalised so that ∫ȳ·W = ∫ȳ).
    Illuminant { c0: f32, c1: f32, c2: f32, scale: f32, illuminant: &'static DenseSpectrum },
    /// Piecewise linear through (nm, value) samples, constant beyond the first and last.
    Tabulated(Tabulated),
    /// Planck's law at `kelvin`, normalised to a peak of 1 (over all λ, so the maximum over
    /// [360, 830] nm is ≤ 1).
    Blackbody { kelvin: f32 },
}

/// Samples of a [`Spectrum::Tabulated`] (shared: cloning a spectrum copies a pointer).
#[derive(Clone, Debug, PartialEq)]
pub struct Tabulated(Arc<TabulatedData>);

#[derive(Debug, PartialEq)]
struct TabulatedData {
    lambda: Box<[f32]>,
    value: Box<[f32]>,
    max: f32,
    /// Intervals per nm if the samples were evenly spaced: the first guess of the interval
    /// holding a wavelength, corrected by a step or two (or a binary search) where the grid is
    /// uneven, so the interval found is always the one a search would find.
    inv_step: f32,
    /// The samples sit on consecutive whole nanometres (water tabulated at 1 nm): the interval
    /// and the fraction within it come from one subtraction, with the bits of the search.
    unit: bool,
}

impl Tabulated {
    #[inline]
    fn eval(&self, l: f32) -> f32 {
        self.0.eval(l)
    }
    /// The sample wavelengths (nm), strictly increasing.
    pub fn lambda(&self) -> &[f32] {
        &self.0.lambda
    }
    /// The sample values.
    pub fn value(&self) -> &[f32] {
        &self.0.value
    }
}

impl TabulatedData {
    /// Two or more samples, wavelengths increasing.
    fn new(lambda: &[f32], value: &[f32]) -> TabulatedData {
        let n = lambda.len();
        let unit = lambda[0].fract() == 0.0 && lambda.iter().enumerate().all(|(k, &x)| x == lambda[0] + k as f32);
        let inv_step = (n - 1) as f32 / (lambda[n - 1] - lambda[0]);
        TabulatedData { lambda: lambda.into(), value: value.into(), max: 0.0, inv_step, unit }
    }

    #[inline]
    fn eval(&self, l: f32) -> f32 {
        let (xs, ys) = (&*self.lambda, &*self.value);
        let n = xs.len();
        if !(l > xs[0]) {
            return ys[0];
        }
        if l >= xs[n - 1] {
            return ys[n - 1];
        }
        if self.unit {
            // l − xs[0] is exact (xs[0] a whole number no larger than l, the difference no
            // larger than l), so are its integer part i and u − i = (l − xs[i]) / 1
            let u = l - xs[0];
            let i = (u as usize).min(n - 2);
            return ys[i] + (u - i as f32) * (ys[i + 1] - ys[i]);
        }
        // the interval i with xs[i] <= l < xs[i + 1]
        let mut i = (((l - xs[0]) * self.inv_step) as usize).min(n - 2);
        let mut steps = 0;
        while xs[i] > l || xs[i + 1] <= l {
            steps += 1;
            if steps > 2 {
                i = xs.partition_point(|&x| x <= l) - 1;
                break;
            }
            if xs[i] > l {
                i -= 1;
            } else {
                i += 1;
            }
        }
        let t = (l - xs[i]) / (xs[i + 1] - xs[i]);
        ys[i] + t * (ys[i + 1] - ys[i])
    }
}

/// What a spectrum describes, which decides how RGB is uplifted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpectrumKind {
    /// Reflectance-like: clamped to [0, 1], spectrum bounded by [0, 1].
    Albedo,
    /// A non-negative coefficient without upper bound (e.g. σa in 1/m).
    Unbounded,
    /// Emitted light: RGB (1,1,1) seen directly renders (1,1,1).
    Illuminant,
}

/// Why a spectrum could not be built.
#[derive(Clone, Debug, PartialEq)]
pub enum SpectrumError {
    /// An RGB with a NaN or infinite channel.
    NonFiniteRgb([f32; 3]),
    /// An RGB with a negative channel (only albedo clamps).
    NegativeRgb([f32; 3]),
    /// Tabulated wavelength and value arrays of different lengths.
    TabulatedLengthMismatch { lambda: usize, value: usize },
    /// A tabulated spectrum without samples.
    TabulatedEmpty,
    /// Tabulated wavelength `index` is not finite or not strictly greater than the previous.
    TabulatedWavelength { index: usize, lambda: f32 },
    /// Tabulated value `index` is not finite or negative.
    TabulatedValue { index: usize, value: f32 },
    /// A blackbody temperature outside the supported range.
    ColorTemperature(f32),
}

impl fmt::Display for SpectrumError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SpectrumError::NonFiniteRgb(c) => write!(f, "RGB {c:?} has a non-finite channel"),
            SpectrumError::NegativeRgb(c) => write!(f, "RGB {c:?} has a negative channel"),
            SpectrumError::TabulatedLengthMismatch { lambda, value } => {
                write!(f, "tabulated spectrum has {lambda} wavelengths but {value} values")
            }
            SpectrumError::TabulatedEmpty => write!(f, "tabulated spectrum has no samples"),
            SpectrumError::TabulatedWavelength { index, lambda } => {
                write!(f, "tabulated spectrum wavelength #{index} ({lambda} nm) is not finite or not increasing")
            }
            SpectrumError::TabulatedValue { index, value } => {
                write!(f, "tabulated spectrum value #{index} ({value}) is not finite and non-negative")
            }
            SpectrumError::ColorTemperature(k) => write!(
                f,
                "colour temperature {k} K is outside [{}, {}] K",
                Spectrum::BLACKBODY_MIN_K,
                Spectrum::BLACKBODY_MAX_K
            ),
        }
    }
}

impl std::error::Error for SpectrumError {}

/// Second radiation constant h·c/k in nm·K.
const PLANCK_C2: f32 = 1.438_776_9e7;
/// Wien's displacement constant in nm·K.
const WIEN_B: f32 = 2.897_772e6;
/// expm1(c2/(λ_peak·T)) = expm1(c2/b), the same for every temperature.
const PEAK_DENOM: f32 = 142.324_51;

/// Planck's law divided by its peak value.
#[inline]
fn blackbody(lambda: f32, kelvin: f32) -> f32 {
    let r = WIEN_B / (kelvin * lambda);
    let r2 = r * r;
    r2 * r2 * r * PEAK_DENOM / (PLANCK_C2 / (lambda * kelvin)).exp_m1()
}

/// c0·l² + c1·l + c2 (Horner; plain products and sums: `mul_add` is a library call where the
/// build does not target FMA, and this runs for every wavelength of every spectral lookup).
#[inline]
fn poly(c0: f32, c1: f32, c2: f32, l: f32) -> f32 {
    (c0 * l + c1) * l + c2
}

/// Largest value of sigmoid(c0·λ² + c1·λ + c2) over [360, 830] nm (sigmoid is increasing, so
/// it is at an end or at the parabola's vertex).
fn sigmoid_max(c0: f32, c1: f32, c2: f32) -> f32 {
    let mut m = poly(c0, c1, c2, LAMBDA_MIN).max(poly(c0, c1, c2, LAMBDA_MAX));
    if c0 != 0.0 {
        let v = -c1 / (2.0 * c0);
        if (LAMBDA_MIN..=LAMBDA_MAX).contains(&v) {
            m = m.max(poly(c0, c1, c2, v));
        }
    }
    sigmoid(m)
}

impl Spectrum {
    /// Lowest supported blackbody temperature.
    pub const BLACKBODY_MIN_K: f32 = 100.0;
    /// Highest supported blackbody temperature.
    pub const BLACKBODY_MAX_K: f32 = 1.0e6;

    /// Values at the path's wavelengths.
    #[inline]
    pub fn sample(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        match self {
            Spectrum::Constant(c) => SampledSpectrum::splat(*c),
            Spectrum::Sigmoid { c0, c1, c2, scale } => {
                SampledSpectrum::from_fn(|i| scale * sigmoid(poly(*c0, *c1, *c2, lambda.lambda[i])))
            }
            Spectrum::Illuminant { c0, c1, c2, scale, illuminant } => SampledSpectrum::from_fn(|i| {
                let l = lambda.lambda[i];
                scale * sigmoid(poly(*c0, *c1, *c2, l)) * illuminant.eval(l)
            }),
            Spectrum::Tabulated(t) => SampledSpectrum::from_fn(|i| t.eval(lambda.lambda[i])),
            Spectrum::Blackbody { kelvin } => SampledSpectrum::from_fn(|i| blackbody(lambda.lambda[i], *kelvin)),
        }
    }

    /// Value at one wavelength (nm).
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        match self {
            Spectrum::Constant(c) => *c,
            Spectrum::Sigmoid { c0, c1, c2, scale } => scale * sigmoid(poly(*c0, *c1, *c2, lambda)),
            Spectrum::Illuminant { c0, c1, c2, scale, illuminant } => {
                scale * sigmoid(poly(*c0, *c1, *c2, lambda)) * illuminant.eval(lambda)
            }
            Spectrum::Tabulated(t) => t.eval(lambda),
            Spectrum::Blackbody { kelvin } => blackbody(lambda, *kelvin),
        }
    }

    /// An upper bound of the spectrum over the sampled range (exact except for
    /// `Illuminant`, where it is the product of the two factors' maxima).
    pub fn max_value(&self) -> f32 {
        match self {
            Spectrum::Constant(c) => *c,
            Spectrum::Sigmoid { c0, c1, c2, scale } => scale * sigmoid_max(*c0, *c1, *c2),
            Spectrum::Illuminant { c0, c1, c2, scale, illuminant } => {
                scale * sigmoid_max(*c0, *c1, *c2) * illuminant.max_value()
            }
            Spectrum::Tabulated(t) => t.0.max,
            Spectrum::Blackbody { kelvin } => {
                let peak = WIEN_B / kelvin;
                if (LAMBDA_MIN..=LAMBDA_MAX).contains(&peak) {
                    1.0
                } else {
                    blackbody(peak.clamp(LAMBDA_MIN, LAMBDA_MAX), *kelvin)
                }
            }
        }
    }

    /// A piecewise-linear spectrum through (`lambda` nm, `value`) samples, constant beyond
    /// the ends. Wavelengths must increase strictly; values must be finite and ≥ 0.
    pub fn tabulated(lambda: &[f32], value: &[f32]) -> Result<Spectrum, SpectrumError> {
        if lambda.len() != value.len() {
            return Err(SpectrumError::TabulatedLengthMismatch { lambda: lambda.len(), value: value.len() });
        }
        if lambda.is_empty() {
            return Err(SpectrumError::TabulatedEmpty);
        }
        for (i, &l) in lambda.iter().enumerate() {
            if !l.is_finite() || (i > 0 && !(l > lambda[i - 1])) {
                return Err(SpectrumError::TabulatedWavelength { index: i, lambda: l });
            }
        }
        for (i, &v) in value.iter().enumerate() {
            if !(v.is_finite() && v >= 0.0) {
                return Err(SpectrumError::TabulatedValue { index: i, value: v });
            }
        }
        if lambda.len() == 1 {
            return Ok(Spectrum::Constant(value[0]));
        }
        // the maximum over [360, 830]: interior samples plus the curve at the two ends
        let mut t = TabulatedData::new(lambda, value);
        let mut max = t.eval(LAMBDA_MIN).max(t.eval(LAMBDA_MAX));
        for (&l, &v) in lambda.iter().zip(value) {
            if (LAMBDA_MIN..=LAMBDA_MAX).contains(&l) {
                max = max.max(v);
            }
        }
        t.max = max;
        Ok(Spectrum::Tabulated(Tabulated(Arc::new(t))))
    }

    /// Planck's law at `kelvin` ∈ [[`Self::BLACKBODY_MIN_K`], [`Self::BLACKBODY_MAX_K`]],
    /// normalised to a peak value of 1.
    pub fn blackbody(kelvin: f32) -> Result<Spectrum, SpectrumError> {
        if !(Self::BLACKBODY_MIN_K..=Self::BLACKBODY_MAX_K).contains(&kelvin) {
            return Err(SpectrumError::ColorTemperature(kelvin));
        }
        Ok(Spectrum::Blackbody { kelvin })
    }

    /// The spectrum a scene description states. RGB is uplifted per `kind` in the working
    /// colour space `cs`; tabulated values are used as given, except that albedo clamps them
    /// to [0, 1] as it clamps RGB. Non-finite input, and negative RGB for `Unbounded` and
    /// `Illuminant`, are errors.
    pub fn from_desc(desc: &SpectrumDesc, kind: SpectrumKind, cs: ColorSpace) -> Result<Spectrum, SpectrumError> {
        match desc {
            SpectrumDesc::Rgb(rgb) => {
                if !rgb.iter().all(|v| v.is_finite()) {
                    return Err(SpectrumError::NonFiniteRgb(*rgb));
                }
                if kind != SpectrumKind::Albedo && rgb.iter().any(|&v| v < 0.0) {
                    return Err(SpectrumError::NegativeRgb(*rgb));
                }
                Ok(match kind {
                    SpectrumKind::Albedo => uplift::albedo(*rgb, cs),
                    SpectrumKind::Unbounded => uplift::unbounded(*rgb, cs),
                    SpectrumKind::Illuminant => uplift::illuminant(*rgb, cs),
                })
            }
            SpectrumDesc::Tabulated { lambda, value } => {
                if kind == SpectrumKind::Albedo {
                    let clamped: Vec<f32> =
                        value.iter().map(|&v| if v.is_finite() { v.clamp(0.0, 1.0) } else { v }).collect();
                    Spectrum::tabulated(lambda, &clamped)
                } else {
                    Spectrum::tabulated(lambda, value)
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn tabulated_lookup_finds_the_searched_interval_on_even_and_uneven_grids() {
        let mut x = 0x9e37_79b9u32;
        let mut next = || {
            x = crate::sampler::hash_u32(x);
            (x >> 8) as f32 / (1u32 << 24) as f32
        };
        let even: Vec<f32> = (0..95).map(|i| 360.0 + 5.0 * i as f32).collect();
        let mut uneven = vec![300.0f32];
        for _ in 0..60 {
            let last = *uneven.last().unwrap();
            uneven.push(last + 0.1 + 20.0 * next() * next());
        }
        // whole nanometres (the unit-grid path), and a grid at 0.5 nm that must not take it
        let unit: Vec<f32> = (360..=830).map(|l| l as f32).collect();
        let half: Vec<f32> = (0..200).map(|i| 400.0 + 0.5 * i as f32).collect();
        let offset: Vec<f32> = (0..200).map(|i| 400.25 + i as f32).collect();
        for (g, xs) in [even, uneven, unit, half, offset].into_iter().enumerate() {
            let ys: Vec<f32> = xs.iter().map(|l| (l * 0.01).sin().abs()).collect();
            let t = TabulatedData::new(&xs, &ys);
            assert_eq!(t.unit, g == 2, "grid {g}");
            for k in 0..20_000 {
                let l = if k % 7 == 0 { xs[k % xs.len()] } else { xs[0] - 5.0 + (xs[xs.len() - 1] - xs[0] + 10.0) * next() };
                // the reference: binary search
                let want = if !(l > xs[0]) {
                    ys[0]
                } else if l >= xs[xs.len() - 1] {
                    ys[xs.len() - 1]
                } else {
                    let i = xs.partition_point(|&x| x <= l) - 1;
                    ys[i] + (l - xs[i]) / (xs[i + 1] - xs[i]) * (ys[i + 1] - ys[i])
                };
                assert_eq!(t.eval(l).to_bits(), want.to_bits(), "λ = {l}");
            }
        }
    }

    use super::*;
    use crate::spectrum::color::sample_wavelengths;

    #[test]
    fn sample_agrees_with_eval_for_every_variant() {
        let cs = ColorSpace::AcesCg;
        let all = [
            Spectrum::Constant(0.3),
            uplift::albedo([0.7, 0.2, 0.1], cs),
            uplift::unbounded([0.05, 3.0, 1.0], cs),
            uplift::illuminant([2.0, 1.0, 0.5], cs),
            Spectrum::tabulated(&[380.0, 520.0, 700.0], &[0.1, 0.9, 0.4]).unwrap(),
            Spectrum::blackbody(3200.0).unwrap(),
        ];
        let mut rng = crate::testing::chi2::TestRng::new(4);
        for s in &all {
            for _ in 0..100 {
                let w = sample_wavelengths(rng.next_f32());
                let v = s.sample(&w);
                for i in 0..4 {
                    assert_eq!(v[i], s.eval(w.lambda[i]), "{s:?}");
                    assert!(v[i] >= 0.0 && v[i] <= s.max_value(), "{s:?}");
                }
            }
        }
    }

    #[test]
    fn spectrum_is_small() {
        // four f32 and a pointer, plus the tag: materials store many of these
        assert!(std::mem::size_of::<Spectrum>() <= 32);
    }

    #[test]
    fn tabulated_interpolates_and_clamps() {
        let s = Spectrum::tabulated(&[400.0, 500.0, 600.0], &[1.0, 3.0, 2.0]).unwrap();
        assert_eq!(s.eval(300.0), 1.0);
        assert_eq!(s.eval(450.0), 2.0);
        assert_eq!(s.eval(550.0), 2.5);
        assert_eq!(s.eval(800.0), 2.0);
        assert_eq!(s.max_value(), 3.0);
        let w = sample_wavelengths(0.3);
        let v = s.sample(&w);
        for i in 0..4 {
            assert_eq!(v[i], s.eval(w.lambda[i]));
        }
        assert_eq!(Spectrum::tabulated(&[500.0], &[0.7]).unwrap(), Spectrum::Constant(0.7));
    }

    #[test]
    fn tabulated_rejects_bad_input_with_a_reason() {
        let e = Spectrum::tabulated(&[400.0, 500.0], &[1.0]).unwrap_err();
        assert_eq!(e, SpectrumError::TabulatedLengthMismatch { lambda: 2, value: 1 });
        assert_eq!(Spectrum::tabulated(&[], &[]).unwrap_err(), SpectrumError::TabulatedEmpty);
        let e = Spectrum::tabulated(&[500.0, 500.0], &[1.0, 1.0]).unwrap_err();
        assert!(matches!(e, SpectrumError::TabulatedWavelength { index: 1, .. }));
        assert!(e.to_string().contains("#1"));
        let e = Spectrum::tabulated(&[400.0, 500.0], &[1.0, f32::NAN]).unwrap_err();
        assert!(matches!(e, SpectrumError::TabulatedValue { index: 1, .. }));
        let e = Spectrum::tabulated(&[400.0, 500.0], &[-1.0, 0.0]).unwrap_err();
        assert!(matches!(e, SpectrumError::TabulatedValue { index: 0, .. }));
    }

    #[test]
    fn from_desc_dispatches_and_validates() {
        let cs = ColorSpace::LinearRec709;
        let d = SpectrumDesc::Rgb([0.2, 0.4, 0.6]);
        assert_eq!(Spectrum::from_desc(&d, SpectrumKind::Albedo, cs).unwrap(), uplift::albedo([0.2, 0.4, 0.6], cs));
        assert_eq!(
            Spectrum::from_desc(&d, SpectrumKind::Unbounded, cs).unwrap(),
            uplift::unbounded([0.2, 0.4, 0.6], cs)
        );
        assert_eq!(
            Spectrum::from_desc(&d, SpectrumKind::Illuminant, cs).unwrap(),
            uplift::illuminant([0.2, 0.4, 0.6], cs)
        );
        let bad = SpectrumDesc::Rgb([0.2, f32::INFINITY, 0.6]);
        assert!(matches!(Spectrum::from_desc(&bad, SpectrumKind::Albedo, cs), Err(SpectrumError::NonFiniteRgb(_))));
        let neg = SpectrumDesc::Rgb([0.2, -0.1, 0.6]);
        assert!(matches!(Spectrum::from_desc(&neg, SpectrumKind::Unbounded, cs), Err(SpectrumError::NegativeRgb(_))));
        assert!(Spectrum::from_desc(&neg, SpectrumKind::Albedo, cs).is_ok());
        let tab = SpectrumDesc::Tabulated { lambda: vec![400.0, 700.0], value: vec![0.5, 2.0] };
        assert_eq!(Spectrum::from_desc(&tab, SpectrumKind::Albedo, cs).unwrap().max_value(), 1.0);
        assert_eq!(Spectrum::from_desc(&tab, SpectrumKind::Unbounded, cs).unwrap().max_value(), 2.0);
    }

    #[test]
    fn blackbody_peaks_at_one_at_wien_wavelength() {
        // 5000 K peaks at b/T = 579.55 nm; normalised peak 1 (f32 evaluation: 1e-5).
        let s = Spectrum::blackbody(5000.0).unwrap();
        let peak = WIEN_B / 5000.0;
        assert!((s.eval(peak) - 1.0).abs() < 1e-5);
        assert!(s.eval(peak - 20.0) < 1.0 && s.eval(peak + 20.0) < 1.0);
        assert_eq!(s.max_value(), 1.0);
        // 2000 K peaks in the infrared: the maximum over the range is at 830 nm.
        let warm = Spectrum::blackbody(2000.0).unwrap();
        assert_eq!(warm.max_value(), warm.eval(830.0));
        assert!(warm.max_value() < 1.0);
        // ratio of two wavelengths against Planck's law in f64
        let planck = |l: f64, t: f64| l.powi(-5) / ((1.438776877e7 / (l * t)).exp() - 1.0);
        let want = planck(450.0, 3000.0) / planck(650.0, 3000.0);
        let s = Spectrum::blackbody(3000.0).unwrap();
        let got = (s.eval(450.0) / s.eval(650.0)) as f64;
        assert!((got / want - 1.0).abs() < 1e-5, "{got} {want}");
        for k in [f32::NAN, 0.0, -1.0, 50.0, 2.0e6] {
            assert!(matches!(Spectrum::blackbody(k), Err(SpectrumError::ColorTemperature(_))), "{k}");
        }
        assert!(Spectrum::blackbody(Spectrum::BLACKBODY_MIN_K).unwrap().eval(360.0).is_finite());
        assert!(Spectrum::blackbody(Spectrum::BLACKBODY_MAX_K).unwrap().eval(830.0).is_finite());
    }

    #[test]
    fn sigmoid_max_value_bounds_the_spectrum() {
        let s = Spectrum::Sigmoid { c0: -1e-4, c1: 0.1, c2: -24.0, scale: 2.0 };
        let m = s.max_value();
        let mut best = 0.0f32;
        for i in 0..=4700 {
            best = best.max(s.eval(360.0 + i as f32 * 0.1));
        }
        // exact maximum at the vertex (500 nm); the 0.1 nm scan comes within f32 rounding
        assert!(best <= m * (1.0 + 1e-6) && best >= m * (1.0 - 1e-5), "{best} {m}");
    }
}
