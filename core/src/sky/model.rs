//! The Hošek–Wilkie spectral sky-dome model (2012) and its solar disc with limb darkening
//! (2013), evaluated at a path's wavelengths. See the module docs ([`crate::sky`]) for the
//! conventions, units and the behaviour outside the model's range.

use glam::{DVec3, Vec3};
use std::sync::OnceLock;

use super::data::{tables, Tables, BAND_FIRST_NM, BAND_STEP_NM, N_BANDS, N_CTRL, N_LIMB, N_PARAMS, N_SOLAR_SEGMENTS, N_TURBIDITY};
use super::SkyError;
use crate::scene::ColorSpace;
use crate::spectrum::cie::{cie, node_lambda, quad_weight, N_DENSE};
use crate::spectrum::{uplift, SampledSpectrum, SampledWavelengths, Spectrum, LAMBDA_MAX, LAMBDA_MIN, N_SPECTRUM};

/// Angular radius of the solar disc (rad): 0.51° / 2, as in the reference implementation.
pub const SUN_ANGULAR_RADIUS: f64 = 0.51 / 2.0 * std::f64::consts::PI / 180.0;

/// Wavelengths (nm) of the model's 11 bands: 320, 360, …, 720.
pub fn band_wavelength(band: usize) -> f64 {
    BAND_FIRST_NM + BAND_STEP_NM * band as f64
}

/// Solid angle of the solar disc (sr), 2π(1 − cos r).
pub fn sun_solid_angle() -> f64 {
    4.0 * std::f64::consts::PI * (0.5 * SUN_ANGULAR_RADIUS).sin().powi(2)
}

/// Ground albedo of the model: one value, an RGB colour (uplifted as a reflectance), or a
/// spectrum; evaluated at the 11 band wavelengths, each of which must lie in [0, 1].
#[derive(Clone, Debug, PartialEq)]
pub enum GroundAlbedo {
    Constant(f32),
    Rgb { rgb: [f32; 3], color_space: ColorSpace },
    Spectrum(Spectrum),
}

impl From<f32> for GroundAlbedo {
    fn from(v: f32) -> Self {
        GroundAlbedo::Constant(v)
    }
}

impl From<Spectrum> for GroundAlbedo {
    fn from(s: Spectrum) -> Self {
        GroundAlbedo::Spectrum(s)
    }
}

impl GroundAlbedo {
    /// The albedo at each band, or an error naming the offending value.
    pub fn per_band(&self) -> Result<[f64; N_BANDS], SkyError> {
        let bad = |v: f32| !(0.0..=1.0).contains(&v);
        let spectrum = match self {
            GroundAlbedo::Constant(v) => {
                if bad(*v) {
                    return Err(SkyError::GroundAlbedo(format!("{v} is outside [0, 1]")));
                }
                return Ok([*v as f64; N_BANDS]);
            }
            GroundAlbedo::Rgb { rgb, color_space } => {
                if let Some(v) = rgb.iter().find(|v| bad(**v)) {
                    return Err(SkyError::GroundAlbedo(format!("colour ({}, {}, {}) has a component {v} outside [0, 1]", rgb[0], rgb[1], rgb[2])));
                }
                uplift::albedo(*rgb, *color_space)
            }
            GroundAlbedo::Spectrum(s) => s.clone(),
        };
        let mut out = [0.0; N_BANDS];
        for (b, o) in out.iter_mut().enumerate() {
            let v = spectrum.eval(band_wavelength(b) as f32);
            if bad(v) {
                return Err(SkyError::GroundAlbedo(format!("{v} at {} nm is outside [0, 1]", band_wavelength(b))));
            }
            *o = v as f64;
        }
        Ok(out)
    }
}

/// Band interval and fraction for a wavelength: λ in [320, 720] interpolates between bands
/// i and i + 1; λ in (720, 830] holds the 720 nm value; anything else is outside the model.
#[inline]
pub fn band_position(lambda: f64) -> Option<(usize, f64)> {
    if !(lambda >= BAND_FIRST_NM && lambda <= LAMBDA_MAX as f64) {
        return None;
    }
    let x = ((lambda - BAND_FIRST_NM) / BAND_STEP_NM).min((N_BANDS - 1) as f64);
    let i = (x as usize).min(N_BANDS - 2);
    Some((i, x - i as f64))
}

/// Quintic Bernstein weights at t ∈ [0, 1].
fn bezier_weights(t: f64) -> [f64; N_CTRL] {
    const BINOM: [f64; N_CTRL] = [1.0, 5.0, 10.0, 10.0, 5.0, 1.0];
    std::array::from_fn(|k| BINOM[k] * (1.0 - t).powi((N_CTRL - 1 - k) as i32) * t.powi(k as i32))
}

/// The 9 parameters (stored order A..G, I, H) of a band and the radiance scale L_M, blended:
/// Bézier in elevation, linear in turbidity and albedo.
fn cook_band(t: &Tables, band: usize, elevation: f64, turbidity: f64, albedo: f64) -> ([f64; N_PARAMS], f64) {
    let w = bezier_weights((elevation / std::f64::consts::FRAC_PI_2).cbrt());
    let ti = (turbidity.floor() as usize).clamp(1, N_TURBIDITY);
    let rem = turbidity - ti as f64;
    let mut params = [0.0; N_PARAMS];
    let mut rad = 0.0;
    let mut add = |a: usize, turb_index: usize, weight: f64| {
        if weight == 0.0 {
            return;
        }
        for (k, wk) in w.iter().enumerate() {
            let p = t.params(band, a, turb_index, k);
            for (o, v) in params.iter_mut().zip(p) {
                *o += weight * wk * v;
            }
            rad += weight * wk * t.radiance(band, a, turb_index, k);
        }
    };
    add(0, ti - 1, (1.0 - albedo) * (1.0 - rem));
    add(1, ti - 1, albedo * (1.0 - rem));
    if ti < N_TURBIDITY {
        add(0, ti, (1.0 - albedo) * rem);
        add(1, ti, albedo * rem);
    }
    (params, rad)
}

/// The model's distribution F(θ, γ) for one parameter set (stored order A..G, I, H).
#[inline]
fn shape(c: &[f32; N_PARAMS], cos_theta: f32, gamma: f32, cos_gamma: f32) -> f32 {
    let exp_m = (c[4] * gamma).exp();
    let ray_m = cos_gamma * cos_gamma;
    let q = (1.0 + c[8] * c[8] - 2.0 * c[8] * cos_gamma).max(1e-12);
    let mie_m = (1.0 + ray_m) / (q * q.sqrt());
    let zenith = cos_theta.sqrt();
    (1.0 + c[0] * (c[1] / (cos_theta + 0.01)).exp()) * (c[2] + c[3] * exp_m + c[5] * ray_m + c[6] * mie_m + c[7] * zenith)
}

/// CIE XYZ weights of the bands: the XYZ of the model's spectrum (linear between bands, held at
/// its 720 nm value up to 830 nm) is Σ_b weight_b · L_b, normalised so that a constant spectrum
/// of value 1 has Y = 1 (Tide's radiance scale; see the module docs).
pub fn band_xyz_weights() -> &'static [[f64; 3]; N_BANDS] {
    static W: OnceLock<[[f64; 3]; N_BANDS]> = OnceLock::new();
    W.get_or_init(|| {
        let c = cie();
        let mut w = [[0.0; 3]; N_BANDS];
        for i in 0..N_DENSE {
            let Some((b, f)) = band_position(node_lambda(i)) else { continue };
            let m = c.cmf_node(i);
            for ch in 0..3 {
                let v = quad_weight(i) * m[ch] as f64 / c.y_integral;
                w[b][ch] += (1.0 - f) * v;
                w[b + 1][ch] += f * v;
            }
        }
        w
    })
}

/// Quadrature of the solar disc: per band interval, the disc integrals of the three products
/// that make up the irradiance at a fraction f between its bands (see [`HosekWilkieSky::sun_irradiance`]).
const DISC_MU_NODES: usize = 32;
const DISC_PSI_NODES: usize = 32;

/// The sky (and sun) for one solar elevation, turbidity and ground albedo.
///
/// Directions are world-space unit vectors; `zenith` is the sky's up axis and `to_sun` the
/// direction towards the centre of the sun.
#[derive(Clone, Debug, PartialEq)]
pub struct HosekWilkieSky {
    zenith: Vec3,
    to_sun: Vec3,
    sun_elevation: f64,
    turbidity: f64,
    albedo: [f64; N_BANDS],
    /// Blended parameters per band, stored order A..G, I, H.
    config: [[f32; N_PARAMS]; N_BANDS],
    /// Radiance scale L_M per band (W m⁻² sr⁻¹ nm⁻¹).
    scale: [f32; N_BANDS],
    /// Solar turbidity interpolation: lower table index and weight of the upper one.
    solar_turb: (usize, f64),
    /// Per band interval i: disc integrals of (d_i l_i, d_i l_{i+1} + d_{i+1} l_i, d_{i+1} l_{i+1}).
    disc_terms: [[f64; 3]; N_BANDS - 1],
}

impl HosekWilkieSky {
    /// The sky in Tide's default frame: zenith +Y (USD's up axis, as for dome lights) and the
    /// sun in the +Y/+Z half-plane, `sun_elevation` radians above the horizon.
    ///
    /// `sun_elevation` must lie in [0, π/2] (below the horizon the model has no data: that is
    /// [`SkyError::SunBelowHorizon`]); `turbidity` in [1, 10]; albedo values in [0, 1].
    pub fn new(sun_elevation: f32, turbidity: f32, ground_albedo: impl Into<GroundAlbedo>) -> Result<Self, SkyError> {
        if !sun_elevation.is_finite() {
            return Err(SkyError::SunElevation(format!("{sun_elevation} is not finite")));
        }
        let (s, c) = sun_elevation.sin_cos();
        Self::with_frame(Vec3::Y, Vec3::new(0.0, s, c), turbidity, ground_albedo)
    }

    /// The sky for an arbitrary up axis and sun direction (neither needs to be normalised; the
    /// solar elevation is the angle between `to_sun` and the horizon plane of `zenith`).
    pub fn with_frame(zenith: Vec3, to_sun: Vec3, turbidity: f32, ground_albedo: impl Into<GroundAlbedo>) -> Result<Self, SkyError> {
        let zenith = unit("zenith", zenith)?;
        let to_sun = unit("sun direction", to_sun)?;
        let sin_elev = (zenith.as_dvec3().dot(to_sun.as_dvec3())).clamp(-1.0, 1.0);
        let sun_elevation = sin_elev.asin();
        if sun_elevation < 0.0 {
            return Err(SkyError::SunBelowHorizon { elevation_deg: sun_elevation.to_degrees() as f32 });
        }
        if !(turbidity.is_finite() && (1.0..=10.0).contains(&turbidity)) {
            return Err(SkyError::Turbidity(turbidity));
        }
        let albedo = ground_albedo.into().per_band()?;
        let t = tables().map_err(SkyError::Data)?;
        let turbidity = turbidity as f64;
        let mut config = [[0.0f32; N_PARAMS]; N_BANDS];
        let mut scale = [0.0f32; N_BANDS];
        for b in 0..N_BANDS {
            let (p, r) = cook_band(t, b, sun_elevation, turbidity, albedo[b]);
            config[b] = p.map(|v| v as f32);
            scale[b] = r as f32;
        }
        let tl = turbidity.floor() as usize - 1;
        let solar_turb = if tl >= N_TURBIDITY - 1 { (N_TURBIDITY - 2, 1.0) } else { (tl, turbidity - (tl + 1) as f64) };
        let mut sky = HosekWilkieSky {
            zenith,
            to_sun,
            sun_elevation,
            turbidity,
            albedo,
            config,
            scale,
            solar_turb,
            disc_terms: [[0.0; 3]; N_BANDS - 1],
        };
        sky.disc_terms = sky.integrate_disc(t);
        Ok(sky)
    }

    pub fn zenith(&self) -> Vec3 {
        self.zenith
    }
    pub fn to_sun(&self) -> Vec3 {
        self.to_sun
    }
    /// Solar elevation (rad).
    pub fn sun_elevation(&self) -> f64 {
        self.sun_elevation
    }
    pub fn turbidity(&self) -> f64 {
        self.turbidity
    }
    /// Ground albedo at the 11 bands.
    pub fn albedo(&self) -> &[f64; N_BANDS] {
        &self.albedo
    }

    /// Sky radiance of band `b` (W m⁻² sr⁻¹ nm⁻¹) for view zenith cosine and sun angle γ.
    #[inline]
    pub fn band_radiance(&self, b: usize, cos_theta: f32, gamma: f32, cos_gamma: f32) -> f32 {
        (shape(&self.config[b], cos_theta, gamma, cos_gamma) * self.scale[b]).max(0.0)
    }

    /// All 11 band radiances towards unit `dir` (zero below the horizon).
    pub fn band_radiances(&self, dir: Vec3) -> [f32; N_BANDS] {
        match self.angles(dir) {
            None => [0.0; N_BANDS],
            Some((ct, g, cg)) => std::array::from_fn(|b| self.band_radiance(b, ct, g, cg)),
        }
    }

    /// (cos θ, γ, cos γ) of unit `dir`, or None below the horizon.
    #[inline]
    fn angles(&self, dir: Vec3) -> Option<(f32, f32, f32)> {
        let cos_theta = dir.dot(self.zenith);
        if !(cos_theta >= 0.0) {
            return None;
        }
        let cos_gamma = dir.dot(self.to_sun).clamp(-1.0, 1.0);
        Some((cos_theta.min(1.0), cos_gamma.acos(), cos_gamma))
    }

    /// Sky radiance (W m⁻² sr⁻¹ nm⁻¹) towards unit `dir` at one wavelength (nm); the sun's
    /// disc is not included (see [`HosekWilkieSky::sun_radiance`]).
    pub fn radiance_at(&self, dir: Vec3, lambda: f32) -> f32 {
        let (Some((ct, g, cg)), Some((i, f))) = (self.angles(dir), band_position(lambda as f64)) else { return 0.0 };
        let f = f as f32;
        let lo = if f < 1.0 { self.band_radiance(i, ct, g, cg) } else { 0.0 };
        let hi = if f > 0.0 { self.band_radiance(i + 1, ct, g, cg) } else { 0.0 };
        (1.0 - f) * lo + f * hi
    }

    /// Sky radiance (W m⁻² sr⁻¹ nm⁻¹) towards unit `dir` at the path's wavelengths: zero below
    /// the horizon, the sun's disc not included. No allocation; each band is evaluated once.
    pub fn radiance(&self, dir: Vec3, lambda: &SampledWavelengths) -> SampledSpectrum {
        let Some((ct, g, cg)) = self.angles(dir) else { return SampledSpectrum::ZERO };
        let mut cache = [f32::NAN; N_BANDS];
        let mut band = |b: usize| {
            if cache[b].is_nan() {
                cache[b] = self.band_radiance(b, ct, g, cg);
            }
            cache[b]
        };
        let mut out = SampledSpectrum::ZERO;
        for k in 0..N_SPECTRUM {
            if let Some((i, f)) = band_position(lambda.lambda[k] as f64) {
                let f = f as f32;
                let lo = if f < 1.0 { band(i) } else { 0.0 };
                let hi = if f > 0.0 { band(i + 1) } else { 0.0 };
                out[k] = (1.0 - f) * lo + f * hi;
            }
        }
        out
    }

    /// ∫ of each band's sky radiance over the upper hemisphere (W m⁻² nm⁻¹ per band; the sun's
    /// disc excluded), by the midpoint rule on a grid uniform in cos θ and in azimuth from the
    /// sun: 512 × 1024 cells of 2·10⁻³ in cos θ and 0.35°, fine enough for the circumsolar
    /// peak (the narrowest term, e^{Eγ}, decays over ≳ 2° for the published parameters).
    pub fn band_hemisphere_integrals(&self) -> [f64; N_BANDS] {
        const NT: usize = 512;
        const NP: usize = 1024;
        let z = self.zenith;
        let h = self.to_sun - z * z.dot(self.to_sun);
        let x = if h.length_squared() > 1e-12 { h.normalize() } else { z.any_orthonormal_vector() };
        let y = z.cross(x);
        let mut acc = [0.0f64; N_BANDS];
        let trig: Vec<(f32, f32)> = (0..NP).map(|ip| (2.0 * std::f32::consts::PI * (ip as f32 + 0.5) / NP as f32).sin_cos()).collect();
        for it in 0..NT {
            let mu = (it as f32 + 0.5) / NT as f32;
            let st = (1.0 - mu * mu).max(0.0).sqrt();
            let mut row = [0.0f64; N_BANDS];
            for &(sp, cp) in &trig {
                let d = z * mu + x * (st * cp) + y * (st * sp);
                let Some((ct, g, cg)) = self.angles(d) else { continue };
                for (b, r) in row.iter_mut().enumerate() {
                    *r += self.band_radiance(b, ct, g, cg) as f64;
                }
            }
            for (a, r) in acc.iter_mut().zip(row) {
                *a += r;
            }
        }
        let cell = 2.0 * std::f64::consts::PI / (NT * NP) as f64;
        acc.map(|a| a * cell)
    }

    /// Sky luminance towards `dir` on Tide's scale (Y of the model's spectrum with a constant
    /// spectrum 1 having Y = 1), exact for the band-interpolated spectrum.
    pub fn luminance(&self, dir: Vec3) -> f32 {
        let w = band_xyz_weights();
        let l = self.band_radiances(dir);
        (0..N_BANDS).map(|b| w[b][1] * l[b] as f64).sum::<f64>() as f32
    }

    /// Direct solar radiance (no limb darkening) of band `b` at elevation `elev` (rad) for table
    /// turbidity index `turb`: the piecewise cubic of the 2013 model.
    fn solar_poly(t: &Tables, b: usize, turb: usize, elev: f64) -> f64 {
        let seg = (((2.0 * elev / std::f64::consts::PI).cbrt() * N_SOLAR_SEGMENTS as f64) as usize).min(N_SOLAR_SEGMENTS - 1);
        let start = (seg as f64 / N_SOLAR_SEGMENTS as f64).powi(3) * std::f64::consts::FRAC_PI_2;
        let x = elev - start;
        let c = t.solar_segment(b, turb, seg);
        ((c[0] * x + c[1]) * x + c[2]) * x + c[3]
    }

    /// Direct solar radiance of band `b` at elevation `elev`, blended in turbidity.
    fn solar_band(&self, t: &Tables, b: usize, elev: f64) -> f64 {
        if !(elev >= 0.0) {
            return 0.0;
        }
        let elev = elev.min(std::f64::consts::FRAC_PI_2);
        let (tl, tf) = self.solar_turb;
        let lo = Self::solar_poly(t, b, tl, elev);
        if tf == 0.0 {
            return lo;
        }
        (1.0 - tf) * lo + tf * Self::solar_poly(t, b, tl + 1, elev)
    }

    /// Limb-darkening factor of band `b` at μ (1 at the disc's centre, 0 at its limb).
    fn limb_band(t: &Tables, b: usize, mu: f64) -> f64 {
        let c = &t.limb[b];
        let mut acc = 0.0;
        for k in (0..N_LIMB).rev() {
            acc = acc * mu + c[k];
        }
        acc
    }

    /// Solar-disc radiance (W m⁻² sr⁻¹ nm⁻¹) at wavelength `lambda` (nm) for a point of the
    /// disc at elevation `elev` (rad) and limb parameter `mu` ∈ [0, 1]. Direct radiance and
    /// limb darkening are each interpolated linearly between bands, then multiplied.
    pub fn sun_radiance_at(&self, elev: f64, mu: f64, lambda: f64) -> f64 {
        let (Ok(t), Some((i, f))) = (tables(), band_position(lambda)) else { return 0.0 };
        if !(elev >= 0.0) {
            return 0.0;
        }
        let mu = mu.clamp(0.0, 1.0);
        let direct = (1.0 - f) * self.solar_band(t, i, elev) + f * self.solar_band(t, i + 1, elev);
        let ld = (1.0 - f) * Self::limb_band(t, i, mu) + f * Self::limb_band(t, i + 1, mu);
        direct * ld
    }

    /// Limb parameter μ and elevation of unit `dir` if it lies within the solar disc.
    fn disc_point(&self, dir: Vec3) -> Option<(f64, f64)> {
        let d = dir.as_dvec3().normalize();
        let s = self.to_sun.as_dvec3();
        let sin2_r = SUN_ANGULAR_RADIUS.sin().powi(2);
        let sin2_g = d.cross(s).length_squared();
        if !(d.dot(s) > 0.0 && sin2_g <= sin2_r) {
            return None;
        }
        let mu = (1.0 - sin2_g / sin2_r).max(0.0).sqrt();
        let elev = d.dot(self.zenith.as_dvec3()).clamp(-1.0, 1.0).asin();
        Some((mu, elev))
    }

    /// Radiance of the solar disc towards unit `dir` (zero outside the disc of angular radius
    /// [`SUN_ANGULAR_RADIUS`] and for the part of it below the horizon), with limb darkening.
    /// The elevation used is that of `dir` itself, so a low sun reddens towards its lower rim.
    /// The sky's own radiance ([`HosekWilkieSky::radiance`]) adds to it.
    pub fn sun_radiance(&self, dir: Vec3, lambda: &SampledWavelengths) -> SampledSpectrum {
        let Some((mu, elev)) = self.disc_point(dir) else { return SampledSpectrum::ZERO };
        SampledSpectrum::from_fn(|k| self.sun_radiance_at(elev, mu, lambda.lambda[k] as f64) as f32)
    }

    fn integrate_disc(&self, t: &Tables) -> [[f64; 3]; N_BANDS - 1] {
        let a = SUN_ANGULAR_RADIUS.sin();
        let (sin_e, cos_e) = self.sun_elevation.sin_cos();
        let mut terms = [[0.0; 3]; N_BANDS - 1];
        let mut direct = [0.0; N_BANDS];
        let mut ld = [0.0; N_BANDS];
        // ∫disc g dω = a² ∫₀¹ ∫₀^{2π} g μ / cos ρ dψ dμ with sin ρ = a √(1 − μ²): the limb
        // darkening is a polynomial in μ, so midpoint nodes in μ and ψ converge fast.
        let dmu = 1.0 / DISC_MU_NODES as f64;
        let dpsi = 2.0 * std::f64::consts::PI / DISC_PSI_NODES as f64;
        for im in 0..DISC_MU_NODES {
            let mu = (im as f64 + 0.5) * dmu;
            let sin_rho = a * (1.0 - mu * mu).sqrt();
            let cos_rho = (1.0 - sin_rho * sin_rho).sqrt();
            for (b, l) in ld.iter_mut().enumerate() {
                *l = Self::limb_band(t, b, mu);
            }
            for ip in 0..DISC_PSI_NODES {
                let psi = (ip as f64 + 0.5) * dpsi;
                let elev = (cos_rho * sin_e + sin_rho * psi.cos() * cos_e).clamp(-1.0, 1.0).asin();
                let w = a * a * mu / cos_rho * dmu * dpsi;
                for (b, d) in direct.iter_mut().enumerate() {
                    *d = self.solar_band(t, b, elev);
                }
                for (i, term) in terms.iter_mut().enumerate() {
                    term[0] += w * direct[i] * ld[i];
                    term[1] += w * (direct[i] * ld[i + 1] + direct[i + 1] * ld[i]);
                    term[2] += w * direct[i + 1] * ld[i + 1];
                }
            }
        }
        terms
    }

    /// Irradiance (W m⁻² nm⁻¹) the whole solar disc delivers to a surface facing the sun, at
    /// wavelength `lambda` (nm): ∫disc [`HosekWilkieSky::sun_radiance`] dω.
    pub fn sun_irradiance(&self, lambda: f32) -> f32 {
        let Some((i, f)) = band_position(lambda as f64) else { return 0.0 };
        let t = &self.disc_terms[i];
        ((1.0 - f) * (1.0 - f) * t[0] + f * (1.0 - f) * t[1] + f * f * t[2]) as f32
    }

    /// The solar disc as a uniform emitter: its mean radiance (irradiance / solid angle)
    /// tabulated every 5 nm over Tide's range, for a distant light with the disc's angular size
    /// ([`SUN_ANGULAR_RADIUS`]). Limb darkening and the elevation gradient across the disc are
    /// averaged out; the irradiance is exact.
    pub fn sun_spectrum(&self) -> Result<Spectrum, SkyError> {
        let omega = sun_solid_angle() as f32;
        self.sun_table(|l| self.sun_irradiance(l) / omega)
    }

    /// Spectral irradiance of the sun on a surface facing it (W m⁻² nm⁻¹), tabulated every
    /// 5 nm: the emission of a delta distant light standing for the sun.
    pub fn sun_irradiance_spectrum(&self) -> Result<Spectrum, SkyError> {
        self.sun_table(|l| self.sun_irradiance(l))
    }

    fn sun_table(&self, f: impl Fn(f32) -> f32) -> Result<Spectrum, SkyError> {
        let n = ((LAMBDA_MAX - LAMBDA_MIN) / 5.0) as usize + 1;
        let lambda: Vec<f32> = (0..n).map(|i| LAMBDA_MIN + 5.0 * i as f32).collect();
        let value: Vec<f32> = lambda.iter().map(|&l| f(l)).collect();
        Spectrum::tabulated(&lambda, &value).map_err(|e| SkyError::Data(format!("sun spectrum: {e}")))
    }
}

fn unit(what: &str, v: Vec3) -> Result<Vec3, SkyError> {
    let d: DVec3 = v.as_dvec3();
    let len = d.length();
    if !(len.is_finite() && len > 1e-12) {
        return Err(SkyError::Direction(format!("{what} ({}, {}, {}) is zero or not finite", v.x, v.y, v.z)));
    }
    Ok((d / len).as_vec3())
}
