//! In-place radix-2 complex FFT (power-of-two sizes) and the 2-D inverse transform the ocean
//! is synthesised with. Twiddles come from `libm` and the butterflies run in a fixed order, so
//! the output is the same bits on every IEEE-754 machine whatever its SIMD width.

use std::ops::{Add, Mul, Sub};

use rayon::prelude::*;

/// A complex number in f64.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct C64 {
    pub re: f64,
    pub im: f64,
}

impl C64 {
    pub const ZERO: C64 = C64 { re: 0.0, im: 0.0 };
    #[inline]
    pub fn new(re: f64, im: f64) -> Self {
        C64 { re, im }
    }
    #[inline]
    pub fn scale(self, s: f64) -> C64 {
        C64::new(self.re * s, self.im * s)
    }
    #[inline]
    pub fn conj(self) -> C64 {
        C64::new(self.re, -self.im)
    }
    /// Multiplication by i.
    #[inline]
    pub fn times_i(self) -> C64 {
        C64::new(-self.im, self.re)
    }
    /// e^{iθ}.
    #[inline]
    pub fn cis(theta: f64) -> C64 {
        C64::new(libm::cos(theta), libm::sin(theta))
    }
    #[inline]
    pub fn norm_sqr(self) -> f64 {
        self.re * self.re + self.im * self.im
    }
}

impl Mul for C64 {
    type Output = C64;
    #[inline]
    fn mul(self, o: C64) -> C64 {
        C64::new(self.re * o.re - self.im * o.im, self.re * o.im + self.im * o.re)
    }
}

impl Add for C64 {
    type Output = C64;
    #[inline]
    fn add(self, o: C64) -> C64 {
        C64::new(self.re + o.re, self.im + o.im)
    }
}

impl Sub for C64 {
    type Output = C64;
    #[inline]
    fn sub(self, o: C64) -> C64 {
        C64::new(self.re - o.re, self.im - o.im)
    }
}

/// Precomputed twiddles e^{+2πi j/n}, j < n/2, for the inverse transform of size n.
pub struct Fft {
    n: usize,
    twiddles: Vec<C64>,
}

impl Fft {
    /// `n` must be a power of two (≥ 1).
    pub fn new(n: usize) -> Self {
        assert!(n.is_power_of_two());
        let twiddles = (0..n / 2).map(|j| C64::cis(2.0 * std::f64::consts::PI * j as f64 / n as f64)).collect();
        Fft { n, twiddles }
    }

    /// In place: x[p] ← Σ_m x[m] e^{+2πi m p / n} (no 1/n factor).
    pub fn inverse(&self, x: &mut [C64]) {
        let n = self.n;
        debug_assert_eq!(x.len(), n);
        if n < 2 {
            return;
        }
        let bits = n.trailing_zeros();
        for i in 0..n {
            let j = i.reverse_bits() >> (usize::BITS - bits);
            if j > i {
                x.swap(i, j);
            }
        }
        let mut len = 2;
        while len <= n {
            let half = len / 2;
            let stride = n / len;
            for start in (0..n).step_by(len) {
                for j in 0..half {
                    let w = self.twiddles[j * stride];
                    let a = x[start + j];
                    let b = x[start + j + half] * w;
                    x[start + j] = a + b;
                    x[start + j + half] = a - b;
                }
            }
            len *= 2;
        }
    }

    /// 2-D inverse transform of an n×n row-major array (`data[row * n + col]`).
    pub fn inverse_2d(&self, data: &mut [C64]) {
        let n = self.n;
        data.par_chunks_mut(n).for_each(|row| self.inverse(row));
        transpose(data, n);
        data.par_chunks_mut(n).for_each(|row| self.inverse(row));
        transpose(data, n);
    }
}

fn transpose(data: &mut [C64], n: usize) {
    for r in 0..n {
        for c in r + 1..n {
            data.swap(r * n + c, c * n + r);
        }
    }
}
