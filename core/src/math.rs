//! Small geometric helpers shared by every module: orthonormal frames, spherical
//! directions and robust ray-origin offsetting.

use glam::{Vec2, Vec3};

pub const PI: f32 = std::f32::consts::PI;
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
pub const INV_2PI: f32 = 0.5 * std::f32::consts::FRAC_1_PI;
pub const INV_4PI: f32 = 0.25 * std::f32::consts::FRAC_1_PI;

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

/// Offsets a ray origin off a surface so the new ray does not re-hit the surface it leaves,
/// while staying close enough that it cannot tunnel through thin shells. Integer-ULP offset
/// along the geometric normal (Wächter & Binder, "A Fast and Robust Method for Avoiding
/// Self-Intersection", Ray Tracing Gems, 2019): scale-independent, so it works on a small
/// droplet and on an ocean mesh kilometres from the origin alike.
/// `n` must be the geometric normal, flipped to the side the new ray leaves towards.
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let of_i = [(INT_SCALE * n.x) as i32, (INT_SCALE * n.y) as i32, (INT_SCALE * n.z) as i32];
    let pa = p.to_array();
    let na = n.to_array();
    let mut out = [0.0f32; 3];
    for k in 0..3 {
        let bits = pa[k].to_bits() as i32;
        let moved = bits.wrapping_add(if pa[k] < 0.0 { -of_i[k] } else { of_i[k] });
        let p_i = f32::from_bits(moved as u32);
        out[k] = if pa[k].abs() < ORIGIN { pa[k] + FLOAT_SCALE * na[k] } else { p_i };
    }
    Vec3::from_array(out)
}

/// Offset towards the side of `n` that `w` points into.
#[inline]
pub fn offset_towards(p: Vec3, ng: Vec3, w: Vec3) -> Vec3 {
    if ng.dot(w) >= 0.0 {
        offset_ray_origin(p, ng)
    } else {
        offset_ray_origin(p, -ng)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        for &scale in &[1e-4f32, 1.0, 1e3, 1e5] {
            let p = Vec3::new(0.37, 0.0, -0.81) * scale;
            let n = Vec3::Y;
            let q = offset_ray_origin(p, n);
            assert!(q.y > 0.0, "scale {scale}: {q:?}");
            // close: far less than a millimetre at kilometre scale
            assert!((q - p).length() < 1e-3 * scale.max(1.0));
            let q2 = offset_ray_origin(p, -n);
            assert!(q2.y < 0.0);
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

