//! Adaptive sampling (`tide:adaptive:threshold`): pixels stop taking samples once their noise
//! is below the threshold, and the render ends early when every pixel has stopped.
//!
//! The noise of a pixel is the standard error of its mean luminance Y (exposed, as displayed)
//! estimated from the samples' Y and Y², divided by √(Y + 10⁻⁴): a relative error where the pixel
//! is bright (threshold 0.01 ≈ 1% noise on a pixel of value 1), eased in the dark the way a
//! display's transfer curve eases it. After each pass, a pixel keeps sampling while the noise of
//! any still-sampling pixel in its 3 × 3 neighbourhood exceeds the threshold (a noisy pixel keeps
//! its neighbours going, so a converged-looking pixel next to a firefly is not stopped early).
//! No pixel stops before it has `min_spp` samples (default 16): rare paths (caustics seen by
//! path tracing, fireflies) leave no variance until one is found, and a pixel that has seen none
//! of them looks converged. A stopped pixel never restarts, so every sampling pixel has taken
//! exactly the samples of every pass so far, and each keeps the sample indices it would have had
//! without adaptive sampling.
//!
//! Decisions are made between passes from the film's sums, which are merged in a fixed order:
//! the same input and seed give the same pixels stopped, whatever the thread count.

use crate::film::Film;

/// Samples every pixel takes before it may stop, when the settings leave it at 0.
pub const AUTO_MIN_SPP: u32 = 16;
/// Added to a pixel's luminance under the square root of the noise's denominator.
const DARK: f64 = 1e-4;

/// Noise of a pixel from `n` samples whose luminances sum to `s` and whose squares sum to `s2`,
/// after multiplying them by `scale` (the exposure): the standard error of the mean over
/// √(mean + 10⁻⁴). Infinite for fewer than 2 samples.
pub fn pixel_noise(s: f64, s2: f64, n: u32, scale: f64) -> f64 {
    if n < 2 {
        return f64::INFINITY;
    }
    let nf = n as f64;
    let mean = s / nf;
    let var = ((s2 - s * mean) / (nf - 1.0)).max(0.0);
    let se = (var / nf).sqrt() * scale.abs();
    se / (mean * scale.abs() + DARK).max(DARK).sqrt()
}

/// Which pixels still take samples.
#[derive(Clone, Debug)]
pub struct Adaptive {
    threshold: f64,
    min_spp: u32,
    width: u32,
    height: u32,
    active: Vec<bool>,
    n_active: usize,
}

impl Adaptive {
    /// Every pixel of the film's window sampling; None when `threshold` is not > 0.
    pub fn new(threshold: f32, min_spp: u32, film: &Film) -> Option<Adaptive> {
        if !(threshold > 0.0 && threshold.is_finite()) {
            return None;
        }
        let [x0, y0, x1, y1] = film.window;
        let mut active = vec![false; (film.width * film.height) as usize];
        for y in y0..y1 {
            for x in x0..x1 {
                active[(y * film.width + x) as usize] = true;
            }
        }
        let n_active = active.iter().filter(|&&a| a).count();
        let min_spp = if min_spp == 0 { AUTO_MIN_SPP } else { min_spp };
        Some(Adaptive { threshold: threshold as f64, min_spp: min_spp.max(2), width: film.width, height: film.height, active, n_active })
    }

    /// Whether pixel (x, y) takes the next pass's samples.
    #[inline]
    pub fn is_active(&self, x: u32, y: u32) -> bool {
        self.active[(y * self.width + x) as usize]
    }

    /// Pixels still sampling.
    pub fn active_count(&self) -> usize {
        self.n_active
    }

    /// Whether every pixel has stopped.
    pub fn converged(&self) -> bool {
        self.n_active == 0
    }

    /// After a pass: stops the pixels whose neighbourhood is below the threshold (nothing
    /// stops before `min_spp` samples).
    pub fn update(&mut self, film: &Film) {
        if film.spp < self.min_spp || self.n_active == 0 {
            return;
        }
        let (w, h) = (self.width as usize, self.height as usize);
        let noisy: Vec<bool> = (0..w * h)
            .map(|i| {
                if !self.active[i] {
                    return false;
                }
                let (s, s2, n) = film.luminance_sums(i);
                let e = pixel_noise(s, s2, n, film.scale as f64);
                // NaN counts as noisy
                !(e <= self.threshold)
            })
            .collect();
        let mut next = self.active.clone();
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                if !self.active[i] {
                    continue;
                }
                let mut keep = false;
                for yy in y.saturating_sub(1)..(y + 2).min(h) {
                    for xx in x.saturating_sub(1)..(x + 2).min(w) {
                        keep |= noisy[yy * w + xx];
                    }
                }
                next[i] = keep;
            }
        }
        self.active = next;
        self.n_active = self.active.iter().filter(|&&a| a).count();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::{FilmTile, SampleValue};
    use crate::testing::chi2::TestRng;

    fn sample(y: f32) -> SampleValue {
        SampleValue { color: [y, y, y], ..Default::default() }
    }

    #[test]
    fn the_noise_is_the_standard_error_of_the_mean() {
        // samples 0 and 2 (mean 1, sample variance 2): SE = √(2/2) = 1, over √(1 + 1e-4)
        let e = pixel_noise(2.0, 4.0, 2, 1.0);
        assert!((e - 1.0 / (1.0 + DARK).sqrt()).abs() < 1e-12, "{e}");
        // exposure scales the standard error and the mean alike: SE 4 over √(4 + 1e-4)
        let e4 = pixel_noise(2.0, 4.0, 2, 4.0);
        assert!((e4 - 4.0 / (4.0 + DARK).sqrt()).abs() < 1e-12, "{e4}");
        // a constant pixel has no noise; one sample is unknown
        assert_eq!(pixel_noise(3.0, 3.0, 3, 1.0), 0.0);
        assert!(pixel_noise(1.0, 1.0, 1, 1.0).is_infinite());
        // Monte Carlo: the estimate of σ/√n for uniform samples on [0, 2) (σ² = 1/3)
        let mut rng = TestRng::new(9);
        let n = 10_000u32;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let v = 2.0 * rng.next_f32() as f64;
            s += v;
            s2 += v * v;
        }
        let want = (1.0f64 / 3.0 / n as f64).sqrt() / (s / n as f64 + DARK).sqrt();
        // the sample variance of 10⁴ uniforms is within 2% of 1/3 (its relative SE is ~1.1%)
        assert!((pixel_noise(s, s2, n, 1.0) / want - 1.0).abs() < 0.02);
    }

    /// A film whose pixels get `spp` samples from `value(x, y, s)`.
    fn film_with(w: u32, h: u32, spp: u32, value: impl Fn(u32, u32, u32) -> f32) -> Film {
        let mut film = Film::new(w, h, [0, 0, w, h]);
        let mut t = FilmTile::new(0, 0, w, h, true);
        for y in 0..h {
            for x in 0..w {
                for s in 0..spp {
                    t.add(x, y, &sample(value(x, y, s)), s == 0);
                }
            }
        }
        film.merge(&t);
        film.spp = spp;
        film
    }

    #[test]
    fn quiet_pixels_stop_and_a_noisy_one_keeps_its_neighbours() {
        // 8×6 pixels of constant value except one alternating between 0 and 2 at (5, 2)
        let film = film_with(8, 6, 16, |x, y, s| if (x, y) == (5, 2) { 2.0 * (s % 2) as f32 } else { 0.5 });
        let mut a = Adaptive::new(0.01, 0, &film).unwrap();
        assert_eq!(a.active_count(), 48);
        a.update(&film);
        for y in 0..6 {
            for x in 0..8 {
                let near = (x as i32 - 5).abs() <= 1 && (y as i32 - 2).abs() <= 1;
                assert_eq!(a.is_active(x, y), near, "({x}, {y})");
            }
        }
        assert_eq!(a.active_count(), 9);
        assert!(!a.converged());
    }

    #[test]
    fn nothing_stops_before_the_minimum_and_stopped_pixels_stay_stopped() {
        let quiet = film_with(4, 4, 8, |_, _, _| 1.0);
        let mut a = Adaptive::new(0.01, 0, &quiet).unwrap();
        a.update(&quiet);
        assert_eq!(a.active_count(), 16, "stopped before {AUTO_MIN_SPP} samples");
        let quiet = film_with(4, 4, 16, |_, _, _| 1.0);
        a.update(&quiet);
        assert!(a.converged());
        // a later film that looks noisy does not restart them
        let noisy = film_with(4, 4, 32, |_, _, s| (s % 2) as f32);
        a.update(&noisy);
        assert!(a.converged());
    }

    #[test]
    fn the_window_bounds_the_sampling_pixels_and_off_is_none() {
        let film = Film::new(10, 10, [2, 3, 6, 5]);
        let a = Adaptive::new(0.05, 0, &film).unwrap();
        assert_eq!(a.active_count(), 8);
        assert!(a.is_active(2, 3) && !a.is_active(6, 3) && !a.is_active(0, 0));
        assert!(Adaptive::new(0.0, 0, &film).is_none());
        assert!(Adaptive::new(f32::NAN, 0, &film).is_none());
    }

    #[test]
    fn the_threshold_decides_against_the_measured_noise() {
        // every pixel: uniform samples on [0, 2) → noise ≈ √(1/3/n) / 1 = 0.144 at n = 16
        let mut rng_vals = Vec::new();
        let mut rng = TestRng::new(4);
        for _ in 0..(4 * 4 * 16) {
            rng_vals.push(2.0 * rng.next_f32());
        }
        let film = film_with(4, 4, 16, |x, y, s| rng_vals[((y * 4 + x) * 16 + s) as usize]);
        let mut loose = Adaptive::new(0.5, 0, &film).unwrap();
        loose.update(&film);
        assert!(loose.converged());
        let mut tight = Adaptive::new(0.05, 0, &film).unwrap();
        tight.update(&film);
        assert_eq!(tight.active_count(), 16);
    }
}
