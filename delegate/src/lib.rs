//! # tide-delegate
//!
//! The Rust side of Tide's render delegate: prim state keyed by SdfPath with Hydra-like
//! create / set / dirty / sync / destroy, conversion into the core's plain-data scene
//! ([`tide_core::scene::SceneDesc`]), render passes on a background thread and render buffers.
//! The protocol is described in `README.md`.

pub mod curves;
pub mod delegate;
pub mod implicit;
pub mod lux;
pub mod material;
pub mod memo;
pub mod mesh;
pub mod ocean;
pub mod render_pass;
pub mod subdiv;
pub mod value;
pub mod volume;

pub use delegate::{Delegate, PrimClass, PrimType};
pub use render_pass::{Engine, EngineFactory, MappedBuffer, PassStatus, PassWatcher, RenderBuffer, RenderPass};
pub use tide_core::Problem;
pub use value::{Interpolation, Primvar, Value};
