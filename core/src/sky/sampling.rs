//! Importance sampling of the sky dome: a piecewise-constant 2D distribution over (azimuth
//! about the zenith measured from the sun's azimuth, zenith angle θ ∈ [0, π/2]) proportional to
//! the sky's luminance × sin θ, tabulated once per sky. Only the upper hemisphere is sampled;
//! the pdf is 0 below the horizon, where the sky emits nothing.

use glam::{Vec2, Vec3};

use super::model::HosekWilkieSky;
use crate::light::distrib::Distribution2D;
use crate::math::{Frame, PI};

/// Rows of the table in θ over [0, π/2] (1.4° each).
pub const SKY_THETA_RES: usize = 64;
/// Columns of the table in azimuth over [0, 2π) (2.8° each).
pub const SKY_PHI_RES: usize = 128;
/// Luminance evaluations per cell and axis (the cell's weight is their mean × sin θ).
const SUPERSAMPLE: usize = 2;

/// Sampler of directions on the sky dome with density ∝ the tabulated luminance.
#[derive(Clone, Debug, PartialEq)]
pub struct SkySampler {
    /// +Z: the zenith; +X: the horizontal direction of the sun's azimuth.
    frame: Frame,
    distrib: Distribution2D,
    /// ∫ luminance dω over the sky (Tide luminance × sr), from the table.
    luminance_integral: f32,
}

impl SkySampler {
    pub fn new(sky: &HosekWilkieSky) -> SkySampler {
        let z = sky.zenith();
        let s = sky.to_sun();
        let h = s - z * z.dot(s);
        let frame = if h.length_squared() > 1e-12 { Frame::from_normal_tangent(z, h) } else { Frame::from_normal(z) };
        let mut func = Vec::with_capacity(SKY_THETA_RES * SKY_PHI_RES);
        for iv in 0..SKY_THETA_RES {
            for iu in 0..SKY_PHI_RES {
                let mut acc = 0.0f64;
                for a in 0..SUPERSAMPLE {
                    let v = (iv as f32 + (a as f32 + 0.5) / SUPERSAMPLE as f32) / SKY_THETA_RES as f32;
                    let (st, ct) = (v * 0.5 * PI).sin_cos();
                    for b in 0..SUPERSAMPLE {
                        let u = (iu as f32 + (b as f32 + 0.5) / SUPERSAMPLE as f32) / SKY_PHI_RES as f32;
                        let (sp, cp) = (2.0 * PI * u).sin_cos();
                        let d = frame.to_world(Vec3::new(st * cp, st * sp, ct));
                        acc += (sky.luminance(d) * st) as f64;
                    }
                }
                func.push((acc / (SUPERSAMPLE * SUPERSAMPLE) as f64) as f32);
            }
        }
        let distrib = Distribution2D::new(&func, SKY_PHI_RES, SKY_THETA_RES);
        // dω = sin θ dθ dφ = (π/2)(2π) sin θ du dv
        let luminance_integral = distrib.integral() * PI * PI;
        SkySampler { frame, distrib, luminance_integral }
    }

    /// ∫ luminance dω over the dome (Tide luminance × sr) as tabulated.
    pub fn luminance_integral(&self) -> f32 {
        self.luminance_integral
    }

    /// A direction and its solid-angle density from `u` ∈ [0, 1)²; None only for the
    /// measure-zero case of landing exactly on the zenith.
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, f32)> {
        let (uv, p) = self.distrib.sample([u.x, u.y]);
        let (st, ct) = (uv[1] * 0.5 * PI).sin_cos();
        if !(st > 0.0 && p > 0.0) {
            return None;
        }
        let (sp, cp) = (2.0 * PI * uv[0]).sin_cos();
        let d = self.frame.to_world(Vec3::new(st * cp, st * sp, ct)).normalize();
        Some((d, p / (PI * PI * st)))
    }

    /// Solid-angle density of unit `dir` (0 below the horizon).
    pub fn pdf(&self, dir: Vec3) -> f32 {
        let l = self.frame.to_local(dir);
        if !(l.z >= 0.0) {
            return 0.0;
        }
        let st = (l.x * l.x + l.y * l.y).sqrt();
        if !(st > 0.0) {
            return 0.0;
        }
        let theta = st.atan2(l.z);
        let mut phi = l.y.atan2(l.x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let u = (phi / (2.0 * PI)).min(1.0);
        let v = (theta / (0.5 * PI)).min(1.0);
        self.distrib.pdf([u, v]) / (PI * PI * st)
    }
}
