//! # tide-core
//!
//! Tide's renderer: a spectral, volumetric path tracer for water. It knows nothing of USD:
//! plain data goes in ([`scene::SceneDesc`]), images come out.

pub mod bsdf;
pub mod math;
pub mod render;
pub mod scene;
pub mod spectrum;
pub mod testing;

pub use render::{Aov, IntegratorKind, Problem, RenderError, RenderSettings, RenderStats, Renderer};
pub use scene::SceneDesc;
