//! Pixel reconstruction filters, applied by filter importance sampling: each camera sample's
//! offset from the pixel centre is drawn from the filter (separably, per axis), so every
//! sample has weight 1 and a pixel's value is the plain mean of its samples. The filter is
//! `tide:pixelFilter` (`gaussian` | `box` | `triangle`) of full width `tide:pixelFilter:width`
//! pixels on the render settings.
//!
//! - `box` (the default, width 1): uniform over the width; width 1 is the pixel's own square, so
//!   a pixel is the mean radiance over its area (the pixel integral that reference renders and
//!   comparisons between renderers use);
//! - `gaussian` (default width 3): σ = width / 6, truncated at ±3σ (smoother anti-aliasing at
//!   the price of a slightly softer image);
//! - `triangle` (default width 2): a tent reaching 0 at ±width / 2.

/// The shape of a pixel filter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FilterKind {
    Gaussian,
    #[default]
    Box,
    Triangle,
}

impl FilterKind {
    /// The `tide:pixelFilter` token.
    pub fn token(self) -> &'static str {
        match self {
            FilterKind::Gaussian => "gaussian",
            FilterKind::Box => "box",
            FilterKind::Triangle => "triangle",
        }
    }

    /// The kind named by a `tide:pixelFilter` token.
    pub fn from_token(t: &str) -> Option<FilterKind> {
        [FilterKind::Gaussian, FilterKind::Box, FilterKind::Triangle].into_iter().find(|k| k.token() == t)
    }

    /// Full width in pixels used when none is given.
    pub fn default_width(self) -> f32 {
        match self {
            FilterKind::Gaussian => 3.0,
            FilterKind::Box => 1.0,
            FilterKind::Triangle => 2.0,
        }
    }
}

/// Largest accepted full width (pixels).
pub const MAX_FILTER_WIDTH: f32 = 16.0;

/// A separable pixel filter of full width `width` pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelFilter {
    pub kind: FilterKind,
    pub width: f32,
}

impl Default for PixelFilter {
    fn default() -> Self {
        PixelFilter { kind: FilterKind::Box, width: FilterKind::Box.default_width() }
    }
}

/// Φ(−3): the standard normal's mass below −3σ.
const PHI_MINUS_3: f64 = 0.001_349_898_031_630_094_6;

impl PixelFilter {
    /// A filter of `kind` and full `width` pixels; a width ≤ 0 means the kind's default.
    /// Widths that are not finite or exceed [`MAX_FILTER_WIDTH`] are refused.
    pub fn new(kind: FilterKind, width: f32) -> Result<PixelFilter, String> {
        let width = if width == 0.0 { kind.default_width() } else { width };
        if !(width > 0.0 && width <= MAX_FILTER_WIDTH) {
            return Err(format!("width {width} must be in (0, {MAX_FILTER_WIDTH}] pixels"));
        }
        Ok(PixelFilter { kind, width })
    }

    /// Offset (pixels) of a sample from the pixel centre along one axis, for `u` in [0, 1).
    pub fn sample(&self, u: f32) -> f32 {
        let r = 0.5 * self.width;
        match self.kind {
            FilterKind::Box => (u - 0.5) * self.width,
            FilterKind::Triangle => {
                // inverse of the tent's CDF, each half separately
                if u < 0.5 {
                    r * ((2.0 * u).sqrt() - 1.0)
                } else {
                    r * (1.0 - (2.0 * (1.0 - u)).max(0.0).sqrt())
                }
            }
            FilterKind::Gaussian => {
                let sigma = self.width as f64 / 6.0;
                let p = PHI_MINUS_3 + u as f64 * (1.0 - 2.0 * PHI_MINUS_3);
                (sigma * inv_normal_cdf(p)) as f32
            }
        }
    }

    /// The filter's 1D density at offset `x` (integrates to 1 over its support).
    pub fn pdf(&self, x: f32) -> f32 {
        let r = 0.5 * self.width;
        if x.abs() > r {
            return 0.0;
        }
        match self.kind {
            FilterKind::Box => 1.0 / self.width,
            FilterKind::Triangle => (r - x.abs()) / (r * r),
            FilterKind::Gaussian => {
                let sigma = self.width as f64 / 6.0;
                let g = (-(x as f64 * x as f64) / (2.0 * sigma * sigma)).exp() / (sigma * (2.0 * std::f64::consts::PI).sqrt());
                (g / (1.0 - 2.0 * PHI_MINUS_3)) as f32
            }
        }
    }
}

/// Inverse of the standard normal CDF (Acklam's rational approximation, relative error
/// below 1.2e-9 in f64).
pub fn inv_normal_cdf(p: f64) -> f64 {
    const A: [f64; 6] = [-3.969683028665376e1, 2.209460984245205e2, -2.759285104469687e2, 1.383577518672690e2, -3.066479806614716e1, 2.506628277459239];
    const B: [f64; 5] = [-5.447609879822406e1, 1.615858368580409e2, -1.556989798598866e2, 6.680131188771972e1, -1.328068155288572e1];
    const C: [f64; 6] = [-7.784894002430293e-3, -3.223964580411365e-1, -2.400758277161838, -2.549732539343734, 4.374664141464968, 2.938163982698783];
    const D: [f64; 4] = [7.784695709041462e-3, 3.224671290700398e-1, 2.445134137142996, 3.754408661907416];
    let p = p.clamp(1e-300, 1.0 - 1e-16);
    let pl = 0.02425;
    if p < pl {
        let q = (-2.0 * p.ln()).sqrt();
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5]) / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    } else if p <= 1.0 - pl {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    } else {
        -inv_normal_cdf(1.0 - p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{gamma_q, TestRng};

    /// Pearson's χ² of `n` samples of `sample` over 40 equal bins of `f`'s support against the
    /// bins' expected counts from `f.pdf` (Simpson quadrature, 64 intervals per bin).
    fn chi2_p(sample: impl Fn(f32) -> f32, f: &PixelFilter, seed: u64) -> f64 {
        const BINS: usize = 40;
        let n = 200_000usize;
        let r = 0.5 * f.width;
        let mut counts = [0u32; BINS];
        let mut rng = TestRng::new(seed);
        for _ in 0..n {
            let x = sample(rng.next_f32());
            assert!(x.abs() <= r * (1.0 + 1e-5), "{x} outside ±{r}");
            let b = (((x + r) / f.width) * BINS as f32).floor().clamp(0.0, BINS as f32 - 1.0) as usize;
            counts[b] += 1;
        }
        let mut stat = 0.0;
        let mut total = 0.0;
        for (b, &c) in counts.iter().enumerate() {
            let (a, z) = (-r + f.width * b as f32 / BINS as f32, -r + f.width * (b + 1) as f32 / BINS as f32);
            let m = 64;
            let h = (z - a) as f64 / m as f64;
            let mut s = 0.0;
            for k in 0..=m {
                let w = if k == 0 || k == m { 1.0 } else if k % 2 == 1 { 4.0 } else { 2.0 };
                s += w * f.pdf(a + (k as f64 * h) as f32) as f64;
            }
            let p = s * h / 3.0;
            total += p;
            let e = p * n as f64;
            stat += (c as f64 - e).powi(2) / e;
        }
        // the pdf integrates to 1 (quadrature error of Simpson's rule on these smooth pieces is
        // far below 1e-4; the tent's kink sits on a bin edge)
        assert!((total - 1.0).abs() < 1e-4, "∫pdf = {total}");
        gamma_q((BINS - 1) as f64 / 2.0, stat / 2.0)
    }

    #[test]
    fn every_filter_samples_its_own_density() {
        for (i, kind) in [FilterKind::Gaussian, FilterKind::Box, FilterKind::Triangle].into_iter().enumerate() {
            for width in [kind.default_width(), 2.5] {
                let f = PixelFilter::new(kind, width).unwrap();
                let p = chi2_p(|u| f.sample(u), &f, 11 + i as u64);
                // 6 tests at a family-wise 1% level
                assert!(p > 0.01 / 6.0, "{kind:?} width {width}: p = {p}");
            }
        }
    }

    #[test]
    fn a_wrong_density_is_caught() {
        // a tent sampled as a box of its width: the same test must reject it outright
        let tent = PixelFilter::new(FilterKind::Triangle, 2.0).unwrap();
        let boxed = PixelFilter { kind: FilterKind::Box, width: 2.0 };
        assert!(chi2_p(|u| boxed.sample(u), &tent, 5) < 1e-9);
        // and a Gaussian of the wrong σ
        let g = PixelFilter::new(FilterKind::Gaussian, 3.0).unwrap();
        let narrow = PixelFilter::new(FilterKind::Gaussian, 2.7).unwrap();
        assert!(chi2_p(|u| narrow.sample(u), &g, 5) < 1e-9);
    }

    #[test]
    fn the_default_is_the_pixel_box_and_the_gaussian_has_sigma_half_a_pixel() {
        assert_eq!(PixelFilter::default(), PixelFilter { kind: FilterKind::Box, width: 1.0 });
        let f = PixelFilter::new(FilterKind::Gaussian, 0.0).unwrap();
        assert_eq!(f.width, 3.0);
        // the median is the centre; the upper quartile of the ±3σ-truncated normal is
        // Φ⁻¹(0.75 − Φ(−3)/2) ≈ 0.674490 − 0.000675/φ(0.674490) = 0.672366 (to first order,
        // whose error here is ~1e-6) in units of σ = 0.5 px
        assert!(f.sample(0.5).abs() < 1e-6);
        let q = 0.5 * (0.674_490 - 0.5 * PHI_MINUS_3 / 0.317_777);
        assert!((f.sample(0.75) as f64 - q).abs() < 2e-5, "{} vs {q}", f.sample(0.75));
        // every box sample stays inside its pixel
        let b = PixelFilter::new(FilterKind::Box, 0.0).unwrap();
        assert_eq!(b.width, 1.0);
        assert!(b.sample(0.0) >= -0.5 && b.sample(0.999_999) < 0.5);
    }

    #[test]
    fn bad_widths_are_refused_and_tokens_round_trip() {
        assert!(PixelFilter::new(FilterKind::Box, -1.0).is_err());
        assert!(PixelFilter::new(FilterKind::Box, f32::NAN).is_err());
        assert!(PixelFilter::new(FilterKind::Gaussian, 100.0).is_err());
        for k in [FilterKind::Gaussian, FilterKind::Box, FilterKind::Triangle] {
            assert_eq!(FilterKind::from_token(k.token()), Some(k));
        }
        assert_eq!(FilterKind::from_token("mitchell"), None);
    }
}
