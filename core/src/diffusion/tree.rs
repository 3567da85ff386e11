//! Irradiance points on a diffusion body's surface and their octree (Jensen & Buhler 2002):
//! leaves hold the points, inner nodes the area-weighted position and normal, the
//! flux-weighted mean refracted direction and the summed transmitted flux E·A per spectral
//! bin. [`IrradianceTree::exitance`] sums S_d × flux over the tree, replacing a node by its
//! aggregate when it subtends little as seen from the exit point.

use super::profile::{DipoleParams, ProfileModel};
use crate::spectrum::{SampledSpectrum, SampledWavelengths, LAMBDA_MAX, LAMBDA_MIN, N_SPECTRUM};
use glam::Vec3;

/// Spectral bins the cached irradiance is stored in (centres equally spaced over
/// [LAMBDA_MIN, LAMBDA_MAX]; values between centres are interpolated linearly).
pub const N_BINS: usize = 16;

/// Centre wavelength (nm) of bin `b`.
#[inline]
pub fn bin_lambda(b: usize) -> f32 {
    LAMBDA_MIN + (b as f32 + 0.5) * (LAMBDA_MAX - LAMBDA_MIN) / N_BINS as f32
}

/// (lower bin, weight of the upper one) for linear interpolation at `lambda`.
#[inline]
fn bin_lerp(lambda: f32) -> (usize, f32) {
    let x = (lambda - LAMBDA_MIN) / (LAMBDA_MAX - LAMBDA_MIN) * N_BINS as f32 - 0.5;
    if x <= 0.0 {
        return (0, 0.0);
    }
    let b = (x as usize).min(N_BINS - 2);
    (b, (x - b as f32).min(1.0))
}

/// One irradiance point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IrradiancePoint {
    pub p: Vec3,
    /// Outward unit normal.
    pub n: Vec3,
    /// Surface area the point stands for.
    pub area: f32,
    /// Flux-weighted mean direction of the refracted light (into the body), unit length.
    pub dir: Vec3,
    /// Irradiance transmitted into the body (after Fresnel) per spectral bin.
    pub e: [f32; N_BINS],
}

#[derive(Clone, Copy, Debug)]
struct Node {
    /// Area-weighted mean position and normal of the points below.
    p: Vec3,
    n: Vec3,
    dir: Vec3,
    /// Radius of a sphere about `p` that holds every point below.
    radius: f32,
    /// Σ E·A per bin.
    ea: [f32; N_BINS],
    /// Children (indices into `kids`) for inner nodes; points for leaves.
    first: u32,
    count: u32,
    leaf: bool,
}

/// The octree over one body's points.
#[derive(Clone, Debug, Default)]
pub struct IrradianceTree {
    points: Vec<IrradiancePoint>,
    nodes: Vec<Node>,
    kids: Vec<u32>,
}

const LEAF_SIZE: usize = 8;
/// Points closer to the exit point than this many patch sizes (√area) are integrated over
/// their patch (3 × 3 midpoint rule) by the direction-aware profiles, whose peak near the
/// source is narrower than the point spacing.
const NEAR_PATCHES: f32 = 3.0;
const MAX_LEVEL: u32 = 20;
const STACK: usize = 8 * (MAX_LEVEL as usize + 2);

impl IrradianceTree {
    /// Builds the tree; the points are reordered.
    pub fn build(mut points: Vec<IrradiancePoint>) -> Self {
        points.retain(|q| q.area > 0.0 && q.p.is_finite());
        let mut t = IrradianceTree { points: Vec::new(), nodes: Vec::new(), kids: Vec::new() };
        if points.is_empty() {
            return t;
        }
        let mut out = Vec::with_capacity(points.len());
        t.nodes.push(Node { p: Vec3::ZERO, n: Vec3::ZERO, dir: Vec3::ZERO, radius: 0.0, ea: [0.0; N_BINS], first: 0, count: 0, leaf: true });
        t.build_node(0, points, &mut out, 0);
        t.points = out;
        t
    }

    fn build_node(&mut self, idx: usize, pts: Vec<IrradiancePoint>, out: &mut Vec<IrradiancePoint>, level: u32) {
        // aggregate
        let mut area = 0.0f32;
        let mut p = Vec3::ZERO;
        let mut n = Vec3::ZERO;
        let mut dir = Vec3::ZERO;
        let mut ea = [0.0f32; N_BINS];
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for q in &pts {
            area += q.area;
            p += q.p * q.area;
            n += q.n * q.area;
            let flux: f32 = q.e.iter().sum::<f32>() * q.area;
            dir += q.dir * flux;
            for (a, e) in ea.iter_mut().zip(&q.e) {
                *a += e * q.area;
            }
            lo = lo.min(q.p);
            hi = hi.max(q.p);
        }
        let p = p / area;
        let radius = pts.iter().map(|q| (q.p - p).length()).fold(0.0f32, f32::max);
        let n = n.try_normalize().unwrap_or(pts[0].n);
        let dir = dir.try_normalize().unwrap_or(-n);
        let leaf = pts.len() <= LEAF_SIZE || level >= MAX_LEVEL || (hi - lo).max_element() <= 0.0;
        self.nodes[idx] = Node { p, n, dir, radius, ea, first: 0, count: 0, leaf };
        if leaf {
            self.nodes[idx].first = out.len() as u32;
            self.nodes[idx].count = pts.len() as u32;
            out.extend_from_slice(&pts);
            return;
        }
        let c = (lo + hi) * 0.5;
        let mut octs: [Vec<IrradiancePoint>; 8] = Default::default();
        for q in pts {
            let o = (q.p.x > c.x) as usize | ((q.p.y > c.y) as usize) << 1 | ((q.p.z > c.z) as usize) << 2;
            octs[o].push(q);
        }
        let children: Vec<usize> = octs
            .iter()
            .filter(|o| !o.is_empty())
            .map(|_| {
                self.nodes.push(Node { p: Vec3::ZERO, n: Vec3::ZERO, dir: Vec3::ZERO, radius: 0.0, ea: [0.0; N_BINS], first: 0, count: 0, leaf: true });
                self.nodes.len() - 1
            })
            .collect();
        self.nodes[idx].first = self.kids.len() as u32;
        self.nodes[idx].count = children.len() as u32;
        self.kids.extend(children.iter().map(|&k| k as u32));
        let mut ci = 0;
        for o in octs {
            if o.is_empty() {
                continue;
            }
            self.build_node(children[ci], o, out, level + 1);
            ci += 1;
        }
    }

    pub fn points(&self) -> &[IrradiancePoint] {
        &self.points
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Σ S_d(x_p, ω_p; x_o) E_p A_p over the points, per wavelength of `lambda` (each with its
    /// own `params`, None where the medium does not diffuse), for an exit point `xo` with
    /// outward normal `no`.
    ///
    /// Error criterion (Jensen & Buhler's, in terms of the node's radius): a node is replaced
    /// by its aggregate (centroid, mean normal and direction, summed flux) when ρ < ε·d, with
    /// ρ its radius and d the distance from `xo` to its centroid. The first-order error
    /// cancels at the centroid (when the irradiance varies little across the node), so the
    /// relative error of a replaced node is about ½ρ²·|∂²S/∂r²|/S ≈ ½ε²(3 + σtr·d)²: of
    /// order ε² near the exit point, larger far away only where e^{−σtr d} makes the node's
    /// share small. `eps` = 0 sums every point.
    pub fn exitance(&self, params: &[Option<DipoleParams>; N_SPECTRUM], lambda: &SampledWavelengths, xo: Vec3, no: Vec3, eps: f32) -> SampledSpectrum {
        let mut out = SampledSpectrum::ZERO;
        if self.nodes.is_empty() {
            return out;
        }
        let lerp: [(usize, f32); N_SPECTRUM] = std::array::from_fn(|k| bin_lerp(lambda.lambda[k]));
        let directional = params.iter().flatten().any(|p| p.model != ProfileModel::Classical);
        let mut add = |p: Vec3, n: Vec3, dir: Vec3, ea: &[f32; N_BINS]| {
            for k in 0..N_SPECTRUM {
                let Some(pk) = &params[k] else { continue };
                let (b, f) = lerp[k];
                let e = ea[b] * (1.0 - f) + ea[b + 1] * f;
                if e > 0.0 {
                    out[k] += pk.eval(p, n, dir, xo, no) * e;
                }
            }
        };
        let mut stack = [0u32; STACK];
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let node = &self.nodes[stack[sp] as usize];
            if node.leaf {
                for q in &self.points[node.first as usize..(node.first + node.count) as usize] {
                    let mut ea = q.e;
                    let h2 = q.area;
                    if directional && (q.p - xo).length_squared() < NEAR_PATCHES * NEAR_PATCHES * h2 {
                        // a point next to the exit point stands for its patch (about h × h,
                        // h = √area): the patch's integral by the midpoint rule on a 3 × 3 grid
                        let h = h2.sqrt();
                        let (t, b) = q.n.any_orthonormal_pair();
                        ea.iter_mut().for_each(|v| *v *= q.area / 9.0);
                        for i in 0..3 {
                            for j in 0..3 {
                                let off = t * ((i as f32 - 1.0) * h / 3.0) + b * ((j as f32 - 1.0) * h / 3.0);
                                add(q.p + off, q.n, q.dir, &ea);
                            }
                        }
                    } else {
                        ea.iter_mut().for_each(|v| *v *= q.area);
                        add(q.p, q.n, q.dir, &ea);
                    }
                }
                continue;
            }
            let d = (node.p - xo).length();
            if eps > 0.0 && node.radius < eps * d {
                add(node.p, node.n, node.dir, &node.ea);
                continue;
            }
            for &c in &self.kids[node.first as usize..(node.first + node.count) as usize] {
                if sp < STACK {
                    stack[sp] = c;
                    sp += 1;
                }
            }
        }
        out
    }

    /// [`IrradianceTree::exitance`] by summing every point (the reference for the tree).
    pub fn exitance_brute(&self, params: &[Option<DipoleParams>; N_SPECTRUM], lambda: &SampledWavelengths, xo: Vec3, no: Vec3) -> SampledSpectrum {
        let mut out = SampledSpectrum::ZERO;
        for q in &self.points {
            for k in 0..N_SPECTRUM {
                let Some(pk) = &params[k] else { continue };
                let (b, f) = bin_lerp(lambda.lambda[k]);
                let e = q.e[b] * (1.0 - f) + q.e[b + 1] * f;
                out[k] += pk.eval(q.p, q.n, q.dir, xo, no) * e * q.area;
            }
        }
        out
    }
}
