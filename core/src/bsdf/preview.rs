//! UsdPreviewSurface, and the MaterialX PBR surfaces mapped onto it, as a layered multi-lobe
//! BSDF: a GGX clearcoat (IOR 1.5 unless set) over a GGX specular layer over a Lambertian base. Each
//! layer attenuates what lies beneath it by the upper layer's directional albedo on the way in
//! and on the way out, so the stack never creates energy; the diffuse base under the specular
//! layer is renormalised (Kulla & Conty 2017) so that a white base under any specular layer
//! reflects exactly what the specular layer lets through.
//!
//! The MaterialX surfaces add, as MaterialX's own node graphs compute them:
//! * a specular weight and tint: the dielectric reflection is weight × tint × F, while what
//!   lies beneath sees 1 − weight × albedo (the tint absorbs, it never adds light);
//! * a coat colour: everything under the coat is multiplied by mix(1, colour, coat), a coat
//!   IOR, and coat anisotropy (along the specular's tangent); OpenPBR's coat darkening of
//!   what lies beneath (the coat's underside sending light back to the base);
//! * specular anisotropy: two roughnesses along the tangent and bitangent ([`PbrFlavour`]);
//! * a rough diffuse base: Oren–Nayar, the qualitative model for Standard Surface and the
//!   energy-preserving one (EON) for OpenPBR, as MaterialX's graphs choose;
//! * a thin film over the specular layer ([`ThinFilmParams`]): exact interference per
//!   wavelength ([`super::thin_film`]) over the dielectric the layer's F0 implies;
//! * a sheen (Standard Surface's `sheen`, OpenPBR's `fuzz`): MaterialX's Charlie sheen lobe
//!   ([`super::sheen`]), between the coat and the specular layer over the dielectric part
//!   (weight × (1 − metallic)) for Standard Surface, over everything, coat included, for
//!   OpenPBR; what lies beneath sees 1 − weight × its albedo each way;
//! * a thin wall's base ([`ThinWalled`]): a share passing straight through, unbent and
//!   tinted, past the specular layer (what the layer does not reflect), and a translucent
//!   share transmitting diffusely under the layer as the diffuse base reflects.

use super::fresnel::f0_from_ior;
use super::lobes::{FilmFresnel, Lambert, MicrofacetReflection, ReflFresnel};
use super::thin_film::SpectralThinFilm;
use crate::spectrum::SampledWavelengths;
use super::oren_nayar::{OrenNayar, OrenNayarModel};
use super::sheen::Sheen;
use super::microfacet::{roughness_to_alpha, TrowbridgeReitz};
use super::{flags, BsdfSample};
use crate::math::INV_PI;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3};

/// Already-evaluated UsdPreviewSurface inputs at the path's wavelengths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreviewParams {
    /// diffuseColor.
    pub diffuse: SampledSpectrum,
    /// specularColor (specular workflow only).
    pub specular_f0: SampledSpectrum,
    /// metallic in [0, 1] (metallic workflow only).
    pub metallic: f32,
    /// The colour a fully metallic surface reflects at normal incidence (normally diffuseColor).
    pub base_for_metal: SampledSpectrum,
    /// Perceptual roughness in [0, 1].
    pub roughness: f32,
    /// clearcoat weight in [0, 1].
    pub clearcoat: f32,
    /// clearcoatRoughness in [0, 1].
    pub clearcoat_roughness: f32,
    /// ior of the dielectric specular layer (metallic workflow).
    pub ior: f32,
    /// Index of what lies above the surface (1 in air; the water's under geometric water or a
    /// wet film): the layers' Fresnel terms use the indices relative to it.
    pub outside_ior: f32,
    pub use_specular_workflow: bool,
    /// Weight of the dielectric specular reflection in [0, 1] (1 for UsdPreviewSurface).
    pub specular_weight: f32,
    /// Tint of the dielectric specular reflection, in [0, 1] (1 for UsdPreviewSurface).
    pub specular_tint: SampledSpectrum,
    /// Colour the coat gives whatever lies under it, in [0, 1] (1: a clear coat).
    pub coat_color: SampledSpectrum,
    /// IOR of the coat ([`CLEARCOAT_IOR`] for UsdPreviewSurface).
    pub coat_ior: f32,
    /// The coat's anisotropy in [0, 1], along the same tangent as the specular's.
    pub coat_anisotropy: f32,
    /// OpenPBR's coat darkening in [0, 1] (0: none) and the base albedo it estimates it from
    /// (OpenPBR's E_dielectric: the base colour).
    pub coat_darkening: f32,
    pub darkening_albedo: SampledSpectrum,
    /// Specular anisotropy in [0, 1] (0: isotropic), stretching the lobe along the frame's
    /// tangent as `flavour` says.
    pub anisotropy: f32,
    pub flavour: PbrFlavour,
    /// Roughness of the diffuse base in [0, 1] (0: Lambertian).
    pub diffuse_roughness: f32,
    /// The sheen's weight in [0, 1] (0: none), colour in [0, 1] and roughness.
    pub sheen_weight: f32,
    pub sheen_color: SampledSpectrum,
    pub sheen_roughness: f32,
    /// A thin film over the specular layer.
    pub thin_film: Option<ThinFilmParams>,
    /// A thin wall's transmitting base (None: the base only reflects).
    pub thin_walled: Option<ThinWalled>,
}

/// The base of a thin wall (MaterialX's `thin_walled` surfaces: a window pane, a leaf, a sheet
/// of paper), at the path's wavelengths. Under the specular layer, as MaterialX mixes them:
/// the share `transmission` passes straight through, tinted (a shell of no thickness whose one
/// interface reflects what the specular layer reflects and lets the rest through unbent); of
/// the rest, the share `subsurface` is translucent, reflecting `reflect` and transmitting
/// `transmit` diffusely, and the remainder is the diffuse base.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinWalled {
    pub transmission: f32,
    pub tint: SampledSpectrum,
    pub subsurface: f32,
    pub reflect: SampledSpectrum,
    pub transmit: SampledSpectrum,
}

impl Default for PreviewParams {
    /// UsdPreviewSurface's defaults in air, every MaterialX layer neutral.
    fn default() -> Self {
        PreviewParams {
            diffuse: SampledSpectrum::splat(0.18),
            specular_f0: SampledSpectrum::ZERO,
            metallic: 0.0,
            base_for_metal: SampledSpectrum::splat(0.18),
            roughness: 0.5,
            clearcoat: 0.0,
            clearcoat_roughness: 0.01,
            ior: 1.5,
            outside_ior: 1.0,
            use_specular_workflow: false,
            specular_weight: 1.0,
            specular_tint: SampledSpectrum::ONE,
            coat_color: SampledSpectrum::ONE,
            coat_ior: CLEARCOAT_IOR,
            coat_anisotropy: 0.0,
            coat_darkening: 0.0,
            darkening_albedo: SampledSpectrum::ZERO,
            anisotropy: 0.0,
            flavour: PbrFlavour::StandardSurface,
            diffuse_roughness: 0.0,
            sheen_weight: 0.0,
            sheen_color: SampledSpectrum::ONE,
            sheen_roughness: 0.3,
            thin_film: None,
            thin_walled: None,
        }
    }
}

/// A thin film over the specular layer, at the path's wavelengths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinFilmParams {
    /// Share of the layer the film covers, in [0, 1].
    pub weight: f32,
    pub thickness_nm: f32,
    /// The film's index.
    pub ior: f32,
    pub lambda: SampledWavelengths,
}

/// Whose definitions a MaterialX surface's layers follow: how a roughness r and an anisotropy
/// a become the GGX α along the tangent and bitangent, and which Oren–Nayar the rough diffuse
/// base is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PbrFlavour {
    /// Autodesk Standard Surface (MaterialX's `roughness_anisotropy` node): α = r², aspect
    /// √(1 − min(a, 0.98)), α_t = min(α / aspect, 1), α_b = α × aspect.
    #[default]
    StandardSurface,
    /// OpenPBR Surface: α_t = r² √(2 / (1 + (1 − a)²)), α_b = (1 − a) α_t (the mean square
    /// slope of the isotropic lobe is kept).
    OpenPbr,
}

impl PbrFlavour {
    /// The rough diffuse model MaterialX's graph of the surface asks for.
    pub fn diffuse_model(self) -> OrenNayarModel {
        match self {
            PbrFlavour::StandardSurface => OrenNayarModel::Qualitative,
            PbrFlavour::OpenPbr => OrenNayarModel::EnergyPreserving,
        }
    }

    /// (α_t, α_b) for perceptual roughness `r` and anisotropy `a`.
    pub fn alphas(self, r: f32, a: f32) -> (f32, f32) {
        let alpha = roughness_to_alpha(r);
        let a = a.clamp(0.0, 1.0);
        if a == 0.0 {
            return (alpha, alpha);
        }
        match self {
            PbrFlavour::StandardSurface => {
                let aspect = (1.0 - a.min(0.98)).sqrt();
                ((alpha / aspect).min(1.0), alpha * aspect)
            }
            PbrFlavour::OpenPbr => {
                let t = alpha * (2.0 / (1.0 + (1.0 - a) * (1.0 - a))).sqrt();
                (t, (1.0 - a) * t)
            }
        }
    }
}

/// IOR of UsdPreviewSurface's clearcoat layer.
pub const CLEARCOAT_IOR: f32 = 1.5;

/// OpenPBR's darkening of what lies under a coat, as its graph computes it: light the base
/// reflects is partly reflected back by the coat's underside (K = 1 − (1 − F0) / η² of it,
/// diffusely) and meets the base again, so the base's albedo E shows as (1 − K) / (1 − E K),
/// mixed in by coat × coat_darkening. E is the metal's (albedo × specular weight) or the
/// dielectric base's (the albedo) by metalness; a white base is not darkened.
fn coat_darkening(p: &PreviewParams, metallic: f32) -> SampledSpectrum {
    let eta = relative_ior(p.coat_ior, p.outside_ior);
    let k = 1.0 - (1.0 - f0_from_ior(eta)) / (eta * eta);
    let e = p.darkening_albedo * (1.0 - metallic + metallic * p.specular_weight);
    let dark = (SampledSpectrum::ONE - e * k).map(|v| (1.0 - k) / v.max(1e-6));
    SampledSpectrum::ONE + (dark - SampledSpectrum::ONE) * (p.clearcoat * p.coat_darkening)
}

/// A layer's index relative to what lies above it, kept just above 1 (a layer of lower index
/// than its surroundings is not modelled).
#[inline]
fn relative_ior(ior: f32, outside_ior: f32) -> f32 {
    (ior / outside_ior).max(1.0 + 1e-4)
}

/// A normal-incidence reflectance given against air, re-expressed against a medium of index
/// `outside_ior` through the dielectric index it implies.
#[inline]
fn f0_under(f0: f32, outside_ior: f32) -> f32 {
    if !(outside_ior > 1.0 + 1e-4) || f0 >= 1.0 {
        return f0;
    }
    let r = f0.max(0.0).sqrt();
    f0_from_ior(relative_ior((1.0 + r) / (1.0 - r), outside_ior))
}

#[derive(Clone, Copy, Debug)]
pub(crate) struct Preview {
    /// (weight, lobe) of the clearcoat, absent when its weight is 0.
    coat: Option<(f32, MicrofacetReflection)>,
    spec: MicrofacetReflection,
    /// The specular layer as what lies under it sees it (its reflection untinted), when a tint
    /// makes the two differ.
    untinted: Option<MicrofacetReflection>,
    /// Diffuse reflectance including the (1 − metallic) weight.
    diffuse: SampledSpectrum,
    /// The rough diffuse lobe of that reflectance, where the base is rough.
    rough_diffuse: Option<OrenNayar>,
    /// (weight, lobe) of the sheen, absent when its weight is 0.
    sheen: Option<(f32, Sheen)>,
    /// Whether the sheen lies over the coat (OpenPBR's fuzz) rather than under it.
    sheen_over_coat: bool,
    /// 1 − hemispherical average albedo of the untinted specular layer.
    spec_loss_avg: SampledSpectrum,
    /// mix(1, coat colour, coat): the coat's colour on everything beneath it.
    under_tint: SampledSpectrum,
    /// Diffuse transmittance of a thin wall's translucent base, including its weights.
    translucent: SampledSpectrum,
    /// What a thin wall lets straight through past its specular layer, including its weights.
    straight: SampledSpectrum,
}

/// Lobe indices for selection.
const COAT: usize = 0;
const SPEC: usize = 1;
const DIFF: usize = 2;
const SHEEN: usize = 3;
/// A thin wall's diffuse transmission and its straight one.
const TRANS: usize = 4;
const STRAIGHT: usize = 5;
const LOBES: usize = 6;

impl Preview {
    /// Builds the stack from validated parameters (finite, clamped).
    pub fn new(p: &PreviewParams) -> Self {
        let (alpha_t, alpha_b) = p.flavour.alphas(p.roughness, p.anisotropy);
        let distrib = TrowbridgeReitz::new(alpha_t, alpha_b);
        // Schlick's F0 and F90 of the dielectric part (weighted, then tinted) plus the metal's
        let w = p.specular_weight;
        let (dielectric_f0, metal_f0, m) = if p.use_specular_workflow {
            (p.specular_f0.map(|f0| f0_under(f0, p.outside_ior)), SampledSpectrum::ZERO, 0.0)
        } else {
            (SampledSpectrum::splat(f0_from_ior(relative_ior(p.ior, p.outside_ior))), p.base_for_metal, p.metallic)
        };
        let schlick = |tint: SampledSpectrum| (dielectric_f0 * tint * (w * (1.0 - m)) + metal_f0 * m, tint * (w * (1.0 - m)) + SampledSpectrum::splat(m));
        // the film lies over the dielectric whose normal reflectance is the untinted layer's
        // F0 / F90 (metal included), against the outside
        let film = p.thin_film.filter(|t| t.weight > 0.0).map(|t| {
            let (f0, f90) = schlick(SampledSpectrum::ONE);
            let eta = SampledSpectrum::from_fn(|i| {
                let r = (f0[i] / f90[i]).clamp(0.0, 0.99).sqrt();
                if r.is_finite() { p.outside_ior * (1.0 + r) / (1.0 - r) } else { p.outside_ior }
            });
            let n = |v: f32| SampledSpectrum::splat(v);
            let film = SpectralThinFilm::new(&t.lambda, n(p.outside_ior), n(t.ior), t.thickness_nm, eta, SampledSpectrum::ZERO);
            (film, film.average(), t.weight)
        });
        let fresnel = |tint: SampledSpectrum| {
            let (f0, f90) = schlick(tint);
            match film {
                Some((film, avg, weight)) => ReflFresnel::ThinFilm(FilmFresnel::new(film, avg, weight, f0, f90)),
                None => ReflFresnel::Schlick { f0, f90 },
            }
        };
        let spec = MicrofacetReflection::new(distrib, fresnel(p.specular_tint));
        let untinted = (p.specular_tint != SampledSpectrum::ONE).then(|| MicrofacetReflection::new(distrib, fresnel(SampledSpectrum::ONE)));
        let (diffuse, translucent, straight) = match p.thin_walled {
            Some(t) => {
                let opaque = (1.0 - t.transmission) * (1.0 - m);
                let diffuse = (p.diffuse * (1.0 - t.subsurface) + t.reflect * t.subsurface) * opaque;
                (diffuse, t.transmit * (t.subsurface * opaque), t.tint * (t.transmission * (1.0 - m)))
            }
            None => (p.diffuse * (1.0 - m), SampledSpectrum::ZERO, SampledSpectrum::ZERO),
        };
        let coat = (p.clearcoat > 0.0).then(|| {
            let (at, ab) = p.flavour.alphas(p.clearcoat_roughness, p.coat_anisotropy);
            let f0 = SampledSpectrum::splat(f0_from_ior(relative_ior(p.coat_ior, p.outside_ior)));
            (p.clearcoat, MicrofacetReflection::new(TrowbridgeReitz::new(at, ab), ReflFresnel::Schlick { f0, f90: SampledSpectrum::ONE }))
        });
        let spec_loss_avg = (SampledSpectrum::ONE - untinted.as_ref().unwrap_or(&spec).albedo_avg()).map(|v| v.max(0.0));
        let mut under_tint = SampledSpectrum::ONE + (p.coat_color - SampledSpectrum::ONE) * p.clearcoat;
        if p.clearcoat > 0.0 && p.coat_darkening > 0.0 {
            under_tint *= coat_darkening(p, m);
        }
        let rough_diffuse = (p.diffuse_roughness > 0.0).then(|| OrenNayar::new(diffuse, p.diffuse_roughness, p.flavour.diffuse_model()));
        let sheen_over_coat = p.flavour == PbrFlavour::OpenPbr;
        let sheen_weight = if sheen_over_coat { p.sheen_weight } else { p.sheen_weight * (1.0 - m) };
        let sheen = (sheen_weight > 0.0).then(|| (sheen_weight, Sheen::new(p.sheen_color, p.sheen_roughness)));
        Preview { coat, spec, untinted, diffuse, rough_diffuse, sheen, sheen_over_coat, spec_loss_avg, under_tint, translucent, straight }
    }

    pub fn lobe_flags(&self) -> u8 {
        let mut fl = self.spec.lobe_flags();
        if let Some((_, c)) = &self.coat {
            fl |= c.lobe_flags();
        }
        if !self.diffuse.is_black() {
            fl |= flags::DIFFUSE_REFLECTION;
        }
        if self.sheen.is_some() {
            fl |= flags::GLOSSY_REFLECTION;
        }
        if !self.translucent.is_black() {
            fl |= flags::DIFFUSE | flags::TRANSMISSION;
        }
        if !self.straight.is_black() {
            fl |= flags::SPECULAR_TRANSMISSION;
        }
        fl
    }

    /// Whether light may cross the surface (a thin wall's base).
    pub fn transmits(&self) -> bool {
        !(self.translucent.is_black() && self.straight.is_black())
    }

    /// What passes straight through a thin wall along ω (either way, |cosθ| = ω.z): through
    /// the layers above the base both ways and its one interface.
    pub fn straight_through(&self, w: Vec3) -> SampledSpectrum {
        if self.straight.is_black() || w.z <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        self.straight * self.spec_loss(w) * self.under(w.z, w.z)
    }

    /// The translucent base's part of [`Self::f`] towards ωi below the surface.
    fn f_translucent(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        if self.translucent.is_black() {
            return SampledSpectrum::ZERO;
        }
        let wi = Vec3::new(wi.x, wi.y, -wi.z);
        (self.translucent * INV_PI * self.spec_loss(wo) * self.spec_loss(wi)).safe_div(self.spec_loss_avg) * self.under(wo.z, wi.z)
    }

    /// What the sheen lets through to the layers under it, at μ.
    #[inline]
    fn sheen_transmittance(&self, mu: f32) -> f32 {
        self.sheen.as_ref().map_or(1.0, |(w, s)| (1.0 - w * s.albedo(mu)).max(0.0))
    }

    /// What reaches the coat and comes back: through a sheen over it, both ways.
    #[inline]
    fn above_coat(&self, mu_o: f32, mu_i: f32) -> f32 {
        match self.sheen_over_coat {
            true => self.sheen_transmittance(mu_o) * self.sheen_transmittance(mu_i),
            false => 1.0,
        }
    }

    /// What reaches the sheen and comes back: through a coat over it, both ways.
    #[inline]
    fn above_sheen(&self, mu_o: f32, mu_i: f32) -> SampledSpectrum {
        match self.sheen_over_coat {
            true => SampledSpectrum::ONE,
            false => self.under_coat(mu_o, mu_i),
        }
    }

    /// Transmittance of the clearcoat for a direction at μ.
    #[inline]
    fn coat_transmittance(&self, mu: f32) -> f32 {
        match &self.coat {
            Some((w, c)) => (1.0 - w * c.albedo(mu).average()).max(0.0),
            None => 1.0,
        }
    }

    /// What reaches the layers under the coat and comes back: the coat's transmittance both
    /// ways and its colour.
    #[inline]
    fn under_coat(&self, mu_o: f32, mu_i: f32) -> SampledSpectrum {
        self.under_tint * (self.coat_transmittance(mu_o) * self.coat_transmittance(mu_i))
    }

    /// What reaches the specular layer and the base and comes back: through the coat and
    /// the sheen, both ways.
    #[inline]
    fn under(&self, mu_o: f32, mu_i: f32) -> SampledSpectrum {
        self.under_coat(mu_o, mu_i) * (self.sheen_transmittance(mu_o) * self.sheen_transmittance(mu_i))
    }

    /// The specular layer as the base sees it (untinted).
    #[inline]
    fn seen_from_below(&self) -> &MicrofacetReflection {
        self.untinted.as_ref().unwrap_or(&self.spec)
    }

    /// What the specular layer lets through to the base along ω.
    #[inline]
    fn spec_loss(&self, w: Vec3) -> SampledSpectrum {
        (SampledSpectrum::ONE - self.seen_from_below().albedo_along(w)).map(|v| v.max(0.0))
    }

    /// [`Self::spec_loss`] at μ, for the lobe's mean roughness.
    #[inline]
    fn spec_loss_mu(&self, mu: f32) -> SampledSpectrum {
        (SampledSpectrum::ONE - self.seen_from_below().albedo(mu)).map(|v| v.max(0.0))
    }

    fn f_diffuse(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        if self.diffuse.is_black() || wo.z <= 0.0 || wi.z <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        let base = match &self.rough_diffuse {
            Some(on) => on.f(wo, wi),
            None => self.diffuse * INV_PI,
        };
        (base * self.spec_loss(wo) * self.spec_loss(wi)).safe_div(self.spec_loss_avg)
    }

    /// The sheen's part of [`Self::f`].
    #[inline]
    fn f_sheen(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        match &self.sheen {
            Some((w, s)) => s.f(wo, wi) * *w * self.above_sheen(wo.z, wi.z),
            None => SampledSpectrum::ZERO,
        }
    }

    /// Selection probabilities of (coat, spec, diffuse, sheen, translucent, straight) for ωo,
    /// proportional to estimated albedo.
    fn probabilities(&self, wo: Vec3) -> [f32; LOBES] {
        let mu_o = wo.z;
        let under = self.under(mu_o, mu_o);
        let pc = self.coat.as_ref().map_or(0.0, |(w, c)| w * c.albedo(mu_o).average() * self.above_coat(mu_o, mu_o));
        let ps = (under * self.spec.albedo_along(wo)).average();
        let loss = under * self.spec_loss(wo);
        let pd = (loss * self.diffuse).average();
        let ph = self.sheen.as_ref().map_or(0.0, |(w, s)| (self.above_sheen(mu_o, mu_o) * s.reflectance(mu_o)).average() * w);
        let pt = (loss * self.translucent).average();
        let pst = (loss * self.straight).average();
        let sum = pc + ps + pd + ph + pt + pst;
        if !(sum > 0.0) {
            return [0.0; LOBES];
        }
        [pc / sum, ps / sum, pd / sum, ph / sum, pt / sum, pst / sum]
    }

    /// The diffuse base's share of [`Self::f`] (for the light-path AOVs).
    pub fn f_diffuse_share(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        self.f_diffuse(wo, wi) * self.under(wo.z, wi.z)
    }

    pub fn f(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        if wo.z <= 0.0 || wi.z == 0.0 {
            return SampledSpectrum::ZERO;
        }
        if wi.z < 0.0 {
            return self.f_translucent(wo, wi);
        }
        let mut f = (self.spec.f(wo, wi) + self.f_diffuse(wo, wi)) * self.under(wo.z, wi.z) + self.f_sheen(wo, wi);
        if let Some((w, c)) = &self.coat {
            f += c.f(wo, wi) * (*w * self.above_coat(wo.z, wi.z));
        }
        f
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z == 0.0 || (wi.z < 0.0 && self.translucent.is_black()) {
            return 0.0;
        }
        let p = self.probabilities(wo);
        if wi.z < 0.0 {
            return p[TRANS] * -wi.z * INV_PI;
        }
        let mut pdf = p[SPEC] * self.spec.pdf(wo, wi);
        if !self.diffuse.is_black() {
            pdf += p[DIFF] * wi.z * INV_PI;
        }
        if let Some((_, c)) = &self.coat {
            pdf += p[COAT] * c.pdf(wo, wi);
        }
        if let Some((_, s)) = &self.sheen {
            pdf += p[SHEEN] * s.pdf(wo, wi);
        }
        pdf
    }

    /// The stack's delta lobes towards the mirror direction of `wo` (above the surface): their
    /// f over cosθ, as a delta sample carries it, and the probability of choosing them.
    pub fn mirror(&self, wo: Vec3) -> (SampledSpectrum, f32) {
        self.mirror_with(wo, &self.probabilities(wo))
    }

    fn mirror_with(&self, wo: Vec3, p: &[f32; LOBES]) -> (SampledSpectrum, f32) {
        // every delta lobe of the stack reflects into the same mirror direction
        let mut f = SampledSpectrum::ZERO;
        let mut pdf = 0.0;
        if self.spec.is_smooth() {
            f += self.spec.fresnel.eval(wo.z) / wo.z * self.under(wo.z, wo.z);
            pdf += p[SPEC];
        }
        if let Some((w, c)) = &self.coat {
            if c.is_smooth() {
                f += c.fresnel.eval(wo.z) / wo.z * (*w * self.above_coat(wo.z, wo.z));
                pdf += p[COAT];
            }
        }
        (f, pdf)
    }

    pub fn sample_f(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let p = self.probabilities(wo);
        let (lobe, uc) = if uc < p[COAT] {
            (COAT, uc / p[COAT])
        } else if uc < p[COAT] + p[SPEC] {
            (SPEC, (uc - p[COAT]) / p[SPEC])
        } else if uc < p[COAT] + p[SPEC] + p[DIFF] {
            (DIFF, 0.0)
        } else if uc < p[COAT] + p[SPEC] + p[DIFF] + p[SHEEN] {
            (SHEEN, 0.0)
        } else if uc < 1.0 - p[STRAIGHT] && p[TRANS] > 0.0 {
            (TRANS, 0.0)
        } else if p[STRAIGHT] > 0.0 {
            (STRAIGHT, 0.0)
        } else if let Some(last) = [SHEEN, DIFF].into_iter().find(|&l| p[l] > 0.0) {
            // rounding past the last lobe
            (last, 0.0)
        } else {
            return None;
        };
        let uc = uc.clamp(0.0, 1.0 - f32::EPSILON);
        let sampled = match lobe {
            COAT => self.coat.as_ref()?.1.sample_f(wo, uc, u)?,
            SPEC => self.spec.sample_f(wo, uc, u)?,
            SHEEN => self.sheen.as_ref()?.1.sample_f(wo, u)?,
            STRAIGHT => {
                let f = self.straight_through(wo) / wo.z;
                return Some(BsdfSample { f, wi: -wo, pdf: p[STRAIGHT], flags: flags::SPECULAR_TRANSMISSION, eta: 1.0 });
            }
            TRANS => {
                let s = Lambert { reflectance: self.translucent }.sample_f(wo, u)?;
                BsdfSample { wi: Vec3::new(s.wi.x, s.wi.y, -s.wi.z), flags: flags::DIFFUSE | flags::TRANSMISSION, ..s }
            }
            _ => Lambert { reflectance: self.diffuse }.sample_f(wo, u)?,
        };
        if sampled.flags & flags::SPECULAR != 0 {
            let (f, pdf) = self.mirror_with(wo, &p);
            return Some(BsdfSample { f, pdf, ..sampled });
        }
        let wi = sampled.wi;
        let pdf = self.pdf(wo, wi);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample { f: self.f(wo, wi), wi, pdf, flags: sampled.flags, eta: 1.0 })
    }

    /// Rough reflectance at normal incidence for the albedo AOV.
    pub fn albedo_hint(&self) -> SampledSpectrum {
        self.albedo_at(1.0)
    }

    /// Estimated directional albedo at μ (the layers' albedos, as the lobe selection uses them).
    pub fn albedo_at(&self, mu: f32) -> SampledSpectrum {
        let coat = self.coat.as_ref().map_or(SampledSpectrum::ZERO, |(w, c)| c.albedo(mu) * (*w * self.above_coat(mu, mu)));
        let sheen = self.sheen.as_ref().map_or(SampledSpectrum::ZERO, |(w, s)| s.reflectance(mu) * *w * self.above_sheen(mu, mu));
        coat + sheen + (self.spec.albedo(mu) + self.diffuse * self.spec_loss_mu(mu)) * self.under(mu, mu)
    }

    /// Directional albedo of the diffuse base as it shows through the layers above it at μ.
    pub fn diffuse_albedo(&self, mu: f32) -> SampledSpectrum {
        self.diffuse * self.spec_loss_mu(mu) * self.under(mu, mu)
    }
}
