//! The individual scattering lobes behind [`super::Bsdf`]: Lambertian diffuse, GGX microfacet
//! reflection (conductor or Schlick Fresnel) and the smooth/rough dielectric, each rough lobe
//! with its multiple-scattering compensation term (Kulla & Conty 2017).
//!
//! Reflection-only lobes are written for ωo in the upper hemisphere (the caller mirrors both
//! directions otherwise); the dielectric handles both sides itself.

use super::albedo::tables;
use super::fresnel::{
    fresnel_complex_spectrum, fresnel_dielectric, fresnel_schlick, hemispherical_average, schlick_average,
};
use super::microfacet::{reflect, refract, TrowbridgeReitz};
use super::thin_film::SpectralThinFilm;
use super::{flags, BsdfSample, TransportMode};
use crate::math::{sample_cosine_hemisphere, INV_PI};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3};

/// Density μi/π of cosine-weighted directions over the upper hemisphere (0 for either
/// direction below it).
#[inline]
pub(crate) fn cosine_pdf(wo: Vec3, wi: Vec3) -> f32 {
    if wo.z > 0.0 && wi.z > 0.0 {
        wi.z * INV_PI
    } else {
        0.0
    }
}

/// Lambertian reflection.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Lambert {
    pub reflectance: SampledSpectrum,
}

impl Lambert {
    #[inline]
    pub fn f(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        if wo.z > 0.0 && wi.z > 0.0 {
            self.reflectance * INV_PI
        } else {
            SampledSpectrum::ZERO
        }
    }
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        cosine_pdf(wo, wi)
    }
    pub fn sample_f(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        let wi = sample_cosine_hemisphere(u);
        let pdf = self.pdf(wo, wi);
        if pdf == 0.0 {
            return None;
        }
        Some(BsdfSample { f: self.f(wo, wi), wi, pdf, flags: flags::DIFFUSE_REFLECTION, eta: 1.0 })
    }
}

/// Fresnel term of a microfacet reflection lobe.
#[derive(Clone, Copy, Debug)]
pub(crate) enum ReflFresnel {
    /// Conductor with complex relative IOR η + ik.
    Complex { eta: SampledSpectrum, k: SampledSpectrum },
    /// Schlick: F0 at normal incidence, F90 at grazing (1 for a plain dielectric or metal;
    /// less for a tinted or weighted specular).
    Schlick { f0: SampledSpectrum, f90: SampledSpectrum },
    /// A thin film over the layer ([`FilmFresnel`]).
    ThinFilm(FilmFresnel),
}

/// A thin film's interference reflectance over a layer whose Schlick term is (F0, F90):
/// weight × F90 × the film's reflectance + (1 − weight) × Schlick's, F90 carrying the
/// layer's weight and tint.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FilmFresnel {
    film: SpectralThinFilm,
    weight: f32,
    f0: SampledSpectrum,
    f90: SampledSpectrum,
    /// Hemispherical average, computed once.
    avg: SampledSpectrum,
}

impl FilmFresnel {
    /// `film_avg` is `film.average()` (shared by the layers built over one film).
    pub fn new(film: SpectralThinFilm, film_avg: SampledSpectrum, weight: f32, f0: SampledSpectrum, f90: SampledSpectrum) -> Self {
        let avg = schlick_average(f0, f90) * (1.0 - weight) + film_avg * f90 * weight;
        FilmFresnel { film, weight, f0, f90, avg }
    }

    #[inline]
    fn eval(&self, cos: f32) -> SampledSpectrum {
        fresnel_schlick(cos, self.f0, self.f90) * (1.0 - self.weight) + self.film.eval(cos) * self.f90 * self.weight
    }
}

impl ReflFresnel {
    #[inline]
    pub fn eval(&self, cos: f32) -> SampledSpectrum {
        match *self {
            ReflFresnel::Complex { eta, k } => fresnel_complex_spectrum(cos, eta, k),
            ReflFresnel::Schlick { f0, f90 } => fresnel_schlick(cos, f0, f90),
            ReflFresnel::ThinFilm(ref t) => t.eval(cos),
        }
    }
    /// Hemispherical average 2∫F(μ)μ dμ.
    pub fn average(&self) -> SampledSpectrum {
        match *self {
            ReflFresnel::Complex { eta, k } => SampledSpectrum::from_fn(|i| {
                hemispherical_average(|mu| super::fresnel::fresnel_complex(mu, eta[i], k[i]))
            }),
            ReflFresnel::Schlick { f0, f90 } => schlick_average(f0, f90),
            ReflFresnel::ThinFilm(ref t) => t.avg,
        }
    }
}

/// The cosine c between ωo and the microfacets at which Schlick's weight (1 − c)⁵ equals its
/// average over a lobe whose F = 1 albedo is `e1` and Schlick-weighted albedo `s`.
#[inline]
fn mean_cosine(e1: f32, s: f32) -> f32 {
    if e1 > 0.0 {
        1.0 - (s / e1).clamp(0.0, 1.0).powf(0.2)
    } else {
        1.0
    }
}

/// GGX microfacet reflection with multiple-scattering compensation.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MicrofacetReflection {
    pub distrib: TrowbridgeReitz,
    pub fresnel: ReflFresnel,
    /// Perceptual roughness used to index the albedo tables.
    r: f32,
    /// F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)): energy fraction of the multiple-scattering
    /// lobe relative to its F = 1 value (zero when no compensation applies).
    f_ms: SampledSpectrum,
    /// 1 − E_avg of the F = 1 lobe (0 when no compensation applies).
    one_minus_e_avg: f32,
    /// Hemispherical averages of the albedo tables' (E1, Schlick) pair over every direction:
    /// the tables' own averages for an isotropic lobe, a quadrature over μ and the azimuth of
    /// [`Self::r_along`] for an anisotropic one.
    avg: (f32, f32),
}

impl MicrofacetReflection {
    pub fn new(distrib: TrowbridgeReitz, fresnel: ReflFresnel) -> Self {
        let r = distrib.alpha_iso().sqrt();
        let mut lobe = MicrofacetReflection { distrib, fresnel, r, f_ms: SampledSpectrum::ZERO, one_minus_e_avg: 0.0, avg: (0.0, 0.0) };
        lobe.avg = if distrib.alpha_x == distrib.alpha_y {
            tables().conductor_avg(r)
        } else {
            // the lobe is symmetric under x → −x and y → −y: a quarter turn of azimuths
            const N_PHI: usize = 8;
            let table = |k: usize| {
                move |mu: f32| {
                    let phi = (k as f32 + 0.5) * std::f32::consts::FRAC_PI_2 / N_PHI as f32;
                    let sin = (1.0 - mu * mu).max(0.0).sqrt();
                    let w = Vec3::new(sin * phi.cos(), sin * phi.sin(), mu);
                    tables().conductor(mu, lobe.r_along(w))
                }
            };
            let e: f32 = (0..N_PHI).map(|k| hemispherical_average(|mu| table(k)(mu).0)).sum();
            let s: f32 = (0..N_PHI).map(|k| hemispherical_average(|mu| table(k)(mu).1)).sum();
            (e / N_PHI as f32, s / N_PHI as f32)
        };
        if !distrib.is_smooth() {
            let e_avg = lobe.avg.0;
            if 1.0 - e_avg > 1e-6 {
                let favg = fresnel.average();
                lobe.f_ms = SampledSpectrum::from_fn(|i| {
                    favg[i] * favg[i] * e_avg / (1.0 - favg[i] * (1.0 - e_avg))
                });
                lobe.one_minus_e_avg = 1.0 - e_avg;
            }
        }
        lobe
    }

    #[inline]
    pub fn is_smooth(&self) -> bool {
        self.distrib.is_smooth()
    }

    #[inline]
    pub fn lobe_flags(&self) -> u8 {
        if self.is_smooth() {
            flags::SPECULAR_REFLECTION
        } else {
            flags::GLOSSY_REFLECTION
        }
    }

    /// Perceptual roughness of the lobe as seen along ω: an anisotropic lobe's GGX α projected
    /// on ω's azimuth (the α its Smith masking term sees).
    #[inline]
    fn r_along(&self, w: Vec3) -> f32 {
        let (ax, ay) = (self.distrib.alpha_x, self.distrib.alpha_y);
        if ax == ay {
            return self.r;
        }
        let s2 = w.x * w.x + w.y * w.y;
        // along the normal, α² averaged over the azimuth
        let (cx, cy) = if s2 < 1e-12 { (0.5, 0.5) } else { (w.x * w.x / s2, w.y * w.y / s2) };
        (ax * ax * cx + ay * ay * cy).sqrt().sqrt()
    }

    /// Single-scattering albedo of the F = 1 lobe along ω.
    #[inline]
    fn e1(&self, w: Vec3) -> f32 {
        tables().conductor(w.z, self.r_along(w)).0
    }

    /// Directional albedo at μo (exact up to table accuracy for Schlick, F(μo)·E1 + compensation
    /// for a conductor), of the lobe's mean roughness.
    pub fn albedo(&self, mu: f32) -> SampledSpectrum {
        self.albedo_with_r(mu, self.r)
    }

    /// [`Self::albedo`] along ω: for an anisotropic lobe, at the roughness it has along ω.
    pub fn albedo_along(&self, w: Vec3) -> SampledSpectrum {
        self.albedo_with_r(w.z, self.r_along(w))
    }

    fn albedo_with_r(&self, mu: f32, r: f32) -> SampledSpectrum {
        if self.is_smooth() {
            return self.fresnel.eval(mu);
        }
        let (e1, s) = tables().conductor(mu, r);
        let ss = match self.fresnel {
            ReflFresnel::Schlick { f0, f90 } => f0 * e1 + (f90 - f0) * s,
            // the film at the microfacets' mean cosine, the one at which Schlick's weight
            // (1 − c)⁵ is the lobe's average of it: F at the viewing angle alone overstates
            // what a rough lobe reflects at grazing angles
            ReflFresnel::ThinFilm(ref t) => t.eval(mean_cosine(e1, s)) * e1,
            ReflFresnel::Complex { .. } => self.fresnel.eval(mu) * e1,
        };
        ss + self.f_ms * (1.0 - e1)
    }

    /// Hemispherical average of [`Self::albedo`].
    pub fn albedo_avg(&self) -> SampledSpectrum {
        if self.is_smooth() {
            return self.fresnel.average();
        }
        let (e1, s) = self.avg;
        let ss = match self.fresnel {
            ReflFresnel::Schlick { f0, f90 } => f0 * e1 + (f90 - f0) * s,
            ReflFresnel::ThinFilm(_) | ReflFresnel::Complex { .. } => self.fresnel.average() * e1,
        };
        ss + self.f_ms * (1.0 - e1)
    }

    /// Probability of sampling the multiple-scattering lobe for ωo.
    #[inline]
    fn p_ms(&self, wo: Vec3) -> f32 {
        if self.one_minus_e_avg == 0.0 {
            return 0.0;
        }
        let e = self.e1(wo);
        let ms = (1.0 - e) * self.f_ms.average();
        let ss = e * self.fresnel.eval(wo.z).average();
        if ms + ss > 0.0 {
            ms / (ms + ss)
        } else {
            0.0
        }
    }

    pub fn f(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        if self.is_smooth() || wo.z <= 0.0 || wi.z <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        let wm = wo + wi;
        if wm.length_squared() == 0.0 {
            return SampledSpectrum::ZERO;
        }
        let wm = wm.normalize();
        let ss = self.fresnel.eval(wo.dot(wm))
            * (self.distrib.d(wm) * self.distrib.g2(wo, wi) / (4.0 * wo.z * wi.z));
        if self.one_minus_e_avg == 0.0 {
            return ss;
        }
        let ms = (1.0 - self.e1(wo)) * (1.0 - self.e1(wi)) * INV_PI / self.one_minus_e_avg;
        ss + self.f_ms * ms
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.is_smooth() || wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let wm = wo + wi;
        if wm.length_squared() == 0.0 {
            return 0.0;
        }
        let wm = wm.normalize();
        let p_ms = self.p_ms(wo);
        let p_ss = self.distrib.pdf_visible(wo, wm) / (4.0 * wo.dot(wm).abs());
        (1.0 - p_ms) * p_ss + p_ms * wi.z * INV_PI
    }

    pub fn sample_f(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        if self.is_smooth() {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            let f = self.fresnel.eval(wo.z) / wo.z;
            return Some(BsdfSample { f, wi, pdf: 1.0, flags: flags::SPECULAR_REFLECTION, eta: 1.0 });
        }
        let wi = if uc < self.p_ms(wo) {
            sample_cosine_hemisphere(u)
        } else {
            reflect(wo, self.distrib.sample_wm(wo, u))
        };
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample { f: self.f(wo, wi), wi, pdf, flags: flags::GLOSSY_REFLECTION, eta: 1.0 })
    }
}

/// Multiple-scattering compensation of a rough dielectric: a diffuse-like lobe on each side
/// carrying the energy the single-scattering lobe loses, split into reflection and transmission
/// so that the transmission part obeys the generalised reciprocity of refraction.
#[derive(Clone, Copy, Debug)]
struct DielectricMs {
    /// Fractions of the missing energy that are transmitted, from above and from below.
    t_above: f32,
    t_below: f32,
    /// 1 − E_avg on each side.
    loss_above: f32,
    loss_below: f32,
}

/// Smooth or rough dielectric interface; `eta` = n_below / n_above.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Dielectric {
    pub eta: f32,
    pub distrib: TrowbridgeReitz,
    r: f32,
    ms: Option<DielectricMs>,
    /// What each transmission multiplies the light by (a surface tint; 1: clear). Reflection
    /// and the sampling densities are untouched.
    pub tint: SampledSpectrum,
}

impl Dielectric {
    pub fn new(eta: f32, distrib: TrowbridgeReitz) -> Self {
        let r = distrib.alpha_iso().sqrt();
        let mut d = Dielectric { eta, distrib, r, ms: None, tint: SampledSpectrum::ONE };
        if !d.is_smooth() {
            let t = tables();
            let loss_above = 1.0 - t.dielectric_avg(r, eta);
            let loss_below = 1.0 - t.dielectric_avg(r, 1.0 / eta);
            if loss_above > 1e-5 && loss_below > 1e-5 {
                // Reciprocity of the transmitted part (with the symmetric kernel f·n_o²):
                // t_above / loss_below = t_below · η² / loss_above.
                let ratio = loss_above / (eta * eta * loss_below); // t_below = t_above · ratio
                let (mut t_above, mut t_below);
                if eta >= 1.0 {
                    t_above = 1.0 - hemispherical_average(|mu| fresnel_dielectric(mu, eta));
                    t_below = t_above * ratio;
                } else {
                    t_below = 1.0 - hemispherical_average(|mu| fresnel_dielectric(mu, 1.0 / eta));
                    t_above = t_below / ratio;
                }
                if t_below > 1.0 {
                    t_below = 1.0;
                    t_above = 1.0 / ratio;
                }
                if t_above > 1.0 {
                    t_above = 1.0;
                    t_below = ratio;
                }
                d.ms = Some(DielectricMs { t_above, t_below, loss_above, loss_below });
            }
        }
        d
    }

    #[inline]
    pub fn is_smooth(&self) -> bool {
        self.distrib.is_smooth() || (self.eta - 1.0).abs() < 1e-4
    }

    #[inline]
    pub fn lobe_flags(&self) -> u8 {
        if self.is_smooth() {
            flags::REFLECTION | flags::TRANSMISSION | flags::SPECULAR
        } else {
            flags::REFLECTION | flags::TRANSMISSION | flags::GLOSSY
        }
    }

    /// Single-scattering albedo (no η² scaling) for a direction on the given side.
    #[inline]
    fn e_side(&self, mu: f32, above: bool) -> f32 {
        tables().dielectric(mu, self.r, if above { self.eta } else { 1.0 / self.eta })
    }

    fn f_ss(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> f32 {
        rough_dielectric_f(&self.distrib, self.eta, wo, wi, mode)
    }

    fn pdf_ss(&self, wo: Vec3, wi: Vec3) -> f32 {
        rough_dielectric_pdf(&self.distrib, self.eta, wo, wi)
    }

    /// (reflected fraction, transmitted fraction) of the compensation lobe for ωo's side.
    #[inline]
    fn ms_split(ms: &DielectricMs, above: bool) -> (f32, f32) {
        let t = if above { ms.t_above } else { ms.t_below };
        (1.0 - t, t)
    }

    fn f_ms(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> f32 {
        let Some(ms) = self.ms else { return 0.0 };
        if wo.z == 0.0 || wi.z == 0.0 {
            return 0.0;
        }
        let above_o = wo.z > 0.0;
        let above_i = wi.z > 0.0;
        let (rf, tf) = Self::ms_split(&ms, above_o);
        let lo = 1.0 - self.e_side(wo.z.abs(), above_o);
        let li = 1.0 - self.e_side(wi.z.abs(), above_i);
        let loss_i = if above_i { ms.loss_above } else { ms.loss_below };
        if above_o == above_i {
            rf * lo * li * INV_PI / loss_i
        } else {
            let f = tf * lo * li * INV_PI / loss_i;
            let etap = if above_o { self.eta } else { 1.0 / self.eta };
            match mode {
                TransportMode::Radiance => f / (etap * etap),
                TransportMode::Importance => f,
            }
        }
    }

    #[inline]
    fn p_ms(&self, wo: Vec3) -> f32 {
        if self.ms.is_none() {
            return 0.0;
        }
        (1.0 - self.e_side(wo.z.abs(), wo.z > 0.0)).clamp(0.0, 1.0)
    }

    pub fn f(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> SampledSpectrum {
        if self.is_smooth() {
            return SampledSpectrum::ZERO;
        }
        let f = self.f_ss(wo, wi, mode) + self.f_ms(wo, wi, mode);
        if wo.z * wi.z < 0.0 {
            self.tint * f
        } else {
            SampledSpectrum::splat(f)
        }
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.is_smooth() || wo.z == 0.0 || wi.z == 0.0 {
            return 0.0;
        }
        let p_ms = self.p_ms(wo);
        let mut pdf = (1.0 - p_ms) * self.pdf_ss(wo, wi);
        if let Some(ms) = self.ms {
            let (rf, tf) = Self::ms_split(&ms, wo.z > 0.0);
            let side = if wo.z * wi.z > 0.0 { rf } else { tf };
            pdf += p_ms * side * wi.z.abs() * INV_PI;
        }
        pdf
    }

    pub fn sample_f(&self, wo: Vec3, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        if self.is_smooth() {
            return self.sample_smooth(wo, uc, mode);
        }
        let p_ms = self.p_ms(wo);
        let wi = if uc < p_ms {
            let ms = self.ms?;
            let (rf, _) = Self::ms_split(&ms, wo.z > 0.0);
            let d = sample_cosine_hemisphere(u);
            let same_side = uc / p_ms < rf;
            let z = if same_side == (wo.z > 0.0) { d.z } else { -d.z };
            Vec3::new(d.x, d.y, z)
        } else {
            let uc = ((uc - p_ms) / (1.0 - p_ms)).min(1.0 - f32::EPSILON);
            scatter_at_facet(wo, self.distrib.sample_wm(wo, u), self.eta, uc)?
        };
        glossy_dielectric_sample(wo, wi, self.eta, self.pdf(wo, wi), || self.f(wo, wi, mode))
    }

    /// A smooth interface's reflection towards the mirror direction of `wo`: its f over |cosθ|,
    /// as a delta sample carries it, and the probability of choosing it (zero when rough).
    pub fn mirror(&self, wo: Vec3) -> (SampledSpectrum, f32) {
        if !self.is_smooth() || wo.z == 0.0 {
            return (SampledSpectrum::ZERO, 0.0);
        }
        let r = fresnel_dielectric(wo.z, self.eta);
        (SampledSpectrum::splat(r / wo.z.abs()), r)
    }

    fn sample_smooth(&self, wo: Vec3, uc: f32, mode: TransportMode) -> Option<BsdfSample> {
        let r = fresnel_dielectric(wo.z, self.eta);
        let t = 1.0 - r;
        if uc < r / (r + t) {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            let f = SampledSpectrum::splat(r / wi.z.abs());
            Some(BsdfSample { f, wi, pdf: r / (r + t), flags: flags::SPECULAR_REFLECTION, eta: 1.0 })
        } else {
            let n = Vec3::Z;
            let (wi, etap) = refract(wo, n, self.eta)?;
            if wi.z == 0.0 {
                return None;
            }
            let mut ft = t / wi.z.abs();
            if mode == TransportMode::Radiance {
                ft /= etap * etap;
            }
            Some(BsdfSample {
                f: self.tint * ft,
                wi,
                pdf: t / (r + t),
                flags: flags::SPECULAR_TRANSMISSION,
                eta: etap,
            })
        }
    }
}

/// A microfacet distribution as the rough-dielectric lobe uses it: normal density, height-
/// correlated masking-shadowing, and the density of visible normals.
pub(crate) trait Microfacets {
    fn d(&self, wm: Vec3) -> f32;
    fn g2(&self, wo: Vec3, wi: Vec3) -> f32;
    fn pdf_visible(&self, w: Vec3, wm: Vec3) -> f32;
}

impl Microfacets for TrowbridgeReitz {
    #[inline]
    fn d(&self, wm: Vec3) -> f32 {
        TrowbridgeReitz::d(self, wm)
    }
    #[inline]
    fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        TrowbridgeReitz::g2(self, wo, wi)
    }
    #[inline]
    fn pdf_visible(&self, w: Vec3, wm: Vec3) -> f32 {
        TrowbridgeReitz::pdf_visible(self, w, wm)
    }
}

/// Generalised half vector of a rough dielectric of relative IOR `eta` (inside below), the
/// relative IOR crossed, and whether (wo, wi) is a reflection; None for degenerate or
/// back-facing configurations.
#[inline]
pub(crate) fn dielectric_half_vector(eta: f32, wo: Vec3, wi: Vec3) -> Option<(Vec3, f32, bool)> {
    let (co, ci) = (wo.z, wi.z);
    if co == 0.0 || ci == 0.0 {
        return None;
    }
    let reflect = co * ci > 0.0;
    let etap = if reflect {
        1.0
    } else if co > 0.0 {
        eta
    } else {
        1.0 / eta
    };
    let wm = wi * etap + wo;
    if wm.length_squared() == 0.0 {
        return None;
    }
    let mut wm = wm.normalize();
    if wm.z < 0.0 {
        wm = -wm;
    }
    if wm.dot(wi) * ci < 0.0 || wm.dot(wo) * co < 0.0 {
        return None;
    }
    Some((wm, etap, reflect))
}

/// Single-scattering rough dielectric BSDF (Walter et al. 2007) over any microfacet distribution.
pub(crate) fn rough_dielectric_f(m: &impl Microfacets, eta: f32, wo: Vec3, wi: Vec3, mode: TransportMode) -> f32 {
    let Some((wm, etap, reflect)) = dielectric_half_vector(eta, wo, wi) else { return 0.0 };
    let fr = fresnel_dielectric(wo.dot(wm), eta);
    let dg = m.d(wm) * m.g2(wo, wi);
    if reflect {
        dg * fr / (4.0 * wo.z * wi.z).abs()
    } else {
        let denom = wi.dot(wm) + wo.dot(wm) / etap;
        let ft = dg * (1.0 - fr) * (wi.dot(wm) * wo.dot(wm) / (wi.z * wo.z * denom * denom)).abs();
        match mode {
            TransportMode::Radiance => ft / (etap * etap),
            TransportMode::Importance => ft,
        }
    }
}

/// Density of [`rough_dielectric_f`]'s sampling: a visible normal, then Fresnel's choice.
pub(crate) fn rough_dielectric_pdf(m: &impl Microfacets, eta: f32, wo: Vec3, wi: Vec3) -> f32 {
    let Some((wm, etap, reflect)) = dielectric_half_vector(eta, wo, wi) else { return 0.0 };
    let r = fresnel_dielectric(wo.dot(wm), eta);
    let pv = m.pdf_visible(wo, wm);
    if reflect {
        pv / (4.0 * wo.dot(wm).abs()) * r
    } else {
        let denom = wi.dot(wm) + wo.dot(wm) / etap;
        pv * wi.dot(wm).abs() / (denom * denom) * (1.0 - r)
    }
}

/// Reflects or refracts `wo` at the microfacet `wm` of a dielectric of relative IOR `eta`, the
/// choice made by Fresnel with `uc`; None when the result lands on the wrong side.
#[inline]
pub(crate) fn scatter_at_facet(wo: Vec3, wm: Vec3, eta: f32, uc: f32) -> Option<Vec3> {
    if uc < fresnel_dielectric(wo.dot(wm), eta) {
        let wi = reflect(wo, wm);
        (wi.z * wo.z > 0.0).then_some(wi)
    } else {
        let (wi, _) = refract(wo, wm, eta)?;
        (wi.z * wo.z < 0.0).then_some(wi)
    }
}

/// The sample record of a glossy dielectric lobe for a sampled `wi` with density `pdf`.
#[inline]
pub(crate) fn glossy_dielectric_sample(wo: Vec3, wi: Vec3, eta: f32, pdf: f32, f: impl FnOnce() -> SampledSpectrum) -> Option<BsdfSample> {
    if !(pdf > 0.0) {
        return None;
    }
    let (fl, eta) = if wi.z * wo.z > 0.0 {
        (flags::GLOSSY_REFLECTION, 1.0)
    } else {
        (flags::GLOSSY_TRANSMISSION, if wo.z > 0.0 { eta } else { 1.0 / eta })
    };
    Some(BsdfSample { f: f(), wi, pdf, flags: fl, eta })
}
