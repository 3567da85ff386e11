//! # tide-core
//!
//! Tide's renderer: a spectral, volumetric path tracer for water. It knows nothing of USD:
//! plain data goes in ([`scene::SceneDesc`]), images come out.

pub mod accel;
pub mod adaptive;
pub mod bsdf;
pub mod camera;
pub mod caustics;
pub mod diffusion;
pub mod displace;
pub mod droplets;
pub mod film;
pub mod filter;
pub mod integrator;
pub mod light;
pub mod math;
pub mod medium;
pub mod noise;
pub mod ocean;
pub mod pause;
pub mod render;
pub mod sampler;
pub mod scene;
pub mod shader_graph;
pub mod sky;
pub mod spectrum;
pub mod testing;
pub mod texture;
pub mod validate;
pub mod volume;
pub mod water;
pub mod world;

pub use film::SampleFormat;
pub use pause::PauseGate;
pub use render::{Aov, AovSet, IntegratorKind, PassProgress, Problem, RenderError, RenderSettings, RenderStats, Renderer};
pub use scene::SceneDesc;
