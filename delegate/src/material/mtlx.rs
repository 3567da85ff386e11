//! MaterialX networks (USD's `mtlx` render context): `standard_surface` and
//! `open_pbr_surface` as the surfaces Tide has, and the MaterialX nodes that feed their inputs.
//!
//! Both surfaces map through one table of input names ([`PbrModel`]) onto a UsdPreviewSurface:
//! base weight × base colour (diffuse), metalness, specular roughness and IOR, coat weight and
//! roughness, emission weight × emission colour (`open_pbr_surface`: `emission_luminance` ×
//! `emission_color`, as MaterialX's own graph computes it), opacity, and the normal through
//! `normalmap`; a specular weight of 0 on a non-metal leaves the diffuse alone. The layers
//! UsdPreviewSurface lacks (specular weight and colour, coat colour, IOR and anisotropy,
//! anisotropy, diffuse roughness, sheen or fuzz, thin film) ride along as [`PbrExtras`].
//! With transmission it becomes a dielectric (as TideWater: specular IOR and roughness),
//! which is what glass and water made in a DCC are; a transmission colour reached at
//! `transmission_depth` fills the body with the absorption that keeps that colour there
//! (Beer–Lambert, σa = −ln(colour) / depth), unless the material's volume output gives the
//! body its medium, and with no depth tints each crossing. A subsurface makes the surface a
//! dielectric of the specular IOR over a scattering body that the path tracer walks through
//! (σt = 1 / (radius × scale), the single-scattering albedo whose multiple-scattering albedo
//! is the subsurface colour, the anisotropy as a Henyey–Greenstein g). A partial or varying
//! transmission or subsurface blends that dielectric with the opaque stack ([`WaterBlend`]).
//! A thin wall (`thin_walled`) has no body: its base passes the transmission straight
//! through and makes the subsurface translucent ([`ThinWalledDesc`]). A transmission's
//! dispersion makes the interface's IOR follow Cauchy's formula through the specular IOR with
//! the Abbe number the model gives (Standard Surface's `transmission_dispersion` is that
//! number; OpenPBR's is `transmission_dispersion_abbe_number` / `transmission_dispersion_scale`;
//! 0 is none), rendered spectrally ([`WaterDesc::abbe`]). What the mapping cannot carry
//! (scattering in the transmission, the coat and other layers over a transmitting share) is
//! reported and left out.
//!
//! Nodes: `image` / `tiledimage` (file, default, u/vaddressmode, texcoord, uvtiling /
//! uvoffset / realworldimagesize / realworldtilesize as MaterialX's own graph applies them),
//! `geompropvalue` (a primvar, as UsdPrimvarReader), `texcoord` (the mesh's uvs), `normalmap`,
//! `constant` and `dot`, and the arithmetic of [`ARITHMETIC`] (math, `mix`, `clamp`, `remap`,
//! `smoothstep`, `luminance`, conversions, channel extraction and combination, `ifgreater`,
//! ramps and splits over the texture coordinates, which `texcoord` also gives as a value, and
//! `position` in the object's or the world's space), and MaterialX's noises and the geometric
//! `normal`, `tangent` and `bitangent` ([`PROCEDURAL`], read in `mtlx_procedural`). An
//! image's texcoord may pass through `place2d` (both operation orders) and arithmetic by
//! constants, folded into the lookup's affine transform. Arithmetic folds into a single lookup
//! where it can (a tint, a gain, an offset of a texture: its scale and bias) and otherwise
//! becomes a [`tide_core::shader_graph::Expr`] evaluated at each hit (a texture times a
//! texture, a mask mixing two layers). MaterialX's UsdPreviewSurface nodes (`ND_UsdUVTexture`,
//! ...) are read as the USD ones.

use super::mtlx_procedural::PROCEDURAL;
use super::{float_input, uv_set, Ctx, Source, WrapKey};
use glam::{Affine2, Vec2};
use tide_core::bsdf::PbrFlavour;
use tide_core::scene::{Channel, ColorInput, FloatInput, PbrExtras, PreviewSurfaceDesc, PrimvarLookup, SurfaceDesc, TexLookup, ThinWalledDesc, WaterBlend, WaterDesc};
use tide_core::shader_graph::{Binary, Expr, Unary};

/// The longest chain of MaterialX nodes read into one input.
const MAX_DEPTH: u32 = 64;
/// The most MaterialX nodes read for one material (a graph that reuses a node reads it once).
const MAX_NODES: u32 = 4096;
/// The most operations the expressions of one material's node outputs hold together. Each
/// output's expression spells out what it reads, so a node reused along many paths is
/// repeated in it (a chain of n nodes each reading the one before twice spells 2^n): past
/// this the graph is reported rather than unrolled.
const MAX_OPS: usize = 1 << 18;

/// A MaterialX node id as the USD node it stands for (MaterialX's UsdPreviewSurface library),
/// or itself.
pub(super) fn canonical_id(id: &str) -> &str {
    match id {
        "ND_UsdPreviewSurface_surfaceshader" => "UsdPreviewSurface",
        // Standard Surface 1.0.0 by its versioned name (the same node)
        "ND_standard_surface_surfaceshader_100" => "ND_standard_surface_surfaceshader",
        _ => id.strip_prefix("ND_").filter(|r| r.starts_with("Usd")).unwrap_or(id),
    }
}

/// The MaterialX node families that [`Ctx::mtlx_source`] reads: lookups, the arithmetic of
/// [`Ctx::arithmetic`], and the procedural and geometric nodes of [`PROCEDURAL`].
const LOOKUPS: [&str; 9] = ["image", "tiledimage", "geompropvalue", "texcoord", "position", "constant", "dot", "normalmap", "place2d"];
const ARITHMETIC: [&str; 38] = [
    "multiply", "add", "subtract", "divide", "min", "max", "power", "modulo", "absval", "floor", "ceil", "sqrt", "exp", "ln", "sin", "cos", "sign", "mix", "clamp",
    "invert", "remap", "smoothstep", "luminance", "convert", "extract", "separate2", "separate3", "separate4", "combine2", "combine3", "combine4", "ifgreater",
    "ifgreatereq", "ramplr", "ramptb", "ramp4", "splitlr", "splittb",
];

/// The node family of a MaterialX node id (`ND_multiply_color3FA` → `multiply`).
fn family(id: &str) -> Option<&str> {
    let name = id.strip_prefix("ND_")?.split('_').next()?;
    (LOOKUPS.contains(&name) || ARITHMETIC.contains(&name) || PROCEDURAL.contains(&name)).then_some(name)
}

/// Whether `id` is a MaterialX node this module reads.
pub(super) fn is_mtlx_node(id: &str) -> bool {
    family(id).is_some()
}

/// `source` × `mul` + `add`, per component, folded into the source where one lookup can carry
/// it: a constant, a texture's scale and bias (its fallback too), or a primvar's scale; the
/// identity leaves any source as it is. None where it cannot (a primvar's offset, a
/// single-channel texture scaled unevenly, a graph).
fn affine(source: &Source, mul: [f32; 4], add: [f32; 4]) -> Option<Source> {
    if mul == [1.0; 4] && add == [0.0; 4] {
        return Some(source.clone());
    }
    let map = |v: [f32; 4]| -> [f32; 4] { std::array::from_fn(|k| v[k] * mul[k] + add[k]) };
    let even = |v: [f32; 4]| v[..3].iter().all(|x| *x == v[0]);
    Some(match source.clone() {
        Source::Fallback(v) => Source::Fallback(map(v)),
        Source::Texture(mut t) if t.channel == Channel::Rgb || (even(mul) && even(add)) => {
            t.tex_scale = std::array::from_fn(|k| t.tex_scale[k] * mul[k]);
            t.bias = map(t.bias);
            t.fallback = map(t.fallback);
            Source::Texture(t)
        }
        Source::Primvar(mut l) if add == [0.0; 4] => {
            l.scale = std::array::from_fn(|k| l.scale[k] * mul[k]);
            Source::Primvar(l)
        }
        _ => return None,
    })
}

/// `outer` after an inner map of a coordinate set.
fn map(outer: Affine2, (inner, set): (Affine2, Option<PrimvarLookup>)) -> (Affine2, Option<PrimvarLookup>) {
    (outer * inner, set)
}

/// `a` × `b`: folded into one lookup where either is a constant, a graph otherwise.
fn product(a: Source, b: Source) -> Source {
    let folded = match (&a, &b) {
        (_, Source::Fallback(c)) => affine(&a, *c, [0.0; 4]),
        (Source::Fallback(c), _) => affine(&b, *c, [0.0; 4]),
        _ => None,
    };
    folded.unwrap_or_else(|| Source::from_expr(Expr::binary(Binary::Mul, a.into_expr(), b.into_expr())))
}

/// A component index from an output name (`outr`, `outy`, ...) or a number.
fn component(name: &str) -> Option<u8> {
    match name.chars().last()? {
        'r' | 'x' => Some(0),
        'g' | 'y' => Some(1),
        'b' | 'z' => Some(2),
        'a' | 'w' => Some(3),
        _ => None,
    }
}

/// How a MaterialX PBR surface names the inputs that map onto Tide's surfaces.
pub(super) struct PbrModel {
    /// (weight, weight default, colour, colour default) of the diffuse base.
    base: (&'static str, f32, &'static str, f32),
    metalness: &'static str,
    /// (weight, colour) of the specular lobe.
    specular: (&'static str, &'static str),
    roughness: (&'static str, f32),
    /// Whose definitions the layers follow (anisotropy mapping, rough diffuse model).
    flavour: PbrFlavour,
    /// The specular anisotropy, and the turn of its direction if the model has one.
    anisotropy: (&'static str, Option<&'static str>),
    diffuse_roughness: &'static str,
    /// (weight, colour, roughness, roughness default) of the sheen.
    sheen: (&'static str, &'static str, &'static str, f32),
    /// The thin film: its weight (None: the film is there wherever it has a thickness), its
    /// thickness and default, nanometres per unit of thickness, its IOR and default.
    thin_film: (Option<&'static str>, &'static str, f32, f32, &'static str, f32),
    ior: &'static str,
    /// (weight, roughness, roughness default, colour) of the coat.
    coat: (&'static str, &'static str, f32, &'static str),
    /// The coat's IOR and its default.
    coat_ior: (&'static str, f32),
    /// The coat's anisotropy, and the turn of its direction if the model has one (read only
    /// where it is the specular's).
    coat_anisotropy: (&'static str, Option<&'static str>),
    /// The coat's darkening and saturation of the base colour, and its roughening of the
    /// specular (Standard Surface's `coat_affect_color`, `coat_affect_roughness`).
    coat_affect: Option<(&'static str, &'static str)>,
    /// OpenPBR's darkening of what lies under the coat (default 1).
    coat_darkening: Option<&'static str>,
    /// (weight, colour): emission = weight × colour.
    emission: (&'static str, &'static str),
    /// The opacity input, and whether it is a colour.
    opacity: (&'static str, bool),
    normal: &'static str,
    /// (weight, colour, depth, thin walled) of the transmission.
    transmission: (&'static str, &'static str, &'static str, &'static str),
    /// Roughness the transmission adds to the specular's, if the model has it.
    transmission_extra_roughness: Option<&'static str>,
    /// How the model gives the transmission's dispersion.
    dispersion: Dispersion,
    /// The subsurface: its weight, colour (default), radius (default) × radius scale (default)
    /// and anisotropy.
    subsurface: Subsurface,
    /// Inputs the mapping cannot carry: (input, its neutral value, what it is).
    unsupported: &'static [(&'static str, f32, &'static str)],
}

/// How a PBR surface gives its transmission's dispersion.
pub(super) enum Dispersion {
    /// The Abbe number itself (0: none), Standard Surface's.
    Abbe(&'static str),
    /// An Abbe number (and its default) divided by a scale (0: none), OpenPBR's.
    Scaled { scale: &'static str, abbe: (&'static str, f32) },
}

/// How a PBR surface names its subsurface inputs.
pub(super) struct Subsurface {
    weight: &'static str,
    color: (&'static str, f32),
    radius: (&'static str, [f32; 3]),
    scale: (&'static str, [f32; 3]),
    anisotropy: &'static str,
}

/// What fills a body whose surface asks for it: a homogeneous medium (RGB coefficients per
/// scene unit), and the attribute that asked.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Body {
    pub sigma_a: [f32; 3],
    pub sigma_s: [f32; 3],
    pub g: f32,
    pub attr: String,
}

/// The single-scattering albedo of a medium whose multiple-scattering albedo (the colour a
/// thick body of it shows) is `a`: Christensen and Burley's (2015) inversion of van de Hulst's
/// relation (0 at 0 to within 1e-5, 1 at 1).
pub(super) fn single_scattering_albedo(a: f32) -> f32 {
    let a = a.clamp(0.0, 1.0);
    let r = 4.09712 + 4.20863 * a - (9.59217 + 41.6808 * a + 17.7126 * a * a).sqrt();
    (1.0 - r * r).clamp(0.0, 1.0)
}

/// `ND_standard_surface_surfaceshader` (Autodesk Standard Surface).
pub(super) const STANDARD_SURFACE: PbrModel = PbrModel {
    // the defaults of the nodedef's version 1.0.1 (MaterialX 1.39's default version)
    base: ("base", 1.0, "base_color", 0.8),
    metalness: "metalness",
    specular: ("specular", "specular_color"),
    roughness: ("specular_roughness", 0.2),
    flavour: PbrFlavour::StandardSurface,
    anisotropy: ("specular_anisotropy", Some("specular_rotation")),
    diffuse_roughness: "diffuse_roughness",
    sheen: ("sheen", "sheen_color", "sheen_roughness", 0.3),
    thin_film: (None, "thin_film_thickness", 0.0, 1.0, "thin_film_IOR", 1.5),
    ior: "specular_IOR",
    coat: ("coat", "coat_roughness", 0.1, "coat_color"),
    coat_ior: ("coat_IOR", 1.5),
    coat_anisotropy: ("coat_anisotropy", Some("coat_rotation")),
    coat_affect: Some(("coat_affect_color", "coat_affect_roughness")),
    coat_darkening: None,
    emission: ("emission", "emission_color"),
    opacity: ("opacity", true),
    normal: "normal",
    transmission: ("transmission", "transmission_color", "transmission_depth", "thin_walled"),
    transmission_extra_roughness: Some("transmission_extra_roughness"),
    subsurface: Subsurface {
        weight: "subsurface",
        color: ("subsurface_color", 1.0),
        radius: ("subsurface_radius", [1.0; 3]),
        scale: ("subsurface_scale", [1.0; 3]),
        anisotropy: "subsurface_anisotropy",
    },
    dispersion: Dispersion::Abbe("transmission_dispersion"),
    unsupported: &[("transmission_scatter", 0.0, "scattering inside the transmission")],
};

/// `ND_open_pbr_surface_surfaceshader` (OpenPBR Surface).
pub(super) const OPEN_PBR_SURFACE: PbrModel = PbrModel {
    base: ("base_weight", 1.0, "base_color", 0.8),
    metalness: "base_metalness",
    specular: ("specular_weight", "specular_color"),
    roughness: ("specular_roughness", 0.3),
    flavour: PbrFlavour::OpenPbr,
    anisotropy: ("specular_roughness_anisotropy", None),
    diffuse_roughness: "base_diffuse_roughness",
    // OpenPBR's fuzz is rendered with the same Charlie sheen lobe
    sheen: ("fuzz_weight", "fuzz_color", "fuzz_roughness", 0.5),
    thin_film: (Some("thin_film_weight"), "thin_film_thickness", 0.5, 1000.0, "thin_film_ior", 1.4),
    ior: "specular_ior",
    coat: ("coat_weight", "coat_roughness", 0.0, "coat_color"),
    coat_ior: ("coat_ior", 1.6),
    coat_anisotropy: ("coat_roughness_anisotropy", None),
    coat_affect: None,
    coat_darkening: Some("coat_darkening"),
    emission: ("emission_luminance", "emission_color"),
    opacity: ("geometry_opacity", false),
    normal: "geometry_normal",
    transmission: ("transmission_weight", "transmission_color", "transmission_depth", "geometry_thin_walled"),
    transmission_extra_roughness: None,
    subsurface: Subsurface {
        weight: "subsurface_weight",
        color: ("subsurface_color", 0.8),
        radius: ("subsurface_radius", [1.0; 3]),
        scale: ("subsurface_radius_scale", [1.0, 0.5, 0.25]),
        anisotropy: "subsurface_scatter_anisotropy",
    },
    dispersion: Dispersion::Scaled { scale: "transmission_dispersion_scale", abbe: ("transmission_dispersion_abbe_number", 20.0) },
    unsupported: &[("transmission_scatter", 0.0, "scattering inside the transmission")],
};

impl Ctx<'_> {
    /// What output `output` of MaterialX node `up` supplies to the attribute `attr` (None:
    /// unusable, reported). `depth` bounds chains of nodes.
    pub(super) fn mtlx_source(&mut self, attr: &str, up: &str, output: &str, depth: u32) -> Option<Source> {
        let key = (up.to_string(), output.to_string());
        if let Some(read) = self.mtlx_read.get(&key) {
            return read.clone();
        }
        self.mtlx_reading.push(key.clone());
        let read = self.mtlx_source_read(attr, up, output, depth);
        self.mtlx_reading.pop();
        let read = match read {
            Some(Source::Graph(e)) => match e.size_within(MAX_OPS - self.mtlx_ops) {
                Some(n) => {
                    self.mtlx_ops += n;
                    Some(Source::Graph(e))
                }
                None => {
                    self.p.add(attr, format!("the node graph spells out more than {MAX_OPS} operations (nodes reused along many paths); this input reads its constant value"));
                    self.mtlx_oversized.insert(key.clone());
                    None
                }
            },
            other => other,
        };
        // what could not be read is not read again (nor reported again)
        self.mtlx_read.insert(key, read.clone());
        read
    }

    /// [`Ctx::mtlx_source`] of a node output not read before.
    fn mtlx_source_read(&mut self, attr: &str, up: &str, output: &str, depth: u32) -> Option<Source> {
        let id = self.node_id(up).unwrap_or("").to_string();
        self.mtlx_nodes += 1;
        if self.mtlx_nodes > MAX_NODES {
            self.p.add(attr, format!("the node graph reads more than {MAX_NODES} nodes; using the constant value"));
            return None;
        }
        match family(&id) {
            Some("image" | "tiledimage") => Some(match self.mtlx_image(up, depth) {
                Ok((mut t, coordinates)) => {
                    if id.ends_with("_float") {
                        t.channel = Channel::R;
                    }
                    match coordinates {
                        None => Source::Texture(t),
                        Some(st) => Source::Graph(Expr::TextureAt(Box::new(Expr::Texture(t)), Box::new(st))),
                    }
                }
                Err(fb) => Source::Fallback(fb),
            }),
            Some("geompropvalue") => Some(Source::Primvar(self.geomprop(up))),
            Some("texcoord") => {
                if self.input_f32(up, "index", 0.0) != 0.0 {
                    self.p.add(&format!("{up}.inputs:index"), "texture coordinate sets other than the first are not read; the first is");
                }
                Some(Source::Graph(Expr::TexCoord))
            }
            // `object` (the fallback) and `model` are the geometry's own space
            Some("position") => Some(Source::Graph(Expr::Position { world: self.world_space(up) })),
            Some("constant") => Some(Source::Fallback(self.value4(up, "value", [0.0; 4]))),
            Some("dot") => match self.operand(up, "in", [0.0; 4], depth) {
                Ok(source) => Some(source),
                Err(why) => {
                    self.p.add(attr, format!("a MaterialX '{}' node {}; using the constant value", id, why));
                    None
                }
            },
            Some(name) if ARITHMETIC.contains(&name) || PROCEDURAL.contains(&name) => {
                let read = match ARITHMETIC.contains(&name) {
                    true => self.arithmetic(name, &id, up, output, depth),
                    false => self.procedural(name, &id, up, depth),
                };
                match read {
                    Ok(source) => Some(source),
                    Err(why) => {
                        self.p.add(attr, format!("a MaterialX '{}' node {}; using the constant value", id, why));
                        None
                    }
                }
            }
            _ => {
                self.p.add(attr, format!("a MaterialX '{}' node is not supported here; using the constant value", id));
                None
            }
        }
    }

    /// An operand of a node: what its connection supplies, or its constant.
    pub(super) fn operand(&mut self, node: &str, input: &str, default: [f32; 4], depth: u32) -> Result<Source, String> {
        match self.nodes[node].connects.get(input).cloned() {
            None => Ok(Source::Fallback(self.value4(node, input, default))),
            // a connection back to a node being read: the cycle is cut here, once, and the
            // input reads its constant
            Some((up, output)) if self.mtlx_reading.iter().any(|r| r.0 == up && r.1 == output) => {
                let at = self.mtlx_reading.iter().position(|r| r.0 == up && r.1 == output).unwrap_or(0);
                let cycle: Vec<&str> = self.mtlx_reading[at..].iter().map(|r| r.0.as_str()).chain([up.as_str()]).collect();
                let message = format!("connects the node graph in a cycle ({}); this input reads its constant value", cycle.join(" → "));
                self.p.add(&format!("{node}.inputs:{input}"), message);
                Ok(Source::Fallback(self.value4(node, input, default)))
            }
            Some(_) if depth >= MAX_DEPTH => Err(format!("chains more than {MAX_DEPTH} nodes")),
            Some((up, output)) => match self.connection_at(&format!("{}.inputs:{}", node, input), &up, &output, depth + 1) {
                Some(source) => Ok(source),
                // a graph past the bound on operations reads the input's constant (reported
                // once, where it was met)
                None if self.mtlx_oversized.contains(&(up, output)) => Ok(Source::Fallback(self.value4(node, input, default))),
                None => Err(format!("has an unusable {input}")),
            },
        }
    }

    /// An operand as an expression, its default `d` in every component.
    pub(super) fn arg(&mut self, node: &str, input: &str, d: f32, depth: u32) -> Result<Expr, String> {
        self.operand(node, input, [d; 4], depth).map(Source::into_expr)
    }

    /// A MaterialX arithmetic node (family `name`, id `id`) as what it computes: folded into
    /// a lookup or a constant where it can be, an expression otherwise.
    fn arithmetic(&mut self, name: &str, id: &str, node: &str, output: &str, depth: u32) -> Result<Source, String> {
        let c = |v: f32| Expr::Const([v; 4]);
        let bin = Expr::binary;
        let e = match name {
            "multiply" | "add" | "subtract" | "divide" | "min" | "max" | "power" | "modulo" => {
                let d2 = if matches!(name, "multiply" | "divide" | "power" | "modulo") { 1.0 } else { 0.0 };
                let a = self.operand(node, "in1", [0.0; 4], depth)?;
                let b = self.operand(node, "in2", [d2; 4], depth)?;
                let neg = |v: &[f32; 4]| v.map(|x| -x);
                let folded = match (name, &a, &b) {
                    ("multiply", _, _) => return Ok(product(a, b)),
                    ("add", _, Source::Fallback(k)) => affine(&a, [1.0; 4], *k),
                    ("add", Source::Fallback(k), _) => affine(&b, [1.0; 4], *k),
                    ("subtract", _, Source::Fallback(k)) => affine(&a, [1.0; 4], neg(k)),
                    ("subtract", Source::Fallback(k), _) => affine(&b, [-1.0; 4], *k),
                    _ => None,
                };
                if let Some(source) = folded {
                    return Ok(source);
                }
                let op = match name {
                    "add" => Binary::Add,
                    "subtract" => Binary::Sub,
                    "divide" => Binary::Div,
                    "min" => Binary::Min,
                    "max" => Binary::Max,
                    "power" => Binary::Pow,
                    _ => Binary::Modulo,
                };
                bin(op, a.into_expr(), b.into_expr())
            }
            "absval" | "floor" | "ceil" | "sqrt" | "exp" | "ln" | "sin" | "cos" | "sign" => {
                let op = match name {
                    "absval" => Unary::Abs,
                    "floor" => Unary::Floor,
                    "ceil" => Unary::Ceil,
                    "sqrt" => Unary::Sqrt,
                    "exp" => Unary::Exp,
                    "ln" => Unary::Ln,
                    "sin" => Unary::Sin,
                    "cos" => Unary::Cos,
                    _ => Unary::Sign,
                };
                Expr::unary(op, self.arg(node, "in", 0.0, depth)?)
            }
            "mix" => {
                let fg = self.operand(node, "fg", [0.0; 4], depth)?;
                let bg = self.operand(node, "bg", [0.0; 4], depth)?;
                let m = self.operand(node, "mix", [0.0; 4], depth)?;
                // fg·m + bg·(1 − m) with a constant amount and one constant side: one lookup
                let folded = match (&fg, &bg, &m) {
                    (_, Source::Fallback(b), Source::Fallback(m)) => affine(&fg, *m, std::array::from_fn(|k| b[k] * (1.0 - m[k]))),
                    (Source::Fallback(f), _, Source::Fallback(m)) => affine(&bg, m.map(|x| 1.0 - x), std::array::from_fn(|k| f[k] * m[k])),
                    _ => None,
                };
                if let Some(source) = folded {
                    return Ok(source);
                }
                Expr::mix(fg.into_expr(), bg.into_expr(), m.into_expr())
            }
            "clamp" => {
                let x = self.arg(node, "in", 0.0, depth)?;
                let (lo, hi) = (self.arg(node, "low", 0.0, depth)?, self.arg(node, "high", 1.0, depth)?);
                bin(Binary::Max, bin(Binary::Min, x, hi), lo)
            }
            "invert" => {
                let x = self.arg(node, "in", 0.0, depth)?;
                bin(Binary::Sub, self.arg(node, "amount", 1.0, depth)?, x)
            }
            "remap" => {
                let x = self.arg(node, "in", 0.0, depth)?;
                let (il, ih) = (self.arg(node, "inlow", 0.0, depth)?, self.arg(node, "inhigh", 1.0, depth)?);
                let (ol, oh) = (self.arg(node, "outlow", 0.0, depth)?, self.arg(node, "outhigh", 1.0, depth)?);
                // outlow + (in − inlow) · (outhigh − outlow) / (inhigh − inlow)
                let t = bin(Binary::Div, bin(Binary::Sub, x, il.clone()), bin(Binary::Sub, ih, il));
                bin(Binary::Add, ol.clone(), bin(Binary::Mul, t, bin(Binary::Sub, oh, ol)))
            }
            "smoothstep" => {
                let x = self.arg(node, "in", 0.0, depth)?;
                let (lo, hi) = (self.arg(node, "low", 0.0, depth)?, self.arg(node, "high", 1.0, depth)?);
                // t = clamp((in − low) / (high − low), 0, 1); t²(3 − 2t)
                let t = bin(Binary::Div, bin(Binary::Sub, x, lo.clone()), bin(Binary::Sub, hi, lo));
                let t = bin(Binary::Max, bin(Binary::Min, t, c(1.0)), c(0.0));
                bin(Binary::Mul, bin(Binary::Mul, t.clone(), t.clone()), bin(Binary::Sub, c(3.0), bin(Binary::Mul, c(2.0), t)))
            }
            "luminance" => {
                let x = self.arg(node, "in", 0.0, depth)?;
                let w = self.value4(node, "lumacoeffs", [0.2722287, 0.6740818, 0.0536895, 0.0]);
                let wx = bin(Binary::Mul, x, Expr::Const([w[0], w[1], w[2], 0.0]));
                bin(Binary::Add, bin(Binary::Add, Expr::splat(wx.clone(), 0), Expr::splat(wx.clone(), 1)), Expr::splat(wx, 2))
            }
            "convert" => {
                let x = self.arg(node, "in", 0.0, depth)?;
                let from = id.trim_start_matches("ND_convert_").split('_').next().unwrap_or("");
                match from {
                    "float" | "integer" | "boolean" => Expr::splat(x, 0),
                    // three components to four: alpha 1
                    "color3" | "vector3" if id.ends_with("4") => bin(Binary::Add, bin(Binary::Mul, x, Expr::Const([1.0, 1.0, 1.0, 0.0])), Expr::Const([0.0, 0.0, 0.0, 1.0])),
                    // two to four: (x, y, 0, 1), as MaterialX's graph makes it
                    "vector2" if id.ends_with("4") => bin(Binary::Add, bin(Binary::Mul, x, Expr::Const([1.0, 1.0, 0.0, 0.0])), Expr::Const([0.0, 0.0, 0.0, 1.0])),
                    _ => x,
                }
            }
            "extract" => {
                let x = self.arg(node, "in", 0.0, depth)?;
                let index = self.input_f32(node, "index", 0.0);
                if !(0.0..4.0).contains(&index) {
                    return Err(format!("extracts component {index}, which does not exist"));
                }
                Expr::splat(x, index as u8)
            }
            "separate2" | "separate3" | "separate4" => {
                let Some(k) = component(output) else { return Err(format!("has no output '{output}'")) };
                Expr::splat(self.arg(node, "in", 0.0, depth)?, k)
            }
            "combine2" | "combine3" | "combine4" => {
                let n = name.trim_start_matches("combine").parse::<usize>().unwrap_or(2);
                // the components each input gives, in order: floats, but color4CF / vector4VF
                // (a colour or vector3, then a float) and vector4VV (two vector2s)
                let widths: Vec<usize> = if id.ends_with("CF") || id.ends_with("VF") {
                    vec![3, 1]
                } else if id.ends_with("VV") {
                    vec![2, 2]
                } else {
                    vec![1; n]
                };
                let mut sum = Expr::Const([0.0; 4]);
                let mut at = 0;
                for (k, &width) in widths.iter().enumerate() {
                    let input = self.arg(node, &format!("in{}", k + 1), 0.0, depth)?;
                    for j in 0..width {
                        let mask = std::array::from_fn(|i| f32::from(u8::from(i == at + j)));
                        sum = bin(Binary::Add, sum, bin(Binary::Mul, Expr::splat(input.clone(), j as u8), Expr::Const(mask)));
                    }
                    at += width;
                }
                sum
            }
            "ramplr" | "ramptb" | "ramp4" | "splitlr" | "splittb" => self.ramp(name, node, depth)?,
            _ => {
                // ifgreater: in1 where value1 > value2, else in2; ifgreatereq: where value1 ≥ value2
                let (v1, v2) = (self.arg(node, "value1", 1.0, depth)?, self.arg(node, "value2", 0.0, depth)?);
                let (a, b) = (self.arg(node, "in1", 0.0, depth)?, self.arg(node, "in2", 0.0, depth)?);
                let pick = match name {
                    "ifgreater" => bin(Binary::Greater, v1, v2),
                    _ => bin(Binary::Sub, c(1.0), bin(Binary::Greater, v2, v1)),
                };
                Expr::mix(a, b, pick)
            }
        };
        Ok(Source::from_expr(e))
    }

    /// `ramplr`, `ramptb`, `ramp4`, `splitlr` and `splittb` over the texture coordinates (the
    /// mesh's unless connected): u left to right, v bottom to top, clamped to [0, 1] for the
    /// ramps; a split gives its second value from `center` on.
    fn ramp(&mut self, name: &str, node: &str, depth: u32) -> Result<Expr, String> {
        let c = |v: f32| Expr::Const([v; 4]);
        let bin = Expr::binary;
        let tc = match self.nodes[node].connects.contains_key("texcoord") {
            true => self.arg(node, "texcoord", 0.0, depth)?,
            false => Expr::TexCoord,
        };
        let unit = |x: Expr| bin(Binary::Max, bin(Binary::Min, x, c(1.0)), c(0.0));
        let (u, v) = (Expr::splat(tc.clone(), 0), Expr::splat(tc, 1));
        let value = |this: &mut Self, input: &str| this.arg(node, input, 0.0, depth);
        Ok(match name {
            "ramplr" => Expr::mix(value(self, "valuer")?, value(self, "valuel")?, unit(u)),
            "ramptb" => Expr::mix(value(self, "valuet")?, value(self, "valueb")?, unit(v)),
            "ramp4" => {
                let top = Expr::mix(value(self, "valuetr")?, value(self, "valuetl")?, unit(u.clone()));
                let bottom = Expr::mix(value(self, "valuebr")?, value(self, "valuebl")?, unit(u));
                Expr::mix(top, bottom, unit(v))
            }
            _ => {
                let (at, second, first) = if name == "splitlr" { (u, "valuer", "valuel") } else { (v, "valuet", "valueb") };
                let from = bin(Binary::Sub, c(1.0), bin(Binary::Greater, self.arg(node, "center", 0.5, depth)?, at));
                Expr::mix(value(self, second)?, value(self, first)?, from)
            }
        })
    }

    /// An input's value as four components: a scalar fills all four (an operand of a node that
    /// mixes scalars and colours applies to each component), three components take alpha 1.
    pub(super) fn value4(&mut self, node: &str, input: &str, default: [f32; 4]) -> [f32; 4] {
        match self.nodes[node].inputs.get(input).map(|v| v.to_f32s()) {
            None => default,
            Some(Some(v)) if !v.is_empty() && v.len() <= 4 && v.iter().all(|x| x.is_finite()) => match v[..] {
                [x] => [x; 4],
                _ => std::array::from_fn(|i| v.get(i).copied().unwrap_or(if i == 3 { 1.0 } else { 0.0 })),
            },
            Some(_) => {
                self.p.add(&format!("{}.inputs:{}", node, input), format!("expected 1 to 4 finite numbers; using {:?}", default));
                default
            }
        }
    }

    /// A `geompropvalue` node: the primvar its `geomprop` names, its `default` elsewhere.
    fn geomprop(&mut self, node: &str) -> PrimvarLookup {
        let name = self.nodes[node].inputs.get("geomprop").and_then(|v| v.as_str()).unwrap_or("").to_string();
        if name.is_empty() {
            self.p.add(&format!("{}.inputs:geomprop", node), "names no primvar; the node gives its default");
        }
        let mut fallback = self.value4(node, "default", [0.0; 4]);
        fallback[3] = 0.0;
        PrimvarLookup::new(name, fallback)
    }

    /// An `image` or `tiledimage` node as a texture lookup, or its `default` when the file is
    /// unavailable.
    ///
    /// Coordinates that no affine map of a set of coordinates gives (a texcoord warped by a
    /// noise, say) come back as the expression that computes them at each hit.
    fn mtlx_image(&mut self, node: &str, depth: u32) -> Result<(TexLookup, Option<Expr>), [f32; 4]> {
        let modes = [("periodic", Some(WrapKey::Repeat)), ("clamp", Some(WrapKey::Clamp)), ("mirror", Some(WrapKey::Mirror)), ("constant", Some(WrapKey::Default))];
        let wrap_s = self.wrap_input(node, "uaddressmode", &modes, "periodic");
        let wrap_t = self.wrap_input(node, "vaddressmode", &modes, "periodic");
        let fallback = self.value4(node, "default", [0.0, 0.0, 0.0, 1.0]);
        // tiledimage (as MaterialX's own graph computes it): uv' = (uv · uvtiling − uvoffset)
        // / realworldimagesize · realworldtilesize
        let tiling = Vec2::from(self.input_vec(node, "uvtiling", [1.0, 1.0]));
        let offset = Vec2::from(self.input_vec(node, "uvoffset", [0.0, 0.0]));
        let image_size = Vec2::from(self.input_vec(node, "realworldimagesize", [1.0, 1.0]));
        let tile_size = Vec2::from(self.input_vec(node, "realworldtilesize", [1.0, 1.0]));
        let tiled = Affine2::from_scale(tile_size / image_size) * Affine2::from_translation(-offset) * Affine2::from_scale(tiling);
        let (chain, uv_set, computed) = match self.nodes[node].connects.get("texcoord").cloned() {
            None => (Affine2::IDENTITY, None, None),
            Some((up, _)) => match self.texcoord(&up, 0) {
                Ok((chain, set)) => (chain, set, None),
                Err(_) => match self.arg(node, "texcoord", 0.0, depth) {
                    Ok(st) => (Affine2::IDENTITY, None, Some(st)),
                    Err(why) => {
                        self.p.add(&format!("{}.inputs:texcoord", node), format!("the texture coordinates' node {why}; using the mesh's st"));
                        (Affine2::IDENTITY, None, None)
                    }
                },
            },
        };
        // the file input's colour space (USD's colorSpace metadata, as UsdImaging hands it on:
        // `colorSpace:file`), else the file's own encoding decides
        let encoding = self.file_color_space(node, "file");
        let filter = self.filter_type(node);
        let Some(texture) = self.texture_slot(node, "file", encoding, wrap_s, wrap_t, filter) else { return Err(fallback) };
        let transform = tiled * chain;
        if !(transform.matrix2.is_finite() && transform.translation.is_finite()) {
            self.p.add(&format!("{}.inputs:texcoord", node), "the texture coordinates' transform is not finite; using the mesh's st");
            return Ok((TexLookup { transform: Affine2::IDENTITY, ..self.plain_lookup(texture, fallback, None) }, None));
        }
        Ok((TexLookup { transform, ..self.plain_lookup(texture, fallback, uv_set) }, computed))
    }

    /// An untransformed RGB lookup of `texture`.
    pub(super) fn plain_lookup(&self, texture: usize, fallback: [f32; 4], uv_set: Option<PrimvarLookup>) -> TexLookup {
        TexLookup { texture, channel: Channel::Rgb, transform: Affine2::IDENTITY, tex_scale: [1.0; 4], bias: [0.0; 4], fallback, uv_set }
    }

    /// The texture coordinates node `up` gives, as an affine map of a set of coordinates (the
    /// mesh's, or a primvar's): `texcoord`, `geompropvalue` or a UsdPrimvarReader, through
    /// `dot`, `place2d`, and `multiply`, `divide`, `add` or `subtract` by constants. Err says why
    /// not.
    fn texcoord(&mut self, up: &str, depth: u32) -> Result<(Affine2, Option<PrimvarLookup>), String> {
        if depth > MAX_DEPTH {
            return Err(format!("texcoord chains more than {MAX_DEPTH} nodes"));
        }
        let id = self.node_id(up).unwrap_or("").to_string();
        let next = |this: &mut Self, input: &str| -> Result<(Affine2, Option<PrimvarLookup>), String> {
            match this.nodes[up].connects.get(input).cloned() {
                Some((n, _)) => this.texcoord(&n, depth + 1),
                None if input == "texcoord" => Ok((Affine2::IDENTITY, None)),
                None => Err(format!("texcoord comes from a '{id}' node whose {input} is not connected")),
            }
        };
        let kind = family(&id).unwrap_or("");
        Ok(match kind {
            _ if id.starts_with("ND_texcoord_") => (Affine2::IDENTITY, None),
            _ if id.starts_with("ND_geompropvalue_") => (Affine2::IDENTITY, uv_set(self.geomprop(up))),
            _ if id.starts_with("UsdPrimvarReader_") => (Affine2::IDENTITY, uv_set(self.primvar_reader(up))),
            "dot" => next(self, "in")?,
            "place2d" => {
                let (inner, set) = next(self, "texcoord")?;
                let pivot = Vec2::from(self.input_vec(up, "pivot", [0.0, 0.0]));
                let scale = Vec2::from(self.input_vec(up, "scale", [1.0, 1.0]));
                let offset = Vec2::from(self.input_vec(up, "offset", [0.0, 0.0]));
                // MaterialX turns coordinates by −rotate (clockwise for positive degrees)
                let turn = Affine2::from_angle(-self.input_f32(up, "rotate", 0.0).to_radians());
                let shrink = Affine2::from_scale(Vec2::ONE / scale);
                let t = Affine2::from_translation;
                let place = match self.input_f32(up, "operationorder", 0.0) as i64 {
                    // SRT: turn((uv − pivot) / scale) − offset + pivot
                    0 => t(pivot - offset) * turn * shrink * t(-pivot),
                    // TRS: turn(uv − pivot − offset) / scale + pivot
                    _ => t(pivot) * shrink * turn * t(-pivot - offset),
                };
                (place * inner, set)
            }
            "multiply" | "divide" | "add" | "subtract" => {
                let vec2 = |this: &mut Self, input: &str, d: f32| -> Option<Vec2> {
                    (!this.nodes[up].connects.contains_key(input)).then(|| {
                        let v = this.value4(up, input, [d; 4]);
                        Vec2::new(v[0], v[1])
                    })
                };
                let d2 = if matches!(kind, "multiply" | "divide") { 1.0 } else { 0.0 };
                let (c1, c2) = (vec2(self, "in1", 0.0), vec2(self, "in2", d2));
                let t = Affine2::from_translation;
                let s = Affine2::from_scale;
                match (kind, c1, c2) {
                    ("multiply", None, Some(c)) => map(s(c), next(self, "in1")?),
                    ("multiply", Some(c), None) => map(s(c), next(self, "in2")?),
                    ("divide", None, Some(c)) => map(s(Vec2::ONE / c), next(self, "in1")?),
                    ("add", None, Some(c)) => map(t(c), next(self, "in1")?),
                    ("add", Some(c), None) => map(t(c), next(self, "in2")?),
                    ("subtract", None, Some(c)) => map(t(-c), next(self, "in1")?),
                    ("subtract", Some(c), None) => map(t(c) * s(Vec2::NEG_ONE), next(self, "in2")?),
                    _ => return Err(format!("texcoord comes from a '{id}' node that is not texture coordinates and constants")),
                }
            }
            _ => return Err(format!("texcoord comes from a '{id}' node")),
        })
    }

    /// A colour input times a scalar input (`base` × `base_color`), either constant or not.
    /// `weight` × `color` (the colour first raised to `gamma`, where given).
    fn weighted_color(&mut self, node: &str, color: &str, color_default: f32, weight: &str, weight_default: f32, gamma: Option<Expr>) -> ColorInput {
        let c = self.input_vec(node, color, [color_default; 3]);
        let c = self.source(node, color).unwrap_or(Source::Fallback([c[0], c[1], c[2], 1.0]));
        let c = match gamma {
            Some(g) => Source::from_expr(Expr::binary(Binary::Pow, Expr::binary(Binary::Max, c.into_expr(), Expr::Const([0.0; 4])), g)),
            None => c,
        };
        let w = self.input_f32(node, weight, weight_default);
        // a scalar: one channel of a texture, the first component of a graph
        let w = match self.source(node, weight).map(Source::scalar) {
            None => Source::Fallback([w, w, w, 1.0]),
            Some(Source::Graph(e)) => Source::Graph(Expr::splat(e, 0)),
            Some(other) => other,
        };
        product(c, w).into_color()
    }

    /// The specular roughness, and the power Standard Surface's graph raises the base colour
    /// to under a coat (None: 1): its `coat_affected_roughness`, mix(roughness, 1,
    /// coat_affect_roughness × coat × coat_roughness), and its `coat_gamma`, 1 + clamp(coat) ×
    /// coat_affect_color.
    fn coat_affected(&mut self, n: &str, m: &PbrModel) -> (Option<Expr>, FloatInput) {
        let roughness = self.float(n, m.roughness.0, m.roughness.1);
        let Some((affect_color, affect_roughness)) = m.coat_affect else { return (None, roughness) };
        let scalar = |this: &mut Self, input: &str, d: f32| {
            this.scalar_arg(n, input, d, 0).unwrap_or_else(|why| {
                this.p.add(&format!("{}.inputs:{}", n, input), format!("its node {why}; using {d}"));
                Expr::Const([d; 4])
            })
        };
        let (c, mul, add) = (|v: f32| Expr::Const([v; 4]), Binary::Mul, Binary::Add);
        let zero = |e: &Expr| e.constant_value().is_some_and(|v| v[0] == 0.0);
        let coat = scalar(self, m.coat.0, 0.0);
        let (affect_color, affect_roughness) = (scalar(self, affect_color, 0.0), scalar(self, affect_roughness, 0.0));
        if zero(&coat) {
            return (None, roughness);
        }
        let clamped = Expr::binary(Binary::Min, Expr::binary(Binary::Max, coat.clone(), c(0.0)), c(1.0));
        let gamma = (!zero(&affect_color)).then(|| Source::from_expr(Expr::binary(add, c(1.0), Expr::binary(mul, clamped, affect_color))).into_expr());
        if zero(&affect_roughness) {
            return (gamma, roughness);
        }
        let t = Expr::binary(mul, Expr::binary(mul, affect_roughness, coat), scalar(self, m.coat.1, m.coat.2));
        let r = match roughness {
            FloatInput::Const(v) => c(v),
            FloatInput::Texture(t) => Expr::Texture(t),
            FloatInput::Primvar(l) => Expr::Primvar(l),
            FloatInput::Graph(e) => e,
        };
        let mixed = Source::from_expr(Expr::mix(c(1.0), r, t));
        (gamma, float_input(m.roughness.1, Some(mixed)))
    }

    /// A scalar input that only its constant can set (a connection is reported and ignored).
    fn constant_only(&mut self, node: &str, input: &str, default: f32) -> f32 {
        if self.nodes[node].connects.contains_key(input) {
            self.p.add(&format!("{}.inputs:{}", node, input), "a connection is not supported here; its constant is used");
        }
        self.input_f32(node, input, default)
    }

    /// Reports an input that is set away from `neutral` and that the mapping leaves out.
    fn unsupported(&mut self, node: &str, input: &str, neutral: &[f32], what: &str) {
        let connected = self.nodes[node].connects.contains_key(input);
        let set = self.nodes[node].inputs.get(input).and_then(|v| v.to_f32s()).is_some_and(|v| v.iter().zip(neutral.iter().cycle()).any(|(a, b)| a != b));
        if connected || set {
            self.p.add(&format!("{}.inputs:{}", node, input), format!("{what} is not supported; left out"));
        }
    }

    /// The normal map behind a normal input (`normal`, `geometry_normal`): `normalmap` over an image (its [0, 1] texels
    /// remapped to [−1, 1]), or a UsdUVTexture as UsdPreviewSurface takes it.
    fn mtlx_normal(&mut self, node: &str, input: &str) -> Option<TexLookup> {
        let (up, _) = self.nodes[node].connects.get(input).cloned()?;
        if self.node_id(&up) != Some("ND_normalmap") {
            self.p.add(&format!("{}.inputs:{}", node, input), "a normal not from a normalmap node is not supported; the surface's own normal is used");
            return None;
        }
        let scale = self.input_f32(&up, "scale", 1.0);
        let (img, output) = self.nodes[&up].connects.get("in").cloned()?;
        match self.connection_at(&format!("{}.inputs:in", up), &img, &output, 0) {
            Some(Source::Texture(mut t)) => {
                t.channel = Channel::Rgb;
                t.tex_scale = [2.0 * scale, 2.0 * scale, 2.0, 1.0];
                t.bias = [-scale, -scale, -1.0, 0.0];
                Some(t)
            }
            _ => None,
        }
    }

    /// A MaterialX PBR surface (`standard_surface`, `open_pbr_surface`) as a surface Tide has
    /// (see the module's text), and the absorption coefficients (RGB, per scene unit) of the
    /// body that its tinted transmission or its subsurface fills, if any.
    pub(super) fn pbr_surface(&mut self, n: &str, m: &PbrModel) -> (SurfaceDesc, Option<Body>) {
        for (input, neutral, what) in m.unsupported {
            self.unsupported(n, input, &[*neutral], what);
        }
        let ior = self.constant_only(n, m.ior, 1.5);
        let transmission = self.float(n, m.transmission.0, 0.0);
        let ss = m.subsurface.weight;
        let subsurface = self.float(n, ss, 0.0);
        if transmission == FloatInput::Const(0.0) && subsurface == FloatInput::Const(0.0) {
            return (SurfaceDesc::Preview(self.pbr_preview(n, m)), None);
        }
        if self.constant_only(n, m.transmission.3, 0.0) != 0.0 {
            return (SurfaceDesc::Preview(self.thin_wall(n, m, transmission, subsurface)), None);
        }
        // a dielectric interface over the share that transmits, blended with the rest
        let mut roughness = self.constant_only(n, m.roughness.0, m.roughness.1);
        let (share, weight, tint, body) = if transmission != FloatInput::Const(0.0) {
            if subsurface != FloatInput::Const(0.0) && transmission != FloatInput::Const(1.0) {
                self.p.add(&format!("{}.inputs:{}", n, ss), "a subsurface beside a partial transmission renders as the diffuse base");
            }
            let attr = format!("{}.inputs:{}", n, m.transmission.1);
            let (tint, sigma_a) = self.transmission_colour(n, m);
            let extra = m.transmission_extra_roughness.map_or(0.0, |e| self.constant_only(n, e, 0.0));
            roughness = (roughness + extra).clamp(0.0, 1.0);
            (transmission, m.transmission.0, tint, sigma_a.map(|sigma_a| Body { sigma_a, sigma_s: [0.0; 3], g: 0.0, attr }))
        } else {
            (subsurface, ss, None, Some(self.subsurface_medium(n, &m.subsurface)))
        };
        let opaque = self.pbr_preview(n, m);
        let plain = share == FloatInput::Const(1.0) && opaque.metallic == FloatInput::Const(0.0) && opaque.emissive_color == ColorInput::Const([0.0; 3]) && opaque.opacity == FloatInput::Const(1.0);
        self.on_opaque_share(n, m, weight, &opaque);
        let blend = (!plain).then(|| Box::new(WaterBlend { transmission: share, surface: opaque }));
        let abbe = if weight == m.transmission.0 { self.abbe_number(n, &m.dispersion) } else { None };
        (SurfaceDesc::Water(WaterDesc { ior, roughness, tint, blend, abbe, ..WaterDesc::default() }), body)
    }

    /// The Abbe number of a transmission's dispersion (None: no dispersion); a negative or
    /// non-finite one is reported and left out.
    fn abbe_number(&mut self, n: &str, d: &Dispersion) -> Option<f32> {
        let (input, v) = match *d {
            Dispersion::Abbe(input) => (input, self.constant_only(n, input, 0.0)),
            Dispersion::Scaled { scale, abbe } => {
                let k = self.constant_only(n, scale, 0.0);
                if k == 0.0 {
                    return None;
                }
                if !(k > 0.0 && k.is_finite()) {
                    self.p.add(&format!("{}.inputs:{}", n, scale), format!("a dispersion scale of {k} is not positive; no dispersion"));
                    return None;
                }
                (abbe.0, self.constant_only(n, abbe.0, abbe.1) / k)
            }
        };
        if v == 0.0 {
            return None;
        }
        if !(v > 0.0 && v.is_finite()) {
            self.p.add(&format!("{}.inputs:{}", n, input), format!("an Abbe number of {v} is not positive; no dispersion"));
            return None;
        }
        Some(v)
    }

    /// A material's MaterialX displacement node (`ND_displacement_float`): displacement ×
    /// scale along the normal, as UsdPreviewSurface's displacement goes. A vector displacement
    /// or another node is reported and displaces nothing.
    pub(super) fn mtlx_displacement(&mut self, n: &str) -> Option<FloatInput> {
        match self.node_id(n) {
            Some("ND_displacement_float") => {
                let mut scalar = |input: &str, default: f32| {
                    let v = self.input_f32(n, input, default);
                    self.source(n, input).map_or(Source::Fallback([v; 4]), Source::scalar)
                };
                let (d, scale) = (scalar("displacement", 0.0), scalar("scale", 1.0));
                Some(float_input(0.0, Some(product(d, scale))))
            }
            Some("ND_displacement_vector3") => {
                self.p.add(&format!("{n}.info:id"), "a vector displacement is not supported (only a scalar one, along the normal); the surface is not displaced");
                None
            }
            other => {
                self.p.add(&format!("{n}.info:id"), format!("unknown displacement shader id '{}'; the surface is not displaced", other.unwrap_or("")));
                None
            }
        }
    }

    /// A thin wall (`thin_walled`, `geometry_thin_walled`: a pane, a leaf, a sheet of paper):
    /// the opaque stack whose base passes the transmission's share straight through, tinted by
    /// the transmission colour, and makes the subsurface's share of the rest translucent, as
    /// MaterialX's graphs mix them: Standard Surface's translucent lobe of the subsurface
    /// colour; OpenPBR's half diffuse reflection of colour × (1 − g) and half translucency of
    /// colour × (1 + g), g being the subsurface anisotropy.
    fn thin_wall(&mut self, n: &str, m: &PbrModel, transmission: FloatInput, subsurface: FloatInput) -> PreviewSurfaceDesc {
        let mut p = self.pbr_preview(n, m);
        let (_, color, depth, _) = m.transmission;
        let tint = if transmission == FloatInput::Const(0.0) {
            ColorInput::Const([1.0; 3])
        } else {
            if self.input_f32(n, depth, 0.0) > 0.0 {
                self.p.add(&format!("{}.inputs:{}", n, depth), format!("a thin wall has no inside to absorb in; {color} tints its surface"));
            }
            self.color(n, color, [1.0; 3])
        };
        let (reflect, transmit) = if subsurface == FloatInput::Const(0.0) {
            (ColorInput::Const([0.0; 3]), ColorInput::Const([0.0; 3]))
        } else {
            let c = self.color(n, m.subsurface.color.0, [m.subsurface.color.1; 3]);
            match m.flavour {
                PbrFlavour::StandardSurface => (ColorInput::Const([0.0; 3]), c),
                PbrFlavour::OpenPbr => {
                    let g = self.constant_only(n, m.subsurface.anisotropy, 0.0).clamp(-1.0, 1.0);
                    (c.clone().scaled([0.5 * (1.0 - g); 3]), c.scaled([0.5 * (1.0 + g); 3]))
                }
            }
        };
        let extras = p.extras.get_or_insert_with(|| Box::new(PbrExtras { flavour: m.flavour, ..PbrExtras::default() }));
        extras.thin_walled = Some(ThinWalledDesc { transmission, tint, subsurface, reflect, transmit });
        p
    }

    /// Reports the layers of a surface that transmits (or scatters beneath) that cover only the
    /// share that does not: the coat, sheen, thin film and a weighted or tinted specular.
    fn on_opaque_share(&mut self, n: &str, m: &PbrModel, weight: &str, opaque: &PreviewSurfaceDesc) {
        let mut layers = Vec::new();
        if opaque.clearcoat != FloatInput::Const(0.0) {
            layers.push(m.coat.0);
        }
        if let Some(x) = &opaque.extras {
            if x.specular_weight != FloatInput::Const(1.0) || x.specular_tint != ColorInput::Const([1.0; 3]) {
                layers.extend([m.specular.0, m.specular.1]);
            }
            if x.sheen_weight != FloatInput::Const(0.0) {
                layers.push(m.sheen.0);
            }
            if x.thin_film_weight != FloatInput::Const(0.0) {
                layers.push(m.thin_film.1);
            }
        }
        for layer in layers {
            self.p.add(&format!("{}.inputs:{}", n, layer), format!("covers only the share that {weight} leaves opaque"));
        }
    }

    /// A PBR surface's opaque stack: everything but its transmission and subsurface.
    fn pbr_preview(&mut self, n: &str, m: &PbrModel) -> PreviewSurfaceDesc {
        let ior = self.input_f32(n, m.ior, 1.5);
        let metallic = self.float(n, m.metalness, 0.0);
        let specular_weight = self.float(n, m.specular.0, 1.0);
        // no specular on a non-metal: UsdPreviewSurface's specular workflow with black specular
        let plain_diffuse = specular_weight == FloatInput::Const(0.0) && metallic == FloatInput::Const(0.0);
        let (anisotropy, rotation) = m.anisotropy;
        let flavour = m.flavour;
        let mut extras = PbrExtras {
            specular_weight,
            specular_tint: self.color(n, m.specular.1, [1.0; 3]),
            coat_color: self.color(n, m.coat.3, [1.0; 3]),
            coat_ior: self.constant_only(n, m.coat_ior.0, m.coat_ior.1),
            coat_anisotropy: self.float(n, m.coat_anisotropy.0, 0.0),
            coat_darkening: m.coat_darkening.map_or(FloatInput::Const(0.0), |d| self.float(n, d, 1.0)),
            darkening_albedo: match m.coat_darkening {
                Some(_) => self.color(n, m.base.2, [m.base.3; 3]),
                None => ColorInput::Const([0.0; 3]),
            },
            anisotropy: self.float(n, anisotropy, 0.0),
            flavour,
            anisotropy_rotation: rotation.map_or(FloatInput::Const(0.0), |r| self.float(n, r, 0.0)),
            diffuse_roughness: self.float(n, m.diffuse_roughness, 0.0),
            sheen_weight: self.float(n, m.sheen.0, 0.0),
            sheen_color: self.color(n, m.sheen.1, [1.0; 3]),
            sheen_roughness: self.float(n, m.sheen.2, m.sheen.3),
            thin_film_weight: FloatInput::Const(1.0),
            thin_film_thickness: self.float(n, m.thin_film.1, m.thin_film.2),
            thin_film_unit_nm: m.thin_film.3,
            thin_film_ior: self.constant_only(n, m.thin_film.4, m.thin_film.5),
            thin_walled: None,
        };
        // Standard Surface's film is there wherever it is thicker than 0
        extras.thin_film_weight = match m.thin_film.0 {
            Some(weight) => self.float(n, weight, 0.0),
            None if extras.thin_film_thickness == FloatInput::Const(0.0) => FloatInput::Const(0.0),
            None => FloatInput::Const(1.0),
        };
        let clearcoat = self.float(n, m.coat.0, 0.0);
        let coat_stretched = clearcoat != FloatInput::Const(0.0) && extras.coat_anisotropy != FloatInput::Const(0.0);
        if let (Some(coat_turn), Some(turn), true) = (m.coat_anisotropy.1, rotation, coat_stretched) {
            let (a, b) = (self.float(n, coat_turn, 0.0), self.float(n, turn, 0.0));
            if a != b {
                self.p.add(&format!("{}.inputs:{}", n, coat_turn), format!("a coat turned apart from the specular is not supported; the coat follows {turn}"));
            }
        }
        // with no coat, the coat's colour, IOR and darkening change nothing
        let mut neutral = PbrExtras { flavour, sheen_roughness: extras.sheen_roughness.clone(), ..PbrExtras::default() };
        if clearcoat == FloatInput::Const(0.0) {
            (neutral.coat_color, neutral.coat_ior, neutral.coat_anisotropy) = (extras.coat_color.clone(), extras.coat_ior, extras.coat_anisotropy.clone());
            (neutral.coat_darkening, neutral.darkening_albedo) = (extras.coat_darkening.clone(), extras.darkening_albedo.clone());
        }
        if extras.sheen_weight == FloatInput::Const(0.0) {
            neutral.sheen_color = extras.sheen_color.clone();
        }
        if extras.thin_film_weight == FloatInput::Const(0.0) {
            (neutral.thin_film_thickness, neutral.thin_film_unit_nm, neutral.thin_film_ior) = (extras.thin_film_thickness.clone(), extras.thin_film_unit_nm, extras.thin_film_ior);
        }
        let opacity = match m.opacity {
            (input, false) => self.float(n, input, 1.0),
            // a colour's coverage is the mean of its channels, however it is given
            (input, true) => match self.color(n, input, [1.0; 3]) {
                ColorInput::Const(c) => FloatInput::Const((c[0] + c[1] + c[2]) / 3.0),
                // one channel read into all three (a float image): that channel
                ColorInput::Texture(t) if t.channel != Channel::Rgb => FloatInput::Texture(t),
                ColorInput::Texture(t) => FloatInput::Graph(channel_mean(Expr::Texture(t))),
                ColorInput::Primvar(l) => FloatInput::Graph(channel_mean(Expr::Primvar(l))),
                ColorInput::Graph(e) => FloatInput::Graph(channel_mean(e)),
            },
        };
        let normal = self.mtlx_normal(n, m.normal).map(ColorInput::Texture);
        let (gamma, roughness) = self.coat_affected(n, m);
        PreviewSurfaceDesc {
            diffuse_color: self.weighted_color(n, m.base.2, m.base.3, m.base.0, m.base.1, gamma),
            emissive_color: self.weighted_color(n, m.emission.1, 1.0, m.emission.0, 0.0, None),
            use_specular_workflow: plain_diffuse,
            specular_color: ColorInput::Const([0.0; 3]),
            metallic,
            roughness,
            clearcoat,
            clearcoat_roughness: self.float(n, m.coat.1, m.coat.2),
            opacity,
            opacity_threshold: 0.0,
            ior,
            normal,
            wet: None,
            extras: (extras != neutral).then(|| Box::new(extras)),
        }
    }

    /// The medium under a subsurface-scattering surface, which the path tracer walks through:
    /// mean free path radius × scale per channel (σt = 1 / mfp), single-scattering albedo from
    /// the colour ([`single_scattering_albedo`]), the anisotropy as a Henyey–Greenstein g.
    fn subsurface_medium(&mut self, n: &str, s: &Subsurface) -> Body {
        for input in [s.color.0, s.radius.0, s.scale.0, s.anisotropy] {
            if self.nodes[n].connects.contains_key(input) {
                self.p.add(&format!("{}.inputs:{}", n, input), "a varying subsurface is not supported; its constant is used");
            }
        }
        let color = self.input_vec(n, s.color.0, [s.color.1; 3]);
        let radius = self.input_vec(n, s.radius.0, s.radius.1);
        let scale = self.input_vec(n, s.scale.0, s.scale.1);
        let g = self.input_f32(n, s.anisotropy, 0.0).clamp(-0.99, 0.99);
        let mut sigma_a = [0.0; 3];
        let mut sigma_s = [0.0; 3];
        for k in 0..3 {
            let mfp = (radius[k] * scale[k]).max(1e-6);
            let alpha = single_scattering_albedo(color[k]);
            sigma_s[k] = alpha / mfp;
            sigma_a[k] = (1.0 - alpha) / mfp;
        }
        Body { sigma_a, sigma_s, g, attr: format!("{}.inputs:{}", n, s.weight) }
    }

    /// What a transmission's colour asks for: with a `transmission_depth` above 0, the body's
    /// absorption (Beer–Lambert, so that light crossing that depth keeps the colour, σa =
    /// −ln(colour) / depth); with none, a tint at the surface, which may vary. Neither for a
    /// clear one.
    fn transmission_colour(&mut self, n: &str, m: &PbrModel) -> (Option<ColorInput>, Option<[f32; 3]>) {
        let (_, color, depth, _) = m.transmission;
        let d = self.constant_only(n, depth, 0.0);
        if !(d > 0.0) {
            let tint = self.color(n, color, [1.0; 3]);
            return ((tint != ColorInput::Const([1.0; 3])).then_some(tint), None);
        }
        if self.nodes[n].connects.contains_key(color) {
            self.p.add(&format!("{}.inputs:{}", n, color), "a varying transmission colour is not supported; its constant is used");
        }
        let c = self.input_vec(n, color, [1.0; 3]);
        if c == [1.0; 3] {
            return (None, None);
        }
        if c.iter().any(|x| *x > 1.0) {
            self.p.add(&format!("{}.inputs:{}", n, color), format!("{:?} above 1 would add light; clamped to 1", c));
        }
        (None, Some(c.map(|x| -x.clamp(1e-4, 1.0).ln() / d)))
    }
}

/// The mean of a colour expression's three channels, in every component.
pub(super) fn channel_mean(e: Expr) -> Expr {
    let sum = Expr::binary(Binary::Add, Expr::binary(Binary::Add, Expr::splat(e.clone(), 0), Expr::splat(e.clone(), 1)), Expr::splat(e, 2));
    Expr::binary(Binary::Mul, sum, Expr::Const([1.0 / 3.0; 4]))
}

