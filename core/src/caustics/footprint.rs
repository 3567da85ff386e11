//! Pixel footprints carried along camera paths through specular chains: the photon lookup
//! radius at a receiver seen in a mirror, through a glass ball or through curved water.
//!
//! # Model: ray cones with curvature
//! A [`Footprint`] is an isotropic ray cone (Akenine-Möller et al., "Improved shader and
//! texture level of detail using ray cones", JCGT 2021): a signed width `w` across the bundle
//! and a signed spread `β` (change of width per unit length; negative while the bundle
//! converges). Full ray differentials (Igehy 1999) would carry two position and two direction
//! differentials per vertex (twelve numbers) and then have to be reduced to one radius anyway,
//! because a photon lookup is a disk; a cone carries the two numbers the lookup needs, costs
//! nothing on paths that do not gather photons, and is exact at normal incidence on a curved
//! surface (a lens, a ball, a wave crest seen from above) and close at any incidence on a flat
//! interface (see below).
//!
//! Travelling `t`: `w ← w + β t`. The width keeps its sign past a focus (the bundle is
//! inverted there) so that the curvature terms below, which are linear in the signed width,
//! stay right; the lookup uses `|w|`.
//!
//! # Specular events (paraxial optics of one principal section each)
//! With `κ` the surface's mean curvature, positive where the surface is convex towards the
//! incoming ray (its normal, turned towards the incoming side, fans out), the two hit points of
//! the bundle's edge rays are `w / cos θᵢ` apart along the surface in the plane of incidence
//! (tangential section) and `w` apart across it (sagittal section), and the normal turns by
//! `κ` times that. Differentiating the vector law of refraction `t = η_r d + (η_r cos θᵢ −
//! cos θₜ) n` (`η_r = nᵢ/nₜ`) in each section gives Coddington's equations:
//!
//! | section | width after | spread after |
//! |---|---|---|
//! | tangential | `w cos θₜ / cos θᵢ` | `(η_r cos θᵢ β + μ κ w / cos θᵢ) / cos θₜ` |
//! | sagittal | `w` | `η_r β + μ κ w` |
//!
//! with `μ = η_r cos θᵢ − cos θₜ`; reflection is the same with `η_r = 1`, `cos θₜ = −cos θᵢ`
//! (widths unchanged; spreads `β + 2κw / cos θᵢ` and `β + 2κw cos θᵢ`). The isotropic cone
//! takes the geometric mean of the two sections, term by term:
//!
//! - refraction: `w' = w √(cos θₜ / cos θᵢ)`, `β' = (η_r cos θᵢ β + μ κ w) / √(cos θᵢ cos θₜ)`;
//! - reflection: `w' = w`, `β' = β + 2κw`.
//!
//! Why the geometric mean: the area of the footprint sets how many photons a lookup reaches,
//! and at a flat interface (`κ = 0`) the isotropic disk has the area of the true elliptical
//! footprint (`w'² = w_t w_s`) at the interface and far beyond it, where widths are spreads
//! times distance; in between it is smaller only through the cross term, by the factor
//! `2 / (a + 1/a)` with `a = cos θₜ / cos θᵢ` (0.92 at 60° from air into water). The étendue
//! `n w β` is conserved as in each section. For a
//! parallel bundle on a curved surface the isotropic focal distance is the geometric mean of
//! the tangential and sagittal ones (the astigmatic pair), and both coincide at normal
//! incidence, where the cone is the paraxial lens formula.
//!
//! # Never zero
//! At a focus the paraxial width passes through zero; a real bundle there is as wide as its
//! aberrations and the pixel filter make it. [`Footprint::width`] therefore never falls below
//! [`MIN_WIDTH_FRACTION`] of the unfocused pixel cone's width at the same path length, so the
//! lookup radius stays positive and finite (the photon map's own density limit then decides
//! the radius at a bright focus). Non-finite results of an event (a grazing angle, a curvature
//! estimate on a degenerate triangle) leave the cone as it was.

// `!(x > y)` is used on purpose: it rejects NaN along with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::{Vec2, Vec3};

/// Spread (radians per unit length) a footprint has at least after a non-specular bounce:
/// lookups at later vertices gather over a wider area.
pub const DIFFUSE_SPREAD: f32 = 0.05;

/// Smallest width of a footprint as a fraction of the unfocused pixel cone's width at the same
/// path length. A paraxial focus is a point, while the real bundle keeps a waist (spherical
/// aberration, the pixel filter's extent, the lens aperture) that the cone does not model; the
/// floor lets focusing shrink a lookup's area up to 64× and no further, and where photons are
/// dense the photon map's own limit (about 48 in reach) shrinks it anyway.
pub const MIN_WIDTH_FRACTION: f32 = 0.125;

/// Cosines below this are taken as this at specular events: bounds the width change across a
/// grazing interface (a factor of at most √(1/MIN_COS) ≈ 32).
const MIN_COS: f32 = 1e-3;

/// A camera path's footprint: an isotropic ray cone with a signed width and spread, and the
/// unfocused pixel cone it is never narrower than a fraction of.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Footprint {
    /// Signed width across the bundle (negative past a focus).
    w: f32,
    /// Signed growth of the width per unit length (negative while converging).
    beta: f32,
    /// The pixel cone at the camera: width and spread.
    pixel_w0: f32,
    pixel_spread: f32,
    /// Path length travelled so far.
    travelled: f32,
}

impl Footprint {
    /// The footprint of a camera ray: width `w0` at the camera, spread `spread` (≥ 0).
    pub fn camera(w0: f32, spread: f32) -> Footprint {
        let w0 = if w0.is_finite() { w0.max(0.0) } else { 0.0 };
        let spread = if spread.is_finite() { spread.max(0.0) } else { 0.0 };
        Footprint { w: w0, beta: spread, pixel_w0: w0, pixel_spread: spread, travelled: 0.0 }
    }

    /// A bundle of width `w` and spread `beta` (signed) whose lower bound is the pixel cone
    /// (`pixel_w0`, `pixel_spread`).
    pub fn with_cone(w: f32, beta: f32, pixel_w0: f32, pixel_spread: f32) -> Footprint {
        Footprint { w, beta, pixel_w0, pixel_spread, travelled: 0.0 }
    }

    /// Moves the footprint `t` along the ray.
    #[inline]
    pub fn advance(&mut self, t: f32) {
        if t.is_finite() {
            self.w += self.beta * t;
            self.travelled += t;
        }
    }

    /// Width here (the lookup's scale): `|w|`, never below the floor.
    #[inline]
    pub fn width(&self) -> f32 {
        self.width_at(0.0)
    }

    /// Width `t` further along the current ray, without moving the footprint.
    #[inline]
    pub fn width_at(&self, t: f32) -> f32 {
        let floor = MIN_WIDTH_FRACTION * (self.pixel_w0 + self.pixel_spread * (self.travelled + t));
        let w = (self.w + self.beta * t).abs();
        if w.is_finite() { w.max(floor) } else { floor }
    }

    /// Signed spread (change of width per unit length; negative while converging).
    #[inline]
    pub fn spread(&self) -> f32 {
        self.beta
    }

    /// Signed width (negative past a focus), without the floor.
    #[inline]
    pub fn signed_width(&self) -> f32 {
        self.w
    }

    /// Specular reflection off a surface of mean curvature `curvature` (positive: convex
    /// towards the incoming ray).
    #[inline]
    pub fn reflect(&mut self, curvature: f32) {
        let beta = self.beta + 2.0 * curvature * self.w;
        if beta.is_finite() {
            self.beta = beta;
        }
    }

    /// Specular refraction through a surface of mean curvature `curvature` (positive: convex
    /// towards the incoming ray), `eta = n_transmitted / n_incident`, with the cosines of the
    /// incident and transmitted directions to the normal (either sign; their magnitudes are
    /// used).
    #[inline]
    pub fn refract(&mut self, curvature: f32, eta: f32, cos_i: f32, cos_t: f32) {
        if !(eta > 0.0) {
            return;
        }
        let ci = cos_i.abs().clamp(MIN_COS, 1.0);
        let ct = cos_t.abs().clamp(MIN_COS, 1.0);
        let eta_r = 1.0 / eta;
        let mu = eta_r * ci - ct;
        let w = self.w * (ct / ci).sqrt();
        let beta = (eta_r * ci * self.beta + mu * curvature * self.w) / (ci * ct).sqrt();
        if w.is_finite() && beta.is_finite() {
            self.w = w;
            self.beta = beta;
        }
    }

    /// After a non-specular bounce the bundle is no longer coherent: it keeps its width here
    /// and spreads by at least [`DIFFUSE_SPREAD`].
    #[inline]
    pub fn after_diffuse(&mut self) {
        self.w = self.width();
        self.beta = self.beta.abs().max(DIFFUSE_SPREAD);
    }
}

/// Mean curvature of a triangle's shading-normal field at barycentrics `b` (of vertices 1 and
/// 2), from its vertex positions `p` and unit vertex normals `n`: the normals vary linearly
/// across the triangle, so `dN/dp` is constant on it; its trace over the triangle's plane,
/// halved and divided by the interpolated normal's length (the derivative of the normalised
/// normal), is the mean of the principal curvatures. Positive where the normals fan out (convex
/// on the side they face); 0 for equal normals or a degenerate triangle.
pub fn triangle_mean_curvature(p: [Vec3; 3], n: [Vec3; 3], b: Vec2) -> f32 {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let (dn1, dn2) = (n[1] - n[0], n[2] - n[0]);
    let ni = n[0] + dn1 * b.x + dn2 * b.y;
    let len = ni.length();
    let (g11, g12, g22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let det = g11 * g22 - g12 * g12;
    if !(len > 1e-6) || !(det > 1e-12 * g11 * g22) {
        return 0.0;
    }
    // dN maps e_j to dn_j; its matrix in the basis (e1, e2) is G⁻¹ M with M_ij = e_i · dn_j
    let (m11, m12, m21, m22) = (e1.dot(dn1), e1.dot(dn2), e2.dot(dn1), e2.dot(dn2));
    let trace = (g22 * m11 - g12 * m21 - g12 * m12 + g11 * m22) / det;
    let k = 0.5 * trace / len;
    if k.is_finite() { k } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Refracts unit `d` at unit normal `n` (facing the incoming side) with `eta_r = nᵢ/nₜ`.
    pub(super) fn snell(d: glam::DVec3, n: glam::DVec3, eta_r: f64) -> glam::DVec3 {
        let ci = -d.dot(n);
        let st2 = eta_r * eta_r * (1.0 - ci * ci);
        let ct = (1.0 - st2).sqrt();
        d * eta_r + n * (eta_r * ci - ct)
    }

    #[test]
    fn flat_interface_matches_ray_pairs_refracted_by_snells_law() {
        // Two rays from a common point a small angle ε apart, in the plane of incidence
        // (tangential) and across it (sagittal), refracted at the plane y = 0 (normal +y):
        // their angle after refraction is the spread per unit length there. Derivation: the
        // tangential component of the direction scales by η_r, so in the plane of incidence
        // cos θₜ dθₜ = η_r cos θᵢ dθᵢ (β_t = β η_r cos θᵢ / cos θₜ, i.e. β cos θᵢ / (η cos θₜ)
        // with η = nₜ/nᵢ), and across it the out-of-plane component scales by η_r
        // (β_s = η_r β). The cone's spread is their geometric mean.
        let eps = 1e-5f64;
        for &(n_i, n_t) in &[(1.0f64, 1.333f64), (1.333, 1.0), (1.0, 1.5)] {
            let eta_r = n_i / n_t;
            for deg in [0.0f64, 10.0, 30.0, 45.0, 60.0, 75.0] {
                let th = deg.to_radians();
                if eta_r * th.sin() >= 0.95 {
                    continue; // near total internal reflection
                }
                let d = glam::DVec3::new(th.sin(), -th.cos(), 0.0);
                let n = glam::DVec3::Y;
                let t0 = snell(d, n, eta_r);
                // tangential: rotate d within the xy plane
                let th2 = th + eps;
                let dt = glam::DVec3::new(th2.sin(), -th2.cos(), 0.0);
                let beta_t = t0.angle_between(snell(dt, n, eta_r)) / eps;
                // sagittal: tilt d out of the plane
                let ds = (d + glam::DVec3::Z * eps).normalize();
                let beta_s = t0.angle_between(snell(ds, n, eta_r)) / eps;
                let (ci, ct) = (th.cos(), -t0.y);
                // finite differences of step 1e-5 in f64: relative error ~1e-5
                assert!((beta_t - eta_r * ci / ct).abs() < 1e-4 * beta_t, "tangential {deg}° {beta_t}");
                assert!((beta_s - eta_r).abs() < 1e-4 * beta_s, "sagittal {deg}° {beta_s}");
                // the cone: a unit spread from a point (w = 0) and a unit width with no spread
                let mut f = Footprint::with_cone(0.0, 1.0, 0.0, 0.0);
                f.refract(0.0, (n_t / n_i) as f32, ci as f32, ct as f32);
                let want = (beta_t * beta_s).sqrt();
                // against the finite-difference reference above: its 1e-5 relative error
                assert!((f.spread() as f64 - want).abs() < 1e-4 * want, "{deg}°: {} vs {want}", f.spread());
                let mut g = Footprint::with_cone(1.0, 0.0, 0.0, 0.0);
                g.refract(0.0, (n_t / n_i) as f32, ci as f32, ct as f32);
                // widths: tangential cos θₜ / cos θᵢ, sagittal 1
                assert!((g.signed_width() as f64 - (ct / ci).sqrt()).abs() < 1e-5, "{deg}°");
                assert_eq!(g.spread(), 0.0);
                // étendue: n w β (per section, so (n w β)² of the 2D bundle) is the same on
                // both sides
                let mut h = Footprint::with_cone(0.7, 0.3, 0.0, 0.0);
                h.refract(0.0, (n_t / n_i) as f32, ci as f32, ct as f32);
                let e0 = n_i * 0.7 * 0.3;
                let e1 = n_t * h.signed_width() as f64 * h.spread() as f64;
                assert!((e0 - e1).abs() < 1e-5 * e0, "{deg}°: étendue {e0} {e1}");
                // the disk's area against the ellipse's at a distance: equal at the interface,
                // short by at most the cross term's 2/(a + 1/a) in between
                let a = ct / ci;
                for dist in [0.0, 0.5, 2.0, 1e4] {
                    let ellipse = (0.7 * a + 0.3 * beta_t * dist) * (0.7 + 0.3 * beta_s * dist);
                    let disk = (h.width_at(dist as f32) as f64).powi(2);
                    let bound = 2.0 / (a + 1.0 / a);
                    // 1e-4: the finite-difference spreads
                    assert!(disk <= ellipse * (1.0 + 1e-4) && disk >= ellipse * (bound - 1e-4), "{deg}° at {dist}: {disk} vs {ellipse}");
                }
            }
        }
    }

    #[test]
    fn flat_mirror_leaves_width_and_spread_unchanged() {
        let mut f = Footprint::camera(0.01, 0.002);
        f.advance(3.0);
        let before = f;
        f.reflect(0.0);
        assert_eq!(f, before);
        f.advance(2.0);
        assert!((f.width() - (0.01 + 0.002 * 5.0)).abs() < 1e-7);
    }

    #[test]
    fn the_width_never_reaches_zero_or_nan() {
        // a converging bundle passes its focus: the width stays at the floor there
        let mut f = Footprint::with_cone(0.01, -0.01, 0.004, 0.001);
        f.advance(1.0);
        assert_eq!(f.signed_width(), 0.0);
        let floor = MIN_WIDTH_FRACTION * (0.004 + 0.001 * 1.0);
        assert!(f.width() == floor && floor > 0.0);
        f.advance(1.0);
        assert!((f.width() - 0.01).abs() < 1e-7, "grows again past the focus");
        // bad inputs leave it as it was
        let g = f;
        f.refract(f32::NAN, 1.33, 0.5, 0.6);
        f.reflect(f32::INFINITY);
        f.refract(0.1, 0.0, 0.5, 0.6);
        f.advance(f32::NAN);
        assert_eq!(f, g);
        // grazing cosines are bounded
        f.refract(0.0, 1.33, 0.0, 0.0);
        assert!(f.width().is_finite() && f.spread().is_finite());
        // the pixel cone floors a diffuse bounce's width
        let mut d = Footprint::camera(0.0, 0.001);
        d.advance(2.0);
        d.after_diffuse();
        assert!((d.width() - 0.002).abs() < 1e-8 && d.spread() == DIFFUSE_SPREAD);
    }

    /// Scenes traced through the renderer's own intersection and shading: an implicit sphere
    /// or a tessellated one with radial vertex normals.
    mod traced {
        use super::super::*;
        use super::snell;
        use crate::accel::{Hit, Ray};
        use crate::render::RenderSettings;
        use crate::scene::*;
        use crate::world::World;
        use glam::{DVec3, Mat4};

        /// A UV sphere (poles on ±y) with vertices exactly on the sphere and radial normals,
        /// counter-clockwise seen from outside.
        pub fn uv_sphere(c: Vec3, r: f32, n_lat: u32, n_lon: u32) -> MeshDesc {
            let mut m = MeshDesc { name: "/ball".into(), ..Default::default() };
            let mut normals = vec![Vec3::Y];
            for i in 1..n_lat {
                let th = std::f32::consts::PI * i as f32 / n_lat as f32;
                for j in 0..n_lon {
                    let ph = 2.0 * std::f32::consts::PI * j as f32 / n_lon as f32;
                    normals.push(Vec3::new(th.sin() * ph.cos(), th.cos(), -th.sin() * ph.sin()));
                }
            }
            normals.push(-Vec3::Y);
            let ring = |i: u32, j: u32| 1 + (i - 1) * n_lon + j % n_lon;
            let south = normals.len() as u32 - 1;
            for j in 0..n_lon {
                m.indices.extend([0, ring(1, j), ring(1, j + 1)]);
                m.indices.extend([south, ring(n_lat - 1, j + 1), ring(n_lat - 1, j)]);
                for i in 1..n_lat - 1 {
                    let (a, b, c2, d) = (ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1));
                    m.indices.extend([a, c2, d, a, d, b]);
                }
            }
            m.positions = normals.iter().map(|n| c + *n * r).collect();
            m.normals = Some(normals);
            m
        }

        pub fn world(geometry: GeometryRef, mesh: Option<MeshDesc>, sphere: Option<(Vec3, f32)>, xf: Mat4) -> World {
            let mut s = SceneDesc::default();
            s.meshes.extend(mesh.map(std::sync::Arc::new));
            if let Some((c, r)) = sphere {
                s.spheres.push(std::sync::Arc::new(SpheresDesc { name: "/ball".into(), centers: vec![c], radii: vec![r], velocities: None, ..Default::default() }));
            }
            s.materials.push(MaterialDesc { name: "/m".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.5; 3]) }, interior_medium: None });
            s.instances_mut().push(InstanceDesc { name: "/ball".into(), geometry, transforms: vec![xf], times: vec![0.0], material: 0, id: 0, visible_to_camera: true, casts_shadows: true, primvar_row: None, index: None });
            World::build(&s, &RenderSettings::default(), &mut Vec::new())
        }

        fn hit(w: &World, o: DVec3, d: DVec3) -> (Ray, Hit) {
            let ray = Ray { o: o.as_vec3(), d: d.as_vec3(), t_max: f32::INFINITY, time: 0.0 };
            let h = w.accel.intersect(&ray).expect("the ball is hit");
            (ray, h)
        }

        /// A ray through a ball of index `n` by Snell's law at the shading normals: the exit
        /// point and direction, in f64 from the renderer's f32 hits.
        pub fn through_ball(w: &World, o: DVec3, d: DVec3, n: f64) -> (DVec3, DVec3) {
            let (ray, h) = hit(w, o, d);
            let s = w.surface(&ray, &h);
            let d1 = snell(d, s.ns.as_dvec3().normalize(), 1.0 / n);
            let p1 = s.p.as_dvec3();
            let o1 = p1 + d1 * 1e-4;
            let (ray, h) = hit(w, o1, d1);
            let s = w.surface(&ray, &h);
            let d2 = snell(d1, -s.ns.as_dvec3().normalize(), n);
            (s.p.as_dvec3(), d2)
        }

        /// The footprint of a bundle of width `w0` and no spread along the ray `(o, d)` through
        /// the ball: the curvature from [`World::mean_curvature`], the cosines from the ray.
        pub fn footprint_through_ball(w: &World, o: DVec3, d: DVec3, n: f64, w0: f32) -> (Footprint, DVec3, DVec3) {
            let mut f = Footprint::with_cone(w0, 0.0, 0.0, 0.0);
            let (ray, h) = hit(w, o, d);
            let s = w.surface(&ray, &h);
            f.advance(h.t);
            let ns = s.ns.as_dvec3().normalize();
            let d1 = snell(d, ns, 1.0 / n);
            f.refract(w.mean_curvature(&ray, &h), n as f32, d.dot(ns) as f32, d1.dot(ns) as f32);
            let (ray, h) = hit(w, s.p.as_dvec3() + d1 * 1e-4, d1);
            let s = w.surface(&ray, &h);
            f.advance(h.t + 1e-4);
            let ns = s.ns.as_dvec3().normalize();
            let d2 = snell(d1, -ns, n);
            // from inside, the curvature seen by the ray is the outside's negative
            f.refract(-w.mean_curvature(&ray, &h), (1.0 / n) as f32, d1.dot(ns) as f32, d2.dot(ns) as f32);
            (f, s.p.as_dvec3(), d2)
        }

        /// Distance of the point `q` from the line `(p, d)`.
        fn off_line(q: DVec3, p: DVec3, d: DVec3) -> f64 {
            (q - p).reject_from(d).length()
        }

        fn ball_lens(w: &World, c: DVec3, r: f64, n: f64, mesh: bool) {
            // the axis passes through the centre (on the tessellated ball too: its
            // interpolated normals are radial, p/|p|), avoiding vertices and edges
            let d = DVec3::new(0.013, 0.021, 1.0).normalize();
            let o = c - d * 5.0 * r;
            let h = 2e-3 * r;
            let (f, exit, d_out) = footprint_through_ball(w, o, d, n, h as f32);
            // paraxial focus of the footprint, from the centre
            let t_focus = -(f.signed_width() / f.spread()) as f64;
            let focus = (exit + d_out * t_focus - c).dot(d);
            let paraxial = n * r / (2.0 * (n - 1.0));
            // the exact sphere: f32 hits and curvature, ~1e-5; the tessellated one: its hits
            // lie on flat triangles up to the sagitta 1 − cos(π/n_lon) ≈ 3e-4 R inside the
            // sphere, which moves the focus by about as much
            let tol = if mesh { 1e-3 } else { 1e-4 };
            assert!((focus - paraxial).abs() < tol * paraxial, "focus {focus} vs nR/(2(n−1)) = {paraxial}");
            // the brute-force reference: a real ray pair h apart, traced by Snell's law
            let e = d.cross(DVec3::X).normalize();
            let (p2, d2) = through_ball(w, o + e * h, d, n);
            let (p1, d1) = through_ball(w, o, d, n);
            // where the outer ray crosses the axis ray (closest approach)
            let w0 = p1 - p2;
            let (a, b, cc, dd, ee) = (d1.dot(d1), d1.dot(d2), d2.dot(d2), d1.dot(w0), d2.dot(w0));
            let s_axis = (b * ee - cc * dd) / (a * cc - b * b);
            let crossing = (p1 + d1 * s_axis - c).dot(d);
            // spherical aberration moves a ray at height h by ~(h/R)² R from the paraxial
            // focus (4e-6 R here), well inside the tolerances above
            assert!((crossing - paraxial).abs() < tol * paraxial, "ray pair crosses at {crossing} vs {paraxial}");
            // widths beyond the focus: the footprint against the pair's separation
            for dist in [0.5 * r, 2.0 * r, 10.0 * r] {
                let t = t_focus + dist;
                let predicted = f.width_at(t as f32) as f64;
                let q = p2 + d2 * ((p1 + d1 * t - p2).dot(d2));
                let sep = off_line(q, p1, d1);
                // f32 hits and normals perturb the pair's ~3e-3 rad deviation by ~1e-7 rad on
                // either surface: a few 1e-5 of the width at any distance
                assert!((predicted - sep).abs() < 1e-4 * sep, "{dist}: footprint {predicted} vs ray pair {sep}");
                // and the paraxial prediction: the width grows from the focus at the exit
                // spread, h · 2(n−1)/(nR)
                let paraxial_w = h * 2.0 * (n - 1.0) / (n * r) * dist;
                assert!((predicted - paraxial_w).abs() < tol * paraxial_w, "{dist}: {predicted} vs {paraxial_w}");
            }
        }

        #[test]
        fn ball_lens_footprint_focuses_at_the_paraxial_focus() {
            let c = Vec3::new(0.3, -0.2, 1.0);
            for n in [1.5, 1.333] {
                let w = world(GeometryRef::Spheres(0), None, Some((c, 0.8)), Mat4::IDENTITY);
                ball_lens(&w, c.as_dvec3(), 0.8, n, false);
                // the same ball as a unit sphere scaled by 0.8 by its instance
                let w = world(GeometryRef::Spheres(0), None, Some((Vec3::ZERO, 1.0)), Mat4::from_scale_rotation_translation(Vec3::splat(0.8), glam::Quat::IDENTITY, c));
                ball_lens(&w, c.as_dvec3(), 0.8, n, false);
                let w = world(GeometryRef::Mesh(0), Some(uv_sphere(c, 0.8, 128, 256)), None, Mat4::IDENTITY);
                ball_lens(&w, c.as_dvec3(), 0.8, n, true);
            }
        }

        #[test]
        fn convex_mirror_spreads_a_ray_pair_by_the_predicted_amount() {
            let r = 1.5f64;
            let c = DVec3::new(0.0, 0.0, 0.0);
            let w = world(GeometryRef::Spheres(0), None, Some((c.as_vec3(), r as f32)), Mat4::IDENTITY);
            let h = 1e-3;
            let reflect = |o: DVec3, d: DVec3| -> (DVec3, DVec3, f32, f32) {
                let (ray, hh) = hit(&w, o, d);
                let s = w.surface(&ray, &hh);
                let n = s.ns.as_dvec3().normalize();
                (s.p.as_dvec3(), d - n * 2.0 * d.dot(n), w.mean_curvature(&ray, &hh), -d.dot(n) as f32)
            };
            for deg in [0.0f64, 20.0, 40.0, 60.0] {
                // a parallel pair along +z with impact parameter R sin θ in the xz plane
                let b = r * deg.to_radians().sin();
                let o = DVec3::new(b, 0.0, -5.0);
                let d = DVec3::Z;
                let (_, r0, k, cos_i) = reflect(o, d);
                let (_, rt, _, _) = reflect(o + DVec3::X * h, d);
                let (_, rs, _, _) = reflect(o + DVec3::Y * h, d);
                // divergence per unit width: tangential 2/(R cos θ), sagittal 2 cos θ / R
                let (bt, bs) = (r0.angle_between(rt) / h, r0.angle_between(rs) / h);
                let ct = deg.to_radians().cos();
                // a pair 1e-3 apart on R = 1.5: the second-order term of the tangential
                // pair grows like h/(R cos²θ) (1.2e-3 at 60°); f32 normals add ~1e-6
                assert!((bt - 2.0 / (r * ct)).abs() < 2e-3 * bt, "{deg}° tangential {bt}");
                assert!((bs - 2.0 * ct / r).abs() < 2e-3 * bs, "{deg}° sagittal {bs}");
                let mut f = Footprint::with_cone(1.0, 0.0, 0.0, 0.0);
                f.reflect(k);
                let want = (bt * bs).sqrt();
                assert!((f.spread() as f64 - want).abs() < 2e-3 * want, "{deg}°: {} vs {want} (cos {cos_i})", f.spread());
            }
        }

        #[test]
        fn tessellated_sphere_curvature_is_one_over_r_within_the_tessellation() {
            let (c, r) = (Vec3::new(1.0, 2.0, -0.5), 0.6f32);
            for (n_lat, n_lon) in [(16u32, 32u32), (64, 128)] {
                let mesh = uv_sphere(c, r, n_lat, n_lon);
                // the largest angle between two vertex normals of a triangle bounds how short
                // the interpolated normal gets: κ ∈ [1/R, 1/(R cos α)]
                let nn = mesh.normals.clone().unwrap();
                let cos_min = mesh.indices.chunks(3).map(|t| {
                    let [a, b, cc] = [t[0], t[1], t[2]].map(|i| nn[i as usize]);
                    a.dot(b).min(b.dot(cc)).min(a.dot(cc))
                }).fold(1.0f32, f32::min);
                for (xf, scale) in [(Mat4::IDENTITY, 1.0f32), (Mat4::from_scale(Vec3::splat(2.0)), 2.0)] {
                    let w = world(GeometryRef::Mesh(0), Some(mesh.clone()), None, xf);
                    let centre = (xf.transform_point3(c)).as_dvec3();
                    let mut rng = crate::testing::chi2::TestRng::new(7);
                    let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
                    for _ in 0..500 {
                        let d = crate::math::sample_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32())).as_dvec3();
                        let (ray, h) = hit(&w, centre - d * 10.0, d);
                        let k = w.mean_curvature(&ray, &h) * r * scale;
                        lo = lo.min(k);
                        hi = hi.max(k);
                    }
                    // f32 normals and positions: 1e-4 relative
                    assert!(lo > 1.0 - 1e-4 && hi < 1.0 / cos_min + 1e-4, "{n_lat}×{n_lon}: κR ∈ [{lo}, {hi}], bound {}", 1.0 / cos_min);
                    // and it does vary: the estimate is not a constant
                    assert!(hi > lo);
                }
                // wound inside out with outward normals: concave seen from its outside
                let mut inv = mesh.clone();
                for t in inv.indices.chunks_mut(3) {
                    t.swap(1, 2);
                }
                let w = world(GeometryRef::Mesh(0), Some(inv), None, Mat4::IDENTITY);
                let (ray, h) = hit(&w, c.as_dvec3() - DVec3::Z * 10.0, DVec3::Z);
                assert!(w.mean_curvature(&ray, &h) < -0.9 / r);
                // flat shading: no curvature
                let mut flat = mesh.clone();
                flat.normals = None;
                let w = world(GeometryRef::Mesh(0), Some(flat), None, Mat4::IDENTITY);
                let (ray, h) = hit(&w, c.as_dvec3() - DVec3::Z * 10.0, DVec3::Z);
                assert_eq!(w.mean_curvature(&ray, &h), 0.0);
            }
        }
    }

    #[test]
    fn triangle_curvature_of_exact_sphere_and_cylinder_normals() {
        // on a sphere of radius R the vertex normals are (p − c)/R, so dN/dp = I/R exactly on
        // the triangle and the estimate is 1/(R |n_interp|): 1/R at the vertices
        let r = 2.5f32;
        let dirs = [Vec3::new(1.0, 0.1, 0.0).normalize(), Vec3::new(0.95, 0.0, 0.3).normalize(), Vec3::new(0.97, 0.25, 0.2).normalize()];
        let p = dirs.map(|d| Vec3::new(1.0, -2.0, 0.5) + d * r);
        let k = triangle_mean_curvature(p, dirs, Vec2::ZERO);
        assert!((k - 1.0 / r).abs() < 1e-5, "{k}");
        // inward normals: concave, the negative
        let k = triangle_mean_curvature(p, dirs.map(|d| -d), Vec2::new(0.2, 0.3));
        assert!(k < 0.0);
        // a cylinder of radius R along z: principal curvatures 1/R and 0, mean 1/(2R)
        let cyl = |a: f32, z: f32| (Vec3::new(a.cos(), a.sin(), 0.0) * r + Vec3::Z * z, Vec3::new(a.cos(), a.sin(), 0.0));
        let v = [cyl(0.0, 0.0), cyl(0.05, 0.0), cyl(0.0, 0.3)];
        let k = triangle_mean_curvature(v.map(|x| x.0), v.map(|x| x.1), Vec2::ZERO);
        assert!((k - 0.5 / r).abs() < 1e-4, "{k}");
        // equal normals (flat shading) and a degenerate triangle: 0
        assert_eq!(triangle_mean_curvature(p, [Vec3::Y; 3], Vec2::splat(0.3)), 0.0);
        assert_eq!(triangle_mean_curvature([Vec3::ZERO, Vec3::X, Vec3::X * 2.0], dirs, Vec2::splat(0.3)), 0.0);
    }
}
