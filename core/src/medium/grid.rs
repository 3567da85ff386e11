//! A heterogeneous medium from a density grid (a `UsdVolVolume`'s OpenVDB `density` field):
//! σa(p) = ρ(p)·σa, σs(p) = ρ(p)·σs with ρ the trilinearly interpolated grid and (σa, σs) the
//! bound `TideMedium`'s spectra (already multiplied by its `densityScale`).
//!
//! # Grid
//! The grid spans its *local* index space: the value `[i, j, k]` sits at the point
//! u = (i, j, k); ρ between points is trilinear, with 0 outside the array, so ρ can be non-zero
//! only in the open box (−1, dims). An affine `local_to_world` places it. The values are held
//! in [`Bricks`] of [`BRICK`]³ (an OpenVDB leaf's size), a brick of zeros not at all, found
//! through a two-level table, so a sparse grid over a large box (spray, foam, a plume) takes
//! the memory of its occupied bricks; the bricks are shared, not copied, between the scene
//! description and the medium.
//!
//! # Majorants
//! A coarse grid of super-voxels of [`SUPER`]³ cells (cell c of an axis covers
//! u ∈ [−1 + cS, −1 + (c+1)S)) stores the largest value any trilinear lookup in it can
//! return; a 3-D DDA (Amanatides & Woo) walks a ray through it, giving a piecewise-constant
//! majorant m(t) ≥ ρ(t) in density units. Like the bricks' table it is held in nodes of
//! [`NODE`]³ super-voxels, only those in reach of a stored brick, and the walk crosses a node
//! with nothing in reach in one step: the box's size costs 4 bytes per node of 64³ voxels in
//! memory and a step per node along a ray.
//!
//! # Collisions: delta tracking with spectral MIS
//! As in [`super::tracking`], channel c is chosen uniformly among the live wavelengths and
//! tentative collisions are drawn with rate m(t)·σt_c. Because every wavelength's σt is the
//! same density times a constant, a tentative collision is real with probability ρ/m for every
//! channel, and in the MIS weight (f_j / ((1/N) Σ_c p_c)) the factors Π(m_i − ρ_i) and ρ are
//! common to all strategies. With M = ∫ m dt up to the event and k null collisions,
//!
//! w_j = e^{−σt_j M} σt_j^k σs_j / ((1/N) Σ_c e^{−σt_c M} σt_c^{k+1})  (scatter),
//! w_j = e^{−σt_j M} σt_j^k / ((1/N) Σ_c e^{−σt_c M} σt_c^k)  (pass),
//!
//! unbiased for every wavelength and bounded by N (kept in the log domain).
//!
//! # Shadow rays: residual ratio tracking
//! Each super-voxel also stores the least density c a lookup in it can return. With the control
//! c·σt_j and the scalar residual rate μ(t) = (m(t) − c(t))·max_j σt_j,
//! T_j = e^{−σt_j ∫c} Π_i (1 − (ρ(t_i) − c) σt_j / ((m − c) max σt)) over the points of a
//! Poisson process of rate μ (Novák et al. 2014); each factor lies in [0, 1]. Where the density
//! is constant over a super-voxel (m = c) the estimate is exact there and draws nothing; outside
//! the box T = 1. Once the estimate is small it is played with Russian roulette
//! ([`super::tracking::roulette`]), so a shadow ray through a dense grid ends in a few points.

use super::homogeneous::DistanceSample;
use super::phase::{PhaseFunction, ONE_MINUS_EPSILON};
use super::tracking::{mis_weight, roulette, MAX_TRACKING_STEPS};
use crate::spectrum::{SampledSpectrum, SampledWavelengths, Spectrum, N_SPECTRUM};
use glam::{Mat4, Vec3};

/// Edge of a super-voxel of the majorant grid, in grid cells.
pub const SUPER: usize = 8;

/// Edge of a brick of [`Bricks`], in voxels (an OpenVDB leaf node's).
pub const BRICK: usize = 8;
const BRICK_VALUES: usize = BRICK * BRICK * BRICK;

/// Edge of a node of the two-level tables, in bricks (or super-voxels): a grid's table has one
/// entry per node of its box and [`NODE`]³ per node that holds anything.
pub const NODE: usize = 8;
const NODE_ENTRIES: usize = NODE * NODE * NODE;

/// Most nodes a table's box may have (its top level: 1 GiB of entries).
const MAX_NODES: usize = 1 << 28;

/// A sparse 3-D array of `T` over `dims` cells, `T::default()` where nothing is stored: a top
/// level with one entry per node of [`NODE`]³ cells (0 for a node with nothing stored, else 1 +
/// its index) and, per node with something stored, its [`NODE`]³ values (x fastest). Memory
/// follows the nodes occupied, not the box (4 bytes per node of the box).
#[derive(Clone, Debug, Default, PartialEq)]
struct NodeTable<T> {
    dims: [usize; 3],
    ndims: [usize; 3],
    top: Vec<u32>,
    nodes: Vec<T>,
}

impl<T: Copy + Default + PartialEq> NodeTable<T> {
    fn new(dims: [usize; 3]) -> Option<Self> {
        let ndims = dims.map(|n| n.div_ceil(NODE));
        let count = ndims[0].checked_mul(ndims[1])?.checked_mul(ndims[2])?;
        if count > MAX_NODES {
            return None;
        }
        let mut top = Vec::new();
        top.try_reserve_exact(count).ok()?;
        top.resize(count, 0);
        Some(NodeTable { dims, ndims, top, nodes: Vec::new() })
    }

    #[inline]
    fn node_of(&self, x: usize, y: usize, z: usize) -> usize {
        x / NODE + self.ndims[0] * (y / NODE + self.ndims[1] * (z / NODE))
    }

    #[inline]
    fn within(x: usize, y: usize, z: usize) -> usize {
        x % NODE + NODE * (y % NODE + NODE * (z % NODE))
    }

    /// The value of cell [x, y, z] (inside `dims`).
    #[inline]
    fn get(&self, x: usize, y: usize, z: usize) -> T {
        let n = self.top[self.node_of(x, y, z)];
        if n == 0 {
            return T::default();
        }
        self.nodes[(n as usize - 1) * NODE_ENTRIES + Self::within(x, y, z)]
    }

    /// Whether the node holding cell [x, y, z] stores nothing.
    #[inline]
    fn node_empty(&self, x: usize, y: usize, z: usize) -> bool {
        self.top[self.node_of(x, y, z)] == 0
    }

    /// A mutable reference to cell [x, y, z]'s value, its node made first if need be; None
    /// when there is no memory for it.
    fn entry(&mut self, x: usize, y: usize, z: usize) -> Option<&mut T> {
        let t = self.node_of(x, y, z);
        if self.top[t] == 0 {
            let made = self.nodes.len() / NODE_ENTRIES;
            if made >= u32::MAX as usize {
                return None;
            }
            self.nodes.try_reserve(NODE_ENTRIES).ok()?;
            self.nodes.resize(self.nodes.len() + NODE_ENTRIES, T::default());
            self.top[t] = made as u32 + 1;
        }
        let at = (self.top[t] as usize - 1) * NODE_ENTRIES + Self::within(x, y, z);
        Some(&mut self.nodes[at])
    }

    /// The cells whose nodes are stored, with their values, in node order.
    fn stored_cells(&self) -> impl Iterator<Item = ([usize; 3], T)> + '_ {
        let nd = self.ndims;
        self.top.iter().enumerate().filter(|(_, &n)| n != 0).flat_map(move |(t, &n)| {
            let node = [t % nd[0], t / nd[0] % nd[1], t / (nd[0] * nd[1])];
            (0..NODE_ENTRIES).filter_map(move |k| {
                let c = [node[0] * NODE + k % NODE, node[1] * NODE + k / NODE % NODE, node[2] * NODE + k / (NODE * NODE)];
                (c[0] < self.dims[0] && c[1] < self.dims[1] && c[2] < self.dims[2]).then(|| (c, self.nodes[(n as usize - 1) * NODE_ENTRIES + k]))
            })
        })
    }

    fn memory_bytes(&self) -> usize {
        self.top.len() * 4 + self.nodes.len() * std::mem::size_of::<T>()
    }
}

/// A grid's values in bricks of [`BRICK`]³ voxels, those all zero left out: the voxel
/// [x, y, z] lies in brick [x, y, z] / BRICK, at x % BRICK + BRICK·(y % BRICK + BRICK·(z %
/// BRICK)) within it. The bricks are found through a two-level table ([`NODE`]³ bricks per
/// node, only occupied nodes stored), so a sparse grid over a vast box takes the memory of its
/// occupied bricks and nodes. Values that are not finite, or are negative, are 0.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bricks {
    dims: [usize; 3],
    /// Per brick: 0 where it is all zero, else 1 + its index among the stored bricks.
    table: NodeTable<u32>,
    /// [`BRICK`]³ values per stored brick.
    pool: Vec<f32>,
}

/// A value as a grid holds it: what is not finite, or is negative, is 0.
#[inline]
fn clean(v: f32) -> f32 {
    if v.is_finite() && v > 0.0 {
        v
    } else {
        0.0
    }
}

impl Bricks {
    /// An empty grid of `dims` voxels; None for a zero or too vast box.
    fn empty_of(dims: [u32; 3]) -> Option<Bricks> {
        let d = dims.map(|v| v as usize);
        if d.contains(&0) {
            return None;
        }
        Some(Bricks { dims: d, table: NodeTable::new(d.map(|n| n.div_ceil(BRICK)))?, pool: Vec::new() })
    }

    /// `values` (x fastest over `dims`) in bricks.
    pub fn from_dense(dims: [u32; 3], values: &[f32]) -> Result<Bricks, GridError> {
        let err = GridError::Dims { dims, len: values.len() };
        let Some(mut out) = Bricks::empty_of(dims) else { return Err(err) };
        let d = out.dims;
        if d[0].checked_mul(d[1]).and_then(|v| v.checked_mul(d[2])) != Some(values.len()) {
            return Err(err);
        }
        let b = out.table.dims;
        let mut brick = [0f32; BRICK_VALUES];
        for bz in 0..b[2] {
            for by in 0..b[1] {
                for bx in 0..b[0] {
                    let mut any = false;
                    for (k, v) in brick.iter_mut().enumerate() {
                        let (x, y, z) = (bx * BRICK + k % BRICK, by * BRICK + k / BRICK % BRICK, bz * BRICK + k / (BRICK * BRICK));
                        *v = if x < d[0] && y < d[1] && z < d[2] { clean(values[x + d[0] * (y + d[1] * z)]) } else { 0.0 };
                        any |= *v != 0.0;
                    }
                    if any {
                        out.pool.extend_from_slice(&brick);
                        let n = (out.pool.len() / BRICK_VALUES) as u32;
                        *out.table.entry(bx, by, bz).ok_or(GridError::Dims { dims, len: values.len() })? = n;
                    }
                }
            }
        }
        Ok(out)
    }

    /// Bricks as a reader hands them over: `coords` the brick coordinates (voxel / [`BRICK`],
    /// three per brick) of the bricks whose values `pool` holds ([`BRICK`]³ each, x fastest),
    /// each brick once; the others are all zero.
    pub fn from_coords(dims: [u32; 3], coords: &[u32], mut pool: Vec<f32>) -> Result<Bricks, String> {
        let mut out = Bricks::empty_of(dims).ok_or_else(|| format!("a grid of {}×{}×{} voxels (at most {MAX_NODES} nodes of {} voxels in its box)", dims[0], dims[1], dims[2], (NODE * BRICK).pow(3)))?;
        let stored = pool.len() / BRICK_VALUES;
        if pool.len() % BRICK_VALUES != 0 || coords.len() != 3 * stored || stored >= u32::MAX as usize {
            return Err(format!("{} brick coordinates and {} values for bricks of {BRICK_VALUES} values", coords.len(), pool.len()));
        }
        let b = out.table.dims;
        for (i, c) in coords.chunks_exact(3).enumerate() {
            let c = [c[0] as usize, c[1] as usize, c[2] as usize];
            if (0..3).any(|k| c[k] >= b[k]) {
                return Err(format!("brick {:?} lies outside the grid's {}×{}×{} bricks", c, b[0], b[1], b[2]));
            }
            let e = out.table.entry(c[0], c[1], c[2]).ok_or("not enough memory for the grid's table")?;
            if *e != 0 {
                return Err(format!("brick {:?} is given twice", c));
            }
            *e = i as u32 + 1;
        }
        pool.iter_mut().for_each(|v| *v = clean(*v));
        out.pool = pool;
        Ok(out)
    }

    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// The bricks holding values (the others are all zero).
    pub fn stored(&self) -> usize {
        self.pool.len() / BRICK_VALUES
    }

    /// Bytes held (the table and the stored bricks).
    pub fn memory_bytes(&self) -> usize {
        self.table.memory_bytes() + self.pool.len() * 4
    }

    /// The coordinates of the stored bricks.
    fn stored_bricks(&self) -> impl Iterator<Item = [usize; 3]> + '_ {
        self.table.stored_cells().filter(|&(_, t)| t != 0).map(|(c, _)| c)
    }

    /// The value at voxel [x, y, z], inside the grid.
    #[inline]
    pub fn get(&self, x: usize, y: usize, z: usize) -> f32 {
        let t = self.table.get(x / BRICK, y / BRICK, z / BRICK);
        if t == 0 {
            return 0.0;
        }
        self.pool[(t as usize - 1) * BRICK_VALUES + x % BRICK + BRICK * (y % BRICK + BRICK * (z % BRICK))]
    }

    /// The values at the corners of the cell [x, x + 1] × [y, y + 1] × [z, z + 1] (all inside
    /// the grid), x fastest: from one brick, found once, where the cell lies in one.
    #[inline]
    pub fn cell(&self, x: usize, y: usize, z: usize) -> [f32; 8] {
        let (ix, iy, iz) = (x % BRICK, y % BRICK, z % BRICK);
        if ix < BRICK - 1 && iy < BRICK - 1 && iz < BRICK - 1 {
            let t = self.table.get(x / BRICK, y / BRICK, z / BRICK);
            if t == 0 {
                return [0.0; 8];
            }
            let p = &self.pool[(t as usize - 1) * BRICK_VALUES + ix + BRICK * (iy + BRICK * iz)..];
            const Y: usize = BRICK;
            const Z: usize = BRICK * BRICK;
            return [p[0], p[1], p[Y], p[Y + 1], p[Z], p[Z + 1], p[Z + Y], p[Z + Y + 1]];
        }
        [self.get(x, y, z), self.get(x + 1, y, z), self.get(x, y + 1, z), self.get(x + 1, y + 1, z), self.get(x, y, z + 1), self.get(x + 1, y, z + 1), self.get(x, y + 1, z + 1), self.get(x + 1, y + 1, z + 1)]
    }

    /// Every value, x fastest.
    pub fn to_dense(&self) -> Vec<f32> {
        let d = self.dims;
        (0..d[2]).flat_map(|z| (0..d[1]).flat_map(move |y| (0..d[0]).map(move |x| (x, y, z)))).map(|(x, y, z)| self.get(x, y, z)).collect()
    }
}

/// A density grid with a world placement and its majorant grid.
#[derive(Clone, Debug, PartialEq)]
pub struct DensityGrid {
    dims: [usize; 3],
    values: std::sync::Arc<Bricks>,

    local_to_world: Mat4,
    world_to_local: Mat4,
    super_dims: [usize; 3],
    /// Per super-voxel (upper, lower) bound of the density (the lower one is the control of
    /// residual ratio tracking); (0, 0) where no stored brick is in reach.
    bounds: NodeTable<[f32; 2]>,
    max_density: f32,
    /// Grid-local to world over the shutter when the volume moves (`local_to_world` is then its
    /// value at the first key): see [`DensityGrid::rest_ray`].
    motion: Option<crate::accel::motion::MotionTransform>,
}

/// Why a grid cannot be built.
#[derive(Clone, Debug, PartialEq)]
pub enum GridError {
    Dims { dims: [u32; 3], len: usize },
    Transform,
}

impl std::fmt::Display for GridError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GridError::Dims { dims, len } => write!(f, "grid of {}×{}×{} needs as many values, has {len}", dims[0], dims[1], dims[2]),
            GridError::Transform => write!(f, "grid transform is not finite and invertible"),
        }
    }
}

impl DensityGrid {
    /// A grid of `dims` values (x fastest) placed by `local_to_world` (affine). Non-finite or
    /// negative values are read as 0 (the caller reports them).
    pub fn new(dims: [u32; 3], values: &[f32], local_to_world: Mat4) -> Result<Self, GridError> {
        DensityGrid::from_bricks(std::sync::Arc::new(Bricks::from_dense(dims, values)?), local_to_world)
    }

    /// A grid of the values `bricks` holds (shared, not copied) placed by `local_to_world`.
    pub fn from_bricks(values: std::sync::Arc<Bricks>, local_to_world: Mat4) -> Result<Self, GridError> {
        let d = values.dims();
        if d.contains(&0) {
            return Err(GridError::Dims { dims: d.map(|v| v as u32), len: 0 });
        }
        let world_to_local = local_to_world.inverse();
        if !local_to_world.is_finite() || !world_to_local.is_finite() || local_to_world.determinant().abs() < 1e-30 {
            return Err(GridError::Transform);
        }
        let super_dims = d.map(|n| (n + 1).div_ceil(SUPER));
        let mut bounds = NodeTable::<[f32; 2]>::new(super_dims).ok_or(GridError::Dims { dims: d.map(|v| v as u32), len: 0 })?;
        let b = &*values;
        // Lookups in super-voxel c of an axis, u ∈ [−1 + cS, −1 + (c+1)S), read the values at
        // indices ⌊u⌋ and ⌊u⌋ + 1: from −1 + cS to (c+1)S, which lie in bricks c − 1 to c + 1
        // (S = BRICK). Only the super-voxels in reach of a stored brick can be non-zero: they
        // are marked (NaN), then bounded; the others are left out, (0, 0).
        const _: () = assert!(SUPER == BRICK);
        let out_of_memory = GridError::Dims { dims: d.map(|v| v as u32), len: 0 };
        for c in b.stored_bricks() {
            for z in c[2].saturating_sub(1)..(c[2] + 2).min(super_dims[2]) {
                for y in c[1].saturating_sub(1)..(c[1] + 2).min(super_dims[1]) {
                    for x in c[0].saturating_sub(1)..(c[0] + 2).min(super_dims[0]) {
                        bounds.entry(x, y, z).ok_or_else(|| out_of_memory.clone())?[0] = f32::NAN;
                    }
                }
            }
        }
        let marked: Vec<[usize; 3]> = bounds.stored_cells().filter(|(_, v)| v[0].is_nan()).map(|(c, _)| c).collect();
        let mut max_density = 0f32;
        for [cx, cy, cz] in marked {
            // every lookup is a convex combination of the values in the range, so their max
            // and min bound it; a range reaching outside the array includes a 0
            let range = |c: usize, n: usize| {
                let lo = (c * SUPER) as i64 - 1;
                let hi = ((c + 1) * SUPER) as i64;
                let outside = lo < 0 || hi > n as i64 - 1;
                (lo.max(0) as usize, (hi.min(n as i64 - 1)).max(0) as usize, outside)
            };
            let (x0, x1, ox) = range(cx, d[0]);
            let (y0, y1, oy) = range(cy, d[1]);
            let (z0, z1, oz) = range(cz, d[2]);
            let mut m = 0f32;
            let mut lo = if ox || oy || oz { 0.0 } else { f32::INFINITY };
            for z in z0..=z1 {
                for y in y0..=y1 {
                    for x in x0..=x1 {
                        let v = b.get(x, y, z);
                        m = m.max(v);
                        lo = lo.min(v);
                    }
                }
            }
            max_density = max_density.max(m);
            if let Some(e) = bounds.entry(cx, cy, cz) {
                *e = [m, lo.min(m)];
            }
        }
        Ok(DensityGrid { dims: d, values, local_to_world, world_to_local, super_dims, bounds, max_density, motion: None })
    }

    /// The grid's values, in bricks.
    pub fn bricks(&self) -> &std::sync::Arc<Bricks> {
        &self.values
    }

    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    pub fn max_density(&self) -> f32 {
        self.max_density
    }

    pub fn local_to_world(&self) -> Mat4 {
        self.local_to_world
    }

    /// The box outside which the density is 0, in local coordinates: [−1, dims].
    pub fn local_bounds(&self) -> (Vec3, Vec3) {
        (Vec3::splat(-1.0), Vec3::new(self.dims[0] as f32, self.dims[1] as f32, self.dims[2] as f32))
    }

    #[inline]
    fn value(&self, x: i64, y: i64, z: i64) -> f32 {
        let d = self.dims;
        if x < 0 || y < 0 || z < 0 || x >= d[0] as i64 || y >= d[1] as i64 || z >= d[2] as i64 {
            return 0.0;
        }
        self.values.get(x as usize, y as usize, z as usize)
    }

    /// Trilinear density at local point `u`.
    #[inline]
    pub fn density_local(&self, u: Vec3) -> f32 {
        let (lo, hi) = self.local_bounds();
        if !(u.x > lo.x && u.y > lo.y && u.z > lo.z && u.x < hi.x && u.y < hi.y && u.z < hi.z) {
            return 0.0;
        }
        let f = u.floor();
        let (x, y, z) = (f.x as i64, f.y as i64, f.z as i64);
        let w = u - f;
        let d = self.dims;
        let inside = x >= 0 && y >= 0 && z >= 0 && x + 1 < d[0] as i64 && y + 1 < d[1] as i64 && z + 1 < d[2] as i64;
        // the cell's corners: from their brick at once where they share one (most cells)
        let c = if inside {
            self.values.cell(x as usize, y as usize, z as usize)
        } else {
            [self.value(x, y, z), self.value(x + 1, y, z), self.value(x, y + 1, z), self.value(x + 1, y + 1, z), self.value(x, y, z + 1), self.value(x + 1, y, z + 1), self.value(x, y + 1, z + 1), self.value(x + 1, y + 1, z + 1)]
        };
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let c00 = lerp(c[0], c[1], w.x);
        let c10 = lerp(c[2], c[3], w.x);
        let c01 = lerp(c[4], c[5], w.x);
        let c11 = lerp(c[6], c[7], w.x);
        lerp(lerp(c00, c10, w.y), lerp(c01, c11, w.y), w.z).max(0.0)
    }

    /// The grid moving over the shutter: grid-local to world `mats[i]` at `times[i]`
    /// (increasing), interpolated as instance transforms are (so the volume's box and its
    /// density move together); its rest placement becomes `mats[0]`. Fewer than two keys leave
    /// it still.
    pub fn with_motion(mut self, mats: &[Mat4], times: &[f32]) -> Result<Self, GridError> {
        if mats.len() < 2 || mats.len() != times.len() {
            return Ok(self);
        }
        if mats.iter().any(|m| !m.is_finite() || m.determinant().abs() < 1e-30) {
            return Err(GridError::Transform);
        }
        self.local_to_world = mats[0];
        self.world_to_local = mats[0].inverse();
        self.motion = Some(crate::accel::motion::MotionTransform::new(mats, times));
        Ok(self)
    }

    /// A ray at shutter time `time` expressed where the grid rests (at its first key), with the
    /// same parameter t: o + t·d at `time` lies in the grid where o′ + t·d′ lies at rest. The
    /// coefficients stay per unit of t, so a grid that scales over the shutter is stretched,
    /// not diluted. The identity for a grid that does not move.
    #[inline]
    pub fn rest_ray(&self, time: f32, o: Vec3, d: Vec3) -> (Vec3, Vec3) {
        match &self.motion {
            Some(m) => {
                let to_rest = self.local_to_world * m.at(time).inverse();
                (to_rest.transform_point3(o), to_rest.transform_vector3(d))
            }
            None => (o, d),
        }
    }

    /// Trilinear density at world point `p`.
    #[inline]
    pub fn density(&self, p: Vec3) -> f32 {
        self.density_local(self.world_to_local.transform_point3(p))
    }

    /// The super-voxel segments of `o + t·d`, t ∈ [0, t_max], that lie in the box.
    #[inline]
    pub fn segments(&self, o: Vec3, d: Vec3, t_max: f32) -> MajorantSegments<'_> {
        let uo = self.world_to_local.transform_point3(o);
        let ud = self.world_to_local.transform_vector3(d);
        MajorantSegments::new(self, uo, ud, t_max)
    }
}

/// A walk over the super-voxels a ray crosses: (t0, t1, majorant density) in ray order;
/// [`MajorantSegments::minorant`] is the lower bound of the super-voxel last returned. A node
/// of [`NODE`]³ super-voxels with nothing in reach is crossed in one step, as one segment of
/// majorant 0.
pub struct MajorantSegments<'a> {
    grid: &'a DensityGrid,
    /// Local origin and direction (t is the world ray's parameter).
    pub uo: Vec3,
    pub ud: Vec3,
    cell: [i64; 3],
    step: [i64; 3],
    t_next: [f32; 3],
    dt: [f32; 3],
    t: f32,
    t_end: f32,
    /// The bounds of the last segment returned.
    last: [f32; 2],
}

impl<'a> MajorantSegments<'a> {
    /// Lower bound of the density in the super-voxel of the last segment returned.
    #[inline]
    pub fn minorant(&self) -> f32 {
        self.last[1]
    }

    fn new(grid: &'a DensityGrid, uo: Vec3, ud: Vec3, t_max: f32) -> Self {
        let (lo, hi) = grid.local_bounds();
        let (mut t0, mut t1) = (0.0f32, t_max);
        for k in 0..3 {
            if ud[k] == 0.0 {
                if uo[k] <= lo[k] || uo[k] >= hi[k] {
                    t1 = -1.0;
                }
                continue;
            }
            let inv = 1.0 / ud[k];
            let (a, b) = ((lo[k] - uo[k]) * inv, (hi[k] - uo[k]) * inv);
            let (a, b) = if a < b { (a, b) } else { (b, a) };
            t0 = t0.max(a);
            t1 = t1.min(b);
        }
        let mut s = MajorantSegments { grid, uo, ud, cell: [0; 3], step: [0; 3], t_next: [f32::INFINITY; 3], dt: [f32::INFINITY; 3], t: t0, t_end: t1, last: [0.0; 2] };
        if !(t0 < t1) {
            s.t_end = f32::NEG_INFINITY;
            return s;
        }
        // cell coordinates q = (u + 1) / S, entered at t0
        let scale = 1.0 / SUPER as f32;
        let q0 = (uo + ud * t0 + Vec3::ONE) * scale;
        let qd = ud * scale;
        for k in 0..3 {
            let n = grid.super_dims[k] as i64;
            let c = (q0[k].floor() as i64).clamp(0, n - 1);
            s.cell[k] = c;
            if qd[k] > 0.0 {
                s.step[k] = 1;
                s.t_next[k] = t0 + ((c + 1) as f32 - q0[k]) / qd[k];
                s.dt[k] = 1.0 / qd[k];
            } else if qd[k] < 0.0 {
                s.step[k] = -1;
                s.t_next[k] = t0 + (c as f32 - q0[k]) / qd[k];
                s.dt[k] = -1.0 / qd[k];
            }
        }
        s
    }
}

impl Iterator for MajorantSegments<'_> {
    type Item = (f32, f32, f32);

    #[inline]
    fn next(&mut self) -> Option<(f32, f32, f32)> {
        let n = self.grid.super_dims;
        loop {
            if !(self.t < self.t_end) || (0..3).any(|k| self.cell[k] < 0 || self.cell[k] >= n[k] as i64) {
                return None;
            }
            let axis = if self.t_next[0] <= self.t_next[1] && self.t_next[0] <= self.t_next[2] {
                0
            } else if self.t_next[1] <= self.t_next[2] {
                1
            } else {
                2
            };
            let t0 = self.t;
            let [cx, cy, cz] = self.cell.map(|c| c as usize);
            if self.grid.bounds.node_empty(cx, cy, cz) {
                self.skip_node(n);
                self.last = [0.0; 2];
                if self.t > t0 {
                    return Some((t0, self.t, 0.0));
                }
                continue;
            }
            let t1 = self.t_next[axis].min(self.t_end).max(t0);
            self.last = self.grid.bounds.get(cx, cy, cz);
            self.t = t1;
            self.cell[axis] += self.step[axis];
            self.t_next[axis] += self.dt[axis];
            if t1 > t0 {
                return Some((t0, t1, self.last[0]));
            }
        }
    }
}

impl MajorantSegments<'_> {
    /// Moves the walk from inside an empty node to the first super-voxel past it (or to the
    /// walk's end): the crossings of each axis before the node's exit are taken at once, each
    /// axis kept inside the node but the one it leaves by.
    fn skip_node(&mut self, n: [usize; 3]) {
        let node = self.cell.map(|c| c / NODE as i64 * NODE as i64);
        // crossings left inside the node along each axis (its last cell to the far side)
        let inside = |k: usize, cell: i64| match self.step[k] {
            1 => (node[k] + NODE as i64 - 1).min(n[k] as i64 - 1) - cell,
            -1 => cell - node[k],
            _ => i64::MAX,
        };
        let mut exit = (f32::INFINITY, 0);
        for k in 0..3 {
            if self.step[k] != 0 {
                let t = self.t_next[k] + inside(k, self.cell[k]) as f32 * self.dt[k];
                if t < exit.0 {
                    exit = (t, k);
                }
            }
        }
        let t1 = exit.0.min(self.t_end).max(self.t);
        for k in 0..3 {
            if self.step[k] == 0 {
                continue;
            }
            let left = inside(k, self.cell[k]);
            let crossed = if self.t_next[k] <= t1 { ((t1 - self.t_next[k]) / self.dt[k]).floor() as i64 + 1 } else { 0 };
            // the exit axis leaves by one crossing more than the cells left inside
            let steps = if k == exit.1 && t1 < self.t_end { left + 1 } else { crossed.clamp(0, left) };
            self.cell[k] += self.step[k] * steps;
            self.t_next[k] += steps as f32 * self.dt[k];
        }
        self.t = t1;
    }
}

/// The medium of a volume: a density grid times a homogeneous medium's coefficients.
#[derive(Clone, Debug, PartialEq)]
pub struct GridMedium {
    pub grid: DensityGrid,
    /// Coefficients at density 1 (per scene unit), `densityScale` included.
    pub sigma_a: Spectrum,
    pub sigma_s: Spectrum,
    pub phase: PhaseFunction,
}

#[inline]
fn unit(rng: &mut impl FnMut() -> f32) -> f32 {
    rng().clamp(0.0, ONE_MINUS_EPSILON)
}

impl GridMedium {
    /// (σa, σs) at density 1, at the live wavelengths (0 elsewhere and where negative).
    #[inline]
    pub fn coefficients(&self, lambda: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        let keep = |s: SampledSpectrum| SampledSpectrum::from_fn(|j| if lambda.pdf[j] > 0.0 && s[j] > 0.0 && s[j].is_finite() { s[j] } else { 0.0 });
        (keep(self.sigma_a.sample(lambda)), keep(self.sigma_s.sample(lambda)))
    }

    /// σt bound over the whole grid.
    pub fn majorant(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        let (a, s) = self.coefficients(lambda);
        (a + s) * self.grid.max_density
    }

    /// (σa, σs) at world point `p`.
    pub fn coefficients_at(&self, p: Vec3, lambda: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        let (a, s) = self.coefficients(lambda);
        let rho = self.grid.density(p);
        (a * rho, s * rho)
    }

    /// Delta tracking with spectral MIS over the majorant grid (see the module docs).
    pub fn sample_distance(&self, o: Vec3, d: Vec3, t_max: f32, rng: &mut impl FnMut() -> f32, lambda: &SampledWavelengths) -> DistanceSample {
        let live = |j: usize| lambda.pdf[j] > 0.0;
        let n = (0..N_SPECTRUM).filter(|&j| live(j)).count();
        let all_live = SampledSpectrum::from_fn(|j| if live(j) { 1.0 } else { 0.0 });
        if n == 0 || !(t_max > 0.0) {
            return DistanceSample::Pass { weight: all_live };
        }
        let (sa, ss) = self.coefficients(lambda);
        let st = sa + ss;
        if ss.is_black() {
            // purely absorbing: collisions would carry weight 0; the transmittance estimate
            // is itself an unbiased passing weight
            return DistanceSample::Pass { weight: self.transmittance(o, d, t_max, rng, lambda) };
        }
        let scaled = unit(rng) * n as f32;
        let kc = (scaled as usize).min(n - 1);
        let v = (scaled - kc as f32).clamp(0.0, ONE_MINUS_EPSILON);
        let c = (0..N_SPECTRUM).filter(|&j| live(j)).nth(kc).unwrap_or(0);
        // log weights: L_j = −σt_j M + k ln σt_j
        let logs = |m_acc: f32, k: u32| -> [f32; N_SPECTRUM] {
            std::array::from_fn(|j| {
                let a = if st[j] > 0.0 { -st[j] * m_acc } else { 0.0 };
                if k == 0 {
                    a
                } else if st[j] > 0.0 {
                    a + k as f32 * st[j].ln()
                } else {
                    f32::NEG_INFINITY
                }
            })
        };
        let mut m_acc = 0.0f32;
        let mut k = 0u32;
        let mut steps = 0u32;
        // remaining optical depth to the next tentative collision, in density units
        let mut need = if st[c] > 0.0 { -(-v).ln_1p() / st[c] } else { f32::INFINITY };
        for (t0, t1, m) in self.grid.segments(o, d, t_max) {
            if !(m > 0.0) {
                continue;
            }
            let mut t = t0;
            loop {
                let room = m * (t1 - t);
                if need >= room {
                    need -= room;
                    m_acc += room;
                    break;
                }
                t += need / m;
                m_acc += need;
                let rho = self.grid.density(o + d * t);
                if unit(rng) * m < rho {
                    return DistanceSample::Scatter { t, weight: mis_weight(&logs(m_acc, k), ss, st, lambda, n) };
                }
                k += 1;
                steps += 1;
                if steps >= MAX_TRACKING_STEPS {
                    return DistanceSample::Pass { weight: SampledSpectrum::ZERO };
                }
                need = -(-unit(rng)).ln_1p() / st[c];
            }
        }
        DistanceSample::Pass { weight: mis_weight(&logs(m_acc, k), SampledSpectrum::ONE, SampledSpectrum::ONE, lambda, n) }
    }

    /// Ratio tracking over [0, t] (see the module docs); 1 for the parts outside the box.
    pub fn transmittance(&self, o: Vec3, d: Vec3, t: f32, rng: &mut impl FnMut() -> f32, lambda: &SampledWavelengths) -> SampledSpectrum {
        let live = |j: usize| lambda.pdf[j] > 0.0;
        let mut tr = SampledSpectrum::from_fn(|j| if live(j) { 1.0 } else { 0.0 });
        if !(t > 0.0) {
            return tr;
        }
        let (sa, ss) = self.coefficients(lambda);
        let st = sa + ss;
        let st_max = st.max_component();
        if !(st_max > 0.0) {
            return tr;
        }
        let ratio = st / st_max;
        let mut steps = 0u32;
        let mut segs = self.grid.segments(o, d, t);
        while let Some((t0, t1, m)) = segs.next() {
            if !(m > 0.0) {
                continue;
            }
            // the control: the super-voxel's minimum density, attenuating exactly
            let c = segs.minorant().clamp(0.0, m);
            if c > 0.0 {
                for j in 0..N_SPECTRUM {
                    tr.0[j] *= (-st[j] * c * (t1 - t0)).exp();
                }
            }
            let r = m - c;
            if !(r > 0.0) {
                continue;
            }
            let mut s = t0;
            loop {
                s += -(-unit(rng)).ln_1p() / (st_max * r);
                if !(s < t1) {
                    break;
                }
                let f = (self.grid.density(o + d * s) - c).max(0.0) / r;
                for j in 0..N_SPECTRUM {
                    tr.0[j] *= (1.0 - f * ratio[j]).max(0.0);
                }
                steps += 1;
                if tr.is_black() || !roulette(&mut tr, rng) {
                    return tr;
                }
                if steps >= MAX_TRACKING_STEPS {
                    return SampledSpectrum::ZERO;
                }
            }
        }
        tr
    }
}
