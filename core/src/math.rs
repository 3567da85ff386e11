//! Small geometric helpers shared by every module: orthonormal frames, spherical
//! directions and robust ray-origin offsetting.

use glam::{Vec2, Vec3};

pub const PI: f32 = std::f32::consts::PI;
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
pub const INV_2PI: f32 = 0.5 * std::f32::consts::FRAC_1_PI;
pub const INV_4PI: f32 = 0.25 * std::f32::consts::FRAC_1_PI;
/// The largest f32 below one: where a uniform number in [0, 1) is rescaled, it stays below one.
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// An orthonormal basis. Local shading space has the normal along +Z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Builds a frame around the unit vector `n` (Duff et al. 2017, branchless).
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// Builds a frame from a normal and a (not necessarily orthogonal) tangent hint.
    pub fn from_normal_tangent(n: Vec3, tangent: Vec3) -> Self {
        let s = tangent - n * n.dot(tangent);
        let len = s.length();
        if !(len > 1e-6) || !len.is_finite() {
            return Self::from_normal(n);
        }
        let s = s / len;
        Frame { s, t: n.cross(s), n }
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// ∂p/∂u over a triangle with corners `p` at texture coordinates `uv` (its first edge where
/// the coordinates are degenerate).
pub fn triangle_dpdu(p: [Vec3; 3], uv: [Vec2; 3]) -> Vec3 {
    let (du1, du2) = (uv[1] - uv[0], uv[2] - uv[0]);
    let det = du1.x * du2.y - du1.y * du2.x;
    if det.abs() > 1e-12 { ((p[1] - p[0]) * du2.y - (p[2] - p[0]) * du1.y) / det } else { p[1] - p[0] }
}

/// Direction from spherical coordinates (theta from +Z, phi from +X towards +Y).
#[inline]
pub fn spherical_direction(sin_theta: f32, cos_theta: f32, phi: f32) -> Vec3 {
    let (sp, cp) = phi.sin_cos();
    Vec3::new(sin_theta.clamp(-1.0, 1.0) * cp, sin_theta.clamp(-1.0, 1.0) * sp, cos_theta.clamp(-1.0, 1.0))
}

/// Polar angle theta of a unit vector (about +Z).
#[inline]
pub fn spherical_theta(v: Vec3) -> f32 {
    safe_acos(v.z)
}

/// Azimuth phi in [0, 2π) of a vector (about +Z, from +X).
#[inline]
pub fn spherical_phi(v: Vec3) -> f32 {
    let p = v.y.atan2(v.x);
    if p < 0.0 {
        p + 2.0 * PI
    } else {
        p
    }
}

#[inline]
pub fn safe_acos(x: f32) -> f32 {
    x.clamp(-1.0, 1.0).acos()
}

/// The angle between unit vectors `a` and `b`, accurate for small angles too: 2·atan2(|a − b|,
/// |a + b|). (acos of the dot product, as glam's `angle_between`, loses them: the cosine of a
/// pixel's angle is within a few single-precision steps of 1.)
#[inline]
pub fn angle_between(a: Vec3, b: Vec3) -> f32 {
    2.0 * (a - b).length().atan2((a + b).length())
}

#[inline]
pub fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

#[inline]
pub fn sqr(x: f32) -> f32 {
    x * x
}

#[inline]
pub fn lerp(t: f32, a: f32, b: f32) -> f32 {
    (1.0 - t) * a + t * b
}

/// Uniform sample of the unit disk by Shirley–Chiu concentric mapping.
pub fn sample_concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, (PI / 4.0) * (o.y / o.x))
    } else {
        (o.y, PI / 2.0 - (PI / 4.0) * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Cosine-weighted hemisphere sample about +Z; pdf = cosθ/π.
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = sample_concentric_disk(u);
    let z = safe_sqrt(1.0 - d.x * d.x - d.y * d.y);
    Vec3::new(d.x, d.y, z)
}

/// Uniform direction on the sphere; pdf = 1/(4π).
pub fn sample_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = safe_sqrt(1.0 - z * z);
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform direction inside the cone of half-angle acos(cos_max) about +Z;
/// pdf = 1 / (2π (1 − cos_max)).
pub fn sample_uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let cos_t = (1.0 - u.x) + u.x * cos_max;
    let sin_t = safe_sqrt(1.0 - cos_t * cos_t);
    let phi = u.y * 2.0 * PI;
    Vec3::new(phi.cos() * sin_t, phi.sin() * sin_t, cos_t)
}

#[inline]
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max))
}

/// Power heuristic (β = 2) for multiple importance sampling.
#[inline]
pub fn power_heuristic(nf: f32, f_pdf: f32, ng: f32, g_pdf: f32) -> f32 {
    let f = nf * f_pdf;
    let g = ng * g_pdf;
    if f.is_infinite() {
        return 1.0;
    }
    let d = f * f + g * g;
    if d == 0.0 {
        0.0
    } else {
        f * f / d
    }
}

/// γ(n) = nu/(1 − nu), u = 2⁻²⁴ the unit roundoff of f32: the relative error bound of n
/// rounded operations (Higham; pbrt's error analysis uses the same bound).
#[inline]
pub const fn gamma(n: u32) -> f32 {
    let nu = n as f32 * (f32::EPSILON * 0.5);
    nu / (1.0 - nu)
}

/// An error bound for a point computed in a few rounded operations from values of its own
/// magnitude (a light's sample point, a point sampled on a surface): γ(8)·|p| per component.
#[inline]
pub fn point_error(p: Vec3) -> Vec3 {
    p.abs() * gamma(8)
}

/// The error bound of `m·p` for an affine `m` and a point `p` carrying the bound `err`:
/// `|M|·err` grown by the product's rounding, plus the rounding of the product itself
/// (γ(8), which also covers the round trip through the inverse that takes a ray back into the
/// object's space).
#[inline]
pub fn transformed_error(m: &glam::Mat4, p: Vec3, err: Vec3) -> Vec3 {
    let a = glam::Mat3::from_cols(m.x_axis.truncate().abs(), m.y_axis.truncate().abs(), m.z_axis.truncate().abs());
    a * err * (1.0 + gamma(3)) + (a * p.abs() + m.w_axis.truncate().abs()) * gamma(8)
}

/// Offsets a ray origin off a surface so that the new ray cannot meet the surface it leaves
/// again, while staying as close as the arithmetic allows, so that it cannot tunnel through
/// thin shells or miss a contact shadow. `p` is the computed point and `err` the bound of its
/// error per component (the hit's [`crate::world::SurfaceHit::err`], or [`point_error`]): the
/// origin moves along the geometric normal `n` (flipped to the side the new ray leaves towards)
/// past the box of that error, then one float further away from `p` in each component. The
/// offset follows the point's own precision: a micrometre droplet and an ocean mesh kilometres
/// from the origin alike (pbrt-v4's `OffsetRayOrigin` reasoning; twice its distance, as the
/// intersectors are not written with conservative rounding).
#[inline]
pub fn offset_ray_origin(p: Vec3, err: Vec3, n: Vec3) -> Vec3 {
    // at least the smallest normal float, so that a point computed exactly (an axis-aligned
    // plane's) still steps one float off its surface
    let d = (2.0 * n.abs().dot(err)).max(f32::MIN_POSITIVE);
    let offset = n * d;
    let po = p + offset;
    let away = |x: f32, o: f32| {
        if o > 0.0 {
            x.next_up()
        } else if o < 0.0 {
            x.next_down()
        } else {
            x
        }
    };
    Vec3::new(away(po.x, offset.x), away(po.y, offset.y), away(po.z, offset.z))
}

/// Offset towards the side of `n` that `w` points into.
#[inline]
pub fn offset_towards(p: Vec3, err: Vec3, ng: Vec3, w: Vec3) -> Vec3 {
    if ng.dot(w) >= 0.0 {
        offset_ray_origin(p, err, ng)
    } else {
        offset_ray_origin(p, err, -ng)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angle_between_unit_vectors_holds_small_angles() {
        // a pixel's angle at 1920 pixels over 90° and smaller, about a turned axis: within
        // 2·10⁻⁵ of the exact angle (acos of the dot product is 12 % off at 7.8·10⁻⁴)
        let axis = glam::Quat::from_euler(glam::EulerRot::XYZ, -0.28, 0.4, 0.1);
        for step in [1.0f64, 1e-1, 1e-2, 7.8e-4, 1e-4, 1e-5] {
            let (a, b) = (axis * Vec3::new(0.0, 0.0, -1.0), axis * Vec3::new(step.tan() as f32, 0.0, -1.0).normalize());
            let got = angle_between(a, b) as f64;
            assert!((got - step).abs() <= 2e-5 * step + 1e-7, "{step}: {got}");
        }
        assert_eq!(angle_between(Vec3::X, Vec3::X), 0.0);
        assert!((angle_between(Vec3::X, -Vec3::X) - std::f32::consts::PI).abs() < 1e-6);
    }

    #[test]
    fn frame_is_orthonormal_for_every_octant() {
        for &n in &[Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Z, Vec3::new(0.3, -0.4, -0.866).normalize(), Vec3::new(1e-8, 0.0, -1.0).normalize()] {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(f.n).abs() < 1e-5 && f.t.dot(f.n).abs() < 1e-5);
            let v = Vec3::new(0.2, -0.7, 0.4);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn offset_moves_off_the_plane_on_the_right_side_at_any_scale() {
        for &scale in &[1e-9f32, 1e-4, 1.0, 1e3, 1e5] {
            let p = Vec3::new(0.37, 0.0, -0.81) * scale;
            let e = point_error(p);
            for n in [Vec3::Y, Vec3::new(0.3, 0.9, -0.2).normalize()] {
                let q = offset_ray_origin(p, e, n);
                assert!((q - p).dot(n) > 0.0, "scale {scale}: {q:?}");
                // close: within a few dozen ulps of the point's size, wherever it is
                assert!((q - p).length() < 64.0 * f32::EPSILON * p.length(), "scale {scale}: {:?}", q - p);
                let q2 = offset_ray_origin(p, e, -n);
                assert!((q2 - p).dot(n) < 0.0);
            }
        }
    }

    #[test]
    fn transformed_error_bounds_the_rounding_of_a_transformed_point() {
        // the f32 product against the exact one in f64, for points and matrices of every size
        let mut rng = 0x1234_5678u64;
        let mut next = || {
            rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (rng >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        for k in 0..2000 {
            let s = 10f32.powi(k % 13 - 6);
            let t = Vec3::new(next(), next(), next()) * 10f32.powi(k % 7 - 1) * 1e3;
            let m = glam::Mat4::from_scale_rotation_translation(Vec3::splat(s), glam::Quat::from_euler(glam::EulerRot::XYZ, next() * 3.0, next() * 3.0, next()), t);
            let p = Vec3::new(next(), next(), next()) * 10f32.powi(k % 5);
            let q = m.transform_point3(p);
            let md = glam::DMat4::from_cols_array(&m.to_cols_array().map(f64::from));
            let exact = md.transform_point3(p.as_dvec3());
            let e = transformed_error(&m, p, Vec3::ZERO);
            for c in 0..3 {
                assert!((q[c] as f64 - exact[c]).abs() <= e[c] as f64, "{k}: component {c}: {} vs {} ± {}", q[c], exact[c], e[c]);
            }
        }
    }
}

#[inline]
fn sign_nonneg(x: f32) -> f32 {
    if x >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// Octahedral mapping of a unit vector to [−1, 1]² (the photon map quantises it; hits on
/// implicit primitives carry it as is).
#[inline]
pub fn oct_encode(v: Vec3) -> Vec2 {
    let l1 = v.x.abs() + v.y.abs() + v.z.abs();
    if !(l1 > 0.0) {
        return Vec2::ZERO;
    }
    let (x, y) = (v.x / l1, v.y / l1);
    if v.z < 0.0 {
        Vec2::new((1.0 - y.abs()) * sign_nonneg(x), (1.0 - x.abs()) * sign_nonneg(y))
    } else {
        Vec2::new(x, y)
    }
}

/// The inverse of [`oct_encode`]: a unit vector.
#[inline]
pub fn oct_decode(e: Vec2) -> Vec3 {
    let (x, y) = (e.x, e.y);
    let z = 1.0 - x.abs() - y.abs();
    let (x, y) = if z < 0.0 { ((1.0 - y.abs()) * sign_nonneg(x), (1.0 - x.abs()) * sign_nonneg(y)) } else { (x, y) };
    Vec3::new(x, y, z).normalize_or_zero()
}

/// Real roots of a t² + b t + c = 0, smaller first (the numerically stable form); None without
/// real roots. A linear equation (a = 0) gives its root twice.
#[inline]
pub fn solve_quadratic(a: f64, b: f64, c: f64) -> Option<(f64, f64)> {
    if a == 0.0 {
        if b == 0.0 {
            return None;
        }
        let t = -c / b;
        return Some((t, t));
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return None;
    }
    let q = -0.5 * (b + disc.sqrt().copysign(b));
    let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (q / a, c / q) };
    Some(if t0 <= t1 { (t0, t1) } else { (t1, t0) })
}

