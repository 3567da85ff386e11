//! `tide-bridge`: the boundary between Tide's C++ Hydra-style layer (`cpp-bridge/cpp`,
//! `cpp-bridge/include/tide`) and the Rust render delegate.
//!
//! The C++ prims (`tide::Mesh`, `tide::Material`, ...) pull values from a `tide::SceneSource`
//! during `Sync` and forward them here through the `cxx` bridge below. Every function C++ may
//! call catches Rust panics and returns a `Result`; `cxx` turns an `Err` into a C++ exception
//! that the C++ layer turns into a problem or a Python exception, never an abort.
//!
//! With the `python` feature the cdylib also exports `PyInit__tide`, so the library copied to
//! `cpp-bridge/python/tide/_tide.so` is the Python module `tide._tide`.

mod backend;

pub use backend::{Delegate, Pass, TexelBuffer};

use std::panic::{catch_unwind, AssertUnwindSafe};

/// Runs `f`, turning a panic into an error message so that no unwind reaches C++.
pub(crate) fn guard<T>(what: &str, f: impl FnOnce() -> Result<T, String>) -> Result<T, String> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(payload) => {
            let msg = if let Some(s) = payload.downcast_ref::<&str>() {
                (*s).to_string()
            } else if let Some(s) = payload.downcast_ref::<String>() {
                s.clone()
            } else {
                "unknown panic".to_string()
            };
            Err(format!("internal error in {what}: {msg}"))
        }
    }
}

#[cxx::bridge(namespace = "tide::rs")]
pub mod ffi {
    /// A problem found in the input: which prim, which attribute, what is wrong.
    #[derive(Clone, Debug, PartialEq, Eq)]
    pub struct ProblemRow {
        pub prim: String,
        pub attribute: String,
        pub message: String,
    }

    /// A copy of a render buffer's (or a texture's) pixels, row-major from the top row.
    #[derive(Clone, Debug, Default)]
    pub struct MappedBuffer {
        pub width: u32,
        pub height: u32,
        pub channels: u32,
        pub pixels: Vec<f32>,
    }

    /// An AOV (UsdRenderVar `sourceName`) rendered into a render buffer prim.
    #[derive(Clone, Debug)]
    pub struct AovBinding {
        pub aov: String,
        pub buffer: String,
        /// What the buffer's pixels hold until a pass publishes into it, a value per channel
        /// (Hydra's `clearValue`; ids in int32 buffers as whole numbers); empty: zeros.
        pub clear: Vec<f64>,
    }

    /// A string pair (a header key and value, ...).
    #[derive(Clone, Debug)]
    pub struct StringPair {
        pub first: String,
        pub second: String,
    }

    /// One AOV of an EXR file: its name (the RenderVar's), its AOV (`sourceName`) and the
    /// RenderVar's `dataType` (a half type stores halves; empty: 32-bit float).
    #[derive(Clone, Debug)]
    pub struct ExrLayer {
        pub name: String,
        pub aov: String,
        pub data_type: String,
    }

    extern "Rust" {
        /// The Rust render delegate (prim store, scene conversion, render passes, buffers).
        type Delegate;
        /// A progressive render pass running on a background thread.
        type Pass;

        /// A texture's values as its file stores them, filled by the reader a band at a time.
        type TexelBuffer;

        fn new_delegate() -> Result<Box<Delegate>>;
        /// Channels of a Hydra AOV as Tide renders it (its name an HdAovTokens one or a Tide
        /// `sourceName`); 0 for one Tide does not render.
        fn hydra_aov_channels(name: &str) -> u32;
        /// An empty buffer of `total` values of one kind (0: bytes, read as byte / 255; 1:
        /// 16-bit integers, code / 65535; 2: half floats' bits; 3: floats), their memory reserved
        /// (and taken as the values are written). Err when it cannot be.
        fn new_texel_buffer(kind: u8, total: usize) -> Result<Box<TexelBuffer>>;
        /// `values` more values (zero) at the end, as the bytes the reader writes them into.
        fn grow(self: &mut TexelBuffer, values: usize) -> Result<&mut [u8]>;
        fn create_prim(self: &Delegate, type_id: &str, path: &str) -> Result<bool>;
        fn destroy_prim(self: &Delegate, path: &str) -> Result<bool>;

        fn set_bool(self: &Delegate, path: &str, key: &str, v: bool, has_time: bool, time: f64) -> Result<()>;
        fn set_int(self: &Delegate, path: &str, key: &str, v: i64, has_time: bool, time: f64) -> Result<()>;
        fn set_float(self: &Delegate, path: &str, key: &str, v: f64, has_time: bool, time: f64) -> Result<()>;
        /// `kind`: 0 token, 1 string, 2 asset (resolved path), 3 path.
        fn set_text(self: &Delegate, path: &str, key: &str, kind: u8, v: &str, has_time: bool, time: f64) -> Result<()>;
        fn set_paths(self: &Delegate, path: &str, key: &str, v: &Vec<String>, has_time: bool, time: f64) -> Result<()>;
        fn set_floats(self: &Delegate, path: &str, key: &str, v: &[f32], tuple: u32, has_time: bool, time: f64) -> Result<()>;
        fn set_doubles(self: &Delegate, path: &str, key: &str, v: &[f64], tuple: u32, has_time: bool, time: f64) -> Result<()>;
        fn set_ints(self: &Delegate, path: &str, key: &str, v: &[i32], has_time: bool, time: f64) -> Result<()>;
        /// 16 values, USD's row-major row-vector convention.
        fn set_matrix(self: &Delegate, path: &str, key: &str, v: &[f64], has_time: bool, time: f64) -> Result<()>;
        /// `kind` 'f' (floats), 'd' (doubles, stored as floats), 'i' (ints).
        fn set_primvar(
            self: &Delegate,
            path: &str,
            name: &str,
            interpolation: &str,
            kind: u8,
            floats: &[f32],
            ints: &[i32],
            tuple: u32,
            has_indices: bool,
            indices: &[i32],
        ) -> Result<()>;

        /// A texture's values as the file holds them (not decoded); `is_srgb`: whether
        /// `sourceColorSpace = "auto"` reads it as sRGB-encoded; `wrapmodes`: the file's wrap
        /// metadata as OpenImageIO reports it (empty if none).
        fn add_texture(self: &Delegate, asset: &str, width: u32, height: u32, channels: u32, pixels: &[f32], is_srgb: bool, wrapmodes: &str) -> Result<()>;
        /// `add_texture` for values read into a [`TexelBuffer`], handed over without a copy.
        fn add_texels(self: &Delegate, asset: &str, width: u32, height: u32, channels: u32, texels: Box<TexelBuffer>, is_srgb: bool, wrapmodes: &str) -> Result<()>;
        fn texture_failed(self: &Delegate, asset: &str, message: &str) -> Result<()>;
        /// The pixels the delegate holds for a texture (for checks; empty if none).
        fn texture_pixels(self: &Delegate, asset: &str) -> Result<MappedBuffer>;
        /// The values the delegate holds for a grid (for checks; empty if none), x fastest:
        /// `width`, `height` and `channels` are its x, y and z sizes.
        fn grid_values(self: &Delegate, asset: &str, field: &str, index: i64) -> Result<MappedBuffer>;
        /// A volume's grid read from `asset` (the `index`-th grid named `field`): `dims` (3)
        /// values x fastest, `index_to_object` a USD-style matrix (16, row-major row vectors).
        /// `values`: a buffer of floats, handed over without a copy.
        fn add_grid(self: &Delegate, asset: &str, field: &str, index: i64, dims: &[u32], coords: &[u32], values: Box<TexelBuffer>, index_to_object: &[f64]) -> Result<bool>;
        fn grid_failed(self: &Delegate, asset: &str, field: &str, index: i64, message: &str) -> Result<()>;
        /// Whether the delegate holds that grid (loaded or failed).
        fn has_grid(self: &Delegate, asset: &str, field: &str, index: i64) -> Result<bool>;

        fn commit_resources(self: &Delegate) -> Result<Vec<ProblemRow>>;
        /// Commits, then prepares the scene as a render would (validation, world build)
        /// without rendering: the problems of both.
        fn check_render(self: &Delegate) -> Result<Vec<ProblemRow>>;
        fn last_synced(self: &Delegate) -> Result<Vec<String>>;
        /// Background rendering (HdRenderDelegate's Pause / Resume / Stop / Restart): paused,
        /// a render waits where it is and goes on from there; stopped, it ends and executions
        /// start nothing until restarted.
        fn pause_render(self: &Delegate) -> Result<()>;
        fn resume_render(self: &Delegate) -> Result<()>;
        fn stop_render(self: &Delegate, blocking: bool) -> Result<bool>;
        fn restart_render(self: &Delegate) -> Result<()>;
        fn render_paused(self: &Delegate) -> Result<bool>;
        fn render_stopped(self: &Delegate) -> Result<bool>;
        fn map_buffer(self: &Delegate, path: &str) -> Result<MappedBuffer>;
        /// A render buffer's dimensions (`pixels` left empty).
        fn buffer_shape(self: &Delegate, path: &str) -> Result<MappedBuffer>;
        /// Copies a render buffer's pixels into `out` (the reader's own storage) where it holds
        /// exactly width × height × channels floats of the buffer's present shape; false (and
        /// `out` untouched) when the shape changed since it was asked.
        fn read_buffer(self: &Delegate, path: &str, out: &mut [f32]) -> Result<bool>;
        fn write_exr(self: &Delegate, path: &str, layers: &Vec<ExrLayer>, header: &Vec<StringPair>) -> Result<()>;

        fn create_render_pass(self: &Delegate) -> Result<Box<Pass>>;
        /// `projection`: the host's projection matrix (16 doubles, GfMatrix4d's order) framing the
        /// image, or none.
        fn execute(self: &Pass, camera: &str, bindings: &Vec<AovBinding>, settings: &str, hydra: bool, projection: &[f64], render_tags: &Vec<String>) -> Result<()>;
        fn is_converged(self: &Pass) -> Result<bool>;
        fn progress(self: &Pass) -> Result<f64>;
        /// The render's figures after its last finished pass, as `key=value` strings.
        fn summary(self: &Pass) -> Result<Vec<String>>;
        /// Waits up to `timeout_s` seconds (negative: forever); true once converged or stopped.
        fn wait(self: &Pass, timeout_s: f64) -> Result<bool>;
        fn cancel(self: &Pass) -> Result<()>;
        /// The error that stopped the pass, or "".
        fn error(self: &Pass) -> Result<String>;
    }

    unsafe extern "C++" {
        include!("tide-bridge/include/tide/selfTest.h");

        /// Runs the C++ layer's own checks; returns the failures, one a line ("" = all passed).
        fn RunSelfTests(scratch_dir: &str) -> String;
    }
}

fn new_texel_buffer(kind: u8, total: usize) -> Result<Box<TexelBuffer>, String> {
    guard("new_texel_buffer", || TexelBuffer::new(kind, total).map(Box::new))
}

fn hydra_aov_channels(name: &str) -> u32 {
    tide_delegate::render_pass::Binding::hydra(name).map_or(0, |b| b.aov.channels() as u32)
}

fn new_delegate() -> Result<Box<Delegate>, String> {
    guard("new_delegate", || Ok(Box::new(Delegate::new())))
}

#[cfg(feature = "python")]
mod python {
    extern "C" {
        fn tide_python_module_init() -> *mut std::ffi::c_void;
    }

    /// The CPython entry point of `tide._tide` (the module itself is written in C++).
    #[no_mangle]
    pub extern "C" fn PyInit__tide() -> *mut std::ffi::c_void {
        // SAFETY: called by the interpreter with the GIL held, as the C++ init expects; the
        // C++ side catches every exception and returns null with a Python error set.
        unsafe { tide_python_module_init() }
    }
}
