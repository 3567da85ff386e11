//! The tiled ocean mesh: copies of the periodic patch out to `extent`, coarser with distance
//! from the camera, stitched without cracks, and closed into a watertight body when the ocean
//! has a depth.
//!
//! Level of detail: a tile drawn at level ℓ has N/2^ℓ cells per side sampling every 2^ℓ-th grid
//! point of the patch: its vertices lie exactly on the surface and carry its exact normals;
//! between them the coarse tile is linear. A tile's level is the coarsest whose cells a
//! camera pixel still covers where the tile comes nearest the camera ([`OceanView`]: the
//! distance in 3-D, the camera's height counting, times the pixel's angle, plus an orthographic
//! pixel's width); where the whole surface would then pass [`MAX_OCEAN_CELLS`], cells of 2, 4, …
//! pixels are taken. Levels are capped where a tile would have fewer than 2×2 cells, and
//! lowered until neighbouring tiles differ by at most one.
//!
//! Stitching: every tile is cut into 2×2-cell blocks, each a fan of triangles about its centre
//! vertex through the 8 vertices around it. Where a tile borders a coarser one, the blocks on
//! that border leave out their edge midpoints, so both tiles use exactly the coarse tile's
//! vertices along the shared edge. Vertices are keyed by their position on the finest grid and
//! their tile's level: tiles of one level share a border vertex by index; where tiles of two
//! levels meet, each has its own vertex there of the same position, normal and uv bits. No gap,
//! no crack, no T-junction (no skirts, which would leave the body open).
//!
//! Slopes: a tile's triangles interpolate the exact normals of their vertices, which smooths
//! away the waves shorter than a few of its cells: coarser tiles carry less of the slope
//! variance. Each level's mean-square slope, as a hit interpolates the normals, is integrated
//! over its triangles (a degree-5 rule on each), and every vertex carries in the primvar
//! [`crate::scene::SEA_SHARE_PRIMVAR`] the share of the Cox–Munk variance its level leaves to
//! the sea BSDF, so that geometry and facets together hold Cox–Munk's at every distance.
//!
//! The closed body (`depth > 0`): the surface's outer rim keeps its height but not its
//! horizontal displacement, so the four walls are vertical planes; the walls run down to
//! y = −depth and a floor closes the body as a fan about its centre. The walls and the floor
//! repeat their rim vertices (same position bits) so each part keeps its own flat normal;
//! welded by position the mesh is a closed, consistently oriented 2-manifold with outward
//! normals.

use std::collections::HashMap;

use glam::{Vec2, Vec3};

use super::patch::OceanPatch;
use super::{OceanError, OceanParams};
use crate::scene::MeshDesc;

/// Most patches along one side of the tiled surface.
pub const MAX_TILES_PER_SIDE: u64 = 512;

/// Most grid cells of the tiled surface (two triangles each) the level of detail aims at.
pub const MAX_OCEAN_CELLS: u64 = 1 << 20;

/// The camera the level of detail serves: its position in the ocean's local space (m) and
/// the size of one of its pixels: the angle it spans (perspective, radians) and its width
/// (orthographic, m). `None` where an ocean is built stands for a camera at the origin whose
/// pixels span 2/N radians (N the patch resolution).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OceanView {
    pub position: Vec3,
    pub pixel_angle: f32,
    pub pixel_width: f32,
}

/// The level of each tile (row-major from (−T, −T), 2T tiles a side) for `view`.
pub fn tile_levels(params: &OceanParams, view: &OceanView) -> Vec<u32> {
    let n = params.resolution as u64;
    let t = params.tiles_per_half_side() as i64;
    let side = 2 * t as usize;
    let l = params.patch_size as f64;
    let delta = l / n as f64;
    let max_level = params.resolution.trailing_zeros().saturating_sub(1);
    let c = view.position.as_dvec3();
    // the distance from the camera to the nearest point of each tile at mean sea level
    let gap = |lo: f64, v: f64| (lo - v).max(v - (lo + l)).max(0.0);
    let dist: Vec<f64> = (-t..t)
        .flat_map(|tj| (-t..t).map(move |ti| (ti, tj)))
        .map(|(ti, tj)| {
            let (dx, dz) = (gap(ti as f64 * l, c.x), gap(tj as f64 * l, c.z));
            (dx * dx + dz * dz + c.y * c.y).sqrt()
        })
        .collect();
    let (angle, width) = (view.pixel_angle.max(0.0) as f64, view.pixel_width.max(0.0) as f64);
    let mut pixels = 1.0;
    loop {
        let mut levels: Vec<u32> = dist
            .iter()
            .map(|&r| {
                let cell = pixels * (angle * r + width) / delta;
                if cell >= 2.0 {
                    (cell.log2().floor() as u32).min(max_level)
                } else {
                    0
                }
            })
            .collect();
        // neighbours differ by at most one level: the finer side wins
        loop {
            let mut changed = false;
            for j in 0..side {
                for i in 0..side {
                    let mut lowest = levels[j * side + i];
                    if i > 0 { lowest = lowest.min(levels[j * side + i - 1] + 1); }
                    if i + 1 < side { lowest = lowest.min(levels[j * side + i + 1] + 1); }
                    if j > 0 { lowest = lowest.min(levels[(j - 1) * side + i] + 1); }
                    if j + 1 < side { lowest = lowest.min(levels[(j + 1) * side + i] + 1); }
                    if lowest < levels[j * side + i] {
                        levels[j * side + i] = lowest;
                        changed = true;
                    }
                }
            }
            if !changed {
                break;
            }
        }
        let cells: u64 = levels.iter().map(|&lv| (n >> lv) * (n >> lv)).sum();
        if cells <= MAX_OCEAN_CELLS || levels.iter().all(|&lv| lv == max_level) || pixels > 1e9 {
            return levels;
        }
        pixels *= 2.0;
    }
}

struct Builder<'a> {
    patch: &'a OceanPatch,
    /// fine-grid samples per tile side (N)
    n: u64,
    /// grid spacing L/N and the offset T·L of the patches' corner from the origin
    delta: f64,
    offset: f64,
    /// the surface's rim on the fine grid: it spans [lo, hi] along both axes (the patches'
    /// [0, max] cut to `extent`)
    lo: u64,
    hi: u64,
    closed: bool,
    /// the level of the tile being drawn
    level: u32,
    /// each grid point's first vertex, and its vertex in a tile of each level drawing it
    first: HashMap<u64, u32>,
    map: HashMap<(u64, u32), u32>,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    /// each vertex's tile level (`FLAT` for the closed body's walls and floor)
    vertex_levels: Vec<u32>,
    indices: Vec<u32>,
    /// rim vertices of the surface: (gx, gz, index), one a grid point
    rim: Vec<(u64, u64, u32)>,
    /// per level: Σ area · mean square slope of the interpolated normals over each triangle,
    /// and Σ area (grid-cell units of the undisplaced plane)
    slopes: Vec<(f64, f64)>,
}

/// The tile level of a vertex of flat geometry (the closed body's walls and floor).
const FLAT: u32 = u32::MAX;

/// Barycentric points and weights of a degree-5 quadrature rule on a triangle (Radon's
/// seven-point rule): the mean of a smooth function over the triangle.
const QUADRATURE: [([f64; 3], f64); 7] = {
    const A1: f64 = 0.059_715_871_789_769_82;
    const B1: f64 = 0.470_142_064_105_115_1;
    const A2: f64 = 0.797_426_985_353_087_3;
    const B2: f64 = 0.101_286_507_323_456_34;
    const W1: f64 = 0.132_394_152_788_506_2;
    const W2: f64 = 0.125_939_180_544_827_15;
    [
        ([1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0], 0.225),
        ([A1, B1, B1], W1),
        ([B1, A1, B1], W1),
        ([B1, B1, A1], W1),
        ([A2, B2, B2], W2),
        ([B2, A2, B2], W2),
        ([B2, B2, A2], W2),
    ]
};

impl Builder<'_> {
    /// A fine-grid coordinate moved onto the surface: points past the rim onto the rim.
    fn clip(&self, g: u64) -> u64 {
        g.clamp(self.lo, self.hi)
    }

    /// The vertex at fine-grid point (gx, gz), which must lie on the surface ([`Self::clip`]),
    /// of the tile level being drawn: a grid point on the border of tiles of two levels has a
    /// vertex for each, with the same position, normal and uv bits (the surface stays closed
    /// to the last bit), so that each carries its own level's share of the slopes.
    fn vertex(&mut self, gx: u64, gz: u64) -> u32 {
        let key = (gx << 32) | gz;
        if let Some(&i) = self.map.get(&(key, self.level)) {
            return i;
        }
        if let Some(&j) = self.first.get(&key) {
            let i = self.add_vertex(self.positions[j as usize], self.normals[j as usize], self.uvs[j as usize]);
            self.vertex_levels[i as usize] = self.level;
            self.map.insert((key, self.level), i);
            return i;
        }
        let (p, q) = ((gx % self.n) as i64, (gz % self.n) as i64);
        let on_rim = gx == self.lo || gz == self.lo || gx == self.hi || gz == self.hi;
        let disp = if self.closed && on_rim { Vec2::ZERO } else { self.patch.displacement(p, q) };
        let x = gx as f64 * self.delta - self.offset;
        let z = gz as f64 * self.delta - self.offset;
        let i = self.positions.len() as u32;
        self.positions.push(Vec3::new((x + disp.x as f64) as f32, self.patch.height(p, q), (z + disp.y as f64) as f32));
        self.normals.push(self.patch.normal(p, q));
        let l = self.patch.patch_size() as f64;
        self.uvs.push(Vec2::new((x / l) as f32, (z / l) as f32));
        self.vertex_levels.push(self.level);
        self.map.insert((key, self.level), i);
        self.first.insert(key, i);
        if on_rim {
            self.rim.push((gx, gz, i));
        }
        i
    }

    fn push_oriented(&mut self, tri: [u32; 3], outward: Vec3) {
        let [a, b, c] = tri.map(|i| self.positions[i as usize]);
        if (b - a).cross(c - a).dot(outward) < 0.0 {
            self.indices.extend_from_slice(&[tri[0], tri[2], tri[1]]);
        } else {
            self.indices.extend_from_slice(&tri);
        }
    }

    fn add_vertex(&mut self, p: Vec3, n: Vec3, uv: Vec2) -> u32 {
        self.positions.push(p);
        self.normals.push(n);
        self.uvs.push(uv);
        self.vertex_levels.push(FLAT);
        (self.positions.len() - 1) as u32
    }

    /// Adds triangle `tri` of the tile being drawn (its undisplaced plane area `area`, any
    /// unit) to its level's mean square slope of the shading normals interpolated across it
    /// (as a hit interpolates them).
    fn add_slopes(&mut self, tri: [u32; 3], area: f64) {
        let n = tri.map(|i| self.normals[i as usize].as_dvec3());
        let mut mean = 0.0;
        for (b, w) in QUADRATURE {
            let v = n[0] * b[0] + n[1] * b[1] + n[2] * b[2];
            mean += w * (v.x * v.x + v.z * v.z) / (v.y * v.y);
        }
        let level = self.level as usize;
        if self.slopes.len() <= level {
            self.slopes.resize(level + 1, (0.0, 0.0));
        }
        if mean.is_finite() {
            self.slopes[level].0 += area * mean;
            self.slopes[level].1 += area;
        }
    }
}

/// The ocean surface of `params` at `time` seconds as one mesh in the prim's local space (Y up,
/// mean sea level y = 0), over x, z ∈ [−E, E] with E = extent on the patch's grid
/// ([`OceanParams::half_side`]): tiled with T = ⌈extent / patchSize⌉ patches each way and cut
/// at E (grid points past it are moved onto it, and the triangles that then have no area are
/// left out), finest
/// around `camera_position` (local space; the origin when `None`; pixels of 2/N radians: see
/// [`ocean_mesh_seen`] for a camera's own), closed down to y = −depth when `depth > 0`.
/// Triangles are counter-clockwise seen from above (outside for the body). uvs are the
/// undisplaced (x, z) over `patchSize`, so a texture repeats with the patch. The level of
/// detail keeps the surface under about 2·[`MAX_OCEAN_CELLS`] triangles.
pub fn ocean_mesh(params: &OceanParams, time: f64, camera_position: Option<Vec3>) -> Result<MeshDesc, OceanError> {
    Ok(build(params, time, &default_view(params, camera_position))?.0)
}

/// [`ocean_mesh`] with its level of detail for `view`.
pub fn ocean_mesh_seen(params: &OceanParams, time: f64, view: &OceanView) -> Result<MeshDesc, OceanError> {
    Ok(build(params, time, view)?.0)
}

/// The view an ocean is built for without one: at `camera_position` (the origin when None),
/// pixels of 2/N radians.
fn default_view(params: &OceanParams, camera_position: Option<Vec3>) -> OceanView {
    OceanView { position: camera_position.unwrap_or(Vec3::ZERO), pixel_angle: 2.0 / params.resolution.max(1) as f32, pixel_width: 0.0 }
}

/// [`ocean_mesh`] and, for an open sea (`depth` = 0), a flat skirt at y = 0 that carries it to
/// the horizon: from the tiled surface's outer rim (its very vertices, so the two meet without
/// a crack) out to the square of half-size `reach` (m, local space; at least the tiled
/// surface's), each rim vertex joined to its radial projection on that square. A camera at
/// height h then sees water up to atan(h / reach) below the horizontal. The skirt has no waves
/// (normals +Y, uvs the undisplaced (x, z) over `patchSize`); its slopes are all sub-grid.
/// A closed body (`depth` > 0) has no skirt.
pub fn ocean_mesh_with_horizon(params: &OceanParams, time: f64, camera_position: Option<Vec3>, reach: f32) -> Result<(MeshDesc, Option<MeshDesc>), OceanError> {
    ocean_mesh_with_horizon_seen(params, time, &default_view(params, camera_position), reach)
}

/// [`ocean_mesh_with_horizon`] with its level of detail for `view`.
pub fn ocean_mesh_with_horizon_seen(params: &OceanParams, time: f64, view: &OceanView, reach: f32) -> Result<(MeshDesc, Option<MeshDesc>), OceanError> {
    if !reach.is_finite() {
        return Err(OceanError { parameter: "horizon reach", message: format!("must be finite, got {reach}") });
    }
    let (mesh, rim, (lo, hi), delta, offset) = build(params, time, view)?;
    if params.depth > 0.0 {
        return Ok((mesh, None));
    }
    // the rim in order round the square: south (z = 0) west to east, then east, north, west
    let side = |v: &(u64, u64, u32)| -> (u8, i64) {
        let (gx, gz) = (v.0 as i64, v.1 as i64);
        let (a, m) = (lo as i64, hi as i64);
        if gz == a && gx < m {
            (0, gx)
        } else if gx == m && gz < m {
            (1, gz)
        } else if gz == m && gx > a {
            (2, -gx)
        } else {
            (3, -gz)
        }
    };
    let mut ring = rim;
    ring.sort_by_key(side);
    let half = (hi - lo) as f64 * 0.5 * delta;
    let reach = (reach as f64).max(half);
    let l = params.patch_size as f64;
    let mut positions = Vec::with_capacity(2 * ring.len());
    let mut uvs = Vec::with_capacity(2 * ring.len());
    for &(gx, gz, i) in &ring {
        let (x, z) = (gx as f64 * delta - offset, gz as f64 * delta - offset);
        positions.push(mesh.positions[i as usize]);
        uvs.push(Vec2::new((x / l) as f32, (z / l) as f32));
        let (fx, fz) = (x * reach / half, z * reach / half);
        positions.push(Vec3::new(fx as f32, 0.0, fz as f32));
        uvs.push(Vec2::new((fx / l) as f32, (fz / l) as f32));
    }
    let count = ring.len() as u32;
    let mut indices = Vec::with_capacity(6 * ring.len());
    for k in 0..count {
        let (a, fa) = (2 * k, 2 * k + 1);
        let (b, fb) = (2 * ((k + 1) % count), 2 * ((k + 1) % count) + 1);
        for tri in [[a, fa, fb], [a, fb, b]] {
            let [p0, p1, p2] = tri.map(|i| positions[i as usize]);
            let up = (p1 - p0).cross(p2 - p0).y >= 0.0;
            indices.extend_from_slice(&if up { tri } else { [tri[0], tri[2], tri[1]] });
        }
    }
    let normals = vec![Vec3::Y; positions.len()];
    let skirt = MeshDesc { name: "TideOcean horizon".to_string(), faces: Vec::new(), positions, indices, normals: Some(normals), uvs: Some(uvs), uv_name: None, double_sided: false, motion: None, primvars: Vec::new(), origin: Default::default() };
    Ok((mesh, Some(skirt)))
}

/// The tiled surface with its rim vertices (fine-grid x, z, index), the fine-grid span [lo, hi]
/// of the surface, the grid spacing and the offset of the patches' corner from the origin.
#[allow(clippy::type_complexity)]
fn build(params: &OceanParams, time: f64, view: &OceanView) -> Result<(MeshDesc, Vec<(u64, u64, u32)>, (u64, u64), f64, f64), OceanError> {
    let patch = OceanPatch::new(params, time)?;
    let cam = view.position;
    if !cam.is_finite() {
        return Err(OceanError { parameter: "camera position", message: format!("must be finite, got {cam}") });
    }
    if !(view.pixel_angle.is_finite() && view.pixel_width.is_finite()) {
        return Err(OceanError { parameter: "camera pixel", message: format!("must be finite, got {} rad, {} m", view.pixel_angle, view.pixel_width) });
    }
    let closed = params.depth > 0.0;
    if closed {
        let lowest = patch.heights().iter().fold(f32::INFINITY, |m, &h| m.min(h));
        if lowest <= -params.depth {
            return Err(OceanError {
                parameter: "depth",
                message: format!("{} m does not reach below the deepest trough ({lowest} m)", params.depth),
            });
        }
    }
    let n = params.resolution as u64;
    let t = params.tiles_per_half_side() as i64;
    let l = params.patch_size as f64;
    let levels = tile_levels(params, view);
    let level = |ti: i64, tj: i64| -> Option<u32> {
        if ti < -t || ti >= t || tj < -t || tj >= t {
            return None;
        }
        Some(levels[((tj + t) * 2 * t + (ti + t)) as usize])
    };

    let max = 2 * t as u64 * n;
    let inset = params.rim_grid_inset();
    let mut b = Builder {
        patch: &patch,
        n,
        delta: l / n as f64,
        offset: t as f64 * l,
        lo: inset,
        hi: max - inset,
        closed,
        level: 0,
        first: HashMap::new(),
        map: HashMap::new(),
        positions: Vec::new(),
        normals: Vec::new(),
        uvs: Vec::new(),
        vertex_levels: Vec::new(),
        indices: Vec::new(),
        rim: Vec::new(),
        slopes: Vec::new(),
    };

    // block ring in tile-local (column, row) steps, counter-clockwise seen from +Y
    const RING: [(u64, u64); 8] = [(0, 0), (0, 1), (0, 2), (1, 2), (2, 2), (2, 1), (2, 0), (1, 0)];
    let mut ring = Vec::with_capacity(8);
    for tj in -t..t {
        for ti in -t..t {
            let lv = level(ti, tj).unwrap_or(0);
            b.level = lv;
            let coarser = |o: Option<u32>| o.is_some_and(|x| x > lv);
            let (west, east) = (coarser(level(ti - 1, tj)), coarser(level(ti + 1, tj)));
            let (south, north) = (coarser(level(ti, tj - 1)), coarser(level(ti, tj + 1)));
            let step = 1u64 << lv;
            let cells = n >> lv;
            let gx0 = (ti + t) as u64 * n;
            let gz0 = (tj + t) as u64 * n;
            for br in 0..cells / 2 {
                for bc in 0..cells / 2 {
                    let (c0, r0) = (2 * bc, 2 * br);
                    // a block wholly past the rim collapses onto it: nothing to draw
                    let (x0, x1) = (b.clip(gx0 + c0 * step), b.clip(gx0 + (c0 + 2) * step));
                    let (z0, z1) = (b.clip(gz0 + r0 * step), b.clip(gz0 + (r0 + 2) * step));
                    if x0 == x1 || z0 == z1 {
                        continue;
                    }
                    let at = |b: &Builder, dc: u64, dr: u64| (b.clip(gx0 + (c0 + dc) * step), b.clip(gz0 + (r0 + dr) * step));
                    let c = at(&b, 1, 1);
                    let center = (b.vertex(c.0, c.1), c);
                    ring.clear();
                    for &(dc, dr) in &RING {
                        let skip = (dc == 0 && dr == 1 && bc == 0 && west)
                            || (dc == 2 && dr == 1 && bc + 1 == cells / 2 && east)
                            || (dr == 0 && dc == 1 && br == 0 && south)
                            || (dr == 2 && dc == 1 && br + 1 == cells / 2 && north);
                        if !skip {
                            let g = at(&b, dc, dr);
                            ring.push((b.vertex(g.0, g.1), g));
                        }
                    }
                    for k in 0..ring.len() {
                        let tri = [center, ring[k], ring[(k + 1) % ring.len()]];
                        // cut at the rim, a triangle whose corners moved onto it may have no
                        // area left on the grid (the same test as the vertices': exact)
                        let [(_, a), (_, p), (_, q)] = tri;
                        let cross = (p.0 as i64 - a.0 as i64) * (q.1 as i64 - a.1 as i64) - (p.1 as i64 - a.1 as i64) * (q.0 as i64 - a.0 as i64);
                        if cross != 0 {
                            let tri = tri.map(|v| v.0);
                            b.indices.extend_from_slice(&tri);
                            b.add_slopes(tri, cross.unsigned_abs() as f64);
                        }
                    }
                }
            }
        }
    }

    if closed {
        close_body(&mut b, params.depth);
    }

    // each level's share of the Cox–Munk slopes left to the sea BSDF: what the level's
    // triangles, with their normals interpolated across them, do not carry
    let (vu, vc) = crate::bsdf::sea::CoxMunk::variances(params.wind_speed);
    let facets = vu as f64 + vc as f64;
    let cm = super::spectrum::cox_munk_mss(params.wind_speed as f64);
    let share = |level: u32| -> f32 {
        match b.slopes.get(level as usize) {
            Some(&(sum, area)) if level != FLAT && area > 0.0 && facets > 0.0 => ((cm - sum / area).max(0.0) / facets) as f32,
            _ => 1.0,
        }
    };
    let shares = b.vertex_levels.iter().map(|&lv| share(lv)).collect();
    let primvars = vec![crate::scene::PrimvarData { name: crate::scene::SEA_SHARE_PRIMVAR.into(), tuple: 1, constant: false, data: shares }];
    let (span, delta, offset) = ((b.lo, b.hi), b.delta, b.offset);
    let mesh = MeshDesc { name: "TideOcean".to_string(), faces: Vec::new(), uv_name: None, positions: b.positions, indices: b.indices, normals: Some(b.normals), uvs: Some(b.uvs), double_sided: false, motion: None, primvars, origin: Default::default() };
    Ok((mesh, b.rim, span, delta, offset))
}

/// Walls from the rim down to y = −depth and a floor, each with its own copies of the rim.
fn close_body(b: &mut Builder<'_>, depth: f32) {
    let (lo, hi) = (b.lo, b.hi);
    let pick = |f: &dyn Fn(&(u64, u64, u32)) -> bool| -> Vec<(u64, u64, u32)> { b.rim.iter().copied().filter(|v| f(v)).collect() };
    let mut south = pick(&|v| v.1 == lo);
    south.sort_by_key(|v| v.0);
    let mut east = pick(&|v| v.0 == hi);
    east.sort_by_key(|v| v.1);
    let mut north = pick(&|v| v.1 == hi);
    north.sort_by_key(|v| std::cmp::Reverse(v.0));
    let mut west = pick(&|v| v.0 == lo);
    west.sort_by_key(|v| std::cmp::Reverse(v.1));
    let l = b.patch.patch_size();
    let y0 = -depth;
    let mut floor_ring: Vec<Vec3> = Vec::new();
    for (side, outward) in [(south, Vec3::NEG_Z), (east, Vec3::X), (north, Vec3::Z), (west, Vec3::NEG_X)] {
        let along = if outward.x != 0.0 { Vec3::Z } else { Vec3::X };
        let mut tops = Vec::with_capacity(side.len());
        let mut bottoms = Vec::with_capacity(side.len());
        for &(_, _, i) in &side {
            let p = b.positions[i as usize];
            let bottom = Vec3::new(p.x, y0, p.z);
            tops.push(b.add_vertex(p, outward, Vec2::new(p.dot(along) / l, p.y / l)));
            bottoms.push(b.add_vertex(bottom, outward, Vec2::new(p.dot(along) / l, y0 / l)));
        }
        for k in 0..side.len() - 1 {
            b.push_oriented([bottoms[k], tops[k], tops[k + 1]], outward);
            b.push_oriented([bottoms[k], tops[k + 1], bottoms[k + 1]], outward);
        }
        for &i in &bottoms[..bottoms.len() - 1] {
            floor_ring.push(b.positions[i as usize]);
        }
    }
    let center = b.add_vertex(Vec3::new(0.0, y0, 0.0), Vec3::NEG_Y, Vec2::ZERO);
    let first = b.positions.len() as u32;
    for p in &floor_ring {
        b.add_vertex(*p, Vec3::NEG_Y, Vec2::new(p.x / l, p.z / l));
    }
    let count = floor_ring.len() as u32;
    for k in 0..count {
        b.push_oriented([center, first + k, first + (k + 1) % count], Vec3::NEG_Y);
    }
}
