//! Portals (`UsdLuxPortalLight`): rectangles in a room's openings through which a dome's (or
//! the sky's) light comes in. They guide the dome's sampling and change nothing else: the
//! dome lights the scene exactly as it does without them, with less noise where its light
//! arrives only through the openings.
//!
//! A portal is its light's local XY rectangle (`width` along X, `height` along Y, centred on
//! the origin); light crosses it towards its local −Z, so it guides receivers on that side.
//! Seen from such a receiver, the portals that face it are sampled uniformly in solid angle
//! (spherical rectangles, Ureña et al. 2013), each chosen in proportion to its solid angle;
//! the dome's own strategy keeps a share of the samples ([`PORTAL_SHARE`],
//! [`PORTAL_SHARE_MAPPED`]) for light that enters elsewhere. The density of a direction is the
//! mixture of both: (1 − s) × the dome's + s × (portals the direction crosses) / (their total
//! solid angle), so sampling and [`super::Light::pdf_li`] always agree and the estimate is
//! unbiased wherever the portals stand.
//!
//! Costs: each sample and each density of a guided dome builds the spherical rectangle of
//! every portal that faces the receiver. A portal that subtends under 1e-3 sr from a
//! receiver does not guide there. A sheared portal guides through the rectangle spanned by
//! its X edge and the part of its Y edge square to it.

use glam::{Mat4, Vec2, Vec3};

use super::SphericalRect;
use crate::math::ONE_MINUS_EPSILON;

#[cfg(test)]
mod tests;

/// Share of a uniform dome's samples taken through the portals that face the receiver: its
/// radiance is the same everywhere, so the portals' uniform sampling is nearly ideal there.
pub const PORTAL_SHARE: f32 = 0.9;

/// The share for a textured dome or the sky, whose own sampling finds the bright regions
/// (a sun in the map) that uniform sampling through a portal would find only by chance.
pub const PORTAL_SHARE_MAPPED: f32 = 0.5;

/// One portal, in world space.
#[derive(Clone, Debug, PartialEq)]
struct PortalRect {
    corner: Vec3,
    /// The edges from `corner` (square to each other).
    a: Vec3,
    b: Vec3,
    /// Unit normal towards the portal's local +Z: light crosses it along −`n`.
    n: Vec3,
}

/// The portals of one dome.
#[derive(Clone, Debug, PartialEq)]
pub struct Portals {
    rects: Vec<PortalRect>,
    share: f32,
}

impl Portals {
    /// Portals from (light-to-world transform, width, height) of each; `share` is the share
    /// of samples taken through them. Err names the portal's index and what is wrong.
    pub fn new(portals: &[(Mat4, f32, f32)], share: f32) -> Result<Portals, (usize, String)> {
        let mut rects = Vec::with_capacity(portals.len());
        for (i, &(m, w, h)) in portals.iter().enumerate() {
            if !m.is_finite() {
                return Err((i, "transform: not finite".into()));
            }
            if !(w > 0.0 && w.is_finite() && h > 0.0 && h.is_finite()) {
                return Err((i, format!("size: width and height must be positive, got {w} × {h}")));
            }
            let a = m.transform_vector3(Vec3::X * w);
            let b = m.transform_vector3(Vec3::Y * h);
            let b = b - a * (a.dot(b) / a.length_squared());
            // the local +Z axis in world space (normals transform by the inverse transpose)
            let n = m.inverse().transpose().transform_vector3(Vec3::Z).normalize_or_zero();
            let area_n = a.cross(b);
            if !(area_n.length_squared() > 0.0) || n == Vec3::ZERO || !area_n.is_finite() {
                return Err((i, "transform: collapses the portal".into()));
            }
            // +Z of the rectangle's plane, on the side the transform puts the local +Z
            let n = area_n.normalize() * area_n.dot(n).signum();
            let corner = m.transform_point3(Vec3::new(-0.5 * w, -0.5 * h, 0.0));
            rects.push(PortalRect { corner, a, b, n });
        }
        Ok(Portals { rects, share })
    }

    /// The portals that face `p` (it lies on their −Z side) as spherical rectangles, with
    /// their solid angles; none when no portal guides at `p`.
    fn facing(&self, p: Vec3) -> impl Iterator<Item = (usize, SphericalRect)> + '_ {
        self.rects.iter().enumerate().filter(move |(_, r)| (p - r.corner).dot(r.n) < 0.0).filter_map(move |(i, r)| SphericalRect::new(p, r.corner, r.a, r.b).map(|s| (i, s)))
    }

    /// Total solid angle of the portals that guide at `p` (0: none do).
    fn solid_angle(&self, p: Vec3) -> f64 {
        self.facing(p).map(|(_, s)| s.s).sum()
    }

    /// Chooses the strategy for a sample at `p` and draws through a portal when it is theirs.
    /// With the total solid angle of the portals that guide at `p`, for [`Portals::mix`].
    pub fn sample(&self, p: Vec3, u: Vec2) -> (Strategy, f64) {
        if u.x >= self.share {
            let total = self.solid_angle(p);
            // no portal guides: the dome's own sampling with `u` as it is
            let u = if total > 0.0 { Vec2::new(((u.x - self.share) / (1.0 - self.share)).min(ONE_MINUS_EPSILON), u.y) } else { u };
            return (Strategy::Own(u), total);
        }
        // a portal in proportion to its solid angle (one pass: each portal replaces the choice
        // with probability its share of the total so far), then a direction uniform within it
        let mut x = (u.x / self.share) as f64;
        let (mut total, mut chosen) = (0.0f64, None);
        for (i, s) in self.facing(p) {
            total += s.s;
            let q = s.s / total;
            if x < q {
                x /= q;
                chosen = Some((i, s));
            } else {
                x = (x - q) / (1.0 - q);
            }
        }
        match chosen {
            None => (Strategy::Own(u), total),
            Some((i, s)) => {
                let ux = (x as f32).clamp(0.0, ONE_MINUS_EPSILON);
                (Strategy::Portal(direction(&s, p, Vec2::new(ux, u.y)), i), total)
            }
        }
    }

    /// The mixture density of unit direction `w` at `p`, given the dome's own density `dome`
    /// and the portals' `total` solid angle there ([`Portals::sample`] gives it; `through`: a
    /// portal `w` is known to cross, drawn through it).
    pub fn mix(&self, p: Vec3, w: Vec3, dome: f32, total: f64, through: Option<usize>) -> f32 {
        if !(total > 0.0) {
            return dome;
        }
        // the portals `w` crosses among those that guide at `p` (only those crossed are
        // checked for their solid angle)
        let crossed = self
            .rects
            .iter()
            .enumerate()
            .filter(|&(i, r)| through == Some(i) || ((p - r.corner).dot(r.n) < 0.0 && r.crossed_by(p, w) && SphericalRect::new(p, r.corner, r.a, r.b).is_some()))
            .count();
        self.mixture(dome, total, crossed)
    }

    /// The mixture density of unit direction `w` at `p`, given the dome's own density `dome`.
    pub fn pdf(&self, p: Vec3, w: Vec3, dome: f32) -> f32 {
        let (mut total, mut crossed) = (0.0f64, 0usize);
        for (i, s) in self.facing(p) {
            total += s.s;
            crossed += self.rects[i].crossed_by(p, w) as usize;
        }
        if !(total > 0.0) {
            return dome;
        }
        self.mixture(dome, total, crossed)
    }

    /// (1 − share) × the dome's density + share × `crossed` portals / their `total` solid angle.
    #[inline]
    fn mixture(&self, dome: f32, total: f64, crossed: usize) -> f32 {
        (1.0 - self.share) * dome + self.share * (crossed as f64 / total) as f32
    }
}

/// How a guided sample is drawn.
pub enum Strategy {
    /// Through portal `.1` (its index), in direction `.0` (None: the draw failed).
    Portal(Option<Vec3>, usize),
    /// By the dome's own sampling, with these numbers.
    Own(Vec2),
}

impl PortalRect {
    /// Whether the ray from `p` along `w` crosses the rectangle.
    fn crossed_by(&self, p: Vec3, w: Vec3) -> bool {
        let denom = w.dot(self.n);
        if !(denom > 0.0) {
            return false;
        }
        let t = (self.corner - p).dot(self.n) / denom;
        if !(t > 0.0) {
            return false;
        }
        let q = p + w * t - self.corner;
        let (x, y) = (q.dot(self.a) / self.a.length_squared(), q.dot(self.b) / self.b.length_squared());
        (0.0..=1.0).contains(&x) && (0.0..=1.0).contains(&y)
    }
}

/// The unit direction from `p` to the point of `s` that `u` picks.
fn direction(s: &SphericalRect, p: Vec3, u: Vec2) -> Option<Vec3> {
    s.sample(u).map(|q| (q - p).normalize()).filter(|w| w.is_finite())
}
