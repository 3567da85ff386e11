//! The public rendering API: build a [`Renderer`] from a [`SceneDesc`] and settings, run
//! progressive passes, read AOVs, write EXR.

use crate::scene::SceneDesc;
use std::sync::atomic::AtomicBool;

/// A problem found in the input: which item (prim path), which attribute, what is wrong.
/// The offending item (or input) was dropped or replaced by its documented default.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Problem {
    pub item: String,
    pub attribute: String,
    pub message: String,
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}: {}", self.item, self.attribute, self.message)
    }
}

/// Which estimator renders the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum IntegratorKind {
    #[default]
    Path,
}

/// An output of the renderer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Aov {
    /// RGBA, scene-linear in the working colour space.
    Color,
    /// Camera-space distance along the view axis (Z).
    Depth,
    /// World-space shading normal of the first hit (X, Y, Z).
    Normal,
    /// Albedo of the first non-specular hit (RGB).
    Albedo,
    /// `InstanceDesc::id` of the first hit, or -1 (one channel, stored as f32).
    PrimId,
    Diffuse,
    Specular,
    Transmission,
    Volume,
    Emission,
}

impl Aov {
    pub const ALL: [Aov; 10] = [
        Aov::Color,
        Aov::Depth,
        Aov::Normal,
        Aov::Albedo,
        Aov::PrimId,
        Aov::Diffuse,
        Aov::Specular,
        Aov::Transmission,
        Aov::Volume,
        Aov::Emission,
    ];

    /// The `sourceName` of a UsdRenderVar (contract §6).
    pub fn source_name(self) -> &'static str {
        match self {
            Aov::Color => "color",
            Aov::Depth => "depth",
            Aov::Normal => "normal",
            Aov::Albedo => "albedo",
            Aov::PrimId => "primId",
            Aov::Diffuse => "tide:diffuse",
            Aov::Specular => "tide:specular",
            Aov::Transmission => "tide:transmission",
            Aov::Volume => "tide:volume",
            Aov::Emission => "tide:emission",
        }
    }

    pub fn from_source_name(name: &str) -> Option<Aov> {
        Aov::ALL.iter().copied().find(|a| a.source_name() == name)
    }

    /// Number of channels stored for this AOV.
    pub fn channels(self) -> usize {
        match self {
            Aov::Color => 4,
            Aov::Depth | Aov::PrimId => 1,
            _ => 3,
        }
    }
}

/// Settings of a render.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Target samples per pixel.
    pub spp: u32,
    pub max_depth: u32,
    pub seed: u64,
    /// Worker threads; 0 = all cores.
    pub threads: usize,
    pub pixel_aspect_ratio: f32,
    /// (xmin, ymin, xmax, ymax) in NDC, as UsdRenderSettings `dataWindowNDC`.
    pub data_window_ndc: [f32; 4],
    pub disable_motion_blur: bool,
    pub disable_depth_of_field: bool,
    /// Seconds of rendering after which progressive passes stop; 0 = none.
    pub time_budget_s: f32,
    pub integrator: IntegratorKind,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 640,
            height: 360,
            spp: 64,
            max_depth: 64,
            seed: 0,
            threads: 0,
            pixel_aspect_ratio: 1.0,
            data_window_ndc: [0.0, 0.0, 1.0, 1.0],
            disable_motion_blur: false,
            disable_depth_of_field: false,
            time_budget_s: 0.0,
            integrator: IntegratorKind::Path,
        }
    }
}

/// Why a render could not be set up at all (an unusable scene or settings).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RenderError(pub String);

impl std::fmt::Display for RenderError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}
impl std::error::Error for RenderError {}

/// Counters of a render so far.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderStats {
    pub samples_per_pixel: u32,
    pub render_seconds: f64,
    pub build_seconds: f64,
    pub samples_per_second: f64,
}

/// A prepared scene plus its film.
pub struct Renderer {
    _scene: SceneDesc,
}

impl Renderer {
    /// Validates the scene (problems are kept, see [`Renderer::problems`]) and builds the
    /// acceleration structures.
    pub fn new(scene: &SceneDesc, settings: RenderSettings) -> Result<Renderer, RenderError> {
        let _ = settings;
        Ok(Renderer { _scene: scene.clone() })
    }

    /// Problems found in the input.
    pub fn problems(&self) -> &[Problem] {
        &[]
    }

    /// Renders `spp` more samples per pixel; returns false if cancelled part way (the film
    /// then holds only whole passes).
    pub fn render_pass(&mut self, spp: u32, cancel: Option<&AtomicBool>) -> bool {
        let _ = (spp, cancel);
        todo!("integrator")
    }

    /// Samples per pixel accumulated so far.
    pub fn samples_per_pixel(&self) -> u32 {
        0
    }

    /// Resolved pixels of an AOV, row-major from the top row, `aov.channels()` per pixel.
    pub fn aov_pixels(&self, aov: Aov) -> Vec<f32> {
        let _ = aov;
        Vec::new()
    }

    /// Writes the chosen AOVs to an OpenEXR file atomically (temporary name, then rename).
    /// `header` entries are stored as string attributes.
    pub fn write_exr(&self, path: &std::path::Path, aovs: &[Aov], header: &[(String, String)]) -> std::io::Result<()> {
        let _ = (path, aovs, header);
        todo!("film")
    }

    pub fn stats(&self) -> RenderStats {
        RenderStats::default()
    }
}
