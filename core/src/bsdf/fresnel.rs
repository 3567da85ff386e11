//! Fresnel reflectance: exact unpolarised dielectric and conductor (complex IOR) terms, the
//! Schlick approximation, and hemispherical averages used by energy compensation.

use crate::spectrum::SampledSpectrum;

/// Reflectances (s, p) of a dielectric interface for light arriving with `cos_i` (cosine to the
/// normal on the incident side; negative means arriving from the other side, `eta` is then
/// inverted). `eta` = n_transmitted / n_incident for `cos_i > 0`. Total internal reflection gives
/// (1, 1).
pub fn fresnel_dielectric_polarized(cos_i: f32, eta: f32) -> (f32, f32) {
    let mut c = cos_i.clamp(-1.0, 1.0);
    let mut eta = eta;
    if c < 0.0 {
        eta = 1.0 / eta;
        c = -c;
    }
    let sin2_i = (1.0 - c * c).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return (1.0, 1.0);
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_s = (c - eta * cos_t) / (c + eta * cos_t);
    let r_p = (eta * c - cos_t) / (eta * c + cos_t);
    (r_s * r_s, r_p * r_p)
}

/// Unpolarised Fresnel reflectance of a dielectric interface (see
/// [`fresnel_dielectric_polarized`] for the conventions).
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let (s, p) = fresnel_dielectric_polarized(cos_i, eta);
    0.5 * (s + p)
}

#[derive(Clone, Copy, Debug)]
struct Complex {
    re: f32,
    im: f32,
}

impl Complex {
    fn new(re: f32, im: f32) -> Self {
        Complex { re, im }
    }
    fn add(self, o: Self) -> Self {
        Complex::new(self.re + o.re, self.im + o.im)
    }
    fn sub(self, o: Self) -> Self {
        Complex::new(self.re - o.re, self.im - o.im)
    }
    fn mul(self, o: Self) -> Self {
        Complex::new(self.re * o.re - self.im * o.im, self.re * o.im + self.im * o.re)
    }
    fn scale(self, s: f32) -> Self {
        Complex::new(self.re * s, self.im * s)
    }
    fn norm(self) -> f32 {
        self.re * self.re + self.im * self.im
    }
    fn div(self, o: Self) -> Self {
        let d = o.norm();
        Complex::new((self.re * o.re + self.im * o.im) / d, (self.im * o.re - self.re * o.im) / d)
    }
    /// Principal square root.
    fn sqrt(self) -> Self {
        let n = self.norm().sqrt();
        if n == 0.0 {
            return Complex::new(0.0, 0.0);
        }
        let t1 = (0.5 * (n + self.re.abs())).sqrt();
        let t2 = 0.5 * self.im / t1;
        if self.re >= 0.0 {
            Complex::new(t1, t2)
        } else {
            Complex::new(t2.abs(), t1.copysign(self.im))
        }
    }
}

/// Unpolarised Fresnel reflectance of a conductor with complex relative IOR `eta + i k`, for
/// light arriving with `cos_i` (clamped to [0, 1]: conductors are only lit from outside).
pub fn fresnel_complex(cos_i: f32, eta: f32, k: f32) -> f32 {
    let c = cos_i.clamp(0.0, 1.0);
    let n = Complex::new(eta, k);
    let sin2_i = 1.0 - c * c;
    let sin2_t = Complex::new(sin2_i, 0.0).div(n.mul(n));
    let cos_t = Complex::new(1.0, 0.0).sub(sin2_t).sqrt();
    let ci = Complex::new(c, 0.0);
    let r_s = ci.sub(n.mul(cos_t)).div(ci.add(n.mul(cos_t)));
    let r_p = n.scale(c).sub(cos_t).div(n.scale(c).add(cos_t));
    let f = 0.5 * (r_s.norm() + r_p.norm());
    if f.is_finite() {
        f.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// [`fresnel_complex`] at every wavelength of a path.
pub fn fresnel_complex_spectrum(cos_i: f32, eta: SampledSpectrum, k: SampledSpectrum) -> SampledSpectrum {
    SampledSpectrum::from_fn(|i| fresnel_complex(cos_i, eta[i], k[i]))
}

/// Schlick's approximation: F0 at normal incidence rising to F90 at grazing (1 for a plain
/// interface).
#[inline]
pub fn fresnel_schlick(cos_i: f32, f0: SampledSpectrum, f90: SampledSpectrum) -> SampledSpectrum {
    let m = (1.0 - cos_i.clamp(0.0, 1.0)).powi(5);
    f0 + (f90 - f0) * m
}

/// Reflectance at normal incidence between media of relative IOR `eta`: ((η−1)/(η+1))².
#[inline]
pub fn f0_from_ior(eta: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// Gauss–Legendre nodes and weights on [0, 1] (8 points).
const GL8: [(f32, f32); 8] = [
    (0.019_855_07, 0.050_614_27),
    (0.101_666_76, 0.111_190_52),
    (0.237_233_8, 0.156_853_32),
    (0.408_282_68, 0.181_341_89),
    (0.591_717_3, 0.181_341_89),
    (0.762_766_2, 0.156_853_32),
    (0.898_333_25, 0.111_190_52),
    (0.980_144_9, 0.050_614_27),
];

/// Hemispherical average 2∫F(μ)μ dμ of any Fresnel function (8-point Gauss–Legendre).
#[inline]
pub fn hemispherical_average(f: impl Fn(f32) -> f32) -> f32 {
    GL8.iter().map(|&(x, w)| 2.0 * w * x * f(x)).sum()
}

/// Hemispherical average of Schlick's term: F0 + (F90 − F0)/21 (exact).
#[inline]
pub fn schlick_average(f0: SampledSpectrum, f90: SampledSpectrum) -> SampledSpectrum {
    f0 + (f90 - f0) * (1.0 / 21.0)
}
