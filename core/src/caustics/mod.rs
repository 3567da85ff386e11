//! Guided caustic photon mapping (Conty & Kulla 2019; Weta's water caustics): the data
//! structures the integrator calls between and during its progressive passes.
//!
//! - [`photon_map`]: spectral photons, a deterministic hashed grid, radius queries with a normal
//!   check and a disk kernel, and stochastic single-photon selection.
//! - [`light_tracing`]: photon stretches in the camera's medium connected to a pinhole camera
//!   (god rays seen directly), with equi-angular sampling.
//! - [`atlas`]: the light–object guiding atlas: one 2D table packing a rectangle per (light,
//!   caster) pair, sampled to emit photons towards casters' bounding spheres, learned from a
//!   fixed-point visibility signal.
//! - [`footprint`]: the pixel footprint (a ray cone with curvature) carried along camera paths
//!   through specular reflection and refraction, which sets the photon lookup radius.
//!
//! # One progressive pass, as the integrator drives it
//! 1. For each of N photons: `s = atlas.sample(u2)`; sample a point `x` on light `s.light` with
//!    the light's own numbers (or take its position), `e = atlas.emit_mixture(&mut s, x, u, u2')`
//!    (`atlas.emit(&s, x)` plus the defensive mixture of refit distant-light disks); trace from
//!    `e.origin` along `e.dir`, rejecting the path unless its first hit is caster `s.caster`;
//!    the emitted power is `Le · cos / (p_x · e.pdf · N)` (area lights) or `E_sun / (e.pdf · N)`
//!    (distant lights, `e.pdf` per m² of the disk); after ≥ 1 specular event store a
//!    [`photon_map::Photon`] (with `cell = s.cell`) at each non-specular receiver.
//! 2. `PhotonMap::build(photons, radius)`.
//! 3. Camera paths gather with [`photon_map::PhotonMap::sample_one`] (or `estimate`), scale the
//!    contribution by `atlas.photon_weight(camera_samples_this_pass)` (0 on the first pass,
//!    which only trains), and record the used photons' throughput into a
//!    [`atlas::VisibilityBuffer`] (`record(photon.cell, kind, value)`) from any thread.
//! 4. `atlas.end_pass(&visibility, camera_samples_this_pass)` learns the next pass's table (and
//!    refits distant lights' disks on its schedule).

pub mod atlas;
pub mod beams;
pub mod engine;
pub mod footprint;
pub mod light_tracing;
pub mod photon_map;

#[cfg(test)]
mod tests;

pub use atlas::{Atlas, AtlasConfig, AtlasError, AtlasLight, AtlasSample, CameraHint, Caster, EmissionMeasure, PairDisk, PhotonEmission, VisibilityBuffer, VisibilityKind};
pub use footprint::Footprint;
pub use photon_map::{NormalCheck, Photon, PhotonError, PhotonMap, Query, SelectedPhoton, SpectralKernel, SpectralLookup};
