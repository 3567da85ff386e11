//! UsdLuxShapingAPI: a light's emission shaped by direction (a spot light's cone, its soft
//! edge, the focus and its tint).
//!
//! With θ the angle between the emission direction `w` (leaving the light) and the light's
//! primary axis (its local −Z), the emitted radiance (or a point light's intensity) is
//! multiplied by, as UsdLux states it:
//!
//! - the cone: 0 beyond θc = `shaping:cone:angle`; with `shaping:cone:softness` s ∈ [0, 1]
//!   (clamped), 1 − smoothstep(θ; θs, θc) with θs = (1 − s) θc, so the edge fades over the
//!   last fraction s of the cone (s = 0: a hard edge, full emission for θ ≤ θc);
//! - the focus: f = |cos θ|^`shaping:focus` (focus ≤ 0: none), tinted by
//!   `shaping:focusTint` t as lerp(f, t, 1) = t + f (1 − t) per wavelength (t uplifted as a
//!   reflectance; black, the default, gives f itself, white disables the focus).
//!
//! - the IES profile (`shaping:ies:file`, [`super::ies`]): its candela at the vertical angle
//!   v/(1 + `shaping:ies:angleScale`) from the nadir (the axis; the schema's scaling about the
//!   axis, angleScale clipped at −1) and the horizontal angle of `w` about the axis, measured in
//!   the light's local XY plane from +X towards +Y; with `shaping:ies:normalize`, divided by
//!   the profile's mean intensity (over the sphere, or the hemisphere for downlight-only files).
//!   Candela multiply the light's emission as they are: the profile is photometric, as UsdLux
//!   states it.
//!
//! A planar light (rect, disk) takes its emitting normal as the axis (the same as its −Z
//! unless its transform shears it). Sampling is not changed by the shaping: samples are
//! weighted by it (a light sample outside the cone carries nothing).
//!
//! Power: the shaped light emits Kf + t(λ)(Kc − Kf) of its unshaped power, where
//! Kc = ∫cone·w dω / ∫w dω and Kf = ∫cone·f·w dω / ∫w dω, `w` being how the light's
//! unshaped power spreads over directions (a point or sphere light: uniformly; a planar light:
//! as the cosine to its normal; a cylinder: as the sine to its length). Both are computed
//! once, by composite Simpson quadrature in θ split at the cone's and the focus's kinks (and
//! graded towards each piece's ends).

use glam::Vec3;

use super::PI;
use super::ies::IesProfile;
use crate::math::Frame;
use crate::scene::{ColorSpace, ShapingDesc};
use crate::spectrum::{color, uplift, SampledSpectrum, SampledWavelengths, Spectrum};

/// How a light's unshaped power spreads over emission directions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Spread {
    /// Evenly over the sphere (point and sphere lights).
    Uniform,
    /// As max(0, n·w) (one-sided planar lights of unit normal `n`).
    Cosine(Vec3),
    /// As the projected area of an open cylinder of unit axis `a`: √(1 − (a·w)²).
    Cylinder(Vec3),
}

impl Spread {
    #[inline]
    fn weight(&self, w: Vec3) -> f64 {
        match *self {
            Spread::Uniform => 1.0,
            Spread::Cosine(n) => n.dot(w).max(0.0) as f64,
            Spread::Cylinder(a) => (1.0 - (a.dot(w) as f64).powi(2)).max(0.0).sqrt(),
        }
    }
}

/// A light's shaping, in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct Shaping {
    /// Unit primary axis (the direction the light points at).
    pub axis: Vec3,
    /// Soft edge start θs and cutoff θc (radians); θc ≥ π: no cone.
    theta_start: f32,
    theta_cut: f32,
    cos_start: f32,
    cos_cut: f32,
    /// Cosine power (0: no focus).
    focus: f32,
    /// Focus tint; None for black (the default).
    tint: Option<Spectrum>,
    /// Luminance of the tint (relative: white = 1).
    tint_y: f32,
    /// Shares of the unshaped power kept by the cone alone (Kc) and by the cone and focus (Kf),
    /// each with the IES profile.
    keep_cone: f32,
    keep_focus: f32,
    /// The profile, the light's local X and Y (unit, perpendicular to the axis; the axis is
    /// its −Z), 1 / (1 + angleScale), and the factor dividing the candela.
    ies: Option<Ies>,
}

#[derive(Clone, Debug, PartialEq)]
struct Ies {
    profile: std::sync::Arc<IesProfile>,
    x: Vec3,
    y: Vec3,
    inv_scale: f32,
    inv_norm: f32,
}

impl Ies {
    /// Candela (÷ the normalisation) along unit `w`, whose cosine to the axis is `c`.
    #[inline]
    fn value(&self, w: Vec3, c: f32) -> f32 {
        let v = (c.clamp(-1.0, 1.0).acos() * self.inv_scale).min(std::f32::consts::PI);
        let h = w.dot(self.y).atan2(w.dot(self.x));
        self.profile.eval(v, h) * self.inv_norm
    }
}

/// Composite Simpson intervals per piece of θ.
const SIMPSON: usize = 256;
/// Midpoints in φ when the integrand depends on it.
const PHI_STEPS: usize = 128;

impl Shaping {
    /// The shaping of a light whose primary axis is `axis` (unit) and whose unshaped power
    /// spreads as `spread`. None when the description shapes nothing (cone ≥ 180°, no focus).
    /// Errors name the attribute (non-finite values).
    #[cfg(test)]
    pub(crate) fn new(desc: &ShapingDesc, axis: Vec3, spread: Spread, cs: ColorSpace) -> Result<Option<Shaping>, String> {
        Shaping::with_frame(desc, axis, Vec3::X, spread, cs)
    }

    /// [`Shaping::new`] for a light whose local X is `x` (world; made perpendicular to the
    /// axis), which orients an IES profile's horizontal angles.
    pub(crate) fn with_frame(desc: &ShapingDesc, axis: Vec3, x: Vec3, spread: Spread, cs: ColorSpace) -> Result<Option<Shaping>, String> {
        let finite = |name: &str, v: f32| if v.is_finite() { Ok(v) } else { Err(format!("{name}: not a finite number ({v})")) };
        let angle = finite("shaping:cone:angle", desc.cone_angle_deg)?.clamp(0.0, 180.0);
        let softness = finite("shaping:cone:softness", desc.cone_softness)?.clamp(0.0, 1.0);
        let focus = finite("shaping:focus", desc.focus)?.max(0.0);
        for &c in &desc.focus_tint {
            finite("shaping:focusTint", c)?;
        }
        let tint_rgb = desc.focus_tint.map(|c| c.max(0.0));
        let angle_scale = finite("shaping:ies:angleScale", desc.ies_angle_scale)?.max(-1.0);
        if angle >= 180.0 && (focus == 0.0 || tint_rgb == [1.0; 3]) && desc.ies.is_none() {
            return Ok(None);
        }
        let Some(axis) = axis.try_normalize() else { return Err("transform: collapses the light's axis".into()) };
        let ies = match &desc.ies {
            None => None,
            Some(profile) => {
                let x = (x - axis * x.dot(axis)).try_normalize().unwrap_or_else(|| Frame::from_normal(axis).s);
                // local Y = local Z × local X with local Z = −axis
                let y = (-axis).cross(x);
                let norm = if desc.ies_normalize { profile.mean_intensity() } else { 1.0 };
                if !(norm > 0.0) {
                    return Err("shaping:ies:file: the profile emits nothing, so it cannot be normalised".into());
                }
                Some(Ies { profile: profile.clone(), x, y, inv_scale: 1.0 / (1.0 + angle_scale).max(1e-6), inv_norm: 1.0 / norm })
            }
        };
        let theta_cut = if angle >= 180.0 { PI } else { angle.to_radians() };
        let theta_start = (1.0 - softness) * theta_cut;
        let (tint, tint_y) = if focus == 0.0 || tint_rgb == [0.0; 3] {
            (None, 0.0)
        } else if tint_rgb.iter().all(|&c| c <= 1.0) {
            (Some(uplift::albedo(tint_rgb, cs)), color::luminance(tint_rgb, cs))
        } else {
            (Some(uplift::unbounded(tint_rgb, cs)), color::luminance(tint_rgb, cs))
        };
        let mut s = Shaping {
            axis,
            theta_start,
            theta_cut,
            cos_start: theta_start.cos(),
            cos_cut: if angle >= 180.0 { -2.0 } else { theta_cut.cos() },
            focus,
            tint,
            tint_y,
            keep_cone: 1.0,
            keep_focus: 1.0,
            ies,
        };
        let (kc, kf) = s.keep(spread);
        s.keep_cone = kc;
        s.keep_focus = kf;
        Ok(Some(s))
    }

    /// cos θc when the cone is narrower than a hemisphere (θc < 90°): emission sampling then
    /// draws its directions within the cone, outside which the light sends nothing.
    #[inline]
    pub fn steering_cos(&self) -> Option<f32> {
        (self.cos_cut > 0.0).then_some(self.cos_cut)
    }

    /// The cone the light emits within, where its cone cuts (θc < π): (axis, θc). Nothing
    /// leaves along a direction further than θc from the axis, whatever the focus and the
    /// IES profile.
    pub fn emission_cone(&self) -> Option<(Vec3, f32)> {
        (self.theta_cut < std::f32::consts::PI).then_some((self.axis, self.theta_cut))
    }

    /// The cone's factor at cos θ (1 − smoothstep from θs to θc).
    #[inline]
    pub fn cone(&self, cos_t: f32) -> f32 {
        if cos_t >= self.cos_start {
            return 1.0;
        }
        if cos_t < self.cos_cut || self.theta_cut <= self.theta_start {
            return 0.0;
        }
        let theta = cos_t.clamp(-1.0, 1.0).acos();
        let t = ((theta - self.theta_start) / (self.theta_cut - self.theta_start)).clamp(0.0, 1.0);
        1.0 - t * t * (3.0 - 2.0 * t)
    }

    /// The focus factor |cos θ|^focus.
    #[inline]
    pub fn focus(&self, cos_t: f32) -> f32 {
        if self.focus > 0.0 {
            cos_t.abs().powf(self.focus)
        } else {
            1.0
        }
    }

    /// The factor on the radiance leaving the light along unit `w`.
    #[inline]
    pub fn factor(&self, w: Vec3, lambda: &SampledWavelengths) -> SampledSpectrum {
        let c = w.dot(self.axis);
        let k = self.cone(c);
        if !(k > 0.0) {
            return SampledSpectrum::ZERO;
        }
        let k = match &self.ies {
            Some(ies) => k * ies.value(w, c),
            None => k,
        };
        let f = self.focus(c);
        match &self.tint {
            None => SampledSpectrum::splat(k * f),
            Some(t) => (t.sample(lambda) * (1.0 - f) + SampledSpectrum::splat(f)) * k,
        }
    }

    /// Share of the unshaped power the light still emits, per wavelength.
    pub fn power_ratio(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        let d = self.keep_cone - self.keep_focus;
        match &self.tint {
            None => SampledSpectrum::splat(self.keep_focus),
            Some(t) => t.sample(lambda) * d + SampledSpectrum::splat(self.keep_focus),
        }
    }

    /// Share of the unshaped power the light still emits, luminance-weighted (the tint taken
    /// at its luminance).
    pub fn power_ratio_y(&self) -> f32 {
        self.keep_focus + self.tint_y * (self.keep_cone - self.keep_focus)
    }

    /// (Kc, Kf) for `spread` (see the module documentation).
    fn keep(&self, spread: Spread) -> (f32, f32) {
        let frame = Frame::from_normal(self.axis);
        let phi_dependent = match spread {
            Spread::Uniform => false,
            Spread::Cosine(n) => n.dot(self.axis) < 1.0 - 1e-6,
            Spread::Cylinder(_) => true,
        } || self.ies.as_ref().is_some_and(|i| !i.profile.is_axial());
        let phi_steps = if self.ies.is_some() { 4 * PHI_STEPS } else { PHI_STEPS };
        // ∫ over φ at θ of (w, cone·w, cone·focus·w), times sin θ
        // the cone is evaluated in θ, at a point nudged into the piece, so that each piece sees
        // its own side of a hard edge
        let (ts, tc) = (self.theta_start as f64, self.theta_cut as f64);
        let cone_at = |theta: f64| -> f64 {
            if theta <= ts {
                1.0
            } else if theta >= tc {
                0.0
            } else {
                let t = (theta - ts) / (tc - ts);
                1.0 - t * t * (3.0 - 2.0 * t)
            }
        };
        let ring = |theta: f64, inside: f64| -> [f64; 3] {
            let (st, ct) = theta.sin_cos();
            let cone = cone_at(inside);
            let focus = self.focus(ct as f32) as f64;
            // (spread weight, weight × profile) along the direction at φ
            let at = |phi: f64| {
                let (sp, cp) = phi.sin_cos();
                let w = frame.to_world(Vec3::new((st * cp) as f32, (st * sp) as f32, ct as f32));
                let weight = spread.weight(w);
                let ies = self.ies.as_ref().map_or(1.0, |i| i.value(w, ct as f32) as f64);
                (weight, weight * ies)
            };
            let (w, wi) = if phi_dependent {
                let h = 2.0 * std::f64::consts::PI / phi_steps as f64;
                (0..phi_steps).map(|i| at((i as f64 + 0.5) * h)).fold((0.0, 0.0), |a, b| (a.0 + b.0 * h, a.1 + b.1 * h))
            } else {
                let (a, b) = at(0.0);
                (a * 2.0 * std::f64::consts::PI, b * 2.0 * std::f64::consts::PI)
            };
            [w * st, cone * wi * st, cone * focus * wi * st]
        };
        // pieces split where the integrand has kinks or narrow features
        let pi = std::f64::consts::PI;
        let mut cuts = vec![0.0, pi, 0.5 * pi, self.theta_start as f64, self.theta_cut as f64];
        if self.focus > 1.0 {
            let width = (4.0 / self.focus as f64).sqrt();
            if width < 0.5 * pi {
                cuts.push(width);
            }
        }
        if let Some(ies) = &self.ies {
            // the profile's kinks, where the scaled vertical angle meets the file's angles
            let scale = 1.0 / ies.inv_scale as f64;
            cuts.extend(ies.profile.vertical_angles().iter().map(|&v| v as f64 * scale));
        }
        cuts.retain(|c| (0.0..=pi).contains(c));
        cuts.sort_by(|a, b| a.total_cmp(b));
        cuts.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
        // each piece is mapped from u ∈ [0, 1] by the quintic smoothstep g(u) = u³(10 − 15u + 6u²)
        // (g' = 30u²(1 − u)²), which crowds the nodes towards the ends: a kink such as
        // |cos θ|^focus at 90° for a focus below 1 becomes smooth in u
        let mut acc = [0.0f64; 3];
        // intervals per piece: fewer when a profile brings many pieces (even, at least 8)
        let per = (SIMPSON.min(4096 / cuts.len().max(1)).max(8) / 2) * 2;
        let h = 1.0 / per as f64;
        for w in cuts.windows(2) {
            let (a, b) = (w[0], w[1]);
            for i in 1..per {
                let u = h * i as f64;
                let coef = if i % 2 == 1 { 4.0 } else { 2.0 };
                let g = u * u * u * (10.0 + u * (6.0 * u - 15.0));
                let dg = 30.0 * u * u * (1.0 - u) * (1.0 - u);
                let theta = a + (b - a) * g;
                let v = ring(theta, theta.clamp(a + 1e-9 * (b - a), b - 1e-9 * (b - a)));
                for k in 0..3 {
                    acc[k] += coef * h / 3.0 * (b - a) * dg * v[k];
                }
            }
        }
        if !(acc[0] > 0.0) {
            return (0.0, 0.0);
        }
        ((acc[1] / acc[0]) as f32, (acc[2] / acc[0]) as f32)
    }
}

#[cfg(test)]
#[path = "shaping/tests.rs"]
mod tests;
