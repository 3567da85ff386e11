//! # The FFT ocean surface (`TideOcean`, contract §5)
//!
//! A deep-water wind sea synthesised by Tessendorf's method: a periodic square patch of ocean
//! whose Fourier amplitudes are Gaussian with variance from a wave spectrum, evolved in time by
//! the deep-water dispersion relation and brought to the spatial domain by inverse FFTs; the
//! patch is then tiled out to the horizon as one triangle mesh.
//!
//! ## Using it
//!
//! ```
//! use tide_core::ocean::{ocean_mesh, OceanParams, OceanPatch, SpectrumKind};
//! let params = OceanParams { wind_speed: 7.0, spectrum: SpectrumKind::Jonswap, ..Default::default() };
//! params.validate().unwrap();
//! // the patch alone: heights, horizontal displacements and normals on an N×N grid
//! let patch = OceanPatch::new(&params, 12.5).unwrap();
//! let _h = patch.height(3, 4);
//! // the tiled surface (and the closed body when `depth > 0`) for the scene
//! let params = OceanParams { extent: 200.0, ..params };
//! let mesh = ocean_mesh(&params, 12.5, Some(glam::Vec3::new(0.0, 2.0, 0.0))).unwrap();
//! assert!(!mesh.indices.is_empty());
//! ```
//!
//! * [`OceanParams`] mirrors the prim's attributes (USD names in each field's doc);
//!   [`OceanParams::validate`] returns an [`OceanError`] naming the attribute at fault.
//! * [`OceanPatch::new`]`(params, time)` synthesises the patch at `time` seconds.
//! * [`ocean_mesh`]`(params, time, camera_position)` returns a [`crate::scene::MeshDesc`] in the
//!   prim's local space (Y up, mean sea level at y = 0), with per-vertex normals and uvs.
//! * [`spectrum`] holds the spectra and statistics ([`spectrum::cox_munk_mss`], spectral moments).
//!
//! ## Conventions
//!
//! * Axes: Y up; the sea surface is the XZ plane. `windDirection` φ (degrees) rotates +X about
//!   +Y (right-handed), so the wind blows towards (cos φ, 0, −sin φ); waves run downwind.
//! * Grid sample (p, q) of the patch sits at x = p·L/N, z = q·L/N before displacement.
//! * The field: η(x, t) = Σ_k h(k, t) e^{i k·x} over k = 2π(m, n)/L with m, n in
//!   (−N/2, N/2) (the Nyquist row and column and k = 0 carry nothing), h(k, t) =
//!   a(k) e^{−iωt} + conj(a(−k)) e^{iωt}, ω = √(g|k|), a(k) = (ξ₁ + iξ₂)/2 · √Ψ(k) · 2π/L with
//!   ξ standard normal from ([`OceanParams::seed`], m, n). The expected variance of η is
//!   Σ_k Ψ(k) (2π/L)², the resolved part of the spectrum; the component a(k) travels along +k.
//! * Choppiness λ moves each point horizontally by λ·D, D = Σ i k/|k| h e^{ik·x} (crests
//!   sharpen, troughs widen, as in a Gerstner wave). Normals are exact for the displaced
//!   surface: the cross product of its analytic tangents, from the FFTs of the slope and
//!   displacement-gradient spectra. Large λ with steep seas can fold the surface (a normal with
//!   y < 0), as in the reference method.
//! * Determinism: the random amplitudes are a pure function of (seed, m, n) — the same ocean on
//!   every machine and at every thread count; the spectra, FFT and twiddles use only IEEE
//!   arithmetic and `libm`, so the heights are the same bits too. Raising the resolution at a
//!   fixed patch size keeps every existing wave and adds shorter ones.
//!
//! ## What the patch resolves
//!
//! The grid holds wavelengths from L down to 2L/N, so the patch's heights carry only the part of
//! the spectrum above k = 2π/L (make L a few peak wavelengths, [`spectrum::peak_wavelength`] =
//! 0.83 U² m, to hold the energetic waves) and its slopes only the part below the Nyquist
//! wavenumber πN/L. The mean-square slope of these spectra grows like ln k without bound, and
//! measured sea slopes (Cox–Munk) include capillary waves the spectra do not describe, so the
//! geometry carries a fraction of the Cox–Munk slope variance; [`OceanPatch::subgrid_slope_variance`]
//! is the remainder, meant for the roughness of the sea-surface BSDF. The tiled mesh carries
//! less than its vertices sample (its triangles interpolate their normals, and tiles far from the
//! camera are coarser): each vertex holds the share its tile leaves to the BSDF (see `mesh`).

pub mod fft;
mod mesh;
mod patch;
pub mod rng;
pub mod spectrum;

#[cfg(test)]
mod tests;

pub use mesh::{ocean_mesh, ocean_mesh_seen, ocean_mesh_with_horizon, ocean_mesh_with_horizon_seen, tile_levels, OceanView, MAX_OCEAN_CELLS, MAX_TILES_PER_SIDE};
pub use patch::{OceanPatch, SurfacePoint};
pub use spectrum::SpectrumKind;

use std::fmt;

/// The `TideOcean` prim's attributes (contract §5). Defaults are the contract's.
#[derive(Clone, Debug, PartialEq)]
pub struct OceanParams {
    /// `windSpeed` (m/s, ≥ 0, default 5): the wind the spectrum is fully developed under.
    pub wind_speed: f32,
    /// `windDirection` (degrees about +Y from +X, default 0): where the wind blows towards.
    pub wind_direction: f32,
    /// `spectrum` (`piersonMoskowitz` | `jonswap`).
    pub spectrum: SpectrumKind,
    /// `patchSize` (m, > 0, default 64): side L of the periodic patch.
    pub patch_size: f32,
    /// `resolution` (default 256): samples N per patch side, a power of two in 8..=4096.
    pub resolution: u32,
    /// `choppiness` (0–1, default 0): scale λ of the horizontal displacement.
    pub choppiness: f32,
    /// `seed` (default 0): selects the random sea.
    pub seed: i64,
    /// `extent` (m, > 0, default 1000): the tiled surface reaches this far from the prim's
    /// origin along X and Z (to the nearest point of the patch's grid, `patchSize / resolution`;
    /// the patches are tiled to cover it and cut there).
    pub extent: f32,
    /// `depth` (m, ≥ 0, default 0): 0 is an open surface over an infinitely deep sea; otherwise
    /// the mesh is a closed body reaching down to y = −depth.
    pub depth: f32,
}

impl Default for OceanParams {
    fn default() -> Self {
        OceanParams {
            wind_speed: 5.0,
            wind_direction: 0.0,
            spectrum: SpectrumKind::PiersonMoskowitz,
            patch_size: 64.0,
            resolution: 256,
            choppiness: 0.0,
            seed: 0,
            extent: 1000.0,
            depth: 0.0,
        }
    }
}

/// A bad ocean input: which attribute (its USD name) and what is wrong with it.
#[derive(Clone, Debug, PartialEq)]
pub struct OceanError {
    pub parameter: &'static str,
    pub message: String,
}

impl fmt::Display for OceanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "TideOcean `{}`: {}", self.parameter, self.message)
    }
}

impl std::error::Error for OceanError {}

fn err(parameter: &'static str, message: String) -> OceanError {
    OceanError { parameter, message }
}

/// Largest wind speed accepted (m/s): beyond hurricane force the spectra are not meaningful.
pub const MAX_WIND_SPEED: f32 = 100.0;

impl OceanParams {
    /// Checks every attribute; the error names the first one at fault.
    pub fn validate(&self) -> Result<(), OceanError> {
        if !self.wind_speed.is_finite() || self.wind_speed < 0.0 || self.wind_speed > MAX_WIND_SPEED {
            return Err(err("windSpeed", format!("must be in [0, {MAX_WIND_SPEED}] m/s, got {}", self.wind_speed)));
        }
        if !self.wind_direction.is_finite() {
            return Err(err("windDirection", format!("must be a finite angle in degrees, got {}", self.wind_direction)));
        }
        if !self.patch_size.is_finite() || self.patch_size <= 0.0 {
            return Err(err("patchSize", format!("must be a positive length in metres, got {}", self.patch_size)));
        }
        if !self.resolution.is_power_of_two() || !(8..=4096).contains(&self.resolution) {
            return Err(err("resolution", format!("must be a power of two from 8 to 4096, got {}", self.resolution)));
        }
        if !self.choppiness.is_finite() || !(0.0..=1.0).contains(&self.choppiness) {
            return Err(err("choppiness", format!("must be in [0, 1], got {}", self.choppiness)));
        }
        if !self.extent.is_finite() || self.extent <= 0.0 {
            return Err(err("extent", format!("must be a positive distance in metres, got {}", self.extent)));
        }
        let tiles = self.tiles_per_half_side() as f64 * 2.0;
        if tiles > MAX_TILES_PER_SIDE as f64 {
            return Err(err(
                "extent",
                format!(
                    "{} m over patchSize {} m needs {tiles} patches per side, more than {MAX_TILES_PER_SIDE}",
                    self.extent, self.patch_size
                ),
            ));
        }
        if !self.depth.is_finite() || self.depth < 0.0 {
            return Err(err("depth", format!("must be 0 (open sea) or a positive depth in metres, got {}", self.depth)));
        }
        Ok(())
    }

    /// Half the side of the surface: `extent` to the nearest point of the patch's grid (at
    /// least one grid step), within the patches [`Self::tiles_per_half_side`] lays.
    pub fn half_side(&self) -> f64 {
        let (t, n) = (self.tiles_per_half_side(), self.resolution as u64);
        let delta = self.patch_size as f64 / n as f64;
        (self.rim_grid_inset() as f64).mul_add(-delta, t as f64 * self.patch_size as f64)
    }

    /// Fine-grid steps from the outermost patches' edge in to the surface's rim.
    pub(crate) fn rim_grid_inset(&self) -> u64 {
        let (t, n) = (self.tiles_per_half_side(), self.resolution as u64);
        let delta = self.patch_size as f64 / n as f64;
        let inset = ((t as f64 * self.patch_size as f64 - self.extent as f64) / delta).round();
        if inset.is_finite() && inset > 0.0 {
            (inset as u64).min(t * n - 1)
        } else {
            0
        }
    }

    /// Unit vector (x, z) the wind blows towards.
    pub fn wind_vector(&self) -> [f64; 2] {
        let phi = (self.wind_direction as f64).to_radians();
        [libm::cos(phi), -libm::sin(phi)]
    }

    /// Patches from the origin out to cover `extent` along X (and Z).
    pub fn tiles_per_half_side(&self) -> u64 {
        let t = (self.extent as f64 / self.patch_size as f64).ceil();
        if t.is_finite() && t >= 1.0 {
            t.min(u64::MAX as f64 / 4.0) as u64
        } else {
            1
        }
    }

    /// Expected mean-square slope Σ |k|² Ψ(k) Δk² of the waves a patch of these parameters
    /// resolves (without choppiness), without synthesising it: O(N²) spectrum evaluations.
    pub fn resolved_slope_variance(&self) -> f64 {
        patch::resolved_moments(self).slope_variance
    }

    /// [`spectrum::cox_munk_mss`] at `windSpeed` minus [`OceanParams::resolved_slope_variance`]
    /// (never below 0): the slope variance left to the sea-surface BSDF, as
    /// [`OceanPatch::subgrid_slope_variance`] without a patch.
    pub fn subgrid_slope_variance(&self) -> f64 {
        (spectrum::cox_munk_mss(self.wind_speed as f64) - self.resolved_slope_variance()).max(0.0)
    }

    /// Significant wave height 4√m₀ (m) of the full spectrum (not only the part a patch resolves).
    pub fn significant_wave_height(&self) -> f64 {
        spectrum::significant_wave_height(self.spectrum, self.wind_speed as f64)
    }
}
