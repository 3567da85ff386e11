//! Input validation where data enters the core: everything wrong is reported as a
//! [`Problem`] naming the item and attribute, and replaced by something renderable (dropped,
//! or a documented default). Never a panic.

use crate::accel::MAX_LEAF_ITEMS;
use crate::render::Problem;
use crate::scene::*;
use glam::{Mat4, Quat, Vec3};

fn problem(out: &mut Vec<Problem>, item: &str, attribute: &str, message: impl Into<String>) {
    out.push(Problem { item: item.to_string(), attribute: attribute.to_string(), message: message.into() });
}

fn finite3(v: Vec3) -> bool {
    v.is_finite()
}

fn mat_ok(m: &Mat4) -> bool {
    m.is_finite() && m.determinant().abs() > 1e-30
}

/// Drops primvars whose data does not fit `n` elements (one when constant) or is not finite.
fn check_primvars(pvs: &mut Vec<PrimvarData>, n: usize, item: &str, p: &mut Vec<Problem>) {
    pvs.retain(|pv| {
        let ok = primvar_fits(pv, n);
        if !ok {
            problem(p, item, &format!("primvars:{}", pv.name), format!("{} values for {} elements of {}, or not finite; ignored", pv.data.len(), if pv.constant { 1 } else { n }, pv.tuple));
        }
        ok
    });
}

/// A primvar lookup's fallback and scale must be finite (zero and one otherwise).
fn fix_fallback(l: &mut PrimvarLookup, item: &str, attr: &str, p: &mut Vec<Problem>) {
    if l.fallback.iter().any(|x| !x.is_finite()) {
        problem(p, item, attr, format!("the fallback of primvar '{}' is not finite; using 0", l.name));
        l.fallback = [0.0; 4];
    }
    if l.scale.iter().any(|x| !x.is_finite()) {
        problem(p, item, attr, format!("the scale of primvar '{}' is not finite; using 1", l.name));
        l.scale = [1.0; 4];
    }
}

/// A node graph's leaves made safe: a missing texture reads its fallback, primvar fallbacks
/// and scales are finite.
fn fix_graph(e: &mut crate::shader_graph::Expr, n_tex: usize, item: &str, attr: &str, p: &mut Vec<Problem>) {
    use crate::shader_graph::Expr;
    use crate::texture::channel_rgba;
    e.leaves_mut(&mut |leaf| match leaf {
        Expr::Texture(l) if l.texture >= n_tex => {
            problem(p, item, attr, "texture missing; fallback used");
            *leaf = Expr::Const(channel_rgba(l.fallback, l.channel));
        }
        Expr::Texture(l) => {
            if let Some(set) = &mut l.uv_set {
                fix_fallback(set, item, attr, p);
            }
        }
        Expr::Primvar(l) => fix_fallback(l, item, attr, p),
        _ => {}
    });
}

/// Whether a primvar's data fits `n` elements (one when constant) and is finite.
fn primvar_fits(pv: &PrimvarData, n: usize) -> bool {
    let need = pv.tuple as usize * if pv.constant { 1 } else { n };
    pv.tuple >= 1 && pv.data.len() == need && pv.data.iter().all(|x| x.is_finite())
}

/// A shading normal as the renderer takes it: normalised (exactly what normalising it again
/// gives), or zero, which marks "use the geometric normal".
fn normal_ok(n: Vec3) -> bool {
    n == Vec3::ZERO || n == n.normalize_or_zero()
}

/// Why a deforming mesh's keys cannot be used, if they cannot.
fn motion_fault(mo: &MeshMotion, nv: usize) -> Option<&'static str> {
    let times_ok = mo.times.len() >= 2 && mo.times.iter().all(|t| t.is_finite()) && mo.times.windows(2).all(|w| w[0] < w[1]);
    let keys_ok = mo.positions.len() == mo.times.len() && mo.positions.iter().all(|k| k.len() == nv && k.iter().all(|&x| finite3(x)));
    let normals_ok = mo.normals.as_ref().is_none_or(|n| n.len() == mo.times.len() && n.iter().all(|k| k.len() == nv));
    if !times_ok {
        Some("motion key times are not finite and increasing")
    } else if !keys_ok {
        Some("a motion key has another point count or NaN/inf points")
    } else if !normals_ok {
        Some("motion normals do not match the point keys")
    } else {
        None
    }
}

#[derive(Clone, Copy, PartialEq)]
enum TriangleFault {
    Index,
    Point,
    Degenerate,
}

fn triangle_fault(positions: &[Vec3], t: &[u32]) -> Option<TriangleFault> {
    if t.iter().any(|&i| i as usize >= positions.len()) {
        return Some(TriangleFault::Index);
    }
    let v = [positions[t[0] as usize], positions[t[1] as usize], positions[t[2] as usize]];
    if !v.iter().all(|&x| finite3(x)) {
        return Some(TriangleFault::Point);
    }
    let area2 = (v[1] - v[0]).cross(v[2] - v[0]).length();
    if !(area2 > 0.0) {
        return Some(TriangleFault::Degenerate);
    }
    None
}

/// Whether [`mend_mesh`] would find nothing to report or change: the common case, where the
/// mesh is taken as it is, shared and not copied.
fn mesh_is_clean(m: &MeshDesc) -> bool {
    let nv = m.positions.len();
    if !finite3(m.origin) || m.indices.len() % 3 != 0 || m.indices.len() / 3 > MAX_LEAF_ITEMS || !(m.faces.is_empty() || m.faces.len() == m.indices.len() / 3) || m.normals.as_ref().is_some_and(|n| n.len() != nv) || m.uvs.as_ref().is_some_and(|u| u.len() != nv) {
        return false;
    }
    if !m.primvars.iter().all(|pv| primvar_fits(pv, nv)) {
        return false;
    }
    if let Some(mo) = &m.motion {
        if motion_fault(mo, nv).is_some() || (m.normals.is_none() && mo.normals.is_some()) || !mo.normals.iter().flatten().flatten().all(|&n| normal_ok(n)) {
            return false;
        }
    }
    m.normals.iter().flatten().all(|&n| normal_ok(n)) && m.indices.chunks_exact(3).all(|t| triangle_fault(&m.positions, t).is_none())
}

/// Drops triangles with bad indices, non-finite vertices or zero area, those past the most one
/// BVH holds, and whatever else of the mesh does not fit its points, reporting each.
fn mend_mesh(m: &mut MeshDesc, p: &mut Vec<Problem>) {
    mend_mesh_within(m, p, MAX_LEAF_ITEMS)
}

/// [`mend_mesh`] keeping at most `max_triangles`.
fn mend_mesh_within(m: &mut MeshDesc, p: &mut Vec<Problem>, max_triangles: usize) {
    let nv = m.positions.len();
    if !finite3(m.origin) {
        problem(p, &m.name, "origin", "not finite; taken as zero".to_string());
        m.origin = Vec3::ZERO;
    }
    if m.indices.len() % 3 != 0 {
        problem(p, &m.name, "indices", format!("{} indices is not a multiple of 3; the tail is dropped", m.indices.len()));
        m.indices.truncate(m.indices.len() / 3 * 3);
    }
    if !(m.faces.is_empty() || m.faces.len() == m.indices.len() / 3) {
        problem(p, &m.name, "faces", format!("{} elements for {} triangles; each triangle taken as its own", m.faces.len(), m.indices.len() / 3));
        m.faces = Vec::new();
    }
    if let Some(n) = &m.normals {
        if n.len() != nv {
            problem(p, &m.name, "normals", format!("{} normals for {} points; normals ignored", n.len(), nv));
            m.normals = None;
        }
    }
    if let Some(uv) = &m.uvs {
        if uv.len() != nv {
            problem(p, &m.name, "primvars:st", format!("{} uvs for {} points; uvs ignored", uv.len(), nv));
            m.uvs = None;
        }
    }
    check_primvars(&mut m.primvars, nv, &m.name, p);
    if let Some(what) = m.motion.as_ref().and_then(|mo| motion_fault(mo, nv)) {
        problem(p, &m.name, "points", format!("{what}; the mesh renders static"));
        m.motion = None;
    } else if m.normals.is_none() {
        if let Some(mo) = m.motion.as_mut() {
            mo.normals = None;
        }
    }
    let (mut bad_index, mut bad_point, mut degenerate) = (0usize, 0usize, 0usize);
    let mut kept = Vec::with_capacity(m.indices.len());
    // the element of each triangle kept (the triangles after a dropped one move up)
    let mut faces = Vec::with_capacity(m.indices.len() / 3);
    for (i, t) in m.indices.chunks_exact(3).enumerate() {
        match triangle_fault(&m.positions, t) {
            Some(TriangleFault::Index) => bad_index += 1,
            Some(TriangleFault::Point) => bad_point += 1,
            Some(TriangleFault::Degenerate) => degenerate += 1,
            None => {
                kept.extend_from_slice(t);
                faces.push(m.element_of(i as u32));
            }
        }
    }
    if bad_index > 0 {
        problem(p, &m.name, "faceVertexIndices", format!("{bad_index} triangles index points out of range; dropped"));
    }
    if bad_point > 0 {
        problem(p, &m.name, "points", format!("{bad_point} triangles use NaN/inf points; dropped"));
    }
    if degenerate > 0 {
        // degenerate triangles are common in production meshes: dropped quietly but counted
        problem(p, &m.name, "points", format!("{degenerate} degenerate (zero-area) triangles dropped"));
    }
    if kept.len() / 3 > max_triangles {
        problem(p, &m.name, "faceVertexIndices", format!("{} triangles exceed the {max_triangles} one mesh can hold; the last {} are dropped (split the mesh)", kept.len() / 3, kept.len() / 3 - max_triangles));
        kept.truncate(max_triangles * 3);
        faces.truncate(max_triangles);
    }
    if kept.len() < m.indices.len() {
        m.faces = faces;
    }
    m.indices = kept;
    // normals are normalised; one that cannot be is zero ("use the geometric normal")
    let fix_normal = |v: &mut Vec3| *v = v.normalize_or_zero();
    if let Some(n) = &mut m.normals {
        n.iter_mut().for_each(fix_normal);
    }
    if let Some(n) = m.motion.as_mut().and_then(|mo| mo.normals.as_mut()) {
        n.iter_mut().flatten().for_each(fix_normal);
    }
}

/// Drops points that are not finite or whose radius is not positive and finite, those past the
/// most one BVH holds, and whatever else of a sphere set does not fit its points, reporting each.
fn mend_spheres(sp: &mut SpheresDesc, p: &mut Vec<Problem>) {
    mend_spheres_within(sp, p, MAX_LEAF_ITEMS)
}

/// [`mend_spheres`] keeping at most `max_points`.
fn mend_spheres_within(sp: &mut SpheresDesc, p: &mut Vec<Problem>, max_points: usize) {
    let n = sp.centers.len();
    if !finite3(sp.origin) {
        problem(p, &sp.name, "origin", "not finite; taken as zero".to_string());
        sp.origin = Vec3::ZERO;
    }
    if sp.radii.len() != n {
        problem(p, &sp.name, "widths", format!("{} widths for {} points; missing ones use the first or 1", sp.radii.len(), n));
        let r0 = sp.radii.first().copied().unwrap_or(0.5);
        sp.radii.resize(n, r0);
    }
    if let Some(v) = &sp.velocities {
        if v.len() != n || v.iter().any(|x| !finite3(*x)) {
            problem(p, &sp.name, "velocities", "wrong count or non-finite velocities; motion ignored");
            sp.velocities = None;
        }
    }
    if !(sp.ids.is_empty() || sp.ids.len() == n) {
        problem(p, &sp.name, "ids", format!("{} ids for {} points; each point taken as its own", sp.ids.len(), n));
        sp.ids = Vec::new();
    }
    fix_point_shape(sp, p);
    check_primvars(&mut sp.primvars, n, &sp.name, p);
    let mut keep = vec![true; n];
    let (mut bad_c, mut bad_r) = (0, 0);
    for i in 0..n {
        if !finite3(sp.centers[i]) {
            keep[i] = false;
            bad_c += 1;
        } else if !(sp.radii[i] > 0.0 && sp.radii[i].is_finite()) {
            keep[i] = false;
            bad_r += 1;
        }
    }
    if bad_c > 0 {
        problem(p, &sp.name, "points", format!("{bad_c} NaN/inf points dropped"));
    }
    if bad_r > 0 {
        problem(p, &sp.name, "widths", format!("{bad_r} points with zero, negative or non-finite width dropped"));
    }
    let good = n - bad_c - bad_r;
    if good > max_points {
        problem(p, &sp.name, "points", format!("{good} points exceed the {max_points} one points prim can hold; the last {} are dropped (split the prim)", good - max_points));
        let mut left = max_points;
        for k in keep.iter_mut().filter(|k| **k) {
            *k = left > 0;
            left = left.saturating_sub(1);
        }
    }
    if good != n || good > max_points {
        let idx: Vec<usize> = (0..n).filter(|&i| keep[i]).collect();
        sp.ids = idx.iter().map(|&i| sp.element_of(i as u32)).collect();
        sp.centers = idx.iter().map(|&i| sp.centers[i]).collect();
        sp.radii = idx.iter().map(|&i| sp.radii[i]).collect();
        if let Some(v) = &sp.velocities {
            sp.velocities = Some(idx.iter().map(|&i| v[i]).collect());
        }
        for pv in sp.primvars.iter_mut().filter(|pv| !pv.constant) {
            let t = pv.tuple as usize;
            pv.data = idx.iter().flat_map(|&i| pv.data[i * t..i * t + t].to_vec()).collect();
        }
        let pick = |v: &mut Vec<f32>| *v = idx.iter().map(|&i| v[i]).collect();
        match &mut sp.shape {
            PointShape::Spheres => {}
            PointShape::Bubbles { top, bottom, orientations } => {
                pick(top);
                pick(bottom);
                if let Some(o) = orientations {
                    *o = idx.iter().map(|&i| o[i]).collect();
                }
            }
            PointShape::Blobby { orientations, scales, .. } => {
                if let Some(o) = orientations {
                    *o = idx.iter().map(|&i| o[i]).collect();
                }
                if let Some(sc) = scales {
                    *sc = idx.iter().map(|&i| sc[i]).collect();
                }
            }
        }
    }
}

/// Keeps the first `max` instances (the top-level BVH addresses at most [`MAX_LEAF_ITEMS`]),
/// naming the first one dropped and how many follow it.
fn cap_instances(instances: &mut Vec<InstanceDesc>, p: &mut Vec<Problem>, max: usize) {
    if instances.len() > max {
        let n = instances.len();
        problem(p, &instances[max].name, "instances", format!("{n} instances exceed the {max} one scene holds; this one and the {} after it are dropped", n - max - 1));
        instances.truncate(max);
    }
}

/// Whether [`mend_spheres`] would find nothing to report or change.
fn spheres_are_clean(sp: &SpheresDesc) -> bool {
    let n = sp.centers.len();
    let quats_ok = |o: &Option<Vec<Quat>>| o.as_ref().is_none_or(|q| q.len() == n && q.iter().all(|q| q.is_finite() && q.length_squared() > 0.0 && *q == q.normalize()));
    let shape_ok = match &sp.shape {
        PointShape::Spheres => true,
        PointShape::Bubbles { top, bottom, orientations } => [top, bottom].iter().all(|v| v.len() == n && v.iter().all(|h| *h > 0.0 && h.is_finite())) && quats_ok(orientations),
        PointShape::Blobby { threshold, orientations, scales } => {
            *threshold > 0.0 && *threshold < 1.0 && quats_ok(orientations) && scales.as_ref().is_none_or(|sc| sc.len() == n && sc.iter().all(|s| s.is_finite() && s.min_element() > 0.0))
        }
    };
    n <= MAX_LEAF_ITEMS
        && finite3(sp.origin)
        && (sp.ids.is_empty() || sp.ids.len() == n)
        && sp.radii.len() == n
        && sp.velocities.as_ref().is_none_or(|v| v.len() == n && v.iter().all(|x| finite3(*x)))
        && shape_ok
        && sp.primvars.iter().all(|pv| primvar_fits(pv, n))
        && sp.centers.iter().zip(&sp.radii).all(|(c, r)| finite3(*c) && *r > 0.0 && r.is_finite())
}

/// Validates one shared item (a mesh, a sphere set): the result an earlier validation made of
/// the same item (by identity, with its problems) if `old` or `now` holds one; else the item
/// itself when `clean` finds nothing to mend, or a mended copy. Recorded in `now` when `keep`.
fn check_shared<T: Clone>(item: &mut std::sync::Arc<T>, old: &mut Memo<T>, now: &mut Memo<T>, keep: bool, p: &mut Vec<Problem>, clean: fn(&T) -> bool, mend: fn(&mut T, &mut Vec<Problem>)) {
    use std::sync::Arc;
    let key = Arc::as_ptr(item) as usize;
    if let Some(e) = now.get(&key).or_else(|| old.get(&key)).filter(|e| Arc::ptr_eq(&e.0, item)) {
        p.extend(e.2.iter().cloned());
        *item = e.1.clone();
        if let Some(e) = old.remove(&key) {
            now.insert(key, e);
        }
        return;
    }
    let input = item.clone();
    let mut found = Vec::new();
    if !clean(item) {
        mend(Arc::make_mut(item), &mut found);
    }
    p.extend(found.iter().cloned());
    if keep {
        now.insert(key, (input, item.clone(), found));
    }
}

/// Items checked, by the input's address: (the input, held so the address is not reused; what
/// validation made of it; its problems).
type Memo<T> = std::collections::HashMap<usize, (std::sync::Arc<T>, std::sync::Arc<T>, Vec<Problem>)>;

/// What earlier validations found, kept so that the next one does not check again what is
/// unchanged: meshes and sphere sets recognised by identity (the same shared item) with what
/// validation made of them and its problems, and texture pixels known to be finite. After each
/// validation the cache holds exactly what that validation used. Cloning shares it.
#[derive(Clone, Default)]
pub struct CheckCache {
    inner: std::sync::Arc<std::sync::Mutex<Checked>>,
}

#[derive(Default)]
struct Checked {
    meshes: Memo<MeshDesc>,
    spheres: Memo<SpheresDesc>,
    /// By the pixels' address: pixels whose every texel is finite.
    finite_pixels: std::collections::HashMap<usize, crate::texture::Texels>,
}

impl CheckCache {
    /// Meshes and sphere sets held.
    pub fn len(&self) -> (usize, usize) {
        let c = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        (c.meshes.len(), c.spheres.len())
    }
}

/// Returns a cleaned copy of the scene and the problems found.
pub fn validate(scene: &SceneDesc) -> (SceneDesc, Vec<Problem>) {
    validate_cached(scene, None)
}

/// [`validate`], taking what `cache` knows of unchanged meshes and textures and leaving in it
/// what this validation found. A mesh with nothing to mend is shared, not copied.
pub fn validate_cached(scene: &SceneDesc, cache: Option<&CheckCache>) -> (SceneDesc, Vec<Problem>) {
    let mut p = Vec::new();
    let mut s = scene.clone();
    let mut old = cache.map(|c| std::mem::take(&mut *c.inner.lock().unwrap_or_else(|e| e.into_inner()))).unwrap_or_default();
    let mut now = Checked::default();

    for m in &mut s.meshes {
        check_shared(m, &mut old.meshes, &mut now.meshes, cache.is_some(), &mut p, mesh_is_clean, mend_mesh);
    }

    // spheres: drop non-finite or non-positive radii
    for sp in &mut s.spheres {
        check_shared(sp, &mut old.spheres, &mut now.spheres, cache.is_some(), &mut p, spheres_are_clean, mend_spheres);
    }

    // textures
    for t in &mut s.textures {
        let need = (t.width as usize) * (t.height as usize) * (t.channels as usize);
        if !(1..=4).contains(&t.channels) || t.pixels.len() != need || t.width == 0 || t.height == 0 {
            problem(&mut p, &t.name, "pixels", "texture size does not match its data; replaced by a 1×1 grey texture");
            *t = TextureDesc { name: t.name.clone(), width: 1, height: 1, channels: 1, pixels: vec![0.18].into(), wrap_s: t.wrap_s, wrap_t: t.wrap_t, filter: t.filter };
        } else {
            let key = t.pixels.address();
            let known = now.finite_pixels.get(&key).or_else(|| old.finite_pixels.get(&key)).is_some_and(|k| k.same(&t.pixels));
            if known || t.pixels.all_finite() {
                if cache.is_some() {
                    now.finite_pixels.insert(key, t.pixels.clone());
                }
            } else {
                problem(&mut p, &t.name, "pixels", "NaN/inf texels replaced by 0");
                t.pixels.zero_non_finite();
            }
        }
    }

    // media
    for m in &mut s.media {
        let check = |d: &mut SpectrumDesc, attr: &str, p: &mut Vec<Problem>| {
            let bad = match d {
                SpectrumDesc::Rgb(c) => c.iter().any(|v| !v.is_finite() || *v < 0.0),
                SpectrumDesc::Tabulated { lambda, value } => {
                    lambda.len() != value.len() || lambda.is_empty() || value.iter().chain(lambda.iter()).any(|v| !v.is_finite() || *v < 0.0) || lambda.windows(2).any(|w| w[1] <= w[0])
                }
            };
            if bad {
                problem(p, &m.name, attr, "negative, non-finite or malformed coefficients; replaced by 0");
                *d = SpectrumDesc::Rgb([0.0; 3]);
            }
        };
        check(&mut m.sigma_a, "absorption", &mut p);
        check(&mut m.sigma_s, "scattering", &mut p);
        if !(m.scale.is_finite() && m.scale >= 0.0) {
            problem(&mut p, &m.name, "densityScale", "must be finite and ≥ 0; using 1");
            m.scale = 1.0;
        }
        let fix_g = |g: &mut f32, attr: &str, p: &mut Vec<Problem>| {
            if !g.is_finite() || g.abs() >= 1.0 {
                problem(p, &m.name, attr, format!("g = {g} outside (−1, 1); clamped"));
                *g = if g.is_finite() { g.clamp(-0.999, 0.999) } else { 0.0 };
            }
        };
        match &mut m.phase {
            PhaseDesc::Isotropic => {}
            PhaseDesc::HenyeyGreenstein { g } => fix_g(g, "g", &mut p),
            PhaseDesc::DualHg { g1, g2, w } => {
                fix_g(g1, "g", &mut p);
                fix_g(g2, "g2", &mut p);
                if !(w.is_finite() && (0.0..=1.0).contains(w)) {
                    problem(&mut p, &m.name, "lobeMix", "outside [0, 1]; clamped");
                    *w = if w.is_finite() { w.clamp(0.0, 1.0) } else { 0.9 };
                }
            }
            PhaseDesc::Tabulated { .. } => {
                if let Err(e) = crate::medium::PhaseFunction::from_desc(&m.phase) {
                    problem(&mut p, &m.name, "phase", format!("{e}; using isotropic"));
                    m.phase = PhaseDesc::Isotropic;
                }
            }
        }
        if let Some(w) = &mut m.water {
            let name = m.name.clone();
            let mut fix = |v: &mut f32, attr: &str, ok: bool, default: f32, what: &str| {
                if !ok {
                    problem(&mut p, &name, attr, format!("{v} {what}; using {default}"));
                    *v = default;
                }
            };
            for (v, attr) in [(&mut w.chlorophyll, "chlorophyll"), (&mut w.cdom, "cdom"), (&mut w.spm, "spm")] {
                let ok = v.is_finite() && *v >= 0.0;
                fix(v, attr, ok, 0.0, "must be finite and ≥ 0");
            }
            if let Some(pr) = &mut w.profile {
                let ok = pr.depth.is_finite();
                fix(&mut pr.depth, "profileDepth", ok, 0.0, "must be finite");
                let ok = pr.width.is_finite() && pr.width >= 0.0;
                fix(&mut pr.width, "profileWidth", ok, 0.0, "must be finite and ≥ 0");
                let ok = pr.peak.is_finite() && pr.peak >= 0.0;
                fix(&mut pr.peak, "profilePeak", ok, 0.0, "must be finite and ≥ 0");
            }
            let ok = w.salinity.is_finite() && (0.0..=45.0).contains(&w.salinity);
            fix(&mut w.salinity, "salinity", ok, 0.0, "PSU is outside [0, 45]");
            if let Some(t) = &mut w.top {
                let ok = t.is_finite();
                fix(t, "top", ok, 0.0, "must be finite");
            }
            if !(w.up.is_finite() && (w.up.length() - 1.0).abs() < 1e-3) {
                problem(&mut p, &m.name, "up", format!("{} is not a unit vector; using +Y", w.up));
                w.up = glam::Vec3::Y;
            }
            if let Some(j) = w.jerlov {
                if !j.source.has_type(j.water_type) {
                    problem(&mut p, &m.name, "jerlovSource", format!("Jerlov type {} is not tabulated by {}; using solonenko2015", j.water_type.name(), j.source.name()));
                    w.jerlov = Some(JerlovDesc { source: crate::water::JerlovSource::Solonenko2015, ..j });
                }
            }
        }
    }

    // materials: references and parameters
    if s.materials.is_empty() {
        s.materials.push(MaterialDesc { name: "/tide/default".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.18; 3]) }, interior_medium: None });
    }
    let n_media = s.media.len();
    let n_tex = s.textures.len();
    for m in &mut s.materials {
        if let Some(i) = m.interior_medium {
            if i >= n_media {
                problem(&mut p, &m.name, "outputs:volume", "refers to a medium that does not exist; ignored");
                m.interior_medium = None;
            }
        }
        let tex_ok = |l: &TexLookup| l.texture < n_tex;
        let fix_color = |c: &mut ColorInput, attr: &str, p: &mut Vec<Problem>, fallback: Rgb| match c {
            ColorInput::Const(v) => {
                if v.iter().any(|x| !x.is_finite()) {
                    problem(p, &m.name, attr, "non-finite colour; default used");
                    *v = fallback;
                }
            }
            ColorInput::Texture(l) => {
                if !tex_ok(l) {
                    problem(p, &m.name, attr, "texture missing; fallback used");
                    *c = ColorInput::Const([l.fallback[0], l.fallback[1], l.fallback[2]]);
                } else if let Some(set) = &mut l.uv_set {
                    fix_fallback(set, &m.name, attr, p);
                }
            }
            ColorInput::Primvar(l) => fix_fallback(l, &m.name, attr, p),
            ColorInput::Graph(e) => fix_graph(e, n_tex, &m.name, attr, p),
        };
        let fix_float = |c: &mut FloatInput, attr: &str, p: &mut Vec<Problem>, fallback: f32| match c {
            FloatInput::Const(v) => {
                if !v.is_finite() {
                    problem(p, &m.name, attr, "non-finite value; default used");
                    *v = fallback;
                }
            }
            FloatInput::Texture(l) => {
                if !tex_ok(l) {
                    problem(p, &m.name, attr, "texture missing; fallback used");
                    *c = FloatInput::Const(l.fallback[0]);
                } else if let Some(set) = &mut l.uv_set {
                    fix_fallback(set, &m.name, attr, p);
                }
            }
            FloatInput::Primvar(l) => fix_fallback(l, &m.name, attr, p),
            FloatInput::Graph(e) => fix_graph(e, n_tex, &m.name, attr, p),
        };
        let fix_preview = |ps: &mut PreviewSurfaceDesc, p: &mut Vec<Problem>| {
            fix_color(&mut ps.diffuse_color, "inputs:diffuseColor", p, [0.18; 3]);
            fix_color(&mut ps.emissive_color, "inputs:emissiveColor", p, [0.0; 3]);
            fix_color(&mut ps.specular_color, "inputs:specularColor", p, [0.0; 3]);
            fix_float(&mut ps.metallic, "inputs:metallic", p, 0.0);
            fix_float(&mut ps.roughness, "inputs:roughness", p, 0.5);
            fix_float(&mut ps.clearcoat, "inputs:clearcoat", p, 0.0);
            fix_float(&mut ps.clearcoat_roughness, "inputs:clearcoatRoughness", p, 0.01);
            fix_float(&mut ps.opacity, "inputs:opacity", p, 1.0);
            if let Some(w) = &mut ps.wet {
                fix_float(&mut w.amount, "tide:wet:amount", p, 0.0);
            }
            if !(ps.ior.is_finite() && ps.ior > 0.0) {
                problem(p, &m.name, "inputs:ior", "must be > 0; using 1.5");
                ps.ior = 1.5;
            }
            if let Some(n) = &mut ps.normal {
                if matches!(n, ColorInput::Texture(l) if !tex_ok(l)) {
                    problem(p, &m.name, "inputs:normal", "texture missing; the surface's own normal is used");
                    ps.normal = None;
                } else {
                    fix_color(n, "inputs:normal", p, [0.0, 0.0, 1.0]);
                }
            }
        };
        match &mut m.surface {
            SurfaceDesc::Diffuse { color } => fix_color(color, "inputs:diffuseColor", &mut p, [0.18; 3]),
            SurfaceDesc::Preview(ps) => fix_preview(ps, &mut p),
            SurfaceDesc::Water(w) => {
                if let Some(t) = &mut w.tint {
                    fix_color(t, "inputs:transmission_color", &mut p, [1.0; 3]);
                }
                if let Some(b) = &mut w.blend {
                    fix_float(&mut b.transmission, "inputs:transmission", &mut p, 1.0);
                    fix_preview(&mut b.surface, &mut p);
                }
                if !(w.ior.is_finite() && w.ior >= 1.0 && w.ior < 10.0) {
                    problem(&mut p, &m.name, "inputs:ior", format!("ior {} not in [1, 10); using 1.333", w.ior));
                    w.ior = 1.333;
                }
                if !(w.roughness.is_finite() && (0.0..=1.0).contains(&w.roughness)) {
                    problem(&mut p, &m.name, "inputs:roughness", "outside [0, 1]; clamped");
                    w.roughness = if w.roughness.is_finite() { w.roughness.clamp(0.0, 1.0) } else { 0.0 };
                }
                if !(w.slope_variance_scale.is_finite() && w.slope_variance_scale >= 0.0) {
                    problem(&mut p, &m.name, "slopeVarianceScale", format!("{} is not a share >= 0; using 1", w.slope_variance_scale));
                    w.slope_variance_scale = 1.0;
                }
            }
            SurfaceDesc::Conductor { eta, k, roughness } => {
                if eta.iter().chain(k.iter()).any(|v| !v.is_finite() || *v < 0.0) || !roughness.is_finite() {
                    problem(&mut p, &m.name, "inputs", "invalid conductor parameters; using a grey diffuse");
                    m.surface = SurfaceDesc::Diffuse { color: ColorInput::Const([0.18; 3]) };
                }
            }
            SurfaceDesc::Emissive { radiance, .. } => {
                if radiance.iter().any(|v| !v.is_finite() || *v < 0.0) {
                    problem(&mut p, &m.name, "inputs:emissiveColor", "negative or non-finite emission; black");
                    *radiance = [0.0; 3];
                }
            }
        }
    }

    // instances
    let n_mat = s.materials.len();
    let (n_mesh, n_sph) = (s.meshes.len(), s.spheres.len());
    for t in &mut s.instance_primvars {
        check_primvars(&mut t.primvars, t.rows as usize, &t.name, &mut p);
    }
    let table_rows: Vec<u32> = s.instance_primvars.iter().map(|t| t.rows).collect();
    let row_ok = |inst: &InstanceDesc| inst.primvar_row.is_none_or(|(t, r)| table_rows.get(t as usize).is_some_and(|&n| r < n));
    let geometry_ok = |inst: &InstanceDesc| match inst.geometry {
        GeometryRef::Mesh(i) => i < n_mesh,
        GeometryRef::Spheres(i) => i < n_sph,
    };
    let times_ok = |inst: &InstanceDesc| inst.times.len() == inst.transforms.len() && inst.times.windows(2).all(|w| w[1] > w[0]) && inst.times.iter().all(|t| t.is_finite());
    let material_ok = |inst: &InstanceDesc| inst.material < n_mat;
    let keys_ok = |inst: &InstanceDesc| inst.transforms.iter().all(mat_ok);
    let clean = |inst: &InstanceDesc| row_ok(inst) && geometry_ok(inst) && material_ok(inst) && !inst.transforms.is_empty() && times_ok(inst) && keys_ok(inst);
    // the instances are shared with the scene given: copied only when one needs mending
    if s.instances.len() > MAX_LEAF_ITEMS || !s.instances.iter().all(clean) {
        let instances = s.instances_mut();
        for inst in instances.iter_mut().filter(|i| !row_ok(i)) {
            problem(&mut p, &inst.name, "primvars", "refers to per-instance primvars that do not exist; ignored");
            inst.primvar_row = None;
        }
        instances.retain_mut(|inst| {
            if !geometry_ok(inst) {
                problem(&mut p, &inst.name, "geometry", "refers to geometry that does not exist; dropped");
                return false;
            }
            if !material_ok(inst) {
                problem(&mut p, &inst.name, "material:binding", "refers to a material that does not exist; default used");
                inst.material = 0;
            }
            if inst.transforms.is_empty() {
                inst.transforms = vec![Mat4::IDENTITY];
                inst.times = vec![0.0];
            }
            if !times_ok(inst) {
                problem(&mut p, &inst.name, "xformOp", "motion samples have bad times; only the first sample is used");
                inst.transforms.truncate(1);
                inst.times = vec![0.0];
            }
            if !keys_ok(inst) {
                problem(&mut p, &inst.name, "xformOp", "singular or non-finite transform; prim dropped");
                return false;
            }
            true
        });
        cap_instances(instances, &mut p, MAX_LEAF_ITEMS);
    }

    // lights
    s.lights.retain_mut(|l| {
        if !mat_ok(&l.transform) {
            problem(&mut p, &l.name, "xformOp", "singular or non-finite transform; light dropped");
            return false;
        }
        if !(l.intensity.is_finite() && l.exposure.is_finite()) || l.color.iter().any(|c| !c.is_finite()) {
            problem(&mut p, &l.name, "inputs:intensity", "non-finite intensity, exposure or colour; light dropped");
            return false;
        }
        let area_bad = match &l.shape {
            LightShape::Sphere { radius, treat_as_point } => !treat_as_point && !(*radius >= 0.0 && radius.is_finite()),
            LightShape::Rect { width, height, .. } => !(*width > 0.0 && *height > 0.0 && width.is_finite() && height.is_finite()),
            LightShape::Disk { radius } => !(*radius > 0.0 && radius.is_finite()),
            LightShape::Cylinder { radius, length, treat_as_line } => !(*length > 0.0 && length.is_finite()) || (!treat_as_line && !(*radius > 0.0 && radius.is_finite())),
            LightShape::Distant { angle_deg } => !(angle_deg.is_finite() && *angle_deg >= 0.0 && *angle_deg <= 360.0),
            LightShape::Dome { texture } => texture.is_some_and(|t| t >= n_tex),
            // checked when the light is built (errors name the tide:sky attribute)
            LightShape::Sky { .. } | LightShape::SkySun { .. } => false,
        };
        if area_bad {
            let attr = match &l.shape {
                LightShape::Sphere { .. } | LightShape::Disk { .. } => "inputs:radius",
                LightShape::Rect { .. } => "inputs:width",
                LightShape::Cylinder { .. } => "inputs:length",
                LightShape::Distant { .. } => "inputs:angle",
                LightShape::Dome { .. } => "inputs:texture:file",
                LightShape::Sky { .. } | LightShape::SkySun { .. } => "tide:sky:model",
            };
            problem(&mut p, &l.name, attr, "zero-area or invalid light shape; light dropped");
            return false;
        }
        // a portal that cannot guide is dropped; the dome still lights everything
        l.portals.retain(|portal| match crate::light::portal::Portals::new(&[(portal.transform, portal.width, portal.height)], 0.5) {
            Ok(_) => true,
            Err((_, e)) => {
                let attr = if e.starts_with("size") { "inputs:width" } else { "xformOp" };
                problem(&mut p, &portal.name, attr, format!("{}; the portal is dropped (the dome lights the scene without its guidance)", e.split_once(": ").map_or(e.as_str(), |x| x.1)));
                false
            }
        });
        true
    });

    validate_camera(&mut s.camera, s.media.len(), &mut p);
    drop(old);
    if let Some(c) = cache {
        *c.inner.lock().unwrap_or_else(|e| e.into_inner()) = now;
    }
    (s, p)
}

/// A camera made safe to render: invalid values replaced (each a problem naming the camera),
/// a medium index past `n_media` dropped.
pub(crate) fn validate_camera(c: &mut CameraDesc, n_media: usize, p: &mut Vec<Problem>) {
    let cam_name = c.name.clone();
    if !(c.horizontal_aperture > 0.0 && c.horizontal_aperture.is_finite()) {
        problem(p, &cam_name, "horizontalAperture", "zero or invalid aperture; using 20.955");
        c.horizontal_aperture = 20.955;
    }
    if !(c.vertical_aperture > 0.0 && c.vertical_aperture.is_finite()) {
        problem(p, &cam_name, "verticalAperture", "zero or invalid aperture; using 15.2908");
        c.vertical_aperture = 15.2908;
    }
    if !(c.focal_length > 0.0 && c.focal_length.is_finite()) {
        problem(p, &cam_name, "focalLength", "zero or invalid focal length; using 50");
        c.focal_length = 50.0;
    }
    if !(c.clipping_range[0] >= 0.0 && c.clipping_range[1] > c.clipping_range[0]) {
        problem(p, &cam_name, "clippingRange", "invalid range; using (1, 1e6)");
        c.clipping_range = [1.0, 1e6];
    }
    if !(c.f_stop >= 0.0 && c.f_stop.is_finite()) || !(c.focus_distance >= 0.0 && c.focus_distance.is_finite()) {
        problem(p, &cam_name, "fStop", "invalid depth of field; pinhole used");
        c.f_stop = 0.0;
    }
    for (v, attr, d) in [
        (&mut c.exposure_f_stop, "exposure:fStop", 1.0),
        (&mut c.exposure_time, "exposure:time", 1.0),
        (&mut c.exposure_iso, "exposure:iso", 100.0),
        (&mut c.exposure_responsivity, "exposure:responsivity", 1.0),
    ] {
        if !(*v > 0.0 && v.is_finite()) {
            problem(p, &cam_name, attr, format!("must be > 0; using {d}"));
            *v = d;
        }
    }
    if !c.exposure.is_finite() {
        problem(p, &cam_name, "exposure", "non-finite; using 0");
        c.exposure = 0.0;
    }
    if !(c.shutter_open.is_finite() && c.shutter_close.is_finite()) {
        problem(p, &cam_name, "shutter:close", "non-finite shutter; motion blur off");
        c.shutter_open = 0.0;
        c.shutter_close = 0.0;
    } else if c.shutter_close < c.shutter_open {
        // UsdGeomCamera: a shutter that closes before it opens exposes nothing, and a renderer
        // should produce a black image
        problem(p, &cam_name, "shutter:close", "the shutter closes before it opens: nothing is exposed and the image is black");
        c.shutter_close = c.shutter_open;
        c.exposure = f32::NEG_INFINITY;
    }
    if c.transforms.is_empty() || !c.transforms.iter().all(mat_ok) || c.times.len() != c.transforms.len() {
        problem(p, &cam_name, "xformOp", "invalid camera transform; identity used");
        c.transforms = vec![Mat4::IDENTITY];
        c.times = vec![0.0];
    }
    if c.medium.is_some_and(|m| m >= n_media) {
        problem(p, &cam_name, "tide:medium", "refers to a medium that does not exist; ignored");
        c.medium = None;
    }
}

/// Makes a points set's shape data agree with its points: one value per point, heights and
/// scales positive and finite, orientations finite (normalised), the blobby threshold in (0, 1).
fn fix_point_shape(sp: &mut SpheresDesc, p: &mut Vec<Problem>) {
    let n = sp.centers.len();
    let name = sp.name.clone();
    let fix_quats = |o: &mut Option<Vec<Quat>>, attr: &str, p: &mut Vec<Problem>| {
        if let Some(q) = o {
            if q.len() != n || q.iter().any(|q| !(q.is_finite() && q.length_squared() > 0.0)) {
                problem(p, &name, attr, format!("expected {n} finite, non-zero quaternions (one per point); ignored"));
                *o = None;
            } else {
                q.iter_mut().for_each(|q| *q = q.normalize());
            }
        }
    };
    match &mut sp.shape {
        PointShape::Spheres => {}
        PointShape::Bubbles { top, bottom, orientations } => {
            for (v, attr) in [(top, "primvars:tide:bubble:top"), (bottom, "primvars:tide:bubble:bottom")] {
                let bad = v.len() != n || v.iter().any(|h| !(*h > 0.0 && h.is_finite()));
                if bad {
                    problem(p, &name, attr, format!("expected {n} positive heights (one per point); the point's radius is used where one is missing or bad"));
                    v.resize(n, 0.0);
                    for (h, r) in v.iter_mut().zip(&sp.radii) {
                        if !(*h > 0.0 && h.is_finite()) {
                            *h = *r;
                        }
                    }
                }
            }
            fix_quats(orientations, "primvars:tide:bubble:orientation", p);
        }
        PointShape::Blobby { threshold, orientations, scales } => {
            if !(*threshold > 0.0 && *threshold < 1.0) {
                problem(p, &name, "tide:blobby:threshold", format!("{threshold} is outside (0, 1); using 0.5"));
                *threshold = 0.5;
            }
            fix_quats(orientations, "primvars:tide:blobby:orientation", p);
            if let Some(sc) = scales {
                if sc.len() != n || sc.iter().any(|s| !(s.is_finite() && s.min_element() > 0.0)) {
                    problem(p, &name, "primvars:tide:blobby:scale", format!("expected {n} positive, finite float3 (one per point); ignored"));
                    *scales = None;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    /// A small mesh with each kind of fault drawn at random (or none).
    fn random_mesh(rng: &mut crate::testing::chi2::TestRng) -> MeshDesc {
        let mut pick = |n: u64| rng.next_u64() % n;
        let nv = 4 + pick(4) as usize;
        let mut m = MeshDesc { name: "/m".into(), ..Default::default() };
        m.positions = (0..nv).map(|i| Vec3::new(i as f32, (i * i % 5) as f32, (i % 3) as f32)).collect();
        m.indices = (0..3 * (1 + pick(4) as u32)).map(|k| (k * 7 + 1) % nv as u32).collect();
        let fault = pick(16);
        match fault {
            0 => m.indices.push(0),
            1 => m.indices[1] = nv as u32 + 2,
            2 => m.positions[m.indices[0] as usize].x = f32::NAN,
            3 => m.indices[2] = m.indices[1],
            _ => {}
        }
        let normals: Vec<Vec3> = m.positions.iter().map(|p| (*p + Vec3::new(0.3, 1.0, 0.2)).normalize()).collect();
        m.normals = match fault {
            4 => Some(normals.iter().map(|n| *n * 1.5).collect()),
            5 => Some(normals.iter().enumerate().map(|(i, n)| if i == 0 { Vec3::splat(f32::INFINITY) } else { *n }).collect()),
            6 => Some(normals[1..].to_vec()),
            7 => Some(normals.iter().enumerate().map(|(i, n)| if i == 0 { Vec3::ZERO } else { *n }).collect()),
            _ if pick(2) == 0 => Some(normals),
            _ => None,
        };
        if fault == 8 {
            m.uvs = Some(vec![glam::Vec2::ZERO; nv + 1]);
        }
        let data = if fault == 9 { vec![0.5; nv + 1] } else { vec![0.5; nv] };
        m.primvars.push(PrimvarData { name: "w".into(), tuple: 1, constant: false, data });
        if fault == 10 || fault == 11 {
            let times = if fault == 10 { vec![0.0, 0.0] } else { vec![0.0, 1.0] };
            let normals = m.normals.clone().map(|n| vec![n.clone(), n]);
            m.motion = Some(MeshMotion { times, positions: vec![m.positions.clone(), m.positions.clone()], normals });
        }
        m
    }

    #[test]
    fn the_clean_check_agrees_with_mending() {
        // a mesh judged clean is one mending would neither report nor change: checked over
        // meshes with every kind of fault, and the check must see each kind
        let mut rng = crate::testing::chi2::TestRng::new(7);
        let (mut clean, mut dirty) = (0, 0);
        for _ in 0..2000 {
            let m = random_mesh(&mut rng);
            let mut mended = m.clone();
            let mut p = Vec::new();
            mend_mesh(&mut mended, &mut p);
            let unchanged = p.is_empty() && mended == m;
            assert_eq!(mesh_is_clean(&m), unchanged, "{m:?}: {p:?}");
            if unchanged {
                clean += 1;
            } else {
                dirty += 1;
            }
        }
        // (about a third of normalised vectors are not exactly what normalising them again
        // gives: such meshes count as dirty)
        assert!(clean > 100 && dirty > 1000, "{clean} clean, {dirty} dirty");
    }

    /// A small sphere set (plain, bubbles or blobbies) with each kind of fault drawn at random
    /// (or none).
    fn random_spheres(rng: &mut crate::testing::chi2::TestRng) -> SpheresDesc {
        let mut pick = |n: u64| rng.next_u64() % n;
        let n = 2 + pick(4) as usize;
        let fault = pick(20);
        let quats: Vec<Quat> = (0..n).map(|i| Quat::from_rotation_y(0.3 * i as f32)).collect();
        let quats = match fault {
            0 => Some(quats.iter().map(|q| *q * 2.0).collect()),
            1 => Some(quats[1..].to_vec()),
            2 => Some(vec![Quat::from_xyzw(0.0, 0.0, 0.0, 0.0); n]),
            _ => (pick(2) == 0).then_some(quats),
        };
        let shape = match pick(3) {
            0 => PointShape::Spheres,
            1 => PointShape::Bubbles {
                top: if fault == 3 { vec![0.5; n - 1] } else { vec![0.5; n] },
                bottom: if fault == 4 { vec![-1.0; n] } else { vec![0.2; n] },
                orientations: quats,
            },
            _ => PointShape::Blobby {
                threshold: if fault == 5 { 1.5 } else { 0.5 },
                orientations: quats,
                scales: match fault {
                    6 => Some(vec![Vec3::new(1.0, 0.0, 1.0); n]),
                    _ if pick(2) == 0 => Some(vec![Vec3::ONE; n]),
                    _ => None,
                },
            },
        };
        let mut sp = SpheresDesc { name: "/p".into(), centers: (0..n).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect(), radii: vec![0.25; n], velocities: None, shape, ..Default::default() };
        match fault {
            7 => sp.radii.pop().map(|_| ()).unwrap_or(()),
            8 => sp.radii[0] = 0.0,
            9 => sp.centers[1].y = f32::NAN,
            10 => sp.velocities = Some(vec![Vec3::X; n + 1]),
            11 => sp.velocities = Some(vec![Vec3::splat(f32::INFINITY); n]),
            12 => sp.primvars.push(PrimvarData { name: "w".into(), tuple: 2, constant: false, data: vec![0.5; n] }),
            13 => sp.velocities = Some(vec![Vec3::X; n]),
            _ => {}
        }
        sp
    }

    #[test]
    fn the_clean_check_of_sphere_sets_agrees_with_mending() {
        let mut rng = crate::testing::chi2::TestRng::new(11);
        let (mut clean, mut dirty) = (0, 0);
        for _ in 0..2000 {
            let sp = random_spheres(&mut rng);
            let mut mended = sp.clone();
            let mut p = Vec::new();
            mend_spheres(&mut mended, &mut p);
            let unchanged = p.is_empty() && mended == sp;
            assert_eq!(spheres_are_clean(&sp), unchanged, "{sp:?}: {p:?}");
            if unchanged {
                clean += 1;
            } else {
                dirty += 1;
            }
        }
        assert!(clean > 300 && dirty > 600, "{clean} clean, {dirty} dirty");
    }

    #[test]
    fn validation_shares_clean_meshes_and_remembers_mended_ones() {
        let good: Arc<MeshDesc> = Arc::new(MeshDesc { name: "/good".into(), positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y], indices: vec![0, 1, 2], normals: Some(vec![Vec3::Z; 3]), ..Default::default() });
        let bad: Arc<MeshDesc> = Arc::new(MeshDesc { name: "/bad".into(), positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y], indices: vec![0, 1, 2, 0, 1, 7], ..Default::default() });
        let nan = TextureDesc { name: "/t".into(), width: 2, height: 1, channels: 1, pixels: vec![f32::NAN, 1.0].into(), wrap_s: Wrap::Repeat, wrap_t: Wrap::Repeat, filter: crate::scene::Filter::Linear };
        let fine = TextureDesc { name: "/u".into(), pixels: vec![0.5, 1.0].into(), ..nan.clone() };
        let points = Arc::new(SpheresDesc { name: "/points".into(), centers: vec![Vec3::ZERO, Vec3::X], radii: vec![0.5, 0.5], ..Default::default() });
        let scene = SceneDesc { meshes: vec![good.clone(), bad.clone()], spheres: vec![points.clone()], textures: vec![nan, fine.clone()], ..Default::default() };
        let cache = CheckCache::default();
        let (a, pa) = validate_cached(&scene, Some(&cache));
        assert!(Arc::ptr_eq(&a.meshes[0], &good), "a clean mesh is shared");
        assert!(Arc::ptr_eq(&a.spheres[0], &points), "and a clean sphere set");
        assert!(!Arc::ptr_eq(&a.meshes[1], &bad) && a.meshes[1].indices == [0, 1, 2]);
        assert!(a.textures[1].pixels.same(&fine.pixels) && a.textures[0].pixels.value(0, 1) == 0.0);
        // again: the mended mesh is the one made before, with the same problems
        let (b, pb) = validate_cached(&scene, Some(&cache));
        assert!(Arc::ptr_eq(&b.meshes[1], &a.meshes[1]));
        assert_eq!(format!("{pa:?}"), format!("{pb:?}"));
        assert_eq!(pa.iter().filter(|p| p.item == "/bad").count(), 1);
        assert_eq!(pa.iter().filter(|p| p.item == "/t").count(), 1, "NaN texels are mended each time: {pa:?}");
        assert_eq!(format!("{:?}", validate(&scene).1), format!("{pa:?}"), "the same problems without a cache");
        // the cache keeps what the last validation used
        assert_eq!(cache.len(), (2, 1));
        validate_cached(&SceneDesc { meshes: vec![good.clone()], ..Default::default() }, Some(&cache));
        assert_eq!(cache.len(), (1, 0));
    }

    #[test]
    fn motion_keys_with_another_point_count_leave_the_mesh_static() {
        let tri = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let mesh = |keys: Vec<Vec<Vec3>>, times: Vec<f32>| MeshDesc {
            name: "/World/Blob".into(),
            positions: tri.clone(),
            indices: vec![0, 1, 2],
            motion: Some(MeshMotion { times, positions: keys, normals: None }),
            ..Default::default()
        };
        let good = mesh(vec![tri.clone(), tri.iter().map(|p| *p + Vec3::Z).collect()], vec![0.0, 0.5]);
        let short = mesh(vec![tri.clone(), tri[..2].to_vec()], vec![0.0, 0.5]);
        let unordered = mesh(vec![tri.clone(), tri.clone()], vec![0.5, 0.0]);
        let s = SceneDesc { meshes: vec![good.clone().into(), short.into(), unordered.into()], ..Default::default() };
        let (clean, p) = validate(&s);
        assert_eq!(clean.meshes[0].motion, good.motion);
        assert!(clean.meshes[1].motion.is_none() && clean.meshes[2].motion.is_none());
        assert_eq!(p.len(), 2, "{p:?}");
        assert!(p.iter().all(|q| q.item == "/World/Blob" && q.attribute == "points"));
        assert_eq!(clean.meshes[1].indices, vec![0, 1, 2], "the static pose still renders");
    }

    #[test]
    fn bad_input_is_reported_by_item_and_attribute_and_the_rest_kept() {
        let mut s = SceneDesc::default();
        s.meshes.push(MeshDesc {
            name: "/World/Mesh".into(),
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(f32::NAN, 0.0, 0.0), Vec3::X * 2.0],
            indices: vec![0, 1, 2, 0, 1, 3, 0, 1, 9, 0, 1, 4],
            ..Default::default()
        }.into());
        s.spheres.push(std::sync::Arc::new(SpheresDesc { name: "/World/Points".into(), centers: vec![Vec3::ZERO, Vec3::ONE], radii: vec![0.0, 1.0], velocities: None, ..Default::default() }));
        s.lights.push(LightDesc {
            shaping: None, response: Default::default(), motion: Vec::new(), portals: Vec::new(), shadow: Default::default(),
            name: "/World/Rect".into(),
            shape: LightShape::Rect { width: 0.0, height: 1.0, texture: None },
            transform: Mat4::IDENTITY,
            color: [1.0; 3],
            intensity: 1.0,
            exposure: 0.0,
            normalize: false,
            color_temperature: None,
            visible_to_camera: true,
            light_link: None,
            shadow_link: None,
        });
        // a dome with a good portal and two bad ones
        let portal = |name: &str, transform: Mat4, width: f32| crate::scene::PortalDesc { name: name.into(), transform, width, height: 1.0 };
        let mut dome = s.lights[0].clone();
        dome.name = "/World/Dome".into();
        dome.shape = LightShape::Dome { texture: None };
        dome.portals = vec![portal("/World/Window", Mat4::IDENTITY, 1.0), portal("/World/Thin", Mat4::IDENTITY, 0.0), portal("/World/Flat", Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0)), 1.0)];
        s.lights.push(dome);
        s.camera.horizontal_aperture = 0.0;
        let (clean, probs) = validate(&s);
        let has = |item: &str, attr: &str| probs.iter().any(|p| p.item == item && p.attribute == attr);
        assert!(has("/World/Thin", "inputs:width") && has("/World/Flat", "xformOp"), "{probs:?}");
        // the rect is dropped, the dome stays with its good portal
        assert_eq!(clean.lights.len(), 1);
        assert_eq!(clean.lights[0].portals.iter().map(|p| p.name.as_str()).collect::<Vec<_>>(), ["/World/Window"]);
        assert!(has("/World/Mesh", "points"), "{probs:?}");
        assert!(has("/World/Mesh", "faceVertexIndices"));
        assert!(has("/World/Points", "widths"));
        assert!(has("/World/Rect", "inputs:width"));
        assert!(has("/camera", "horizontalAperture"));
        // only the good triangle survives; the degenerate (collinear) one is dropped too
        assert_eq!(clean.meshes[0].indices, vec![0, 1, 2]);
        assert_eq!(clean.spheres[0].centers, vec![Vec3::ONE]);
        assert_eq!(clean.camera.horizontal_aperture, 20.955);
    }

    #[test]
    fn a_graph_reading_a_missing_texture_reads_its_fallback() {
        use crate::shader_graph::{Binary, Expr};
        let lookup = |texture| TexLookup { texture, channel: Channel::G, transform: glam::Affine2::IDENTITY, tex_scale: [1.0; 4], bias: [0.0; 4], fallback: [0.1, 0.2, 0.3, 0.4], uv_set: None };
        let mut bad_pv = PrimvarLookup::new("mask", [f32::NAN; 4]);
        bad_pv.scale = [2.0; 4];
        let graph = Expr::binary(Binary::Mul, Expr::Texture(lookup(0)), Expr::binary(Binary::Add, Expr::Texture(lookup(1)), Expr::Primvar(bad_pv)));
        let mut s = SceneDesc::default();
        s.textures.push(TextureDesc { name: "t".into(), width: 1, height: 1, channels: 1, pixels: vec![1.0].into(), wrap_s: Wrap::Repeat, wrap_t: Wrap::Repeat, filter: crate::scene::Filter::Linear });
        let preview = PreviewSurfaceDesc { diffuse_color: ColorInput::Graph(graph), roughness: FloatInput::Graph(Expr::Texture(lookup(5))), ..Default::default() };
        s.materials.push(MaterialDesc { name: "/M".into(), surface: SurfaceDesc::Preview(preview), interior_medium: None });
        let (clean, probs) = validate(&s);
        let SurfaceDesc::Preview(p) = &clean.materials[0].surface else { panic!() };
        // texture 1 is missing: its G fallback in all four; the primvar's fallback is made finite
        let mut fixed_pv = PrimvarLookup::new("mask", [0.0; 4]);
        fixed_pv.scale = [2.0; 4];
        let want = Expr::binary(Binary::Mul, Expr::Texture(lookup(0)), Expr::binary(Binary::Add, Expr::Const([0.2; 4]), Expr::Primvar(fixed_pv)));
        assert_eq!(p.diffuse_color, ColorInput::Graph(want));
        assert_eq!(p.roughness, FloatInput::Graph(Expr::Const([0.2; 4])));
        let at = |attr: &str| probs.iter().filter(|p| p.item == "/M" && p.attribute == attr).count();
        assert_eq!((at("inputs:diffuseColor"), at("inputs:roughness"), probs.len()), (2, 1, 3), "{probs:?}");
    }

    #[test]
    fn bad_water_media_are_reported_and_replaced_by_defaults() {
        use crate::water::{JerlovSource, JerlovType};
        let mut s = SceneDesc::default();
        s.media.push(MediumDesc {
            name: "/Sea/Medium".into(),
            sigma_a: SpectrumDesc::Rgb([0.0; 3]),
            sigma_s: SpectrumDesc::Rgb([0.0; 3]),
            scale: 1.0,
            phase: PhaseDesc::Tabulated { theta: vec![0.0, 1.0], value: vec![1.0] },
            water: Some(WaterIopDesc {
                jerlov: Some(JerlovDesc { water_type: JerlovType::I, source: JerlovSource::Williamson2022 }),
                chlorophyll: -1.0,
                cdom: f32::NAN,
                spm: 2.0,
                profile: Some(DepthProfileDesc { depth: f32::INFINITY, width: -1.0, peak: 3.0 }),
                salinity: 60.0,
                top: Some(f32::NAN),
                up: glam::Vec3::Y,
            }),
            method: Default::default(),
        });
        let (clean, probs) = validate(&s);
        let has = |attr: &str| probs.iter().any(|p| p.item == "/Sea/Medium" && p.attribute == attr);
        for attr in ["phase", "chlorophyll", "cdom", "profileDepth", "profileWidth", "salinity", "top", "jerlovSource"] {
            assert!(has(attr), "{attr}: {probs:?}");
        }
        assert_eq!(probs.len(), 8, "{probs:?}");
        let m = &clean.media[0];
        assert_eq!(m.phase, PhaseDesc::Isotropic);
        let w = m.water.as_ref().unwrap();
        assert_eq!((w.chlorophyll, w.cdom, w.spm, w.salinity, w.top), (0.0, 0.0, 2.0, 0.0, Some(0.0)));
        assert_eq!(w.profile, Some(DepthProfileDesc { depth: 0.0, width: 0.0, peak: 3.0 }));
        assert_eq!(w.jerlov.unwrap().source, JerlovSource::Solonenko2015);
        // what is left builds
        crate::medium::Medium::from_desc(m, ColorSpace::LinearRec709).unwrap();
    }

    /// Past the most one BVH holds (2^29 points, or triangles, per prim; here a smaller limit),
    /// the tail is dropped and named, the data of the points kept following them.
    #[test]
    fn prims_past_the_bvh_limit_keep_their_head_and_say_so() {
        let mut sp = SpheresDesc {
            name: "/Spray".into(),
            centers: vec![Vec3::ZERO, Vec3::splat(f32::NAN), Vec3::X, Vec3::Y, Vec3::Z],
            radii: vec![1.0, 1.0, 2.0, 3.0, 4.0],
            velocities: Some(vec![Vec3::ZERO, Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z]),
            shape: PointShape::Spheres,
            primvars: vec![PrimvarData { name: "heat".into(), tuple: 1, constant: false, data: vec![10.0, 11.0, 12.0, 13.0, 14.0] }],
            ids: Vec::new(),
            origin: Default::default(),
        };
        let mut probs = Vec::new();
        mend_spheres_within(&mut sp, &mut probs, 2);
        assert_eq!(sp.centers, vec![Vec3::ZERO, Vec3::X]);
        assert_eq!(sp.radii, vec![1.0, 2.0]);
        assert_eq!(sp.velocities, Some(vec![Vec3::ZERO, Vec3::X]));
        assert_eq!(sp.primvars[0].data, vec![10.0, 12.0]);
        let over: Vec<&Problem> = probs.iter().filter(|p| p.message.contains("exceed")).collect();
        assert_eq!(over.len(), 1, "{probs:?}");
        assert_eq!((over[0].item.as_str(), over[0].attribute.as_str()), ("/Spray", "points"));
        assert!(over[0].message.contains("4 points exceed the 2") && over[0].message.contains("last 2"), "{}", over[0].message);
        // within the limit nothing is said
        let mut probs = Vec::new();
        mend_spheres_within(&mut sp, &mut probs, 2);
        assert!(probs.is_empty(), "{probs:?}");

        let mut m = MeshDesc {
            name: "/Sea".into(),
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            indices: vec![0, 1, 2, 0, 2, 3, 0, 3, 1],
            ..Default::default()
        };
        let mut probs = Vec::new();
        mend_mesh_within(&mut m, &mut probs, 2);
        assert_eq!(m.indices, vec![0, 1, 2, 0, 2, 3]);
        assert_eq!(probs.len(), 1, "{probs:?}");
        assert_eq!((probs[0].item.as_str(), probs[0].attribute.as_str()), ("/Sea", "faceVertexIndices"));
        assert!(mesh_is_clean(&m) && spheres_are_clean(&sp));
    }

    /// Dropping triangles or points keeps what the others are elements of: the authored face
    /// or point the `elementId` AOV reads; a face list of the wrong length is named and
    /// dropped.
    #[test]
    fn dropped_triangles_and_points_leave_the_others_their_authored_elements() {
        let quad_fan = |faces: Vec<u32>| MeshDesc {
            name: "/Hull".into(),
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE, Vec3::X],
            // triangle 1 is degenerate (vertices 1 and 4 coincide)
            indices: vec![0, 1, 2, 1, 4, 3, 1, 3, 2, 0, 2, 4],
            faces,
            ..Default::default()
        };
        let mut probs = Vec::new();
        let mut m = quad_fan(Vec::new());
        mend_mesh(&mut m, &mut probs);
        assert_eq!(m.indices.len(), 9);
        assert_eq!(m.faces, vec![0, 2, 3], "each triangle its own: the survivors keep their numbers");
        let mut m = quad_fan(vec![7, 7, 8, 8]);
        mend_mesh(&mut m, &mut probs);
        assert_eq!(m.faces, vec![7, 8, 8]);
        assert!(mesh_is_clean(&m));
        assert!(probs.iter().all(|p| p.attribute != "faces"), "{probs:?}");
        let mut m = quad_fan(vec![7, 7]);
        assert!(!mesh_is_clean(&m));
        mend_mesh(&mut m, &mut probs);
        assert!(probs.iter().any(|p| p.item == "/Hull" && p.attribute == "faces" && p.message.contains("2 elements for 4 triangles")), "{probs:?}");
        assert_eq!(m.faces, vec![0, 2, 3]);
        let mut sp = SpheresDesc {
            name: "/Spray".into(),
            centers: vec![Vec3::ZERO, Vec3::splat(f32::NAN), Vec3::X, Vec3::Y],
            radii: vec![1.0, 1.0, 0.0, 3.0],
            ..Default::default()
        };
        mend_spheres(&mut sp, &mut probs);
        assert_eq!(sp.ids, vec![0, 3]);
        assert_eq!((sp.element_of(0), sp.element_of(1)), (0, 3));
        sp.centers[0] = Vec3::splat(f32::INFINITY);
        mend_spheres(&mut sp, &mut probs);
        assert_eq!(sp.ids, vec![3], "a second mending keeps the authored numbers");
    }

    /// A scene whose instances need no mending shares them with the validated scene (no copy
    /// of a million instances); each fault of an instance alone is mended in a copy, reported
    /// once under its attribute, and leaves the given scene as it was.
    #[test]
    fn instances_are_copied_only_to_be_mended() {
        let mut s = SceneDesc::default();
        s.meshes.push(Arc::new(MeshDesc { name: "/m".into(), positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y], indices: vec![0, 1, 2], ..Default::default() }));
        s.materials.push(MaterialDesc { name: "/d".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.5; 3]) }, interior_medium: None });
        s.instance_primvars.push(InstancePrimvars { name: "/P".into(), rows: 2, primvars: vec![] });
        let inst = |k: u32| InstanceDesc {
            name: format!("/P[{k}]"),
            geometry: GeometryRef::Mesh(0),
            transforms: vec![Mat4::from_translation(Vec3::X * k as f32), Mat4::from_translation(Vec3::Y * k as f32)],
            times: vec![0.0, 0.5],
            material: 0,
            id: 1,
            visible_to_camera: true,
            casts_shadows: true,
            primvar_row: Some((0, k % 2)),
            index: Some(k),
        };
        s.instances = Arc::new((0..4).map(inst).collect());
        let (clean, probs) = validate(&s);
        assert!(probs.is_empty(), "{probs:?}");
        assert!(Arc::ptr_eq(&clean.instances, &s.instances));
        type Fault = fn(&mut InstanceDesc);
        let faults: [(Fault, &str, usize); 7] = [
            (|i| i.primvar_row = Some((0, 2)), "primvars", 4),
            (|i| i.primvar_row = Some((1, 0)), "primvars", 4),
            (|i| i.geometry = GeometryRef::Spheres(0), "geometry", 3),
            (|i| i.material = 3, "material:binding", 4),
            (|i| i.times = vec![0.5, 0.5], "xformOp", 4),
            (|i| i.times = vec![0.0], "xformOp", 4),
            (|i| i.transforms[1] = Mat4::ZERO, "xformOp", 3),
        ];
        for (k, (fault, attribute, left)) in faults.into_iter().enumerate() {
            let mut bad = s.clone();
            fault(&mut bad.instances_mut()[2]);
            let before = bad.clone();
            let (clean, probs) = validate(&bad);
            assert_eq!(probs.iter().map(|p| (p.item.as_str(), p.attribute.as_str())).collect::<Vec<_>>(), [("/P[2]", attribute)], "fault {k}");
            assert_eq!(clean.instances.len(), left, "fault {k}");
            assert!(!Arc::ptr_eq(&clean.instances, &bad.instances) && bad == before, "fault {k}");
        }
    }

    /// Instances past the most the top-level BVH holds (here a smaller limit) are dropped and
    /// the first of them named.
    #[test]
    fn instances_past_the_top_level_limit_are_dropped_and_named() {
        let inst = |k: usize| InstanceDesc {
            name: format!("/Reef/Corals[{k}]"),
            geometry: GeometryRef::Mesh(0),
            transforms: vec![Mat4::from_translation(Vec3::X * k as f32)],
            times: vec![0.0],
            material: 0,
            id: 1,
            visible_to_camera: true,
            casts_shadows: true,
            primvar_row: None,
            index: None,
        };
        let mut all: Vec<InstanceDesc> = (0..5).map(inst).collect();
        let mut probs = Vec::new();
        cap_instances(&mut all, &mut probs, 3);
        assert_eq!(all.iter().map(|i| i.name.as_str()).collect::<Vec<_>>(), ["/Reef/Corals[0]", "/Reef/Corals[1]", "/Reef/Corals[2]"]);
        assert_eq!(probs.len(), 1, "{probs:?}");
        assert_eq!((probs[0].item.as_str(), probs[0].attribute.as_str()), ("/Reef/Corals[3]", "instances"));
        assert!(probs[0].message.contains("5 instances exceed the 3") && probs[0].message.contains("the 1 after it"), "{}", probs[0].message);
        let mut probs = Vec::new();
        cap_instances(&mut all, &mut probs, 3);
        assert!(probs.is_empty() && all.len() == 3, "{probs:?}");
    }

    /// Shape data follows the points that survive; bad heights, scales, orientations and
    /// thresholds are named and replaced.
    #[test]
    fn point_shapes_are_checked_and_follow_their_points() {
        let mut s = SceneDesc::default();
        let pts = vec![Vec3::ZERO, Vec3::ONE, Vec3::X];
        s.spheres.push(std::sync::Arc::new(SpheresDesc {
            name: "/Bubbles".into(),
            centers: pts.clone(),
            radii: vec![0.0, 1.0, 2.0],
            velocities: None,
            shape: PointShape::Bubbles { top: vec![0.5, f32::NAN, 0.7], bottom: vec![0.1, 0.2, 0.3], orientations: Some(vec![Quat::IDENTITY; 2]) },
            primvars: vec![
                PrimvarData { name: "heat".into(), tuple: 1, constant: false, data: vec![10.0, 11.0, 12.0] },
                PrimvarData { name: "tint".into(), tuple: 3, constant: true, data: vec![0.1, 0.2, 0.3] },
                PrimvarData { name: "short".into(), tuple: 2, constant: false, data: vec![0.0; 4] },
            ],
            ids: Vec::new(),
            origin: Default::default(),
        }));
        s.spheres.push(std::sync::Arc::new(SpheresDesc {
            name: "/Blobs".into(),
            centers: pts,
            radii: vec![1.0; 3],
            velocities: None,
            shape: PointShape::Blobby { threshold: 1.5, orientations: None, scales: Some(vec![Vec3::ONE, Vec3::new(1.0, 0.0, 1.0), Vec3::ONE]) },
            primvars: Vec::new(),
            ids: Vec::new(),
            origin: Default::default(),
        }));
        let (clean, probs) = validate(&s);
        let attrs: Vec<(&str, &str)> = probs.iter().map(|p| (p.item.as_str(), p.attribute.as_str())).collect();
        for want in [
            ("/Bubbles", "primvars:tide:bubble:top"),
            ("/Bubbles", "primvars:tide:bubble:orientation"),
            ("/Bubbles", "widths"),
            ("/Blobs", "tide:blobby:threshold"),
            ("/Blobs", "primvars:tide:blobby:scale"),
            ("/Bubbles", "primvars:short"),
        ] {
            assert!(attrs.contains(&want), "{want:?} in {attrs:?}");
        }
        // the zero-width point is dropped with its data; the NaN height became the radius
        assert_eq!(clean.spheres[0].shape, PointShape::Bubbles { top: vec![1.0, 0.7], bottom: vec![0.2, 0.3], orientations: None });
        // per-point primvars follow their points; a constant one is kept whole, a short one dropped
        let pvs: Vec<(&str, &[f32])> = clean.spheres[0].primvars.iter().map(|p| (p.name.as_str(), &p.data[..])).collect();
        assert_eq!(pvs, vec![("heat", &[11.0, 12.0][..]), ("tint", &[0.1, 0.2, 0.3][..])]);
        assert_eq!(clean.spheres[1].shape, PointShape::Blobby { threshold: 0.5, orientations: None, scales: None });
    }
}
