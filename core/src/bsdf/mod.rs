//! Bidirectional scattering distribution functions in the local shading frame (normal = +Z;
//! [`crate::math::Frame`] converts). Conventions follow pbrt-v4: `f` excludes the cosine (the
//! integrator multiplies |cosθi|), ωo and ωi both point away from the surface, and the 1/η²
//! scaling of transmitted radiance applies in [`TransportMode::Radiance`] only.
//!
//! One enum-typed model per [`Bsdf`] (no dynamic dispatch). Constructors take parameters the
//! integrator already evaluated at the path's wavelengths and return a [`BsdfError`] naming the
//! offending input instead of panicking.
//!
//! Reflection-only models (Lambert, conductor, preview surface) are two-sided: for ωo below the
//! surface both directions are mirrored through the tangent plane.

pub mod albedo;
mod blend;
pub mod fresnel;
mod lobes;
pub mod microfacet;
pub mod oren_nayar;
pub mod preview;
pub mod sea;
pub mod sea_albedo;
pub mod sheen;
pub mod thin_film;
pub mod wet;
#[cfg(test)]
mod tests;

pub use fresnel::{fresnel_complex, fresnel_dielectric, fresnel_dielectric_polarized, fresnel_schlick};
pub use microfacet::{roughness_to_alpha, TrowbridgeReitz, SMOOTH_ALPHA};
pub use preview::{PbrFlavour, PreviewParams, ThinFilmParams};

use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3};
use blend::Blend;
use lobes::{Dielectric, Lambert, MicrofacetReflection, ReflFresnel};
use preview::Preview;
use sea::{CoxMunk, SeaSurface};
use wet::Wet;

/// Lobe classification bits.
pub mod flags {
    pub const REFLECTION: u8 = 1;
    pub const TRANSMISSION: u8 = 2;
    pub const DIFFUSE: u8 = 4;
    pub const GLOSSY: u8 = 8;
    pub const SPECULAR: u8 = 16;
    pub const DIFFUSE_REFLECTION: u8 = DIFFUSE | REFLECTION;
    pub const GLOSSY_REFLECTION: u8 = GLOSSY | REFLECTION;
    pub const GLOSSY_TRANSMISSION: u8 = GLOSSY | TRANSMISSION;
    pub const SPECULAR_REFLECTION: u8 = SPECULAR | REFLECTION;
    pub const SPECULAR_TRANSMISSION: u8 = SPECULAR | TRANSMISSION;
}

/// Which quantity the path carries: radiance (camera paths) or importance (light paths).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    Radiance,
    Importance,
}

/// Result of [`Bsdf::sample_f`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// BSDF value (for specular samples: the delta's weight divided by |cosθi|).
    pub f: SampledSpectrum,
    pub wi: Vec3,
    /// Solid-angle density (for specular samples: the discrete probability of the choice).
    pub pdf: f32,
    /// The sampled lobe's [`flags`].
    pub flags: u8,
    /// Relative IOR crossed (n_wi side / n_wo side); 1 for reflection.
    pub eta: f32,
}

impl BsdfSample {
    #[inline]
    pub fn is_specular(&self) -> bool {
        self.flags & flags::SPECULAR != 0
    }
    #[inline]
    pub fn is_transmission(&self) -> bool {
        self.flags & flags::TRANSMISSION != 0
    }
}

/// Microfacet roughness in perceptual units ([0, 1], α = roughness²), per tangent axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Roughness {
    pub u: f32,
    pub v: f32,
}

impl From<f32> for Roughness {
    fn from(r: f32) -> Self {
        Roughness { u: r, v: r }
    }
}

impl Roughness {
    fn distribution(self) -> Result<TrowbridgeReitz, BsdfError> {
        check_finite("roughness", self.u)?;
        check_finite("roughness", self.v)?;
        Ok(TrowbridgeReitz::new(roughness_to_alpha(self.u), roughness_to_alpha(self.v)))
    }
}

/// Invalid constructor input.
#[derive(Clone, Debug, PartialEq)]
pub enum BsdfError {
    /// A parameter is NaN or infinite.
    NotFinite { parameter: &'static str },
    /// A parameter lies outside its valid range.
    OutOfRange { parameter: &'static str, value: f32, expected: &'static str },
}

impl std::fmt::Display for BsdfError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BsdfError::NotFinite { parameter } => write!(f, "BSDF parameter `{parameter}` is not finite"),
            BsdfError::OutOfRange { parameter, value, expected } => {
                write!(f, "BSDF parameter `{parameter}` = {value} is out of range (expected {expected})")
            }
        }
    }
}

impl std::error::Error for BsdfError {}

fn check_finite(parameter: &'static str, v: f32) -> Result<f32, BsdfError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(BsdfError::NotFinite { parameter })
    }
}

fn check_spectrum(parameter: &'static str, s: SampledSpectrum) -> Result<SampledSpectrum, BsdfError> {
    if s.is_finite() {
        Ok(s)
    } else {
        Err(BsdfError::NotFinite { parameter })
    }
}

fn check_positive(parameter: &'static str, v: f32) -> Result<f32, BsdfError> {
    check_finite(parameter, v)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(BsdfError::OutOfRange { parameter, value: v, expected: "> 0" })
    }
}

/// Reflectances are clamped to [0, 1] (spectral uplifting may overshoot slightly).
fn reflectance(parameter: &'static str, s: SampledSpectrum) -> Result<SampledSpectrum, BsdfError> {
    Ok(check_spectrum(parameter, s)?.map(|v| v.clamp(0.0, 1.0)))
}

#[derive(Clone, Copy, Debug)]
enum Model {
    Lambert(Lambert),
    Microfacet(MicrofacetReflection),
    Dielectric(Dielectric),
    Preview(Preview),
    Sea(SeaSurface),
    Wet(Wet),
    Blend(Blend),
}

/// A surface's scattering function at one shading point.
#[derive(Clone, Copy, Debug)]
pub struct Bsdf {
    model: Model,
}

/// Mirrors ω through the tangent plane.
#[inline]
fn flip(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, -w.z)
}

/// (ωo, ωi) mirrored to the upper side when ωo is below, where the reflection-only models
/// are defined.
#[inline]
fn upper(wo: Vec3, wi: Vec3) -> (Vec3, Vec3) {
    if wo.z < 0.0 {
        (flip(wo), flip(wi))
    } else {
        (wo, wi)
    }
}

impl Bsdf {
    /// Lambertian diffuse reflection.
    pub fn lambert(reflectance_: SampledSpectrum) -> Result<Bsdf, BsdfError> {
        Ok(Bsdf { model: Model::Lambert(Lambert { reflectance: reflectance("reflectance", reflectance_)? }) })
    }

    /// Conductor with complex relative IOR η + ik (exact Fresnel), GGX roughness.
    pub fn conductor(eta: SampledSpectrum, k: SampledSpectrum, roughness: impl Into<Roughness>) -> Result<Bsdf, BsdfError> {
        let eta = check_spectrum("eta", eta)?;
        let k = check_spectrum("k", k)?;
        if let Some(&v) = eta.0.iter().find(|&&v| v <= 0.0) {
            return Err(BsdfError::OutOfRange { parameter: "eta", value: v, expected: "> 0" });
        }
        if let Some(&v) = k.0.iter().find(|&&v| v < 0.0) {
            return Err(BsdfError::OutOfRange { parameter: "k", value: v, expected: ">= 0" });
        }
        let d = roughness.into().distribution()?;
        Ok(Bsdf { model: Model::Microfacet(MicrofacetReflection::new(d, ReflFresnel::Complex { eta, k })) })
    }

    /// Artist-friendly metal: Schlick Fresnel from the normal-incidence reflectance `f0` (F0 = 1
    /// is a perfect white mirror at every angle).
    pub fn conductor_schlick(f0: SampledSpectrum, roughness: impl Into<Roughness>) -> Result<Bsdf, BsdfError> {
        let f0 = reflectance("f0", f0)?;
        let d = roughness.into().distribution()?;
        Ok(Bsdf { model: Model::Microfacet(MicrofacetReflection::new(d, ReflFresnel::Schlick { f0, f90: SampledSpectrum::ONE })) })
    }

    /// Dielectric interface, `eta` = n_inside / n_outside (inside is −Z) at the hero wavelength.
    pub fn dielectric(eta: f32, roughness: impl Into<Roughness>) -> Result<Bsdf, BsdfError> {
        let eta = check_positive("eta", eta)?;
        let d = roughness.into().distribution()?;
        Ok(Bsdf { model: Model::Dielectric(Dielectric::new(eta, d)) })
    }

    /// This dielectric with each transmission multiplied by `tint` (a surface tint, clamped to
    /// [0, 1]); any other model is returned as it is.
    pub fn tint_transmission(self, tint: SampledSpectrum) -> Result<Bsdf, BsdfError> {
        let tint = reflectance("transmission tint", tint)?;
        Ok(match self.model {
            Model::Dielectric(mut d) => {
                d.tint = tint;
                Bsdf { model: Model::Dielectric(d) }
            }
            _ => self,
        })
    }

    /// A dielectric interface over the share `t` of an opaque preview stack (see [`blend`]):
    /// `clear` must be a dielectric and `opaque` a preview surface, or `clear` is returned.
    pub fn blend(clear: Bsdf, opaque: Bsdf, t: f32) -> Result<Bsdf, BsdfError> {
        let t = check_finite("transmission", t)?.clamp(0.0, 1.0);
        Ok(match (clear.model, opaque.model) {
            (Model::Dielectric(c), Model::Preview(o)) if t < 1.0 => {
                if t > 0.0 {
                    Bsdf { model: Model::Blend(Blend { clear: c, opaque: o, t }) }
                } else {
                    opaque
                }
            }
            _ => clear,
        })
    }

    /// Wind-driven sea surface (see [`sea`]): `eta` = n_water / n_air at the hero wavelength
    /// with the water on the −Z side, `wind_speed` in m/s at 10 m (Cox–Munk slopes, in
    /// [0, [`sea::MAX_WIND_SPEED`]]), `wind_direction` in radians in the tangent plane from +X
    /// towards +Y.
    pub fn sea(eta: f32, wind_speed: f32, wind_direction: f32) -> Result<Bsdf, BsdfError> {
        Self::sea_scaled(eta, wind_speed, wind_direction, 1.0)
    }

    /// [`Bsdf::sea`] whose facets carry `variance_scale` (≥ 0) of the Cox–Munk slope variances:
    /// the sub-grid part when a wave mesh resolves the rest (see [`sea::CoxMunk::with_variance_scale`]).
    pub fn sea_scaled(eta: f32, wind_speed: f32, wind_direction: f32, variance_scale: f32) -> Result<Bsdf, BsdfError> {
        let eta = check_positive("eta", eta)?;
        let slopes = CoxMunk::with_variance_scale(wind_speed, wind_direction, variance_scale)?;
        Ok(Bsdf { model: Model::Sea(SeaSurface::new(eta, slopes)) })
    }

    /// UsdPreviewSurface (see [`PreviewParams`]).
    pub fn preview(p: PreviewParams) -> Result<Bsdf, BsdfError> {
        let p = PreviewParams {
            diffuse: reflectance("diffuseColor", p.diffuse)?,
            specular_f0: reflectance("specularColor", p.specular_f0)?,
            metallic: check_finite("metallic", p.metallic)?.clamp(0.0, 1.0),
            base_for_metal: reflectance("base_for_metal", p.base_for_metal)?,
            roughness: check_finite("roughness", p.roughness)?,
            clearcoat: check_finite("clearcoat", p.clearcoat)?.clamp(0.0, 1.0),
            clearcoat_roughness: check_finite("clearcoatRoughness", p.clearcoat_roughness)?,
            ior: check_positive("ior", p.ior)?,
            outside_ior: check_positive("outside_ior", p.outside_ior)?,
            use_specular_workflow: p.use_specular_workflow,
            specular_weight: check_finite("specular weight", p.specular_weight)?.clamp(0.0, 1.0),
            specular_tint: reflectance("specular tint", p.specular_tint)?,
            coat_color: reflectance("coat colour", p.coat_color)?,
            coat_ior: check_positive("coat ior", p.coat_ior)?,
            coat_anisotropy: check_finite("coat anisotropy", p.coat_anisotropy)?.clamp(0.0, 1.0),
            coat_darkening: check_finite("coat darkening", p.coat_darkening)?.clamp(0.0, 1.0),
            darkening_albedo: reflectance("coat darkening albedo", p.darkening_albedo)?,
            anisotropy: check_finite("anisotropy", p.anisotropy)?.clamp(0.0, 1.0),
            flavour: p.flavour,
            diffuse_roughness: check_finite("diffuse roughness", p.diffuse_roughness)?.clamp(0.0, 1.0),
            sheen_weight: check_finite("sheen weight", p.sheen_weight)?.clamp(0.0, 1.0),
            sheen_color: reflectance("sheen colour", p.sheen_color)?,
            sheen_roughness: check_finite("sheen roughness", p.sheen_roughness)?,
            thin_film: match p.thin_film {
                Some(t) => Some(preview::ThinFilmParams {
                    weight: check_finite("thin film weight", t.weight)?.clamp(0.0, 1.0),
                    thickness_nm: check_finite("thin film thickness", t.thickness_nm)?.max(0.0),
                    ior: check_positive("thin film ior", t.ior)?,
                    ..t
                }),
                None => None,
            },
            thin_walled: match p.thin_walled {
                Some(t) => Some(preview::ThinWalled {
                    transmission: check_finite("thin-walled transmission", t.transmission)?.clamp(0.0, 1.0),
                    tint: reflectance("thin-walled transmission tint", t.tint)?,
                    subsurface: check_finite("thin-walled subsurface", t.subsurface)?.clamp(0.0, 1.0),
                    reflect: reflectance("translucent reflectance", t.reflect)?,
                    transmit: reflectance("translucent transmittance", t.transmit)?,
                }),
                None => None,
            },
        };
        Ok(Bsdf { model: Model::Preview(Preview::new(&p)) })
    }

    /// A thin water film over part of a surface (see [`wet`]): `dry` is the surface as it is,
    /// `covered` the same surface with its layers' indices taken against the film, `amount` the
    /// wet fraction in [0, 1], `film_eta` the film's index over the index outside. Only
    /// reflection-only surfaces (Lambert, conductor, preview) take a film; anything else is
    /// returned dry.
    pub fn wet(dry: Bsdf, covered: Bsdf, amount: f32, film_eta: f32) -> Result<Bsdf, BsdfError> {
        let amount = check_finite("tide:wet:amount", amount)?.clamp(0.0, 1.0);
        let film_eta = check_positive("tide:wet:ior", film_eta)?;
        let base = |b: &Bsdf| match b.model {
            Model::Lambert(l) => Some(wet::Base::Lambert(l)),
            Model::Microfacet(m) => Some(wet::Base::Microfacet(m)),
            Model::Preview(p) if !p.transmits() => Some(wet::Base::Preview(p)),
            Model::Preview(_) => None,
            Model::Dielectric(_) | Model::Sea(_) | Model::Wet(_) | Model::Blend(_) => None,
        };
        match (base(&dry), base(&covered)) {
            (Some(d), Some(c)) => Ok(Bsdf { model: Model::Wet(Wet::new(d, c, amount, film_eta)) }),
            _ => Ok(dry),
        }
    }

    /// BSDF value (cosine excluded); zero for delta lobes.
    pub fn f(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> SampledSpectrum {
        let (wo2, wi2) = upper(wo, wi);
        match &self.model {
            Model::Dielectric(d) => d.f(wo, wi, mode),
            Model::Sea(s) => s.f(wo, wi, mode),
            Model::Lambert(l) => l.f(wo2, wi2),
            Model::Microfacet(m) => m.f(wo2, wi2),
            Model::Preview(p) => p.f(wo2, wi2),
            Model::Wet(w) => w.f(wo2, wi2),
            Model::Blend(b) => b.f(wo, wi, mode),
        }
    }

    /// Solid-angle density with which [`Self::sample_f`] produces ωi (delta lobes excluded).
    pub fn pdf(&self, wo: Vec3, wi: Vec3, _mode: TransportMode) -> f32 {
        let (wo2, wi2) = upper(wo, wi);
        match &self.model {
            Model::Dielectric(d) => d.pdf(wo, wi),
            Model::Sea(s) => s.pdf(wo, wi),
            Model::Lambert(l) => l.pdf(wo2, wi2),
            Model::Microfacet(m) => m.pdf(wo2, wi2),
            Model::Preview(p) => p.pdf(wo2, wi2),
            Model::Wet(w) => w.pdf(wo2, wi2),
            Model::Blend(b) => b.pdf(wo, wi),
        }
    }

    /// Samples ωi given ωo; `uc` chooses among lobes, `u` the direction within one.
    pub fn sample_f(&self, wo: Vec3, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        if let Model::Dielectric(d) = &self.model {
            return d.sample_f(wo, uc, u, mode);
        }
        if let Model::Sea(s) = &self.model {
            return s.sample_f(wo, uc, u, mode);
        }
        if let Model::Blend(b) = &self.model {
            return b.sample_f(wo, uc, u, mode);
        }
        let flipped = wo.z < 0.0;
        let wo2 = if flipped { flip(wo) } else { wo };
        let mut s = match &self.model {
            Model::Lambert(l) => l.sample_f(wo2, u),
            Model::Microfacet(m) => m.sample_f(wo2, uc, u),
            Model::Preview(p) => p.sample_f(wo2, uc, u),
            Model::Wet(w) => w.sample_f(wo2, uc, u),
            Model::Dielectric(_) | Model::Sea(_) | Model::Blend(_) => None,
        }?;
        if flipped {
            s.wi = flip(s.wi);
        }
        Some(s)
    }

    /// Union of the lobes' [`flags`].
    pub fn flags(&self) -> u8 {
        match &self.model {
            Model::Lambert(_) => flags::DIFFUSE_REFLECTION,
            Model::Microfacet(m) => m.lobe_flags(),
            Model::Dielectric(d) => d.lobe_flags(),
            Model::Sea(s) => s.lobe_flags(),
            Model::Preview(p) => p.lobe_flags(),
            Model::Wet(w) => w.lobe_flags(),
            Model::Blend(b) => b.lobe_flags(),
        }
    }

    /// Rough reflectance (at normal incidence) for the albedo AOV and denoisers.
    pub fn albedo_hint(&self) -> SampledSpectrum {
        match &self.model {
            Model::Lambert(l) => l.reflectance,
            Model::Microfacet(m) => m.albedo(1.0),
            Model::Dielectric(_) | Model::Sea(_) => SampledSpectrum::ONE,
            Model::Preview(p) => p.albedo_hint(),
            Model::Wet(w) => w.albedo_hint(),
            Model::Blend(b) => b.albedo_hint(),
        }
    }

    /// The diffuse lobes' share of [`Self::f`] (radiance mode), for splitting a contribution
    /// into the diffuse and specular light-path AOVs.
    pub fn f_diffuse(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        let (wo2, wi2) = upper(wo, wi);
        match &self.model {
            Model::Lambert(l) => l.f(wo2, wi2),
            Model::Preview(p) => p.f_diffuse_share(wo2, wi2),
            Model::Wet(w) => w.f_diffuse_share(wo2, wi2),
            Model::Blend(b) => b.f_diffuse_share(wo, wi),
            Model::Microfacet(_) | Model::Dielectric(_) | Model::Sea(_) => SampledSpectrum::ZERO,
        }
    }

    /// What a thin wall lets straight through along ω, either way (zero for anything else):
    /// the weight its unbent transmission gives a ray that crosses it.
    pub fn straight_through(&self, w: Vec3) -> SampledSpectrum {
        match &self.model {
            Model::Preview(p) => p.straight_through(if w.z < 0.0 { flip(w) } else { w }),
            _ => SampledSpectrum::ZERO,
        }
    }

    /// True when every lobe is a delta (no `f`/`pdf` to evaluate, no light sampling).
    pub fn is_specular(&self) -> bool {
        let fl = self.flags();
        fl & flags::SPECULAR != 0 && fl & (flags::DIFFUSE | flags::GLOSSY) == 0
    }
}
