//! The caustic photon map: compact spectral photons, a hashed grid over them built in
//! O(n log n) with a result independent of thread count and insertion order, radius queries with
//! a normal check and a disk kernel, and stochastic single-photon selection.
//!
//! # Spectral storage
//! A photon keeps the four wavelengths its light path was traced at (quantised to u16, 0.0072 nm
//! steps) and, per wavelength, its flux already divided by the wavelength's sampling density and
//! by the number of wavelengths ([`Photon::new`] does this from the path's
//! [`SampledWavelengths`]). A camera path with other wavelengths reads the photon through a
//! wavelength kernel ([`SpectralKernel`]: Epanechnikov, 50 nm radius by default), renormalised
//! over [`LAMBDA_MIN`, `LAMBDA_MAX`] so that the kernel's weights integrate to one everywhere:
//! `Φ̂(λc) = Σ_k K(λc, λk) · flux_k`, whose expectation is the photon spectrum smoothed by the
//! kernel (exact for constant spectra everywhere and for linear ones away from the range ends).
//! All 16 (camera, photon) wavelength pairs take part, each photon wavelength with weight 1/4,
//! which is the balance heuristic over the four equally likely rotations. Paths whose secondary
//! wavelengths were dropped (dispersion) store zero flux there and four times the hero's.
//!
//! # Queries
//! [`Query`] holds the shading point, its normal (oriented towards the side being shaded), the
//! radius and a [`NormalCheck`]. Photons store their surface normal flipped to the side they
//! arrived from, so [`NormalCheck::SameSide`] (`n·n_p ≥ cos_min`) rejects photons from the other
//! side of a thin wall or a single-sided sheet; [`NormalCheck::EitherSide`] (`|n·n_p| ≥ cos_min`)
//! only rejects creases and suits translucent receivers lit from behind.
//! The kernel is the disk kernel `1/(πr²)` over photons within 3D distance `r`.
//!
//! - [`PhotonMap::for_each_in_radius`]: every photon within `r`, with its kernel weight
//!   (no allocation).
//! - [`PhotonMap::estimate`]: the full kernel estimate `Σ K · Φ̂(λc)` (flux per area, the
//!   irradiance arriving at the point, before any BSDF).
//! - [`PhotonMap::sample_one`]: one photon chosen with probability ∝ kernel × energy (sum of its
//!   flux); the estimator is `f(wo, wi_p) · kernel · Φ̂_p(λc) / prob`, unbiased for the full
//!   kernel estimate, so residual error shows as pixel noise, not blotches.
//!
//! # Sizes
//! A photon takes [`BYTES_PER_PHOTON`] = 48 bytes; the grid adds at most 8 bytes per photon
//! (one u32 bucket start for each of ≤ 2n buckets). A pass holds at most
//! [`MAX_PHOTONS_PER_PASS`] photons (2^26, ≈ 3.4 GiB with the grid);
//! [`PhotonMap::max_photons_for_memory`] turns a memory budget into a photon count.

use std::cmp::Ordering;
use std::fmt;

use glam::Vec3;
use rayon::prelude::*;

use crate::spectrum::{SampledSpectrum, SampledWavelengths, LAMBDA_MAX, LAMBDA_MIN, N_SPECTRUM};

/// Most photons one map (one pass) may hold: indices and bucket starts are u32.
pub const MAX_PHOTONS_PER_PASS: usize = 1 << 26;
/// Default radius of the wavelength kernel (nm).
pub const DEFAULT_SPECTRAL_RADIUS_NM: f32 = 50.0;
/// Memory of one stored photon.
pub const BYTES_PER_PHOTON: usize = std::mem::size_of::<Photon>();
/// Upper bound of the grid's memory per photon (u32 bucket starts, ≤ 2 buckets per photon).
pub const GRID_BYTES_PER_PHOTON: usize = 8;

const LAMBDA_STEP: f32 = (LAMBDA_MAX - LAMBDA_MIN) / 65535.0;

/// What is wrong with a photon or a map's input.
#[derive(Clone, Debug, PartialEq)]
pub enum PhotonError {
    /// The position is not finite.
    Position,
    /// The incoming direction is zero or not finite.
    Direction,
    /// The surface normal is zero or not finite.
    Normal,
    /// A power value is negative or not finite.
    Power,
    /// A wavelength lies outside [LAMBDA_MIN, LAMBDA_MAX] or is not finite.
    Wavelength,
    /// The grid's cell size is not a positive finite number.
    CellSize(f32),
    /// More photons than [`MAX_PHOTONS_PER_PASS`] (or the configured bound).
    TooManyPhotons { count: usize, max: usize },
    /// The spectral kernel's radius is not a positive finite number.
    SpectralRadius(f32),
}

impl fmt::Display for PhotonError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PhotonError::Position => write!(f, "photon position is not finite"),
            PhotonError::Direction => write!(f, "photon incoming direction is zero or not finite"),
            PhotonError::Normal => write!(f, "photon normal is zero or not finite"),
            PhotonError::Power => write!(f, "photon power is negative or not finite"),
            PhotonError::Wavelength => write!(f, "photon wavelength outside [{LAMBDA_MIN}, {LAMBDA_MAX}] nm or not finite"),
            PhotonError::CellSize(c) => write!(f, "photon map cell size {c} is not a positive finite number"),
            PhotonError::TooManyPhotons { count, max } => write!(f, "{count} photons exceed the bound of {max} per pass"),
            PhotonError::SpectralRadius(r) => write!(f, "spectral kernel radius {r} nm is not a positive finite number"),
        }
    }
}

impl std::error::Error for PhotonError {}

/// A photon stored where a caustic light path met a non-specular receiver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Photon {
    /// Where the photon landed.
    pub position: Vec3,
    /// Flux per wavelength, divided by that wavelength's sampling density and by N_SPECTRUM.
    flux: [f32; N_SPECTRUM],
    /// The path's wavelengths, quantised over [LAMBDA_MIN, LAMBDA_MAX].
    lambda_q: [u16; N_SPECTRUM],
    /// Octahedral unit direction towards where the photon came from.
    wi_oct: u32,
    /// Octahedral surface normal, on the side the photon arrived from.
    n_oct: u32,
    /// The guiding-atlas cell the photon's light path was emitted from (for the visibility
    /// signal), or `u32::MAX` for none.
    pub cell: u32,
}

impl Photon {
    /// A photon at `position` whose light path arrived from direction `wi` (unit or not;
    /// pointing away from the surface, towards where the light came from), on a surface with
    /// normal `normal` (either orientation: it is stored flipped to `wi`'s side). `power` is the
    /// path's flux at `lambda`'s wavelengths with the pass's 1/N_photons applied, not yet divided
    /// by the wavelength densities. `cell` is the atlas cell it was emitted from.
    pub fn new(
        position: Vec3,
        wi: Vec3,
        normal: Vec3,
        power: SampledSpectrum,
        lambda: &SampledWavelengths,
        cell: u32,
    ) -> Result<Photon, PhotonError> {
        if !position.is_finite() {
            return Err(PhotonError::Position);
        }
        let wi = wi.try_normalize().ok_or(PhotonError::Direction)?;
        let n = normal.try_normalize().ok_or(PhotonError::Normal)?;
        let n = if n.dot(wi) < 0.0 { -n } else { n };
        let mut flux = [0f32; N_SPECTRUM];
        let mut lambda_q = [0u16; N_SPECTRUM];
        for k in 0..N_SPECTRUM {
            let p = power.0[k];
            if !(p.is_finite() && p >= 0.0) {
                return Err(PhotonError::Power);
            }
            let l = lambda.lambda[k];
            if !(l.is_finite() && (LAMBDA_MIN..=LAMBDA_MAX).contains(&l)) {
                return Err(PhotonError::Wavelength);
            }
            lambda_q[k] = ((l - LAMBDA_MIN) / LAMBDA_STEP).round().clamp(0.0, 65535.0) as u16;
            let pdf = lambda.pdf[k];
            flux[k] = if pdf > 0.0 && pdf.is_finite() { p / (pdf * N_SPECTRUM as f32) } else { 0.0 };
            if !flux[k].is_finite() {
                return Err(PhotonError::Power);
            }
        }
        Ok(Photon { position, flux, lambda_q, wi_oct: oct_encode(wi), n_oct: oct_encode(n), cell })
    }

    /// Unit direction towards where the photon came from.
    #[inline]
    pub fn wi(&self) -> Vec3 {
        oct_decode(self.wi_oct)
    }

    /// Unit surface normal on the side the photon arrived from.
    #[inline]
    pub fn normal(&self) -> Vec3 {
        oct_decode(self.n_oct)
    }

    /// The path's wavelengths (nm).
    #[inline]
    pub fn lambda(&self) -> [f32; N_SPECTRUM] {
        self.lambda_q.map(|q| LAMBDA_MIN + q as f32 * LAMBDA_STEP)
    }

    /// Stored flux per wavelength (already divided by density and wavelength count).
    #[inline]
    pub fn flux(&self) -> [f32; N_SPECTRUM] {
        self.flux
    }

    /// Multiplies the stored flux by `k`.
    pub fn scale_flux(&mut self, k: f32) {
        for f in &mut self.flux {
            *f *= k;
        }
    }

    /// Scalar energy used for stochastic selection: the sum of the stored flux.
    #[inline]
    pub fn energy(&self) -> f32 {
        self.flux.iter().sum()
    }

    /// The photon's spectral flux read at a camera path's wavelengths.
    #[inline]
    pub fn spectral_flux(&self, kernel: &SpectralLookup) -> SampledSpectrum {
        let lp = self.lambda();
        SampledSpectrum::from_fn(|i| {
            let lc = kernel.lambda[i];
            let mut s = 0.0;
            for (&l, &f) in lp.iter().zip(&self.flux) {
                if f != 0.0 {
                    s += kernel.kernel.eval(lc - l) * f;
                }
            }
            s * kernel.inv_norm[i]
        })
    }

    fn sort_key(&self, bucket: u32) -> [u32; 13] {
        let p = self.position;
        [
            bucket,
            p.x.to_bits(),
            p.y.to_bits(),
            p.z.to_bits(),
            self.flux[0].to_bits(),
            self.flux[1].to_bits(),
            self.flux[2].to_bits(),
            self.flux[3].to_bits(),
            (self.lambda_q[0] as u32) << 16 | self.lambda_q[1] as u32,
            (self.lambda_q[2] as u32) << 16 | self.lambda_q[3] as u32,
            self.wi_oct,
            self.n_oct,
            self.cell,
        ]
    }
}

/// Epanechnikov kernel over wavelength, `K(x) = 3/(4h) (1 − (x/h)²)` for `|x| < h`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpectralKernel {
    radius: f32,
    inv_radius: f32,
}

impl Default for SpectralKernel {
    fn default() -> Self {
        SpectralKernel { radius: DEFAULT_SPECTRAL_RADIUS_NM, inv_radius: 1.0 / DEFAULT_SPECTRAL_RADIUS_NM }
    }
}

impl SpectralKernel {
    pub fn new(radius_nm: f32) -> Result<SpectralKernel, PhotonError> {
        if !(radius_nm.is_finite() && radius_nm > 0.0) {
            return Err(PhotonError::SpectralRadius(radius_nm));
        }
        Ok(SpectralKernel { radius: radius_nm, inv_radius: 1.0 / radius_nm })
    }

    pub fn radius(&self) -> f32 {
        self.radius
    }

    #[inline]
    pub fn eval(&self, dl: f32) -> f32 {
        let t = dl * self.inv_radius;
        if t.abs() < 1.0 {
            0.75 * self.inv_radius * (1.0 - t * t)
        } else {
            0.0
        }
    }

    /// ∫ K(λc − λ) dλ over [LAMBDA_MIN, LAMBDA_MAX].
    pub fn mass_in_range(&self, lc: f32) -> f32 {
        let cdf = |t: f32| {
            let t = t.clamp(-1.0, 1.0);
            0.5 + 0.75 * t - 0.25 * t * t * t
        };
        cdf((lc - LAMBDA_MIN) * self.inv_radius) - cdf((lc - LAMBDA_MAX) * self.inv_radius)
    }

    /// Prepares reading photons at a camera path's wavelengths (once per shading point).
    pub fn at(&self, lambda: &SampledWavelengths) -> SpectralLookup {
        let inv_norm = lambda.lambda.map(|l| {
            let m = self.mass_in_range(l);
            if m > 0.0 {
                1.0 / m
            } else {
                0.0
            }
        });
        SpectralLookup { kernel: *self, lambda: lambda.lambda, inv_norm }
    }
}

/// A [`SpectralKernel`] bound to a camera path's wavelengths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpectralLookup {
    kernel: SpectralKernel,
    lambda: [f32; N_SPECTRUM],
    inv_norm: [f32; N_SPECTRUM],
}

/// Which photons' normals are compatible with the shading point's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NormalCheck {
    /// Accept every photon within the radius.
    None,
    /// `n · n_p ≥ cos_min`: the photon arrived on the side being shaded (opaque receivers).
    SameSide { cos_min: f32 },
    /// `|n · n_p| ≥ cos_min`: either side (translucent receivers).
    EitherSide { cos_min: f32 },
}

impl NormalCheck {
    #[inline]
    fn accepts(&self, n: Vec3, np: Vec3) -> bool {
        match *self {
            NormalCheck::None => true,
            NormalCheck::SameSide { cos_min } => n.dot(np) >= cos_min,
            NormalCheck::EitherSide { cos_min } => n.dot(np).abs() >= cos_min,
        }
    }
}

/// A photon lookup around a shading point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Query {
    pub position: Vec3,
    /// Unit normal oriented towards the side being shaded.
    pub normal: Vec3,
    /// Gather radius; any positive value (cells beyond the grid's are visited as needed).
    pub radius: f32,
    pub normal_check: NormalCheck,
}

/// The photon chosen by [`PhotonMap::sample_one`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelectedPhoton {
    pub photon: Photon,
    /// Its kernel weight `1/(πr²)`.
    pub kernel: f32,
    /// The probability it was chosen with.
    pub prob: f32,
}

/// Photons of one pass in a hashed uniform grid.
#[derive(Clone, Debug)]
pub struct PhotonMap {
    /// Sorted by bucket, then by their bits: the order depends on nothing but the photon set.
    photons: Vec<Photon>,
    /// `bucket_start[b]..bucket_start[b + 1]` are bucket b's photons.
    bucket_start: Vec<u32>,
    cell_size: f32,
    inv_cell: f32,
    mask: u32,
}

#[inline]
fn cell_coord(p: Vec3, inv_cell: f32) -> [i32; 3] {
    // `as` saturates: far-off photons share the outermost cells, which only costs speed
    [floor_i32(p.x * inv_cell), floor_i32(p.y * inv_cell), floor_i32(p.z * inv_cell)]
}

/// `x.floor() as i32` (saturating, NaN to 0) without `floorf`, a library call on x86-64
/// without SSE4.1: truncate, then step down where that rounded up.
#[inline(always)]
fn floor_i32(x: f32) -> i32 {
    let i = x as i32;
    if (i as f32) > x {
        i.saturating_sub(1)
    } else {
        i
    }
}

#[inline]
fn hash_cell(c: [i32; 3], mask: u32) -> u32 {
    let h = (c[0] as u32).wrapping_mul(0x8da6_b343) ^ (c[1] as u32).wrapping_mul(0xd816_3841) ^ (c[2] as u32).wrapping_mul(0xcb1a_b31f);
    (h ^ (h >> 15)).wrapping_mul(0x2c1b_3c6d) & mask
}

impl PhotonMap {
    /// Builds the grid with cells of `cell_size` (the usual lookup radius). The photons may come
    /// in any order (e.g. from parallel tracing): they are sorted into a canonical order, so the
    /// map, and every query result, is identical for any thread count.
    pub fn build(photons: Vec<Photon>, cell_size: f32) -> Result<PhotonMap, PhotonError> {
        Self::build_bounded(photons, cell_size, MAX_PHOTONS_PER_PASS)
    }

    /// As [`PhotonMap::build`] with a smaller bound on the photon count.
    pub fn build_bounded(photons: Vec<Photon>, cell_size: f32, max_photons: usize) -> Result<PhotonMap, PhotonError> {
        if !(cell_size.is_finite() && cell_size > 0.0 && (1.0 / cell_size).is_finite()) {
            return Err(PhotonError::CellSize(cell_size));
        }
        let max = max_photons.min(MAX_PHOTONS_PER_PASS);
        if photons.len() > max {
            return Err(PhotonError::TooManyPhotons { count: photons.len(), max });
        }
        if photons.iter().any(|p| !p.position.is_finite()) {
            return Err(PhotonError::Position);
        }
        let inv_cell = 1.0 / cell_size;
        let n_buckets = photons.len().max(1).next_power_of_two();
        let mask = (n_buckets - 1) as u32;
        let mut keyed: Vec<([u32; 13], Photon)> = photons
            .into_par_iter()
            .map(|p| (p.sort_key(hash_cell(cell_coord(p.position, inv_cell), mask)), p))
            .collect();
        // total order on the photon's bits: equal keys are identical photons
        keyed.par_sort_unstable_by(|a, b| a.0.cmp(&b.0));
        let mut bucket_start = vec![0u32; n_buckets + 1];
        for (k, _) in &keyed {
            bucket_start[k[0] as usize + 1] += 1;
        }
        for b in 0..n_buckets {
            bucket_start[b + 1] += bucket_start[b];
        }
        let photons = keyed.into_iter().map(|(_, p)| p).collect();
        Ok(PhotonMap { photons, bucket_start, cell_size, inv_cell, mask })
    }

    /// Photons that fit in `bytes` of memory, map and grid included (capped at the per-pass bound).
    pub fn max_photons_for_memory(bytes: usize) -> usize {
        (bytes / (BYTES_PER_PHOTON + GRID_BYTES_PER_PHOTON)).min(MAX_PHOTONS_PER_PASS)
    }

    pub fn len(&self) -> usize {
        self.photons.len()
    }

    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }

    pub fn cell_size(&self) -> f32 {
        self.cell_size
    }

    /// The photons in the map's canonical order.
    pub fn photons(&self) -> &[Photon] {
        &self.photons
    }

    /// Bytes held by the map (photons and grid).
    pub fn memory_bytes(&self) -> usize {
        self.photons.capacity() * BYTES_PER_PHOTON + self.bucket_start.capacity() * 4 + std::mem::size_of::<Self>()
    }

    /// Calls `f(photon, kernel_weight)` for every photon within `q.radius` of `q.position` that
    /// passes the normal check, in the map's canonical order. Invalid queries (non-finite
    /// position or radius, radius ≤ 0) visit nothing.
    #[inline]
    pub fn for_each_in_radius(&self, q: &Query, mut f: impl FnMut(&Photon, f32)) {
        if self.photons.is_empty() || !(q.radius > 0.0 && q.radius.is_finite()) || !q.position.is_finite() {
            return;
        }
        let r2 = q.radius * q.radius;
        let kernel = 1.0 / (std::f32::consts::PI * r2);
        let within = |p: &Photon| p.position.distance_squared(q.position) <= r2;
        // a photon within the radius
        let mut visit = |p: &Photon| {
            if q.normal_check.accepts(q.normal, p.normal()) {
                f(p, kernel);
            }
        };
        let lo = cell_coord(q.position - Vec3::splat(q.radius), self.inv_cell);
        let hi = cell_coord(q.position + Vec3::splat(q.radius), self.inv_cell);
        let span = |a: i32, b: i32| (b as i64 - a as i64 + 1) as u64;
        let n_cells = span(lo[0], hi[0]).saturating_mul(span(lo[1], hi[1])).saturating_mul(span(lo[2], hi[2]));
        if n_cells >= self.bucket_start.len() as u64 {
            // a radius far beyond the cell size: scanning everything is cheaper
            self.photons.iter().filter(|p| within(p)).for_each(visit);
            return;
        }
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    let c = [x, y, z];
                    let b = hash_cell(c, self.mask) as usize;
                    let range = self.bucket_start[b] as usize..self.bucket_start[b + 1] as usize;
                    for p in &self.photons[range] {
                        // buckets are shared by colliding cells: visit each photon from its own
                        // cell only (tested after the cheaper distance test)
                        if within(p) && cell_coord(p.position, self.inv_cell) == c {
                            visit(p);
                        }
                    }
                }
            }
        }
    }

    /// Photons in the grid bucket of `p`'s cell: an upper bound on the photons within one
    /// cell of `p` (buckets may hold colliding cells), a local density estimate for lookups.
    #[inline]
    pub fn bucket_count(&self, p: Vec3) -> usize {
        if self.photons.is_empty() || !p.is_finite() {
            return 0;
        }
        let b = hash_cell(cell_coord(p, self.inv_cell), self.mask) as usize;
        (self.bucket_start[b + 1] - self.bucket_start[b]) as usize
    }

    /// Full kernel estimate `Σ_p K · Φ̂_p(λc)`: the flux per area arriving at the point, at the
    /// camera path's wavelengths.
    pub fn estimate(&self, q: &Query, lookup: &SpectralLookup) -> SampledSpectrum {
        let mut sum = SampledSpectrum::ZERO;
        self.for_each_in_radius(q, |p, k| sum += p.spectral_flux(lookup) * k);
        sum
    }

    /// Chooses one photon within the query with probability ∝ kernel × [`Photon::energy`], from
    /// one uniform number `u` in [0, 1). None when no photon with energy is in reach.
    pub fn sample_one(&self, q: &Query, u: f32) -> Option<SelectedPhoton> {
        let mut total = 0.0f32;
        self.for_each_in_radius(q, |p, k| total += k * p.energy());
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let target = u.clamp(0.0, 1.0) * total;
        let mut acc = 0.0f32;
        let mut chosen: Option<(Photon, f32, f32)> = None;
        let mut done = false;
        // same visiting order and summation as above, so `acc` ends at `total`
        self.for_each_in_radius(q, |p, k| {
            if done {
                return;
            }
            let w = k * p.energy();
            if w > 0.0 {
                chosen = Some((*p, k, w));
                acc += w;
                if acc > target {
                    done = true;
                }
            }
        });
        chosen.map(|(photon, kernel, w)| SelectedPhoton { photon, kernel, prob: w / total })
    }

    /// One-photon estimate of [`PhotonMap::estimate`] (zero when no photon is in reach).
    pub fn estimate_one(&self, q: &Query, lookup: &SpectralLookup, u: f32) -> SampledSpectrum {
        match self.sample_one(q, u) {
            Some(s) => s.photon.spectral_flux(lookup) * (s.kernel / s.prob),
            None => SampledSpectrum::ZERO,
        }
    }
}

impl PartialEq for PhotonMap {
    fn eq(&self, o: &Self) -> bool {
        self.cell_size.to_bits() == o.cell_size.to_bits()
            && self.bucket_start == o.bucket_start
            && self.photons.len() == o.photons.len()
            && self
                .photons
                .iter()
                .zip(&o.photons)
                .all(|(a, b)| a.sort_key(0).cmp(&b.sort_key(0)) == Ordering::Equal)
    }
}

/// Octahedral encoding of a unit vector in 2 × 16 bits.
fn oct_encode(v: Vec3) -> u32 {
    let e = crate::math::oct_encode(v);
    let q = |t: f32| ((t.clamp(-1.0, 1.0) * 0.5 + 0.5) * 65535.0).round() as u32;
    q(e.x) << 16 | q(e.y)
}

fn oct_decode(e: u32) -> Vec3 {
    let d = |q: u32| (q as f32 / 65535.0) * 2.0 - 1.0;
    crate::math::oct_decode(glam::Vec2::new(d(e >> 16), d(e & 0xffff)))
}

#[cfg(test)]
mod floor_tests {
    use super::floor_i32;

    #[test]
    fn floor_without_floorf_is_floor_as_i32() {
        let mut xs = vec![0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 2.999_999_8, -2.999_999_8, 1e-30, -1e-30, 8_388_607.5, -8_388_607.5];
        xs.extend([2.1e9, -2.1e9, 3e9, -3e9, f32::MAX, f32::MIN, f32::INFINITY, f32::NEG_INFINITY, f32::NAN]);
        // every 2^-8 step over [-40, 40], and neighbours of whole numbers
        xs.extend((-10240..=10240).map(|k| k as f32 / 256.0));
        xs.extend((-40..=40).flat_map(|k| [f32::from_bits((k as f32).to_bits().wrapping_sub(1)), f32::from_bits((k as f32).to_bits() + 1)]));
        for x in xs {
            assert_eq!(floor_i32(x), x.floor() as i32, "x = {x:e}");
        }
    }
}
