//! Trowbridge–Reitz (GGX) microfacet distribution with anisotropic roughness, Smith
//! height-correlated masking–shadowing, and visible-normal sampling by spherical caps
//! (Dupuy & Benyoub 2023), all in the local shading frame (normal = +Z).

use crate::math::{sqr, PI};
use glam::{Vec2, Vec3};

/// Below this alpha (on both axes) a microfacet lobe is treated as a perfect specular lobe.
pub const SMOOTH_ALPHA: f32 = 1e-3;

/// Smallest alpha used in evaluation, so that nearly-degenerate anisotropic lobes stay finite.
const MIN_ALPHA: f32 = 1e-4;

/// Maps perceptual roughness in [0, 1] to the GGX alpha: α = roughness². The squared mapping
/// makes the perceived blur change roughly linearly with the parameter (Burley 2012).
#[inline]
pub fn roughness_to_alpha(roughness: f32) -> f32 {
    let r = roughness.clamp(0.0, 1.0);
    r * r
}

/// GGX distribution of microfacet normals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrowbridgeReitz {
    pub alpha_x: f32,
    pub alpha_y: f32,
}

impl TrowbridgeReitz {
    pub fn new(alpha_x: f32, alpha_y: f32) -> Self {
        TrowbridgeReitz { alpha_x, alpha_y }
    }

    /// True when the lobe is close enough to a mirror to be handled as a delta.
    #[inline]
    pub fn is_smooth(&self) -> bool {
        self.alpha_x.max(self.alpha_y) < SMOOTH_ALPHA
    }

    #[inline]
    fn ax(&self) -> f32 {
        self.alpha_x.max(MIN_ALPHA)
    }
    #[inline]
    fn ay(&self) -> f32 {
        self.alpha_y.max(MIN_ALPHA)
    }

    /// Effective isotropic alpha (geometric mean) used to index albedo tables.
    #[inline]
    pub fn alpha_iso(&self) -> f32 {
        (self.ax() * self.ay()).sqrt()
    }

    /// Density of microfacet normals D(ωm) (projected-area normalised: ∫ D cosθm dωm = 1).
    #[inline]
    pub fn d(&self, wm: Vec3) -> f32 {
        if wm.z <= 0.0 {
            return 0.0;
        }
        let (ax, ay) = (self.ax(), self.ay());
        let t = sqr(wm.x / ax) + sqr(wm.y / ay) + sqr(wm.z);
        1.0 / (PI * ax * ay * t * t)
    }

    /// Smith Λ(ω).
    #[inline]
    pub fn lambda(&self, w: Vec3) -> f32 {
        let z2 = w.z * w.z;
        if z2 == 0.0 {
            return f32::INFINITY;
        }
        let a2t2 = (sqr(self.ax() * w.x) + sqr(self.ay() * w.y)) / z2;
        0.5 * ((1.0 + a2t2).sqrt() - 1.0)
    }

    /// Masking G1(ω).
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking–shadowing G2(ωo, ωi).
    #[inline]
    pub fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Density of normals visible from ω: G1(ω)/|cosθ| · D(ωm) · max(0, ω·ωm), with ω taken on
    /// the upper side (ω below the surface sees the distribution from −ω). This is the pdf of
    /// [`Self::sample_wm`].
    #[inline]
    pub fn pdf_visible(&self, w: Vec3, wm: Vec3) -> f32 {
        let c = w.z.abs();
        if c == 0.0 {
            return 0.0;
        }
        self.g1(w) / c * self.d(wm) * (w.dot(wm) * w.z.signum()).max(0.0)
    }

    /// Samples a normal visible from ω (ω on either side; the result is in the upper hemisphere).
    pub fn sample_wm(&self, w: Vec3, u: Vec2) -> Vec3 {
        let (ax, ay) = (self.ax(), self.ay());
        let mut wh = Vec3::new(ax * w.x, ay * w.y, w.z).normalize_or(Vec3::Z);
        if wh.z < 0.0 {
            wh = -wh;
        }
        // uniform point on the spherical cap of the unit sphere seen from wh
        let phi = 2.0 * PI * u.x;
        let z = (1.0 - u.y) * (1.0 + wh.z) - wh.z;
        let s = (1.0 - z * z).max(0.0).sqrt();
        let (sp, cp) = phi.sin_cos();
        let h = Vec3::new(s * cp, s * sp, z) + wh;
        Vec3::new(ax * h.x, ay * h.y, h.z.max(1e-6)).normalize_or(Vec3::Z)
    }
}

/// Mirror reflection of ω about the normal n.
#[inline]
pub fn reflect(w: Vec3, n: Vec3) -> Vec3 {
    -w + 2.0 * w.dot(n) * n
}

/// Refraction of ω (pointing away from the surface) through the interface with normal n and
/// relative IOR `eta` = n_(side opposite n) / n_(side of n). Returns the refracted direction and
/// the relative IOR actually crossed, or None under total internal reflection.
#[inline]
pub fn refract(w: Vec3, n: Vec3, eta: f32) -> Option<(Vec3, f32)> {
    let mut cos_i = n.dot(w);
    let mut eta = eta;
    let mut n = n;
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
        n = -n;
    }
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-w / eta + (cos_i / eta - cos_t) * n, eta))
}
