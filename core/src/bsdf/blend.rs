//! A dielectric interface over part of a surface: `t` × a clear (possibly tinted) dielectric
//! plus (1 − t) × an opaque preview stack, as MaterialX's PBR surfaces mix their transmission
//! with their diffuse base under one specular layer (the two share that reflection, so the
//! linear mix is the layering). A partial transmission (a frosted or painted glass) and a
//! partial subsurface (the dielectric's share enters the scattering body) take this form.
//!
//! The dielectric sees the true sides of the interface (its inside is −Z); the preview part is
//! two-sided like every reflection-only model, so a path inside the body meets it too.

use super::lobes::Dielectric;
use super::preview::Preview;
use super::{flip, upper, BsdfSample, TransportMode};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3};

#[derive(Clone, Copy, Debug)]
pub(crate) struct Blend {
    pub clear: Dielectric,
    pub opaque: Preview,
    /// The dielectric's share, in (0, 1).
    pub t: f32,
}

impl Blend {
    pub fn lobe_flags(&self) -> u8 {
        self.clear.lobe_flags() | self.opaque.lobe_flags()
    }

    pub fn f(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> SampledSpectrum {
        let (uo, ui) = upper(wo, wi);
        self.clear.f(wo, wi, mode) * self.t + self.opaque.f(uo, ui) * (1.0 - self.t)
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (uo, ui) = upper(wo, wi);
        self.t * self.clear.pdf(wo, wi) + (1.0 - self.t) * self.opaque.pdf(uo, ui)
    }

    /// The opaque part's diffuse lobes (for the light-path AOVs).
    pub fn f_diffuse_share(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        let (uo, ui) = upper(wo, wi);
        self.opaque.f_diffuse_share(uo, ui) * (1.0 - self.t)
    }

    pub fn albedo_hint(&self) -> SampledSpectrum {
        SampledSpectrum::splat(self.t) + self.opaque.albedo_hint() * (1.0 - self.t)
    }

    /// Picks a part with `uc` (its share), samples it with `uc` rescaled; a delta sample of the
    /// smooth dielectric carries its share in both f and pdf, any other sample the mixture's.
    pub fn sample_f(&self, wo: Vec3, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        let (uo, _) = upper(wo, wo);
        let mut s = if uc < self.t {
            self.clear.sample_f(wo, (uc / self.t).min(1.0 - f32::EPSILON), u, mode)?
        } else {
            let uc = ((uc - self.t) / (1.0 - self.t)).min(1.0 - f32::EPSILON);
            let mut s = self.opaque.sample_f(uo, uc, u)?;
            if wo.z < 0.0 {
                s.wi = flip(s.wi);
            }
            s
        };
        if s.is_specular() {
            if s.is_transmission() {
                return Some(BsdfSample { f: s.f * self.t, pdf: s.pdf * self.t, ..s });
            }
            // both parts may hold a delta towards the mirror direction
            let (fc, pc) = self.clear.mirror(wo);
            let (fp, pp) = self.opaque.mirror(uo);
            return Some(BsdfSample { f: fc * self.t + fp * (1.0 - self.t), pdf: self.t * pc + (1.0 - self.t) * pp, ..s });
        }
        s.f = self.f(wo, s.wi, mode);
        s.pdf = self.pdf(wo, s.wi);
        Some(s)
    }
}
