//! MaterialX's procedural noises, computed as MaterialX's standard library defines them so
//! that a node graph renders the pattern a MaterialX reference render shows.
//!
//! The definitions are those of MaterialX's GLSL library, `libraries/stdlib/genglsl/lib/
//! mx_noise.glsl` (itself a port of Open Shading Language's `oslnoise.h`, whose results it
//! matches), with the node functions in `libraries/stdlib/genglsl/mx_noise2d_*.glsl`,
//! `mx_noise3d_*`, `mx_fractal2d_*`, `mx_fractal3d_*`, `mx_cellnoise2d_float`,
//! `mx_cellnoise3d_float`, `mx_worleynoise2d_*` and `mx_worleynoise3d_*`; the nodes' inputs
//! and defaults are in `libraries/stdlib/stdlib_defs.mtlx`, and the colour and
//! float-amplitude (`FA`) variants are the graphs of `libraries/stdlib/stdlib_ng.mtlx` over
//! the vector ones. All arithmetic is in `f32`, in the order the library writes it.
//!
//! - [`hash_int`]: Bob Jenkins' lookup3 `hashword` of 1 to 4 integers with initial value 13
//!   (MaterialX's `mx_hash_int`); [`bits_to_01`] maps a hash to [0, 1].
//! - [`perlin2`], [`perlin3`] (`mx_perlin_noise_float`): gradient noise with the quintic fade
//!   6t⁵ − 15t⁴ + 10t³, 8 gradients (±1, ±2), (±2, ±1) in 2D and the 12 cube edges (16 with
//!   repeats) in 3D, scaled by 0.6616 (2D) and 0.9820 (3D); 0 at every lattice point.
//!   [`perlin2_vec3`], [`perlin3_vec3`] (`mx_perlin_noise_vec3`): three such noises from the
//!   three low bytes of one hash.
//! - [`fractal2`], [`fractal3`] and their `_vec3` forms (`mx_fractal*_noise_*`): a sum of
//!   `octaves` Perlin noises, each at `lacunarity` times the previous frequency and `diminish`
//!   times its amplitude.
//! - [`cell2`], [`cell3`] (`mx_cell_noise_float`): one hashed value in [0, 1] per unit cell.
//! - [`worley2`], [`worley3`] (`mx_worley_noise_*`): distances to the three nearest feature
//!   points among the 3 × 3 (× 3) cells around the point, one feature per cell jittered from
//!   its centre by `jitter` × (hash − ½) per axis, under a [`Metric`] (the nodes use the
//!   Euclidean one), and the nearest feature's cell value.
//!
//! [`Noise`] is what a node graph ([`crate::shader_graph::Expr::Noise`]) evaluates: one node
//! of these families with its output's components, before its amplitude and pivot
//! (result = noise × amplitude + pivot for `noise2d`/`noise3d`, × amplitude for the fractals),
//! which the graph applies.

use glam::{Vec2, Vec3};

/// The most octaves a fractal sums; MaterialX sets no limit, but beyond this many the
/// coordinates of the last octaves outgrow the lattice's integers (2³¹) at any lacunarity
/// above 1.4 and their weight is below 2⁻⁶³ at the default diminish.
pub const MAX_OCTAVES: i32 = 64;

/// lookup3's `mix` of three words (MaterialX's `mx_bjmix`).
fn bj_mix(mut a: u32, mut b: u32, mut c: u32) -> (u32, u32, u32) {
    a = a.wrapping_sub(c) ^ c.rotate_left(4);
    c = c.wrapping_add(b);
    b = b.wrapping_sub(a) ^ a.rotate_left(6);
    a = a.wrapping_add(c);
    c = c.wrapping_sub(b) ^ b.rotate_left(8);
    b = b.wrapping_add(a);
    a = a.wrapping_sub(c) ^ c.rotate_left(16);
    c = c.wrapping_add(b);
    b = b.wrapping_sub(a) ^ a.rotate_left(19);
    a = a.wrapping_add(c);
    c = c.wrapping_sub(b) ^ b.rotate_left(4);
    b = b.wrapping_add(a);
    (a, b, c)
}

/// lookup3's `final` of three words (MaterialX's `mx_bjfinal`): the hash, `c`.
fn bj_final(mut a: u32, mut b: u32, mut c: u32) -> u32 {
    c = (c ^ b).wrapping_sub(b.rotate_left(14));
    a = (a ^ c).wrapping_sub(c.rotate_left(11));
    b = (b ^ a).wrapping_sub(a.rotate_left(25));
    c = (c ^ b).wrapping_sub(b.rotate_left(16));
    a = (a ^ c).wrapping_sub(c.rotate_left(4));
    b = (b ^ a).wrapping_sub(a.rotate_left(14));
    (c ^ b).wrapping_sub(b.rotate_left(24))
}

/// MaterialX's `mx_hash_int` of 1 to 4 integers: lookup3's `hashword(k, N, 13)`, the
/// integers taken as their two's-complement words.
pub fn hash_int<const N: usize>(k: [i32; N]) -> u32 {
    let seed = 0xdead_beef_u32.wrapping_add((N as u32) << 2).wrapping_add(13);
    let (mut a, mut b, mut c) = (seed, seed, seed);
    let mut rest = &k[..];
    while rest.len() > 3 {
        (a, b, c) = bj_mix(a.wrapping_add(rest[0] as u32), b.wrapping_add(rest[1] as u32), c.wrapping_add(rest[2] as u32));
        rest = &rest[3..];
    }
    if rest.len() == 3 {
        c = c.wrapping_add(rest[2] as u32);
    }
    if rest.len() >= 2 {
        b = b.wrapping_add(rest[1] as u32);
    }
    match rest.first() {
        Some(x) => bj_final(a.wrapping_add(*x as u32), b, c),
        None => c,
    }
}

/// A hash as a number in [0, 1] (`mx_bits_to_01`: the word over 2³² − 1, both in `f32`, so
/// the top 128 words give exactly 1).
pub fn bits_to_01(bits: u32) -> f32 {
    bits as f32 / u32::MAX as f32
}

/// The quintic fade 6t⁵ − 15t⁴ + 10t³ (`mx_fade`).
fn fade(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// The lattice cell of `x` and the position in it (`mx_floorfrac`). The fraction is
/// `x − ⌊x⌋`, which is `x − float(int(⌊x⌋))` wherever the cell index fits an `i32` and stays
/// finite (0) beyond, where MaterialX's conversion is undefined.
fn floor_frac(x: f32) -> (i32, f32) {
    let f = x.floor();
    (f as i32, x - f)
}

/// `mx_gradient_float` in 2D: (x, y) dotted with one of (±1, ±2), (±2, ±1) picked by the
/// hash's low three bits.
fn gradient2(hash: u32, x: f32, y: f32) -> f32 {
    let h = hash & 7;
    let (u, v) = if h < 4 { (x, 2.0 * y) } else { (y, 2.0 * x) };
    (if h & 1 != 0 { -u } else { u }) + (if h & 2 != 0 { -v } else { v })
}

/// `mx_gradient_float` in 3D: (x, y, z) dotted with a cube edge's direction picked by the
/// hash's low four bits.
fn gradient3(hash: u32, x: f32, y: f32, z: f32) -> f32 {
    let h = hash & 15;
    let u = if h < 8 { x } else { y };
    let v = if h < 4 {
        y
    } else if h == 12 || h == 14 {
        x
    } else {
        z
    };
    (if h & 1 != 0 { -u } else { u }) + (if h & 2 != 0 { -v } else { v })
}

/// What the lattice interpolation blends: a scalar or three.
trait Blend: Copy + std::ops::Add<Output = Self> + std::ops::Mul<f32, Output = Self> {}
impl<T: Copy + std::ops::Add<Output = T> + std::ops::Mul<f32, Output = T>> Blend for T {}

/// `mx_bilerp`: v0..v3 at the corners (0, 0), (1, 0), (0, 1), (1, 1), at (s, t).
fn bilerp<V: Blend>(v: [V; 4], s: f32, t: f32) -> V {
    let s1 = 1.0 - s;
    (v[0] * s1 + v[1] * s) * (1.0 - t) + (v[2] * s1 + v[3] * s) * t
}

/// `mx_trilerp`: v0..v7 at the corners, x fastest, at (s, t, r).
fn trilerp<V: Blend>(v: [V; 8], s: f32, t: f32, r: f32) -> V {
    let (s1, t1, r1) = (1.0 - s, 1.0 - t, 1.0 - r);
    ((v[0] * s1 + v[1] * s) * t1 + (v[2] * s1 + v[3] * s) * t) * r1 + ((v[4] * s1 + v[5] * s) * t1 + (v[6] * s1 + v[7] * s) * t) * r
}

/// 2D gradient noise before its scale: `grad(hash(X + i, Y + j), offset to that corner)`
/// blended over the cell.
fn perlin2_with<V: Blend>(p: Vec2, grad: impl Fn(u32, f32, f32) -> V) -> V {
    let ((x, fx), (y, fy)) = (floor_frac(p.x), floor_frac(p.y));
    let corner = |i: i32, j: i32| grad(hash_int([x.wrapping_add(i), y.wrapping_add(j)]), fx - i as f32, fy - j as f32);
    bilerp([corner(0, 0), corner(1, 0), corner(0, 1), corner(1, 1)], fade(fx), fade(fy))
}

/// 3D gradient noise before its scale, as [`perlin2_with`].
fn perlin3_with<V: Blend>(p: Vec3, grad: impl Fn(u32, f32, f32, f32) -> V) -> V {
    let ((x, fx), (y, fy), (z, fz)) = (floor_frac(p.x), floor_frac(p.y), floor_frac(p.z));
    let corner = |i: i32, j: i32, k: i32| grad(hash_int([x.wrapping_add(i), y.wrapping_add(j), z.wrapping_add(k)]), fx - i as f32, fy - j as f32, fz - k as f32);
    let v = [corner(0, 0, 0), corner(1, 0, 0), corner(0, 1, 0), corner(1, 1, 0), corner(0, 0, 1), corner(1, 0, 1), corner(0, 1, 1), corner(1, 1, 1)];
    trilerp(v, fade(fx), fade(fy), fade(fz))
}

/// A hash's three low bytes (`mx_hash_vec3`), which pick the gradients of three noises.
fn bytes(h: u32) -> [u32; 3] {
    [h & 0xff, (h >> 8) & 0xff, (h >> 16) & 0xff]
}

/// MaterialX's 2D Perlin noise (`mx_perlin_noise_float(vec2)`), about −1 to 1.
pub fn perlin2(p: Vec2) -> f32 {
    0.6616 * perlin2_with(p, gradient2)
}

/// MaterialX's 3D Perlin noise (`mx_perlin_noise_float(vec3)`), about −1 to 1.
pub fn perlin3(p: Vec3) -> f32 {
    0.9820 * perlin3_with(p, gradient3)
}

/// Three 2D Perlin noises (`mx_perlin_noise_vec3(vec2)`): each corner's three gradients from
/// its hash's bytes 0, 1 and 2.
pub fn perlin2_vec3(p: Vec2) -> Vec3 {
    0.6616 * perlin2_with(p, |h, x, y| Vec3::from_array(bytes(h).map(|b| gradient2(b, x, y))))
}

/// Three 3D Perlin noises (`mx_perlin_noise_vec3(vec3)`), as [`perlin2_vec3`].
pub fn perlin3_vec3(p: Vec3) -> Vec3 {
    0.9820 * perlin3_with(p, |h, x, y, z| Vec3::from_array(bytes(h).map(|b| gradient3(b, x, y, z))))
}

/// Σ diminishᶦ · noise(p · lacunarityᶦ) over `octaves` octaves (at most [`MAX_OCTAVES`];
/// an octave whose point is no longer finite adds nothing).
fn fractal<P: Copy + std::ops::Mul<f32, Output = P>, V: Default + std::ops::AddAssign + std::ops::Mul<f32, Output = V>>(
    mut p: P,
    octaves: i32,
    lacunarity: f32,
    diminish: f32,
    finite: impl Fn(P) -> bool,
    noise: impl Fn(P) -> V,
) -> V {
    let mut sum = V::default();
    let mut amplitude = 1.0;
    for _ in 0..octaves.min(MAX_OCTAVES) {
        if finite(p) {
            sum += noise(p) * amplitude;
        }
        amplitude *= diminish;
        p = p * lacunarity;
    }
    sum
}

/// MaterialX's 2D fractal noise (`mx_fractal2d_noise_float`).
pub fn fractal2(p: Vec2, octaves: i32, lacunarity: f32, diminish: f32) -> f32 {
    fractal(p, octaves, lacunarity, diminish, Vec2::is_finite, perlin2)
}

/// MaterialX's 3D fractal noise (`mx_fractal3d_noise_float`).
pub fn fractal3(p: Vec3, octaves: i32, lacunarity: f32, diminish: f32) -> f32 {
    fractal(p, octaves, lacunarity, diminish, Vec3::is_finite, perlin3)
}

/// Three 2D fractal noises (`mx_fractal2d_noise_vec3`).
pub fn fractal2_vec3(p: Vec2, octaves: i32, lacunarity: f32, diminish: f32) -> Vec3 {
    fractal(p, octaves, lacunarity, diminish, Vec2::is_finite, perlin2_vec3)
}

/// Three 3D fractal noises (`mx_fractal3d_noise_vec3`).
pub fn fractal3_vec3(p: Vec3, octaves: i32, lacunarity: f32, diminish: f32) -> Vec3 {
    fractal(p, octaves, lacunarity, diminish, Vec3::is_finite, perlin3_vec3)
}

/// The value of the unit cell holding `p` (`mx_cell_noise_float(vec2)`), in [0, 1].
pub fn cell2(p: Vec2) -> f32 {
    bits_to_01(hash_int([p.x.floor() as i32, p.y.floor() as i32]))
}

/// The value of the unit cube holding `p` (`mx_cell_noise_float(vec3)`), in [0, 1].
pub fn cell3(p: Vec3) -> f32 {
    bits_to_01(hash_int([p.x.floor() as i32, p.y.floor() as i32, p.z.floor() as i32]))
}

/// Three values of cell (x, y): the hashes of (x, y, 0..3).
fn cell2_values(x: i32, y: i32) -> Vec3 {
    Vec3::from_array([0, 1, 2].map(|k| bits_to_01(hash_int([x, y, k]))))
}

/// Three values of cell (x, y, z): the hashes of (x, y, z, 0..3), which is what MaterialX's
/// shared mix of the first three words followed by three finals gives.
fn cell3_values(x: i32, y: i32, z: i32) -> Vec3 {
    Vec3::from_array([0, 1, 2].map(|k| bits_to_01(hash_int([x, y, z, k]))))
}

/// Three values of the unit cell holding `p` (`mx_cell_noise_vec3(vec2)`).
pub fn cell2_vec3(p: Vec2) -> Vec3 {
    cell2_values(p.x.floor() as i32, p.y.floor() as i32)
}

/// Three values of the unit cube holding `p` (`mx_cell_noise_vec3(vec3)`).
pub fn cell3_vec3(p: Vec3) -> Vec3 {
    cell3_values(p.x.floor() as i32, p.y.floor() as i32, p.z.floor() as i32)
}

/// How a Worley noise measures the distance to a feature point (`mx_worley_distance`'s
/// `metric`). MaterialX's nodes use [`Metric::Euclidean`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    /// The straight-line distance (0).
    Euclidean,
    /// Its square (1).
    DistanceSquared,
    /// The sum of the axes' distances (2).
    Manhattan,
    /// The largest of the axes' distances (3).
    Chebyshev,
}

impl Metric {
    /// The measure of `d` before the final root: the squared length for the first two.
    fn measure(self, d: &[f32]) -> f32 {
        match self {
            Metric::Manhattan => d.iter().map(|x| x.abs()).sum(),
            Metric::Chebyshev => d.iter().fold(0.0, |m: f32, x| m.max(x.abs())),
            _ => d.iter().map(|x| x * x).sum(),
        }
    }
}

/// What a Worley noise finds around a point: the three smallest distances to feature points,
/// ascending, and the nearest feature point (the point where it lies, in the coordinates of
/// the noise, as MaterialX computes it: the feature relative to the point, plus the point).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Worley<P> {
    pub distances: [f32; 3],
    pub nearest: P,
}

/// Feeds `dist` into the three smallest so far (`sq`, ascending) as MaterialX's loops do;
/// true when it is the new nearest.
fn nearest3(sq: &mut [f32; 3], dist: f32) -> bool {
    if dist < sq[0] {
        *sq = [dist, sq[0], sq[1]];
        true
    } else {
        if dist < sq[1] {
            sq[2] = sq[1];
            sq[1] = dist;
        } else if dist < sq[2] {
            sq[2] = dist;
        }
        false
    }
}

/// The jittered offset of a feature in its cell, from the cell's three values
/// (`mx_worley_cell_position`: (value − ½) · jitter + ½).
fn jittered(v: f32, jitter: f32) -> f32 {
    (v - 0.5) * jitter + 0.5
}

/// MaterialX's 2D Worley noise around `p` (`mx_worley_noise_*(vec2)`).
pub fn worley2(p: Vec2, jitter: f32, metric: Metric) -> Worley<Vec2> {
    let ((x0, fx), (y0, fy)) = (floor_frac(p.x), floor_frac(p.y));
    let mut sq = [1e6f32; 3];
    let mut near = Vec2::ZERO;
    for i in -1..=1 {
        for j in -1..=1 {
            let h = cell2_values(x0.wrapping_add(i), y0.wrapping_add(j));
            let cell = Vec2::new(i as f32 + jittered(h.x, jitter), j as f32 + jittered(h.y, jitter));
            let d = Vec2::new(cell.x - fx, cell.y - fy);
            if nearest3(&mut sq, metric.measure(&d.to_array())) {
                near = d;
            }
        }
    }
    worley_result(sq, near + p, metric)
}

/// MaterialX's 3D Worley noise around `p` (`mx_worley_noise_*(vec3)`).
pub fn worley3(p: Vec3, jitter: f32, metric: Metric) -> Worley<Vec3> {
    let ((x0, fx), (y0, fy), (z0, fz)) = (floor_frac(p.x), floor_frac(p.y), floor_frac(p.z));
    let mut sq = [1e6f32; 3];
    let mut near = Vec3::ZERO;
    for i in -1..=1 {
        for j in -1..=1 {
            for k in -1..=1 {
                let h = cell3_values(x0.wrapping_add(i), y0.wrapping_add(j), z0.wrapping_add(k));
                let cell = Vec3::new(i as f32 + jittered(h.x, jitter), j as f32 + jittered(h.y, jitter), k as f32 + jittered(h.z, jitter));
                let d = Vec3::new(cell.x - fx, cell.y - fy, cell.z - fz);
                if nearest3(&mut sq, metric.measure(&d.to_array())) {
                    near = d;
                }
            }
        }
    }
    worley_result(sq, near + p, metric)
}

/// The distances (rooted for the Euclidean metric) and the nearest feature.
fn worley_result<P>(sq: [f32; 3], nearest: P, metric: Metric) -> Worley<P> {
    let distances = if metric == Metric::Euclidean { sq.map(f32::sqrt) } else { sq };
    Worley { distances, nearest }
}

/// The MaterialX noise nodes that [`crate::shader_graph::Expr::Noise`] evaluates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoiseKind {
    /// `noise2d`, `noise3d`: Perlin noise.
    Perlin,
    /// `fractal2d`, `fractal3d`: parameters (octaves, lacunarity, diminish).
    Fractal,
    /// `cellnoise2d`, `cellnoise3d`.
    Cell,
    /// `worleynoise2d`, `worleynoise3d`: parameters (jitter, style: 1 the nearest cell's
    /// value, otherwise the distances).
    Worley,
}

/// One MaterialX noise node's value at a point, before its amplitude and pivot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Noise {
    pub kind: NoiseKind,
    /// Whether it is the noise of a point in space (`*3d`, the point's x, y, z) rather than of
    /// texture coordinates (`*2d`, the point's x, y).
    pub space: bool,
    /// The output's components: 1 (float), 2 (vector2), 3 (vector3, color3) or 4 (vector4,
    /// color4).
    pub channels: u8,
}

/// The point at which MaterialX's 4-component Perlin noise takes its fourth component
/// (`mx_noise2d_vector4`, `mx_noise3d_vector4`): the point moved by this offset.
const PERLIN_W_OFFSET: [f32; 3] = [19.0, 73.0, 29.0];
/// The offset of the fractals' second scalar (`mx_fractal*_noise_vec2`, `_vec4`).
const FRACTAL_W_OFFSET: [f32; 3] = [19.0, 193.0, 17.0];

impl Noise {
    /// The node's output at `at` (its x, y and, in space, z), `params` as [`NoiseKind`] lists
    /// them: a scalar in all four components; a vector2 as (x, y, 0, 0), a vector3 as
    /// (x, y, z, 0).
    pub fn eval(&self, at: [f32; 4], params: [f32; 4]) -> [f32; 4] {
        let (p2, p3) = (Vec2::new(at[0], at[1]), Vec3::new(at[0], at[1], at[2]));
        let moved = |o: [f32; 3]| (p2 + Vec2::new(o[0], o[1]), p3 + Vec3::from_array(o));
        let scalar = |v: f32| [v; 4];
        let vector = |v: Vec3, w: f32| match self.channels {
            2 => [v.x, v.y, 0.0, 0.0],
            3 => [v.x, v.y, v.z, 0.0],
            _ => [v.x, v.y, v.z, w],
        };
        match self.kind {
            NoiseKind::Perlin => {
                let one = |(a, b): (Vec2, Vec3)| if self.space { perlin3(b) } else { perlin2(a) };
                match self.channels {
                    1 => scalar(one((p2, p3))),
                    _ => {
                        let v = if self.space { perlin3_vec3(p3) } else { perlin2_vec3(p2) };
                        let w = if self.channels == 4 { one(moved(PERLIN_W_OFFSET)) } else { 0.0 };
                        vector(v, w)
                    }
                }
            }
            NoiseKind::Fractal => {
                let (octaves, lacunarity, diminish) = (params[0] as i32, params[1], params[2]);
                let one = |(a, b): (Vec2, Vec3)| if self.space { fractal3(b, octaves, lacunarity, diminish) } else { fractal2(a, octaves, lacunarity, diminish) };
                let second = || one(moved(FRACTAL_W_OFFSET));
                match self.channels {
                    1 => scalar(one((p2, p3))),
                    // two scalar fractals, not the vector one's first two components
                    2 => [one((p2, p3)), second(), 0.0, 0.0],
                    _ => {
                        let v = if self.space { fractal3_vec3(p3, octaves, lacunarity, diminish) } else { fractal2_vec3(p2, octaves, lacunarity, diminish) };
                        let w = if self.channels == 4 { second() } else { 0.0 };
                        vector(v, w)
                    }
                }
            }
            NoiseKind::Cell => scalar(if self.space { cell3(p3) } else { cell2(p2) }),
            NoiseKind::Worley => {
                let (jitter, solid) = (params[0], params[1] as i32 == 1);
                let (distances, nearest) = if self.space {
                    let w = worley3(p3, jitter, Metric::Euclidean);
                    (w.distances, w.nearest)
                } else {
                    let w = worley2(p2, jitter, Metric::Euclidean);
                    (w.distances, w.nearest.extend(0.0))
                };
                match (solid, self.channels) {
                    (true, 1) => scalar(if self.space { cell3(nearest) } else { cell2(nearest.truncate()) }),
                    (true, _) => vector(if self.space { cell3_vec3(nearest) } else { cell2_vec3(nearest.truncate()) }, 0.0),
                    (false, 1) => scalar(distances[0]),
                    (false, _) => vector(Vec3::from_array(distances), 0.0),
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::TestRng;

    fn v2(r: &mut TestRng, s: f32) -> Vec2 {
        Vec2::new((r.next_f32() - 0.5) * s, (r.next_f32() - 0.5) * s)
    }

    fn v3(r: &mut TestRng, s: f32) -> Vec3 {
        Vec3::new((r.next_f32() - 0.5) * s, (r.next_f32() - 0.5) * s, (r.next_f32() - 0.5) * s)
    }

    /// MaterialX's hash is lookup3's `hashword(k, N, 13)`; these values were computed from
    /// lookup3.c's definition (its `mix` and `final` on 32-bit words), outside this crate.
    #[test]
    fn the_hash_is_lookup3_hashword() {
        let cases: [(&[i32], u32); 10] = [
            (&[0], 0x9519_dc65),
            (&[1], 0x4ad7_c6a0),
            (&[-1], 0x428a_df39),
            (&[0, 0], 0xdc3d_74f9),
            (&[1, 2], 0x1037_cb9d),
            (&[-3, 7], 0xbf0b_5d30),
            (&[0, 0, 0], 0x9c6e_edfb),
            (&[1, 2, 3], 0xb8d1_7a0a),
            (&[-5, 4, -3], 0x44c8_7bb7),
            (&[1, 2, 3, 4], 0x0584_dec1),
        ];
        for (k, want) in cases {
            let got = match k {
                [a] => hash_int([*a]),
                [a, b] => hash_int([*a, *b]),
                [a, b, c] => hash_int([*a, *b, *c]),
                [a, b, c, d] => hash_int([*a, *b, *c, *d]),
                _ => unreachable!(),
            };
            assert_eq!(got, want, "{k:?}: {got:#x} vs {want:#x}");
        }
        // the map to [0, 1]: both ends, and the cell values are these hashes
        assert_eq!((bits_to_01(0), bits_to_01(u32::MAX), bits_to_01(1 << 31)), (0.0, 1.0, 0.5));
        assert_eq!(cell2(Vec2::new(1.5, 2.25)), bits_to_01(0x1037_cb9d));
        assert_eq!(cell3(Vec3::new(-4.5, 4.0, -2.5)), bits_to_01(0x44c8_7bb7));
        assert_eq!(cell3_vec3(Vec3::new(1.5, 2.5, 3.5)).z, bits_to_01(hash_int([1, 2, 3, 2])));
    }

    /// Every lattice point is a zero of every Perlin noise (each corner's gradient is dotted
    /// with a zero offset), and of a fractal whose lacunarity keeps it on the lattice.
    #[test]
    fn perlin_noise_is_zero_on_the_lattice() {
        for x in -6..=6 {
            for y in -6..=6 {
                let p = Vec2::new(x as f32, y as f32);
                assert_eq!((perlin2(p), perlin2_vec3(p), fractal2(p, 5, 3.0, 0.5)), (0.0, Vec3::ZERO, 0.0), "{p}");
                for z in [-3, 0, 1, 7] {
                    let p = Vec3::new(x as f32, y as f32, z as f32);
                    assert_eq!((perlin3(p), perlin3_vec3(p), fractal3_vec3(p, 4, 2.0, 0.7)), (0.0, Vec3::ZERO, Vec3::ZERO), "{p}");
                }
            }
        }
    }

    /// Bounded by √(N/4) × the gradients' length × the scale (the extreme of N-dimensional
    /// gradient noise): 0.6616 √5 √½ ≈ 1.046 in 2D, 0.982 √2 √¾ ≈ 1.203 in 3D; it reaches
    /// near ±1 ("about −1 to 1"), and is centred on 0 (the gradients come in opposite pairs).
    #[test]
    fn perlin_noise_is_bounded_and_centred() {
        let bound2 = 0.6616 * 5f32.sqrt() * 0.5f32.sqrt();
        let bound3 = 0.9820 * 2f32.sqrt() * 0.75f32.sqrt();
        let mut r = TestRng::new(1);
        let n = 100_000;
        for (name, bound, f) in [
            ("2d", bound2, &(|r: &mut TestRng| [perlin2(v2(r, 200.0)); 3]) as &dyn Fn(&mut TestRng) -> [f32; 3]),
            ("3d", bound3, &|r: &mut TestRng| [perlin3(v3(r, 200.0)); 3]),
            ("2d vec3", bound2, &|r: &mut TestRng| perlin2_vec3(v2(r, 200.0)).to_array()),
            ("3d vec3", bound3, &|r: &mut TestRng| perlin3_vec3(v3(r, 200.0)).to_array()),
        ] {
            let (mut sum, mut sq, mut max) = (0.0f64, 0.0f64, 0.0f32);
            for _ in 0..n {
                for x in f(&mut r) {
                    assert!(x.abs() <= bound, "{name}: {x}");
                    (sum, sq, max) = (sum + x as f64, sq + (x as f64).powi(2), max.max(x.abs()));
                }
            }
            let m = 3.0 * n as f64;
            let (mean, sd) = (sum / m, (sq / m).sqrt());
            assert!(max > 0.85, "{name}: max {max}");
            assert!(mean.abs() < 4.0 * sd / (n as f64).sqrt(), "{name}: mean {mean} (sd {sd})");
        }
    }

    /// Continuous, across cell faces too: a step of h changes the noise by at most L·h, L a
    /// bound on its slope (the corners' values, ≤ |g|√N, times the fade's steepest slope 15/8,
    /// plus |g|, times the scale: under 10 in 2D and 3D); and the same point gives the same
    /// bits.
    #[test]
    fn perlin_noise_is_continuous_and_deterministic() {
        let lip = 10.0;
        let mut r = TestRng::new(2);
        for i in 0..20_000 {
            let h = 1e-3;
            let (p, d) = (v3(&mut r, 40.0), v3(&mut r, 2.0).normalize_or_zero() * h);
            // every tenth point straddles a cell face
            let p = if i % 10 == 0 { Vec3::new(p.x.round() - 0.5 * h, p.y, p.z) } else { p };
            let d = if i % 10 == 0 { Vec3::new(h, 0.0, 0.0) } else { d };
            assert!((perlin3(p + d) - perlin3(p)).abs() <= lip * h, "{p} {d}");
            assert!((perlin3_vec3(p + d) - perlin3_vec3(p)).abs().max_element() <= lip * h, "{p} {d}");
            let (q, e) = (p.truncate(), d.truncate());
            assert!((perlin2(q + e) - perlin2(q)).abs() <= lip * h, "{q} {e}");
            assert_eq!(perlin3(p).to_bits(), perlin3(p).to_bits());
            assert_eq!(perlin2_vec3(q), perlin2_vec3(q));
        }
    }

    /// A fractal is its octaves summed: noise(p·λⁱ)·δⁱ; no octave, no noise.
    #[test]
    fn fractal_noise_is_the_sum_of_its_octaves() {
        let (lacunarity, diminish) = (2.1, 0.45);
        let mut r = TestRng::new(3);
        for _ in 0..1000 {
            let (p, q) = (v3(&mut r, 20.0), v2(&mut r, 20.0));
            let (mut want3, mut want2, mut want_v) = (0.0, 0.0, Vec3::ZERO);
            let (mut pi, mut qi, mut a) = (p, q, 1.0);
            for _ in 0..5 {
                want3 += a * perlin3(pi);
                want2 += a * perlin2(qi);
                want_v += perlin3_vec3(pi) * a;
                (pi, qi, a) = (pi * lacunarity, qi * lacunarity, a * diminish);
            }
            assert!((fractal3(p, 5, lacunarity, diminish) - want3).abs() < 1e-6);
            assert!((fractal2(q, 5, lacunarity, diminish) - want2).abs() < 1e-6);
            assert!((fractal3_vec3(p, 5, lacunarity, diminish) - want_v).abs().max_element() < 1e-6);
            assert_eq!(fractal2(q, 1, lacunarity, diminish), perlin2(q));
            assert_eq!((fractal3(p, 0, lacunarity, diminish), fractal2_vec3(q, -2, lacunarity, diminish)), (0.0, Vec3::ZERO));
        }
        // octaves past the cap add nothing more; points that overflow add nothing
        let p = Vec3::new(0.3, 0.7, 0.1);
        assert_eq!(fractal3(p, 1000, 2.0, 0.5), fractal3(p, MAX_OCTAVES, 2.0, 0.5));
        assert!(fractal3(p, MAX_OCTAVES, 1e9, 0.5).is_finite());
    }

    /// Cell noise is one value per unit cell, the same anywhere inside it, and uniform over
    /// [0, 1] across cells: χ² over 20 bins (p > 0.001) and the Kolmogorov–Smirnov distance
    /// under its 0.1 % critical value 1.95/√n, over 40 000 cells in 2D and 27 000 in 3D.
    #[test]
    fn cell_noise_is_constant_per_cell_and_uniform_across_cells() {
        let mut r = TestRng::new(4);
        let check = |name: &str, values: Vec<f32>| {
            let n = values.len() as f64;
            assert!(values.iter().all(|v| (0.0..=1.0).contains(v)), "{name}");
            let mut bins = [0f64; 20];
            for v in &values {
                bins[((v * 20.0) as usize).min(19)] += 1.0;
            }
            let e = n / 20.0;
            let chi2: f64 = bins.iter().map(|b| (b - e).powi(2) / e).sum();
            let p = crate::testing::chi2::gamma_q(19.0 / 2.0, chi2 / 2.0);
            assert!(p > 0.001, "{name}: χ² {chi2}, p {p}");
            let mut sorted = values;
            sorted.sort_by(f32::total_cmp);
            let d = sorted.iter().enumerate().map(|(i, v)| ((i + 1) as f64 / n - *v as f64).abs().max((*v as f64 - i as f64 / n).abs())).fold(0.0, f64::max);
            assert!(d < 1.95 / n.sqrt(), "{name}: D {d}");
        };
        let mut values = Vec::new();
        for x in -100..100 {
            for y in -100..100 {
                let c = Vec2::new(x as f32, y as f32);
                let v = cell2(c);
                for _ in 0..2 {
                    let inside = c + Vec2::new(r.next_f32(), r.next_f32()) * 0.999;
                    assert_eq!(cell2(inside), v, "{inside}");
                }
                values.push(v);
            }
        }
        check("2d", values);
        let mut values = Vec::new();
        for x in -15..15 {
            for y in -15..15 {
                for z in -15..15 {
                    let c = Vec3::new(x as f32, y as f32, z as f32);
                    let v = cell3(c);
                    assert_eq!(cell3(c + Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()) * 0.999), v);
                    values.push(v);
                }
            }
        }
        check("3d", values);
    }

    /// Every jittered feature point of the cells (x0 + i, y0 + j) for |i|, |j| ≤ `reach`,
    /// placed from the cell's own hashes as MaterialX places it, and its cell.
    fn features2(p: Vec2, jitter: f32, reach: i32) -> Vec<(Vec2, [i32; 2])> {
        let (x0, y0) = (p.x.floor() as i32, p.y.floor() as i32);
        let mut out = Vec::new();
        for i in -reach..=reach {
            for j in -reach..=reach {
                let c = [x0 + i, y0 + j];
                let off = [0, 1].map(|k| (bits_to_01(hash_int([c[0], c[1], k])) - 0.5) * jitter + 0.5);
                out.push((Vec2::new(c[0] as f32 + off[0], c[1] as f32 + off[1]), c));
            }
        }
        out
    }

    fn features3(p: Vec3, jitter: f32, reach: i32) -> Vec<(Vec3, [i32; 3])> {
        let (x0, y0, z0) = (p.x.floor() as i32, p.y.floor() as i32, p.z.floor() as i32);
        let mut out = Vec::new();
        for i in -reach..=reach {
            for j in -reach..=reach {
                for k in -reach..=reach {
                    let c = [x0 + i, y0 + j, z0 + k];
                    let off = [0, 1, 2].map(|w| (bits_to_01(hash_int([c[0], c[1], c[2], w])) - 0.5) * jitter + 0.5);
                    out.push((Vec3::new(c[0] as f32 + off[0], c[1] as f32 + off[1], c[2] as f32 + off[2]), c));
                }
            }
        }
        out
    }

    /// The three smallest of `d` under `metric` (rooted for the Euclidean one), ascending, and
    /// the index of the smallest.
    fn three_smallest(d: impl Iterator<Item = [f32; 3]>, metric: Metric) -> ([f32; 3], usize) {
        let mut all: Vec<(f32, usize)> = d.map(|v| metric.measure(&v)).enumerate().map(|(i, m)| (m, i)).collect();
        all.sort_by(|a, b| a.0.total_cmp(&b.0));
        let root = |m: f32| if metric == Metric::Euclidean { m.sqrt() } else { m };
        ([root(all[0].0), root(all[1].0), root(all[2].0)], all[0].1)
    }

    /// Worley noise is the three smallest distances from the point to the jittered features
    /// of the 3 × 3 (× 3) cells around it, under each metric and jitter, and its solid style
    /// is the nearest feature's cell value.
    #[test]
    fn worley_noise_is_a_search_of_the_neighbouring_features() {
        let metrics = [Metric::Euclidean, Metric::DistanceSquared, Metric::Manhattan, Metric::Chebyshev];
        let mut r = TestRng::new(5);
        for i in 0..4000 {
            let (jitter, metric) = ([0.0, 0.3, 0.7, 1.0, 1.5][i % 5], metrics[i % 4]);
            let close = |a: [f32; 3], b: [f32; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-5 * (1.0 + y.abs()));
            let p = v2(&mut r, 60.0);
            let f = features2(p, jitter, 1);
            let (want, k) = three_smallest(f.iter().map(|(q, _)| [q.x - p.x, q.y - p.y, 0.0]), metric);
            let w = worley2(p, jitter, metric);
            assert!(close(w.distances, want), "{p} {jitter} {metric:?}: {:?} vs {want:?}", w.distances);
            assert!((w.nearest - f[k].0).length() < 1e-4, "{p}: {} vs {}", w.nearest, f[k].0);
            if jitter < 1.0 {
                // the feature lies inside its own cell: the solid value is that cell's
                let c = f[k].1;
                assert_eq!(cell2(w.nearest), bits_to_01(hash_int(c)));
            }
            let p = v3(&mut r, 60.0);
            let f = features3(p, jitter, 1);
            let (want, k) = three_smallest(f.iter().map(|(q, _)| (*q - p).to_array()), metric);
            let w = worley3(p, jitter, metric);
            assert!(close(w.distances, want), "{p} {jitter} {metric:?}: {:?} vs {want:?}", w.distances);
            if jitter < 1.0 {
                assert_eq!(cell3(w.nearest), bits_to_01(hash_int(f[k].1)));
            }
        }
    }

    /// The 3 × 3 (× 3) search finds the true nearest feature: for a jitter of 0.4 or less no
    /// feature further out can be closer (its distance exceeds the own cell's feature's), so a
    /// fresh search over 7 × 7 (× 7) cells agrees everywhere; at jitter 1 the search never
    /// reports less than the truth and misses it at under 0.1 % of points.
    #[test]
    fn worley_noise_agrees_with_a_wider_search() {
        let mut r = TestRng::new(6);
        let n = 5000;
        for jitter in [0.4, 1.0] {
            let mut missed = 0;
            for _ in 0..n {
                let p = v2(&mut r, 80.0);
                let truth = features2(p, jitter, 3).iter().map(|(q, _)| (*q - p).length()).fold(f32::MAX, f32::min);
                let got = worley2(p, jitter, Metric::Euclidean).distances[0];
                let q = v3(&mut r, 80.0);
                let truth3 = features3(q, jitter, 3).iter().map(|(f, _)| (*f - q).length()).fold(f32::MAX, f32::min);
                let got3 = worley3(q, jitter, Metric::Euclidean).distances[0];
                for (got, truth) in [(got, truth), (got3, truth3)] {
                    assert!(got >= truth - 1e-5, "{jitter}: {got} < {truth}");
                    if got > truth + 1e-5 {
                        assert!(jitter > 0.4, "{jitter}: {got} vs {truth}");
                        missed += 1;
                    }
                }
            }
            assert!(missed * 1000 < 2 * n, "{jitter}: {missed} of {}", 2 * n);
        }
    }

    /// Without jitter every feature is its cell's centre: the noise is 0 there and the next
    /// two features are the neighbours at distance 1; the solid style is the cell noise of
    /// the point's own cell, anywhere inside it.
    #[test]
    fn worley_noise_without_jitter_is_the_lattice_of_cell_centres() {
        for (x, y) in [(0, 0), (-3, 5), (12, -7)] {
            let c = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            assert_eq!(worley2(c, 0.0, Metric::Euclidean).distances, [0.0, 1.0, 1.0]);
            let c3 = c.extend(-1.5);
            assert_eq!(worley3(c3, 0.0, Metric::Euclidean).distances, [0.0, 1.0, 1.0]);
        }
        let solid = |space: bool, channels: u8| Noise { kind: NoiseKind::Worley, space, channels };
        let mut r = TestRng::new(7);
        for _ in 0..2000 {
            let p = v3(&mut r, 30.0);
            let at = [p.x, p.y, p.z, 0.0];
            assert_eq!(solid(false, 1).eval(at, [0.0, 1.0, 0.0, 0.0]), [cell2(p.truncate()); 4]);
            assert_eq!(solid(true, 1).eval(at, [0.0, 1.0, 0.0, 0.0]), [cell3(p); 4]);
            assert_eq!(solid(true, 3).eval(at, [0.0, 1.0, 0.0, 0.0]), cell3_vec3(p).extend(0.0).to_array());
            let v = cell2_vec3(p.truncate());
            assert_eq!(solid(false, 2).eval(at, [0.0, 1.0, 0.0, 0.0]), [v.x, v.y, 0.0, 0.0]);
        }
    }

    /// A node's outputs: a scalar in all four components, MaterialX's vector layouts (the
    /// fourth Perlin component from the point moved by (19, 73, 29), the fractals' second
    /// and fourth from (19, 193, 17)), the parameters as listed.
    #[test]
    fn node_outputs_follow_materialx_layouts() {
        let node = |kind: NoiseKind, space: bool, channels: u8| Noise { kind, space, channels };
        let p = Vec3::new(1.3, -2.7, 0.45);
        let at = [p.x, p.y, p.z, 9.0];
        let q = p.truncate();
        let v = perlin3_vec3(p);
        assert_eq!(node(NoiseKind::Perlin, true, 1).eval(at, [0.0; 4]), [perlin3(p); 4]);
        assert_eq!(node(NoiseKind::Perlin, true, 2).eval(at, [0.0; 4]), [v.x, v.y, 0.0, 0.0]);
        assert_eq!(node(NoiseKind::Perlin, true, 4).eval(at, [0.0; 4]), [v.x, v.y, v.z, perlin3(p + Vec3::new(19.0, 73.0, 29.0))]);
        let v = perlin2_vec3(q);
        assert_eq!(node(NoiseKind::Perlin, false, 3).eval(at, [0.0; 4]), [v.x, v.y, v.z, 0.0]);
        assert_eq!(node(NoiseKind::Perlin, false, 4).eval(at, [0.0; 4])[3], perlin2(q + Vec2::new(19.0, 73.0)));
        let params = [4.0, 1.9, 0.6, 0.0];
        let f = |p: Vec3| fractal3(p, 4, 1.9, 0.6);
        assert_eq!(node(NoiseKind::Fractal, true, 1).eval(at, params), [f(p); 4]);
        assert_eq!(node(NoiseKind::Fractal, true, 2).eval(at, params), [f(p), f(p + Vec3::new(19.0, 193.0, 17.0)), 0.0, 0.0]);
        let v = fractal3_vec3(p, 4, 1.9, 0.6);
        assert_eq!(node(NoiseKind::Fractal, true, 4).eval(at, params), [v.x, v.y, v.z, f(p + Vec3::new(19.0, 193.0, 17.0))]);
        let g = |q: Vec2| fractal2(q, 4, 1.9, 0.6);
        assert_eq!(node(NoiseKind::Fractal, false, 2).eval(at, params), [g(q), g(q + Vec2::new(19.0, 193.0)), 0.0, 0.0]);
        assert_eq!(node(NoiseKind::Cell, false, 1).eval(at, [0.0; 4]), [cell2(q); 4]);
        let w = worley3(p, 0.8, Metric::Euclidean).distances;
        assert_eq!(node(NoiseKind::Worley, true, 1).eval(at, [0.8, 0.0, 0.0, 0.0]), [w[0]; 4]);
        assert_eq!(node(NoiseKind::Worley, true, 3).eval(at, [0.8, 0.0, 0.0, 0.0]), [w[0], w[1], w[2], 0.0]);
        let w = worley2(q, 0.8, Metric::Euclidean).distances;
        assert_eq!(node(NoiseKind::Worley, false, 2).eval(at, [0.8, 0.0, 0.0, 0.0]), [w[0], w[1], 0.0, 0.0]);
    }
}
