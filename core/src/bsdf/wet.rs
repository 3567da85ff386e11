//! Wetness (`TideWetAPI`): a thin, smooth water film over an opaque surface response, in closed
//! form — the "thickcoat" of the wetness layering in Manuka (SIGGRAPH 2023 course, §4.3), with a
//! smooth top and the bounces inside the film summed as a geometric series.
//!
//! The film has relative index η = n_film / n_outside (≥ 1; η = 1 when the surface sits in
//! water of the film's index, so the film then changes nothing). Light reflects off the film
//! with the exact Fresnel term F, or refracts in, meets the base (the dry surface response with
//! its own interfaces seen from the film, i.e. index-matched), and leaves after any number of
//! reflections off the film's underside. With ω′ the refracted directions inside the film:
//!
//! f(ωo, ωi) = (1 − F(μo)) (1 − F(μi)) / η² · [ f_base(ωo′, ωi′)
//!             + A_d(μo′) A_d(μi′) r_i / (π (1 − Ā_d r_i)) ]  (+ the film's mirror reflection F)
//!
//! where A_d is the base's diffuse directional albedo, Ā_d its hemispherical average, and r_i
//! = 1 − (1 − r_e)/η² the film underside's reflectance for diffuse light (r_e the external
//! hemispherical Fresnel average). The first term is single scattering seen through the film; the
//! second carries the light the film's underside sends back to the base (total internal
//! reflection included) and that leaves after further diffuse bounces. For a Lambertian base
//! the sum is exact (a white base conserves energy exactly); the glossy share the underside
//! reflects back is dropped, so a glossy base loses a little energy, never gains it. Darkening
//! follows the three factors of the course: mid albedos darken most, a higher film index traps
//! more light, a base that scatters more widely darkens more.
//!
//! `amount` ∈ [0, 1] is the wet fraction of the surface: the response is (1 − amount)·dry +
//! amount·wet, each part sampled in proportion to its share.
//!
//! Water compliance ([`compliance_boost`]): under geometric water the film is index-matched
//! and the water body itself darkens the surface (light it reflects back is absorbed by the
//! base again); a compliant material is brightened instead by the ratio of the darkening a film
//! causes in water to the one it causes in air, computed with the same closed form.

use super::lobes::{Lambert, MicrofacetReflection};
use super::preview::Preview;
use super::{flags, BsdfSample};
use crate::math::{sample_cosine_hemisphere, INV_PI};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3};
use std::sync::OnceLock;

/// Reflection-only responses a film can cover.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Base {
    Lambert(Lambert),
    Microfacet(MicrofacetReflection),
    Preview(Preview),
}

impl Base {
    fn f(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        match self {
            Base::Lambert(l) => l.f(wo, wi),
            Base::Microfacet(m) => m.f(wo, wi),
            Base::Preview(p) => p.f(wo, wi),
        }
    }
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Base::Lambert(l) => l.pdf(wo, wi),
            Base::Microfacet(m) => m.pdf(wo, wi),
            Base::Preview(p) => p.pdf(wo, wi),
        }
    }
    fn sample_f(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        match self {
            Base::Lambert(l) => l.sample_f(wo, u),
            Base::Microfacet(m) => m.sample_f(wo, uc, u),
            Base::Preview(p) => p.sample_f(wo, uc, u),
        }
    }
    fn lobe_flags(&self) -> u8 {
        match self {
            Base::Lambert(_) => flags::DIFFUSE_REFLECTION,
            Base::Microfacet(m) => m.lobe_flags(),
            Base::Preview(p) => p.lobe_flags(),
        }
    }
    /// The diffuse part's directional albedo A_d(μ).
    fn diffuse_albedo(&self, mu: f32) -> SampledSpectrum {
        match self {
            Base::Lambert(l) => l.reflectance,
            Base::Microfacet(_) => SampledSpectrum::ZERO,
            Base::Preview(p) => p.diffuse_albedo(mu),
        }
    }
    /// The diffuse lobes' share of [`Self::f`].
    fn f_diffuse(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        match self {
            Base::Lambert(l) => l.f(wo, wi),
            Base::Microfacet(_) => SampledSpectrum::ZERO,
            Base::Preview(p) => p.f_diffuse_share(wo, wi),
        }
    }
    /// Directional albedo at μ (mean over wavelengths), for lobe selection only.
    fn albedo_estimate(&self, mu: f32) -> f32 {
        match self {
            Base::Lambert(l) => l.reflectance.average(),
            Base::Microfacet(m) => m.albedo(mu).average(),
            Base::Preview(p) => p.albedo_at(mu).average(),
        }
    }
    fn albedo_hint(&self) -> SampledSpectrum {
        match self {
            Base::Lambert(l) => l.reflectance,
            Base::Microfacet(m) => m.albedo(1.0),
            Base::Preview(p) => p.albedo_hint(),
        }
    }
}

/// Largest film relative index tabulated for [`film_reflectances`] (larger ones are computed
/// directly).
const ETA_TABLE_MAX: f32 = 3.0;
const ETA_TABLE_N: usize = 512;

/// r_e = 2∫F(μ)μ dμ of a smooth interface of relative index η seen from outside, by the
/// midpoint rule in x = √μ (the integrand 4F(x²)x³ is smooth where F rises at grazing angles).
fn external_average(eta: f32) -> f32 {
    const N: usize = 512;
    let mut s = 0.0f64;
    for k in 0..N {
        let x = (k as f64 + 0.5) / N as f64;
        let mu = x * x;
        s += 4.0 * super::fresnel_dielectric(mu as f32, eta) as f64 * x * x * x;
    }
    (s / N as f64) as f32
}

fn table() -> &'static [f32] {
    static T: OnceLock<Vec<f32>> = OnceLock::new();
    T.get_or_init(|| {
        (0..ETA_TABLE_N)
            .map(|k| external_average(1.0 + (ETA_TABLE_MAX - 1.0) * k as f32 / (ETA_TABLE_N - 1) as f32))
            .collect()
    })
}

/// (r_e, r_i) of a film of relative index η ≥ 1: the hemispherical reflectance for diffuse
/// light from outside and from inside; r_i = 1 − (1 − r_e)/η² (étendue: what leaves from inside
/// is what enters from outside).
pub fn film_reflectances(eta: f32) -> (f32, f32) {
    if !(eta > 1.0) {
        return (0.0, 0.0);
    }
    let r_e = if eta < ETA_TABLE_MAX {
        let t = (eta - 1.0) / (ETA_TABLE_MAX - 1.0) * (ETA_TABLE_N - 1) as f32;
        let i = (t as usize).min(ETA_TABLE_N - 2);
        let f = t - i as f32;
        let tab = table();
        tab[i] * (1.0 - f) + tab[i + 1] * f
    } else {
        external_average(eta)
    };
    (r_e, 1.0 - (1.0 - r_e) / (eta * eta))
}

/// Diffuse darkening of a Lambertian base of albedo `a` under a film of relative index η: the
/// wet diffuse albedo over the dry one, (1 − r_e) / (η² (1 − a r_i)), excluding what the film
/// itself reflects (which is (1 − r_e) at most). 1 for η ≤ 1 and for a white base.
fn darkening(a: f32, eta: f32, (r_e, r_i): (f32, f32)) -> f32 {
    if !(eta > 1.0) {
        return 1.0;
    }
    (1.0 - r_e) / (eta * eta * (1.0 - a * r_i)).max(1e-6)
}

/// Water compliance: the diffuse albedo a compliant wet material shows when it sits in a medium
/// of index `outside_ior` (> 1: geometric water) — brightened by darkening(in that medium) /
/// darkening(in air) of a film of index `film_ior`, capped at 1. Unchanged in air.
pub fn compliance_boost(diffuse: SampledSpectrum, film_ior: f32, outside_ior: f32) -> SampledSpectrum {
    if !(outside_ior > 1.0 + 1e-4) || !(film_ior > 1.0) {
        return diffuse;
    }
    let eta_here = (film_ior / outside_ior).max(1.0);
    let (here, air) = (film_reflectances(eta_here), film_reflectances(film_ior));
    diffuse.map(|a| {
        let a = a.clamp(0.0, 1.0);
        // ≥ 1 by construction (a film of lower relative index darkens less); max() absorbs rounding
        (a * (darkening(a, eta_here, here) / darkening(a, film_ior, air)).max(1.0)).min(1.0)
    })
}

/// Refracts an upper-hemisphere direction outside the film into the film (both pointing away
/// from the base).
#[inline]
fn inside(w: Vec3, eta: f32) -> Vec3 {
    let z2 = 1.0 - (1.0 - w.z * w.z) / (eta * eta);
    Vec3::new(w.x / eta, w.y / eta, z2.max(0.0).sqrt())
}

/// The inverse of [`inside`]; None beyond the critical angle (total internal reflection).
#[inline]
fn outside(w: Vec3, eta: f32) -> Option<Vec3> {
    let s2 = (1.0 - w.z * w.z) * eta * eta;
    if s2 >= 1.0 {
        return None;
    }
    Some(Vec3::new(w.x * eta, w.y * eta, (1.0 - s2).sqrt()))
}

/// A wet surface: `dry` as it is, `wet` the same surface seen from within the film.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Wet {
    dry: Base,
    wet: Base,
    amount: f32,
    eta: f32,
    /// The film's reflectances for diffuse light from outside and from inside.
    r_e: f32,
    r_i: f32,
    /// Ā_d of the wet base.
    a_avg: SampledSpectrum,
    /// r_i / (π (1 − Ā_d r_i)).
    multi: SampledSpectrum,
}

/// Lobe indices for selection.
const DRY: usize = 0;
const FILM: usize = 1;
const BASE: usize = 2;
const MULTI: usize = 3;

/// Gauss–Legendre nodes on [0, 1] (4 points) for Ā_d: A_d varies slowly with μ.
const GL4: [(f32, f32); 4] = [(0.069_431_84, 0.173_927_42), (0.330_009_48, 0.326_072_58), (0.669_990_5, 0.326_072_58), (0.930_568_16, 0.173_927_42)];

impl Wet {
    /// `eta` = film index over the index outside; `amount` in [0, 1] (validated by the caller).
    pub fn new(dry: Base, wet: Base, amount: f32, eta: f32) -> Self {
        let eta = eta.max(1.0);
        let (r_e, r_i) = film_reflectances(eta);
        let a_avg = GL4.iter().fold(SampledSpectrum::ZERO, |acc, &(x, w)| acc + wet.diffuse_albedo(x) * (2.0 * w * x));
        let multi = a_avg.map(|a| r_i * INV_PI / (1.0 - a.min(1.0) * r_i).max(1e-6));
        Wet { dry, wet, amount, eta, r_e, r_i, a_avg, multi }
    }

    pub fn lobe_flags(&self) -> u8 {
        let mut fl = 0;
        if self.amount < 1.0 {
            fl |= self.dry.lobe_flags();
        }
        if self.amount > 0.0 {
            fl |= self.wet.lobe_flags();
            if self.eta > 1.0 {
                fl |= flags::SPECULAR_REFLECTION;
            }
            if !self.multi_black() {
                fl |= flags::DIFFUSE_REFLECTION;
            }
        }
        fl
    }

    #[inline]
    fn multi_black(&self) -> bool {
        self.r_i == 0.0 || self.a_avg.is_black()
    }

    #[inline]
    fn fresnel(&self, mu: f32) -> f32 {
        if self.eta > 1.0 {
            super::fresnel_dielectric(mu, self.eta)
        } else {
            0.0
        }
    }

    /// The film-covered part without the mirror reflection and without the `amount` weight.
    fn f_covered(&self, wo: Vec3, wi: Vec3, diffuse_only: bool) -> SampledSpectrum {
        let (wo_in, wi_in) = (inside(wo, self.eta), inside(wi, self.eta));
        let t = (1.0 - self.fresnel(wo.z)) * (1.0 - self.fresnel(wi.z)) / (self.eta * self.eta);
        let single = if diffuse_only { self.wet.f_diffuse(wo_in, wi_in) } else { self.wet.f(wo_in, wi_in) };
        let multi = if self.multi_black() {
            SampledSpectrum::ZERO
        } else {
            self.wet.diffuse_albedo(wo_in.z) * self.wet.diffuse_albedo(wi_in.z) * self.multi
        };
        (single + multi) * t
    }

    /// Selection probabilities of (dry, film, base, multi) for ωo at μo.
    fn probabilities(&self, wo: Vec3) -> [f32; 4] {
        let w = self.amount;
        let mut p = [1.0 - w, 0.0, 0.0, 0.0];
        if w > 0.0 {
            let fo = self.fresnel(wo.z);
            let mu_in = inside(wo, self.eta).z;
            let eb = self.wet.albedo_estimate(mu_in).max(0.0);
            let em = if self.multi_black() {
                0.0
            } else {
                (self.wet.diffuse_albedo(mu_in) * self.a_avg * self.multi * std::f32::consts::PI).average().max(0.0)
            };
            let under = (1.0 - fo) * (eb + em);
            let pf = if fo + under > 0.0 { fo / (fo + under) } else { 1.0 };
            let q = if eb + em > 0.0 { eb / (eb + em) } else { 1.0 };
            p[FILM] = w * pf;
            p[BASE] = w * (1.0 - pf) * q;
            p[MULTI] = w * (1.0 - pf) * (1.0 - q);
        }
        p
    }

    pub fn f(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        self.f_mixed(wo, wi, false)
    }

    /// The diffuse lobes' share of [`Self::f`].
    pub fn f_diffuse_share(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        self.f_mixed(wo, wi, true)
    }

    /// (1 − amount)·dry + amount·covered, all lobes or the diffuse ones only.
    fn f_mixed(&self, wo: Vec3, wi: Vec3, diffuse_only: bool) -> SampledSpectrum {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        let mut f = SampledSpectrum::ZERO;
        if self.amount < 1.0 {
            let dry = if diffuse_only { self.dry.f_diffuse(wo, wi) } else { self.dry.f(wo, wi) };
            f += dry * (1.0 - self.amount);
        }
        if self.amount > 0.0 {
            f += self.f_covered(wo, wi, diffuse_only) * self.amount;
        }
        f
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        self.pdf_with(&self.probabilities(wo), wo, wi)
    }

    /// [`Self::pdf`] with the lobe probabilities for ωo already at hand.
    fn pdf_with(&self, p: &[f32; 4], wo: Vec3, wi: Vec3) -> f32 {
        let mut pdf = 0.0;
        if p[DRY] > 0.0 {
            pdf += p[DRY] * self.dry.pdf(wo, wi);
        }
        if p[BASE] > 0.0 {
            let (wo_in, wi_in) = (inside(wo, self.eta), inside(wi, self.eta));
            // dωi′/dωi = μi / (η² μi′)
            pdf += p[BASE] * self.wet.pdf(wo_in, wi_in) * wi.z / (self.eta * self.eta * wi_in.z);
        }
        if p[MULTI] > 0.0 {
            pdf += p[MULTI] * wi.z * INV_PI;
        }
        pdf
    }

    pub fn sample_f(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let p = self.probabilities(wo);
        let mut acc = 0.0;
        let mut lobe = MULTI;
        for (k, &pk) in p.iter().enumerate() {
            if pk > 0.0 && uc < acc + pk {
                lobe = k;
                break;
            }
            acc += pk;
        }
        if !(p[lobe] > 0.0) {
            return None;
        }
        let uc = ((uc - acc) / p[lobe]).clamp(0.0, 1.0 - f32::EPSILON);
        let (wi, fl) = match lobe {
            DRY => {
                let s = self.dry.sample_f(wo, uc, u)?;
                if s.is_specular() {
                    // unbiased on its own: the other parts' mirror reflections are sampled by
                    // their own choices
                    return Some(BsdfSample { f: s.f * (1.0 - self.amount), pdf: s.pdf * p[DRY], ..s });
                }
                (s.wi, s.flags)
            }
            FILM => {
                let f = SampledSpectrum::splat(self.amount * self.fresnel(wo.z) / wo.z);
                return Some(BsdfSample { f, wi: Vec3::new(-wo.x, -wo.y, wo.z), pdf: p[FILM], flags: flags::SPECULAR_REFLECTION, eta: 1.0 });
            }
            BASE => {
                let s = self.wet.sample_f(inside(wo, self.eta), uc, u)?;
                if s.wi.z <= 0.0 {
                    return None;
                }
                let wi = outside(s.wi, self.eta)?;
                if s.is_specular() {
                    let t = (1.0 - self.fresnel(wo.z)) * (1.0 - self.fresnel(wi.z));
                    let f = s.f * (self.amount * t * s.wi.z / wi.z);
                    return Some(BsdfSample { f, wi, pdf: s.pdf * p[BASE], ..s });
                }
                (wi, s.flags)
            }
            _ => (sample_cosine_hemisphere(u), flags::DIFFUSE_REFLECTION),
        };
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf_with(&p, wo, wi);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample { f: self.f(wo, wi), wi, pdf, flags: fl, eta: 1.0 })
    }

    /// Rough reflectance at normal incidence for the albedo AOV.
    pub fn albedo_hint(&self) -> SampledSpectrum {
        let f0 = self.fresnel(1.0);
        let r_e = self.r_e;
        let base = self.wet.albedo_hint();
        let covered = SampledSpectrum::splat(f0)
            + base.map(|a| (1.0 - f0) * (1.0 - r_e) * a / (self.eta * self.eta * (1.0 - a.min(1.0) * self.r_i)).max(1e-6));
        self.dry.albedo_hint() * (1.0 - self.amount) + covered * self.amount
    }
}
