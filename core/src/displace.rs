//! Displacement of a mesh along its normals (UsdPreviewSurface's `displacement`): each vertex
//! moves to P + d·N, d the scalar input read at the vertex (its texture coordinates, its
//! primvars), N the mesh's smooth normal there. The mesh is displaced as finely as it is
//! tessellated: a subdivision level (or the viewer's refinement) gives the detail.
//!
//! Vertices that share a position (a mesh is unwelded where its uvs or normals split) move
//! together, by their mean displacement along their mean normal, so seams do not open. The
//! displaced mesh's shading normals are computed from its faces, averaged over the vertices at a
//! point whose normals agreed before (an authored hard edge stays hard). Every motion key is
//! displaced along its own normals by the same amounts.

use crate::scene::{FloatInput, MeshDesc, PrimvarLookup, TexLookup, TextureDesc};
use crate::shader_graph::Lookups;
use glam::{Vec2, Vec3};
use std::cell::OnceCell;
use std::collections::HashMap;

/// What the displacement reads at vertex `v`.
struct AtVertex<'a> {
    mesh: &'a MeshDesc,
    textures: &'a [TextureDesc],
    v: usize,
    /// Every vertex's unit normal and tangent ([`vertex_frames`]), built when first read.
    frames: &'a OnceCell<Vec<[Vec3; 2]>>,
}

impl AtVertex<'_> {
    /// The vertex's unit normal and tangent.
    fn frame(&self) -> [Vec3; 2] {
        self.frames.get_or_init(|| vertex_frames(self.mesh)).get(self.v).copied().unwrap_or([Vec3::ZERO; 2])
    }
}

impl Lookups for AtVertex<'_> {
    fn texture(&self, l: &TexLookup, st: Vec2) -> [f32; 4] {
        crate::texture::lookup_rgba(self.textures, l, st)
    }

    fn primvar(&self, l: &PrimvarLookup) -> [f32; 4] {
        let v = if self.mesh.uvs_answer(&l.name) {
            let uv = self.uv();
            [uv.x, uv.y, 0.0, 0.0]
        } else {
            self.mesh.primvars.iter().find(|p| p.name == l.name).map_or(l.fallback, |p| p.element(self.v))
        };
        std::array::from_fn(|k| v[k] * l.scale[k])
    }

    fn uv(&self) -> Vec2 {
        self.mesh.uvs.as_ref().and_then(|u| u.get(self.v)).copied().unwrap_or(Vec2::ZERO)
    }

    /// The vertex's own position: a mesh is displaced before any instance places it, so the
    /// world's position is the mesh's own too.
    fn position(&self, _world: bool) -> Vec3 {
        self.mesh.origin + self.mesh.positions[self.v]
    }

    /// The vertex's own normal, in the mesh's space as the position is.
    fn normal(&self, _world: bool) -> Vec3 {
        self.frame()[0]
    }

    fn tangent(&self, _world: bool) -> Vec3 {
        self.frame()[1]
    }
}

/// Each vertex's unit normal (its authored one, else the smooth normal it is displaced along)
/// and unit tangent (the sum of its triangles' ∂p/∂u, over their texture coordinates or, as
/// a hit without them reads, their barycentrics).
fn vertex_frames(mesh: &MeshDesc) -> Vec<[Vec3; 2]> {
    let p = &mesh.positions;
    let normals = match &mesh.normals {
        Some(n) if n.len() == p.len() => n.iter().map(|n| n.normalize_or_zero()).collect(),
        _ => smooth_normals(p, &mesh.indices, &by_position(p)),
    };
    let mut tangents = vec![Vec3::ZERO; p.len()];
    for t in mesh.indices.chunks_exact(3) {
        let k = [0, 1, 2].map(|i| t[i] as usize);
        if k.iter().any(|&v| v >= p.len()) {
            continue;
        }
        let uv = match &mesh.uvs {
            Some(uv) if k.iter().all(|&v| v < uv.len()) => k.map(|v| uv[v]),
            _ => [Vec2::ZERO, Vec2::X, Vec2::Y],
        };
        let dpdu = crate::math::triangle_dpdu(k.map(|v| p[v]), uv);
        for v in k {
            tangents[v] += dpdu;
        }
    }
    normals.into_iter().zip(tangents).map(|(n, t)| [n, t.normalize_or_zero()]).collect()
}

/// The displacement at each vertex of `mesh` (0 where not finite).
fn amounts(mesh: &MeshDesc, d: &FloatInput, textures: &[TextureDesc]) -> Vec<f32> {
    let frames = OnceCell::new();
    (0..mesh.positions.len())
        .map(|v| {
            let at = AtVertex { mesh, textures, v, frames: &frames };
            let x = match d {
                FloatInput::Const(c) => *c,
                FloatInput::Texture(l) => crate::texture::lookup_float(textures, l, at.st(l)),
                FloatInput::Primvar(l) => at.primvar(l)[0],
                FloatInput::Graph(e) => e.eval(&at)[0],
            };
            if x.is_finite() { x } else { 0.0 }
        })
        .collect()
}

/// Area-weighted vertex normals of triangles `indices` over `p` (unnormalised).
fn face_sums(p: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; p.len()];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|k| t[k] as usize);
        let (Some(pa), Some(pb), Some(pc)) = (p.get(a), p.get(b), p.get(c)) else { continue };
        let f = (*pb - *pa).cross(*pc - *pa);
        for i in [a, b, c] {
            n[i] += f;
        }
    }
    n
}

/// The vertices at each position (by exact bits), in vertex order.
fn by_position(p: &[Vec3]) -> Vec<Vec<usize>> {
    let mut at: HashMap<[u32; 3], usize> = HashMap::new();
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (v, x) in p.iter().enumerate() {
        let g = *at.entry(x.to_array().map(f32::to_bits)).or_insert_with(|| {
            groups.push(Vec::new());
            groups.len() - 1
        });
        groups[g].push(v);
    }
    groups
}

/// Shading normals of `p`: each vertex's face normals summed over the vertices of its group
/// whose `before` normals agree with its own (all of them where there were none).
fn shading_normals(p: &[Vec3], indices: &[u32], groups: &[Vec<usize>], before: Option<&[Vec3]>) -> Vec<Vec3> {
    let sums = face_sums(p, indices);
    let mut out = vec![Vec3::ZERO; p.len()];
    for g in groups {
        for &v in g {
            let agree = |w: usize| before.is_none_or(|b| b[v].normalize_or_zero().dot(b[w].normalize_or_zero()) > 0.99);
            out[v] = g.iter().filter(|&&w| agree(w)).map(|&w| sums[w]).sum::<Vec3>().normalize_or_zero();
        }
    }
    out
}

/// The smooth normal at each vertex: the face normals summed over its position group, unit
/// length.
fn smooth_normals(p: &[Vec3], indices: &[u32], groups: &[Vec<usize>]) -> Vec<Vec3> {
    let sums = face_sums(p, indices);
    let mut out = vec![Vec3::ZERO; p.len()];
    for g in groups {
        let n = g.iter().map(|&v| sums[v]).sum::<Vec3>().normalize_or_zero();
        for &v in g {
            out[v] = n;
        }
    }
    out
}

/// Positions `p` moved along their smooth normals by `d` (shared per position group).
fn moved(p: &[Vec3], indices: &[u32], groups: &[Vec<usize>], d: &[f32]) -> Vec<Vec3> {
    let n = smooth_normals(p, indices, groups);
    let mut out = p.to_vec();
    for g in groups {
        let mean = g.iter().map(|&v| d[v]).sum::<f32>() / g.len() as f32;
        for &v in g {
            out[v] = p[v] + n[v] * mean;
        }
    }
    out
}

/// `mesh` displaced by `d` (see the module's text); `textures` are the scene's.
pub fn displace(mesh: &MeshDesc, d: &FloatInput, textures: &[TextureDesc]) -> MeshDesc {
    let d = amounts(mesh, d, textures);
    let groups = by_position(&mesh.positions);
    let mut out = mesh.clone();
    out.positions = moved(&mesh.positions, &mesh.indices, &groups, &d);
    out.normals = Some(shading_normals(&out.positions, &mesh.indices, &groups, mesh.normals.as_deref()));
    if let Some(m) = &mut out.motion {
        let before = m.normals.take();
        let keys: Vec<Vec<Vec3>> = m.positions.iter().map(|p| moved(p, &mesh.indices, &by_position(p), &d)).collect();
        m.normals = Some(keys.iter().enumerate().map(|(k, p)| shading_normals(p, &mesh.indices, &by_position(&m.positions[k]), before.as_ref().map(|b| &b[k][..]))).collect());
        m.positions = keys;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Channel, MeshMotion, PrimvarData, Wrap};

    /// A unit square in z = 0 split into two triangles, unwelded along its diagonal (the two
    /// triangles' copies of corners 0 and 2 have their own uvs there).
    fn square() -> MeshDesc {
        let p = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        MeshDesc {
            positions: vec![p[0], p[1], p[2], p[0], p[2], p[3]],
            indices: vec![0, 1, 2, 3, 4, 5],
            uvs: Some(vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::new(0.5, 0.0), Vec2::ONE, Vec2::Y]),
            ..Default::default()
        }
    }

    #[test]
    fn a_constant_lifts_every_vertex_along_the_normal() {
        let out = displace(&square(), &FloatInput::Const(0.25), &[]);
        assert!(out.positions.iter().zip(&square().positions).all(|(a, b)| *a == *b + Vec3::Z * 0.25));
        assert!(out.normals.unwrap().iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
    }

    #[test]
    fn a_texture_or_primvar_moves_each_vertex_by_its_value_and_shared_points_together() {
        // a 2 × 1 texture: 0.1 on the left half, 0.3 on the right, clamped, nearest at texel
        // centres; the copies of corner 0 read u = 0 and u = 0.5 (texels 0.1 and 0.2 there)
        let tex = TextureDesc { name: "d".into(), width: 2, height: 1, channels: 1, pixels: vec![0.1, 0.3].into(), wrap_s: Wrap::Clamp, wrap_t: Wrap::Clamp, filter: crate::scene::Filter::Linear };
        let l = TexLookup { texture: 0, channel: Channel::R, transform: glam::Affine2::IDENTITY, tex_scale: [1.0; 4], bias: [0.0; 4], fallback: [0.0; 4], uv_set: None };
        let d = amounts(&square(), &FloatInput::Texture(l.clone()), std::slice::from_ref(&tex));
        let want = [0.1, 0.3, 0.3, 0.2, 0.3, 0.1];
        assert!(d.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-6), "{d:?}");
        let out = displace(&square(), &FloatInput::Texture(l), std::slice::from_ref(&tex));
        // corner 0's two copies move together, by their mean 0.15
        assert!((out.positions[0].z - 0.15).abs() < 1e-6 && out.positions[0] == out.positions[3]);
        assert!((out.positions[1].z - 0.3).abs() < 1e-6 && (out.positions[5].z - 0.1).abs() < 1e-6);
        // a per-vertex primvar, scaled, and the fallback where the mesh has none
        let mut m = square();
        m.primvars.push(PrimvarData { name: "h".into(), tuple: 1, constant: false, data: vec![1.0, 2.0, 3.0, 1.0, 3.0, 4.0] });
        let scaled = PrimvarLookup { scale: [0.5; 4], ..PrimvarLookup::new("h", [0.0; 4]) };
        let out = displace(&m, &FloatInput::Primvar(scaled), &[]);
        assert_eq!(out.positions.iter().map(|p| p.z).collect::<Vec<_>>(), vec![0.5, 1.0, 1.5, 0.5, 1.5, 2.0]);
        let absent = displace(&m, &FloatInput::Primvar(PrimvarLookup::new("nope", [0.7; 4])), &[]);
        assert!(absent.positions.iter().all(|p| (p.z - 0.7).abs() < 1e-6));
    }

    /// A graph reads each vertex's normal (the smooth one, or the authored one normalised)
    /// and its tangent (u runs along +X on both triangles of the square, whatever their uvs).
    #[test]
    fn a_graph_reads_each_vertex_normal_and_tangent() {
        use crate::shader_graph::{Binary, Expr};
        // normal.z + tangent.x / 2, then normal.y
        let nz = Expr::splat(Expr::Normal { world: false }, 2);
        let tx = Expr::binary(Binary::Mul, Expr::splat(Expr::Tangent { world: true }, 0), Expr::Const([0.5; 4]));
        let d = amounts(&square(), &FloatInput::Graph(Expr::binary(Binary::Add, nz, tx)), &[]);
        assert!(d.iter().all(|x| (x - 1.5).abs() < 1e-6), "{d:?}");
        let tilted = MeshDesc { normals: Some(vec![Vec3::new(0.0, 2.0, 0.0); 6]), ..square() };
        let d = amounts(&tilted, &FloatInput::Graph(Expr::splat(Expr::Normal { world: true }, 1)), &[]);
        assert!(d.iter().all(|x| (x - 1.0).abs() < 1e-6), "{d:?}");
    }

    #[test]
    fn hard_edges_stay_hard_and_motion_keys_are_displaced_too() {
        // two faces of a cube edge, unwelded at the edge with their own normals (+Z and +X)
        let mesh = MeshDesc {
            positions: vec![Vec3::ZERO, Vec3::Y, Vec3::new(-1.0, 0.0, 0.0), Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), Vec3::Y],
            indices: vec![0, 1, 2, 3, 4, 5],
            normals: Some(vec![Vec3::Z, Vec3::Z, Vec3::Z, Vec3::X, Vec3::X, Vec3::X]),
            ..Default::default()
        };
        let mut moving = mesh.clone();
        moving.motion = Some(MeshMotion { times: vec![0.0, 1.0], positions: vec![mesh.positions.clone(), mesh.positions.iter().map(|p| *p + Vec3::Y * 2.0).collect()], normals: None });
        let out = displace(&moving, &FloatInput::Const(0.0), &[]);
        // nothing moves; each face keeps its own normal at the shared edge
        assert_eq!(out.positions, mesh.positions);
        let n = out.normals.unwrap();
        assert!((n[0] - Vec3::Z).length() < 1e-6 && (n[3] - Vec3::X).length() < 1e-6, "{n:?}");
        let m = out.motion.unwrap();
        assert_eq!(m.positions[1][1], Vec3::Y * 3.0);
        assert_eq!(m.normals.as_ref().unwrap().len(), 2);
        // a displacement moves the shared edge along the mean of the two faces' normals
        let out = displace(&mesh, &FloatInput::Const(1.0), &[]);
        let mean = (Vec3::Z + Vec3::X).normalize();
        assert!((out.positions[0] - mean).length() < 1e-6 && out.positions[0] == out.positions[3]);
    }
}
