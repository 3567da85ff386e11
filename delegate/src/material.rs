//! Material networks → [`MaterialDesc`] (+ the interior [`MediumDesc`]).
//!
//! A material prim carries `surface` / `volume` (paths of the terminal nodes) and, per node N,
//! `N.info:id`, `N.<input>` values and `N.<input>.connect` = `"<node>.<output>"` tokens.
//! The interior medium is the `volume` terminal's TideMedium, or else the TideMedium that the
//! TideWater surface's optional `medium` input is connected to, or else the absorbing body of a
//! MaterialX surface's tinted transmission.
//! Supported nodes: `UsdPreviewSurface` (every input), `UsdUVTexture` (file, st, wrapS/T,
//! fallback, scale, bias, sourceColorSpace, outputs rgb/r/g/b/a), `UsdPrimvarReader_*`,
//! `UsdTransform2d`, `TideWater`, `TideMedium`, and MaterialX's `standard_surface` and
//! `open_pbr_surface` with their texture, primvar and arithmetic nodes ([`mtlx`]). An unknown
//! surface id gives the default material (grey diffuse 0.18) and a problem.
//!
//! Textures are referred to by [`TexKey`] (asset + wrap modes + whether to linearise) in a list
//! local to the material; the scene assembly maps them to `SceneDesc::textures` indices.

mod mtlx;
mod mtlx_procedural;

use crate::value::{normalize_name, AttrStore, Problems, Value};
use glam::{Affine2, Vec2};
use std::collections::BTreeMap;
use tide_core::light::dome_format::DomeFormat;
use tide_core::spectrum::color::FilePrimaries;
use tide_core::shader_graph::Expr;
use tide_core::scene::{
    Channel, ColorInput, FloatInput, MaterialDesc, PrimvarLookup, MediumDesc, PhaseDesc, PreviewSurfaceDesc, SpectrumDesc, SurfaceDesc,
    SurfaceModel, TexLookup, WaterDesc, WetDesc, Wrap,
};

/// The default material: grey diffuse 0.18.
pub fn default_material(name: &str) -> MaterialDesc {
    MaterialDesc { name: name.into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.18; 3]) }, interior_medium: None }
}

/// `med` in a stage of `meters_per_unit` metres per unit, Z-up or not: its coefficients (per
/// metre, by the contract) per unit, its depth profile's depth and width in units, its depth
/// measured down the stage's up axis.
pub fn medium_in_stage(med: &MediumDesc, meters_per_unit: f32, z_up: bool) -> MediumDesc {
    let mut m = med.clone();
    if let Some(w) = m.water.as_mut() {
        w.up = if z_up { glam::Vec3::Z } else { glam::Vec3::Y };
    }
    if meters_per_unit != 1.0 {
        m.scale *= meters_per_unit;
        if let Some(profile) = m.water.as_mut().and_then(|w| w.profile.as_mut()) {
            profile.depth /= meters_per_unit;
            profile.width /= meters_per_unit;
        }
    }
    m
}

/// A texture as a material uses it.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct TexKey {
    pub asset: String,
    pub wrap_s: WrapKey,
    pub wrap_t: WrapKey,
    /// How the file's values are decoded (a UsdUVTexture's `sourceColorSpace`, the file's
    /// colour space metadata).
    pub encoding: Encoding,
    /// A dome light's image layout (resampled to lat-long); `LatLong` for everything else.
    pub dome: DomeFormat,
    /// Texel filtering (a MaterialX image's `filtertype`).
    pub filter: tide_core::scene::Filter,
}

/// How a texture's values are decoded: `sourceColorSpace` `raw`, `sRGB`, or `auto` (sRGB where
/// the file is 8 bits per channel with 3 or 4 channels, as UsdImaging decides; raw otherwise),
/// or a named colour space (USD's and MaterialX's names, see [`Encoding::named`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Encoding {
    Raw,
    Srgb,
    Auto,
    /// Values on `curve` with `primaries`: the curve undone, then taken to linear Rec.709.
    Space { curve: Curve, primaries: FilePrimaries },
}

/// A colour space's transfer curve.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Curve {
    Linear,
    /// IEC 61966-2-1 (the piecewise sRGB curve).
    Srgb,
    Gamma22,
    Gamma18,
    /// Adobe RGB (1998)'s 563/256.
    AdobeGamma,
}

/// The sRGB decoding curve (IEC 61966-2-1).
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

impl Curve {
    /// The linear value of an encoded one (the curve mirrored for negative values).
    pub fn decode(self, v: f32) -> f32 {
        let gamma = |g: f32| v.signum() * v.abs().powf(g);
        match self {
            Curve::Linear => v,
            Curve::Srgb => v.signum() * srgb_to_linear(v.abs()),
            Curve::Gamma22 => gamma(2.2),
            Curve::Gamma18 => gamma(1.8),
            Curve::AdobeGamma => gamma(563.0 / 256.0),
        }
    }
}

impl Encoding {
    /// The encoding a colour space name gives (case ignored): the canonical names OpenUSD,
    /// MaterialX and OCIO share (`lin_ap1_scene`, `srgb_rec709_scene`, ...), MaterialX's own
    /// (`acescg`, `srgb_texture`, `g22_ap1`, `lin_displayp3`, ...), and `raw`, `data`,
    /// `identity` (values as stored); None for a name none of them is.
    pub fn named(name: &str) -> Option<Encoding> {
        use Curve::*;
        use FilePrimaries::*;
        let space = |curve, primaries| Some(Encoding::Space { curve, primaries });
        match name.to_ascii_lowercase().as_str() {
            "srgb_texture" | "srgb" | "srgb_rec709_scene" | "srgb_rec709" => Some(Encoding::Srgb),
            "lin_rec709" | "lin_rec709_scene" | "lin_srgb" | "linear" | "raw" | "data" | "identity" | "none" => Some(Encoding::Raw),
            "g22_rec709" | "g22_rec709_scene" => space(Gamma22, Rec709),
            "g18_rec709" | "g18_rec709_scene" => space(Gamma18, Rec709),
            "acescg" | "lin_ap1" | "lin_ap1_scene" => space(Linear, Ap1),
            "g22_ap1" | "g22_ap1_scene" => space(Gamma22, Ap1),
            "g18_ap1" | "g18_ap1_scene" => space(Gamma18, Ap1),
            "srgb_ap1" | "srgb_ap1_scene" => space(Srgb, Ap1),
            "aces2065-1" | "lin_ap0" | "lin_ap0_scene" => space(Linear, Ap0),
            "lin_rec2020" | "lin_rec2020_scene" => space(Linear, Rec2020),
            "lin_displayp3" | "lin_p3d65" | "lin_p3d65_scene" => space(Linear, P3D65),
            "srgb_displayp3" | "srgb_p3d65" | "srgb_p3d65_scene" | "srgb_displayp3_scene" => space(Srgb, P3D65),
            "lin_adobergb" | "lin_adobergb_scene" => space(Linear, AdobeRgb),
            "adobergb" | "g22_adobergb" | "g22_adobergb_scene" => space(AdobeGamma, AdobeRgb),
            "lin_ciexyzd65_scene" | "lin_ciexyzd65" => space(Linear, XyzD65),
            _ => None,
        }
    }

    /// The encoding a file's colour space metadata `name` gives: `Auto` (the file decides) where
    /// there is none, it is empty or `unknown`; Err with the message to report for a name no
    /// colour space has (the file then decides too).
    pub fn from_metadata(name: Option<&str>) -> Result<Encoding, String> {
        match name.filter(|n| !n.is_empty() && !n.eq_ignore_ascii_case("unknown")) {
            None => Ok(Encoding::Auto),
            Some(n) => Encoding::named(n).ok_or_else(|| format!("colour space '{n}' is not one Tide knows; the file's own encoding decides (8-bit RGB as sRGB, else linear Rec.709)")),
        }
    }

    /// How a file's values are decoded: the curve undone (`file_srgb`: the file is 8-bit RGB,
    /// which `auto` reads as sRGB) and the primaries whose RGB it holds.
    pub fn decoding(self, file_srgb: bool) -> (Curve, FilePrimaries) {
        match self {
            Encoding::Raw => (Curve::Linear, FilePrimaries::Rec709),
            Encoding::Srgb => (Curve::Srgb, FilePrimaries::Rec709),
            Encoding::Auto => (if file_srgb { Curve::Srgb } else { Curve::Linear }, FilePrimaries::Rec709),
            Encoding::Space { curve, primaries } => (curve, primaries),
        }
    }
}

/// `Wrap` with an ordering, for use in keys.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum WrapKey {
    Repeat,
    Mirror,
    Clamp,
    Black,
    Default,
}

impl WrapKey {
    pub fn wrap(self) -> Wrap {
        match self {
            WrapKey::Repeat => Wrap::Repeat,
            WrapKey::Mirror => Wrap::Mirror,
            WrapKey::Clamp => Wrap::Clamp,
            WrapKey::Black => Wrap::Black,
            WrapKey::Default => Wrap::Default,
        }
    }
}

/// What the delegate knows of a texture file.
#[derive(Clone, Debug, PartialEq)]
pub enum TexState {
    /// The values the file holds, undecoded (8-bit files as their codes, read as code / 255);
    /// `is_srgb`: the file's colour space is sRGB; `file_wrap`: the wrap modes (s, t) the
    /// file's metadata names, if any.
    Loaded { width: u32, height: u32, channels: u32, pixels: tide_core::texture::Texels, is_srgb: bool, file_wrap: [Option<WrapKey>; 2] },
    Failed(String),
}

/// The wrap modes (s, t) of a texture file's `wrapmodes` metadata as OpenImageIO reports it
/// ("periodic,clamp"; one token serves both axes): `default`, empty or unknown tokens are no
/// opinion.
pub fn file_wrap_modes(wrapmodes: &str) -> [Option<WrapKey>; 2] {
    let mode = |t: &str| match t.trim() {
        "periodic" | "periodic_pow2" | "periodic_sharedborder" => Some(WrapKey::Repeat),
        "mirror" => Some(WrapKey::Mirror),
        "clamp" => Some(WrapKey::Clamp),
        "black" => Some(WrapKey::Black),
        _ => None,
    };
    let mut tokens = wrapmodes.split(',');
    let s = mode(tokens.next().unwrap_or(""));
    match tokens.next() {
        Some(t) => [s, mode(t)],
        None => [s, s],
    }
}

/// A converted material: texture indices in `desc` refer to `textures`.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialPiece {
    pub desc: MaterialDesc,
    pub medium: Option<MediumDesc>,
    pub textures: Vec<TexKey>,
    /// UsdPreviewSurface's `displacement` (object-space distance along the normal), where set:
    /// applied to the meshes bound to the material ([`tide_core::displace`]).
    pub displacement: Option<FloatInput>,
}

#[derive(Default, Debug)]
struct Node {
    id: Option<String>,
    inputs: BTreeMap<String, Value>,
    connects: BTreeMap<String, (String, String)>,
}

/// Splits `"/a/b.outputs:rgb"` into (`/a/b`, `rgb`).
fn split_target(s: &str) -> (String, String) {
    match s.find('.') {
        Some(i) => (s[..i].to_string(), s[i + 1..].strip_prefix("outputs:").unwrap_or(&s[i + 1..]).to_string()),
        None => (s.to_string(), String::new()),
    }
}

fn parse_nodes(store: &AttrStore) -> BTreeMap<String, Node> {
    let mut nodes: BTreeMap<String, Node> = BTreeMap::new();
    for (key, attr) in &store.attrs {
        if !key.starts_with('/') {
            continue;
        }
        let Some(dot) = key.find('.') else { continue };
        let (node, rest) = (&key[..dot], &key[dot + 1..]);
        let Some(v) = attr.current() else { continue };
        let n = nodes.entry(node.to_string()).or_default();
        if rest == "info:id" {
            n.id = v.as_str().map(String::from);
        } else if let Some(input) = rest.strip_suffix(".connect") {
            if let Some(t) = v.as_str() {
                n.connects.insert(normalize_name(input).to_string(), split_target(t));
            }
        } else {
            n.inputs.insert(normalize_name(rest).to_string(), v.clone());
        }
    }
    nodes
}

/// What a connected input receives.
#[derive(Clone, Debug, PartialEq)]
enum Source {
    Texture(TexLookup),
    Primvar(PrimvarLookup),
    /// A constant: a texture that is unavailable (its fallback value), or a node's value.
    Fallback([f32; 4]),
    /// Arithmetic over lookups that no single lookup can carry (MaterialX nodes).
    Graph(Expr),
}

impl Source {
    /// The source read as a scalar: a texture's `rgb` as its red channel (as UsdPreviewSurface
    /// float inputs connected to `outputs:rgb` read it).
    fn scalar(self) -> Source {
        match self {
            Source::Texture(mut t) if t.channel == Channel::Rgb => {
                t.channel = Channel::R;
                Source::Texture(t)
            }
            other => other,
        }
    }

    /// The source as an expression.
    fn into_expr(self) -> Expr {
        match self {
            Source::Texture(t) => Expr::Texture(t),
            Source::Primvar(l) => Expr::Primvar(l),
            Source::Fallback(v) => Expr::Const(v),
            Source::Graph(e) => e,
        }
    }

    /// The source as a colour input (a constant's first three components).
    fn into_color(self) -> ColorInput {
        match self {
            Source::Texture(t) => ColorInput::Texture(t),
            Source::Primvar(l) => ColorInput::Primvar(l),
            Source::Fallback(fb) => ColorInput::Const([fb[0], fb[1], fb[2]]),
            Source::Graph(e) => ColorInput::Graph(e),
        }
    }

    /// An expression as the simplest source that carries it.
    fn from_expr(e: Expr) -> Source {
        if let Some(v) = e.constant_value() {
            return Source::Fallback(v);
        }
        match e {
            Expr::Texture(t) => Source::Texture(t),
            Expr::Primvar(l) => Source::Primvar(l),
            e => Source::Graph(e),
        }
    }
}

/// A primvar lookup giving a texture's coordinates as a uv set, or None where it names no
/// primvar (the geometry's own texture coordinates). A mesh answers the name of the primvar its
/// own coordinates came from (`st`, `st0` or `uv`) with them, any other name with that primvar,
/// and a name it lacks with the reader's fallback.
fn uv_set(l: PrimvarLookup) -> Option<PrimvarLookup> {
    (!l.name.is_empty()).then_some(l)
}

/// A scalar input: its constant, or what its connection supplies (a texture's `rgb` read as
/// its red channel).
fn float_input(c: f32, source: Option<Source>) -> FloatInput {
    match source.map(Source::scalar) {
        None => FloatInput::Const(c),
        Some(Source::Texture(t)) => FloatInput::Texture(t),
        Some(Source::Primvar(l)) => FloatInput::Primvar(l),
        Some(Source::Fallback(fb)) => FloatInput::Const(fb[0]),
        Some(Source::Graph(e)) => FloatInput::Graph(e),
    }
}

struct Ctx<'a> {
    nodes: &'a BTreeMap<String, Node>,
    textures: &'a dyn Fn(&str) -> Option<TexState>,
    used: Vec<TexKey>,
    p: Problems<'a>,
    /// MaterialX nodes read so far (a bound on the size of the graphs built).
    mtlx_nodes: u32,
    /// Operations in the expressions of the MaterialX node outputs read so far (a node
    /// reused along many paths is in its readers' expressions as many times).
    mtlx_ops: usize,
    /// What each MaterialX node output read so far supplies: a node several others use is
    /// read once.
    mtlx_read: std::collections::HashMap<(String, String), Option<Source>>,
    /// The node outputs whose expressions passed the bound on operations.
    mtlx_oversized: std::collections::HashSet<(String, String)>,
    /// The MaterialX node outputs being read, innermost last: a connection back to one of them
    /// is a cycle.
    mtlx_reading: Vec<(String, String)>,
}

impl Ctx<'_> {
    fn input_f32(&mut self, node: &str, name: &str, default: f32) -> f32 {
        match self.nodes[node].inputs.get(name) {
            None => default,
            Some(v) => match v.as_f64() {
                Some(x) if x.is_finite() => x as f32,
                _ => {
                    self.p.add(&format!("{}.inputs:{}", node, name), format!("expected a finite number, got {}; using {}", v.kind(), default));
                    default
                }
            },
        }
    }

    fn input_vec<const N: usize>(&mut self, node: &str, name: &str, default: [f32; N]) -> [f32; N] {
        match self.nodes[node].inputs.get(name) {
            None => default,
            Some(v) => match v.to_f32s() {
                Some(x) if x.len() == N && x.iter().all(|c| c.is_finite()) => std::array::from_fn(|i| x[i]),
                Some(x) if x.len() == 1 && x[0].is_finite() => [x[0]; N],
                _ => {
                    self.p.add(&format!("{}.inputs:{}", node, name), format!("expected {} finite numbers, got {}; using {:?}", N, v.kind(), default));
                    default
                }
            },
        }
    }

    fn input_token<'s>(&mut self, node: &str, name: &str, allowed: &[&'s str], default: &'s str) -> &'s str {
        match self.nodes[node].inputs.get(name).and_then(|v| v.as_str()) {
            None => default,
            Some("") => default,
            Some(s) => match allowed.iter().find(|a| **a == s) {
                Some(a) => a,
                None => {
                    self.p.add(&format!("{}.inputs:{}", node, name), format!("unknown token '{}' (expected one of {}); using '{}'", s, allowed.join(", "), default));
                    default
                }
            },
        }
    }

    /// A wrap-mode input: the wrap of its token among `modes`, of `default` when unauthored
    /// or unknown (reported).
    fn wrap_input(&mut self, node: &str, input: &str, modes: &[(&'static str, Option<WrapKey>)], default: &'static str) -> Option<WrapKey> {
        let names: Vec<&'static str> = modes.iter().map(|m| m.0).collect();
        let token = self.input_token(node, input, &names, default);
        modes.iter().find(|m| m.0 == token).map_or(Some(WrapKey::Repeat), |m| m.1)
    }

    /// A node's id; MaterialX's UsdPreviewSurface nodes read as the USD ones.
    fn node_id(&self, node: &str) -> Option<&str> {
        self.nodes.get(node).and_then(|n| n.id.as_deref()).map(mtlx::canonical_id)
    }

    /// What the connection of `node.input` supplies; `None` if not connected or unusable (a
    /// problem is recorded and the caller uses its constant).
    fn source(&mut self, node: &str, input: &str) -> Option<Source> {
        let (up, output) = self.nodes[node].connects.get(input)?.clone();
        self.connection(&format!("{}.inputs:{}", node, input), &up, &output)
    }

    /// What output `output` of node `up`, connected to the attribute `attr`, supplies: a
    /// UsdUVTexture's lookup (or its fallback), or a UsdPrimvarReader's primvar.
    fn connection(&mut self, attr: &str, up: &str, output: &str) -> Option<Source> {
        self.connection_at(attr, up, output, 0)
    }

    /// [`Ctx::connection`], `depth` nodes down a chain of MaterialX `dot` nodes.
    fn connection_at(&mut self, attr: &str, up: &str, output: &str, depth: u32) -> Option<Source> {
        if !self.nodes.contains_key(up) {
            self.p.add(attr, format!("connected to '{}', which is not a node of this material; using the constant value", up));
            return None;
        }
        match self.node_id(up) {
            Some(id) if mtlx::is_mtlx_node(id) => return self.mtlx_source(attr, up, output, depth),
            Some("UsdUVTexture") => {}
            Some(id) if id.starts_with("UsdPrimvarReader_") && id != "UsdPrimvarReader_string" => {
                if output != "result" {
                    self.p.add(attr, format!("unknown {} output '{}'; using the constant value", id, output));
                    return None;
                }
                return Some(Source::Primvar(self.primvar_reader(up)));
            }
            other => {
                self.p.add(
                    attr,
                    format!("connected to a '{}' node; only UsdUVTexture, UsdPrimvarReader and MaterialX image, geompropvalue, constant and dot outputs are supported here; using the constant value", other.unwrap_or("")),
                );
                return None;
            }
        }
        let channel = match output {
            "rgb" => Channel::Rgb,
            "r" => Channel::R,
            "g" => Channel::G,
            "b" => Channel::B,
            "a" => Channel::A,
            other => {
                self.p.add(attr, format!("unknown UsdUVTexture output '{}'; using the constant value", other));
                return None;
            }
        };
        Some(match self.uv_texture(up, channel) {
            Ok(t) => Source::Texture(t),
            // the fallback stands for the texture's texel: each output its own channel
            Err(fb) => Source::Fallback(tide_core::texture::channel_rgba(fb, channel)),
        })
    }

    /// A UsdPrimvarReader: the primvar its `varname` names, and its `fallback` (a scalar
    /// fills three components, as the primvar's own value does).
    fn primvar_reader(&mut self, node: &str) -> PrimvarLookup {
        let name = self.nodes[node].inputs.get("varname").and_then(|v| v.as_str()).unwrap_or("").to_string();
        if name.is_empty() {
            self.p.add(&format!("{}.inputs:varname", node), "names no primvar; the reader gives its fallback");
        }
        let mut fallback = [0.0; 4];
        match self.nodes[node].inputs.get("fallback").map(|v| v.to_f32s()) {
            None => {}
            Some(Some(v)) if v.iter().all(|x| x.is_finite()) && !v.is_empty() => match v[..] {
                [x] => fallback = [x, x, x, 0.0],
                _ => v.iter().take(4).enumerate().for_each(|(i, x)| fallback[i] = *x),
            },
            Some(_) => self.p.add(&format!("{}.inputs:fallback", node), "expected finite numbers; using 0"),
        }
        PrimvarLookup::new(name, fallback)
    }

    /// UsdUVTexture `tex`: a lookup, or its fallback when the file is unavailable.
    fn uv_texture(&mut self, tex: &str, channel: Channel) -> Result<TexLookup, [f32; 4]> {
        // useMetadata (the default): the file's own wrap mode, black where it names none
        // (UsdUVTexture; Storm's sampler does the same)
        let modes = [("repeat", Some(WrapKey::Repeat)), ("mirror", Some(WrapKey::Mirror)), ("clamp", Some(WrapKey::Clamp)), ("black", Some(WrapKey::Black)), ("useMetadata", None)];
        let wrap_s = self.wrap_input(tex, "wrapS", &modes, "useMetadata");
        let wrap_t = self.wrap_input(tex, "wrapT", &modes, "useMetadata");
        let fallback = self.input_vec(tex, "fallback", [0.0, 0.0, 0.0, 1.0]);
        let tex_scale = self.input_vec(tex, "scale", [1.0; 4]);
        let bias = self.input_vec(tex, "bias", [0.0; 4]);
        // sourceColorSpace `raw` or `sRGB` says how the file is encoded; `auto` leaves it to the
        // file attribute's colour space metadata, else to the file (8-bit RGB is sRGB)
        let encoding = match self.input_token(tex, "sourceColorSpace", &["auto", "raw", "sRGB"], "auto") {
            "raw" => Encoding::Raw,
            "sRGB" => Encoding::Srgb,
            _ => self.file_color_space(tex, "file"),
        };
        let (transform, uv_set) = self.st_transform(tex);
        let Some(texture) = self.texture_slot(tex, "file", encoding, wrap_s, wrap_t, Default::default()) else { return Err(fallback) };
        Ok(TexLookup { texture, channel, transform, tex_scale, bias, fallback, uv_set })
    }

    /// The encoding the colour space metadata of input `file` of node `tex` names (USD's
    /// `colorSpace` on the asset attribute, handed on as `colorSpace:<input>`, as UsdImaging
    /// does); `Auto` where there is none, or a name no colour space has (a problem).
    pub(super) fn file_color_space(&mut self, tex: &str, file: &str) -> Encoding {
        let name = self.nodes[tex].inputs.get(&format!("colorSpace:{file}")).and_then(|v| v.as_str());
        Encoding::from_metadata(name).unwrap_or_else(|why| {
            self.p.add(&format!("{tex}.inputs:{file}"), why);
            Encoding::Auto
        })
    }

    /// The texture that input `file` of node `tex` names, as an index into this material's list
    /// (`encoding`: how its values are decoded; a wrap of None: the file's metadata's, else
    /// black; `closest`: unfiltered texels); None when there is no usable file (a problem names
    /// the input, but for an empty path).
    fn texture_slot(&mut self, tex: &str, file: &str, encoding: Encoding, wrap_s: Option<WrapKey>, wrap_t: Option<WrapKey>, filter: tide_core::scene::Filter) -> Option<usize> {
        let file_attr = format!("{}.inputs:{}", tex, file);
        let Some(asset) = self.nodes[tex].inputs.get(file).and_then(|v| v.as_str()).map(String::from) else {
            self.p.add(&file_attr, "no texture file; using the fallback value");
            return None;
        };
        if asset.is_empty() {
            return None;
        }
        let file_wrap = match (self.textures)(&asset) {
            None => {
                self.p.add(&file_attr, format!("texture '{}' was not provided; using the fallback value", asset));
                return None;
            }
            Some(TexState::Failed(msg)) => {
                self.p.add(&file_attr, format!("texture '{}' could not be read ({}); using the fallback value", asset, msg));
                return None;
            }
            Some(TexState::Loaded { file_wrap, .. }) => file_wrap,
        };
        let wrap_s = wrap_s.or(file_wrap[0]).unwrap_or(WrapKey::Black);
        let wrap_t = wrap_t.or(file_wrap[1]).unwrap_or(WrapKey::Black);
        let key = TexKey { asset, wrap_s, wrap_t, encoding, dome: DomeFormat::LatLong, filter };
        Some(match self.used.iter().position(|k| *k == key) {
            Some(i) => i,
            None => {
                self.used.push(key);
                self.used.len() - 1
            }
        })
    }

    /// The `st` input of a texture: a primvar reader, optionally through UsdTransform2d. The
    /// mesh's texture coordinates (`st`, `st0` or `uv`) are `uvs`; another primvar is a uv set.
    fn st_transform(&mut self, tex: &str) -> (Affine2, Option<PrimvarLookup>) {
        let mut transform = Affine2::IDENTITY;
        let Some((mut up, _)) = self.nodes[tex].connects.get("st").cloned() else { return (transform, None) };
        if self.node_id(&up) == Some("UsdTransform2d") {
            let scale = Vec2::from(self.input_vec(&up, "scale", [1.0, 1.0]));
            let translation = Vec2::from(self.input_vec(&up, "translation", [0.0, 0.0]));
            let rotation = self.input_f32(&up, "rotation", 0.0).to_radians();
            transform = Affine2::from_scale_angle_translation(scale, rotation, translation);
            match self.nodes[&up].connects.get("in").cloned() {
                Some((u, _)) => up = u,
                None => return (transform, None),
            }
        }
        let uv_set = match self.node_id(&up) {
            Some(id) if id.starts_with("UsdPrimvarReader_") => uv_set(self.primvar_reader(&up)),
            other => {
                self.p.add(&format!("{}.inputs:st", tex), format!("st comes from a '{}' node; using the mesh's st", other.unwrap_or("unknown")));
                None
            }
        };
        (transform, uv_set)
    }

    fn color(&mut self, node: &str, name: &str, default: [f32; 3]) -> ColorInput {
        let c = self.input_vec(node, name, default);
        self.source(node, name).map_or(ColorInput::Const(c), Source::into_color)
    }

    fn float(&mut self, node: &str, name: &str, default: f32) -> FloatInput {
        let c = self.input_f32(node, name, default);
        float_input(c, self.source(node, name))
    }

    fn preview(&mut self, n: &str) -> PreviewSurfaceDesc {
        let d = PreviewSurfaceDesc::default();
        // a tangent-space normal from a texture, a primvar, a node graph or a constant; straight
        // up (the fallback) turns nothing
        let normal = match self.source(n, "normal") {
            Some(Source::Texture(mut t)) => {
                t.channel = Channel::Rgb;
                Some(ColorInput::Texture(t))
            }
            Some(s @ (Source::Primvar(_) | Source::Graph(_))) => Some(s.into_color()),
            _ => Some(ColorInput::Const(self.input_vec(n, "normal", [0.0, 0.0, 1.0]))).filter(|c| *c != ColorInput::Const([0.0, 0.0, 1.0])),
        };
        PreviewSurfaceDesc {
            diffuse_color: self.color(n, "diffuseColor", [0.18; 3]),
            emissive_color: self.color(n, "emissiveColor", [0.0; 3]),
            use_specular_workflow: self.input_f32(n, "useSpecularWorkflow", 0.0) != 0.0,
            specular_color: self.color(n, "specularColor", [0.0; 3]),
            metallic: self.float(n, "metallic", 0.0),
            roughness: self.float(n, "roughness", 0.5),
            clearcoat: self.float(n, "clearcoat", 0.0),
            clearcoat_roughness: self.float(n, "clearcoatRoughness", 0.01),
            opacity: self.float(n, "opacity", 1.0),
            opacity_threshold: self.input_f32(n, "opacityThreshold", d.opacity_threshold),
            ior: self.input_f32(n, "ior", d.ior),
            normal,
            wet: None,
            extras: None,
        }
    }

    fn water(&mut self, n: &str) -> WaterDesc {
        let d = WaterDesc::default();
        let model = self.input_token(n, "surfaceModel", &["dielectric", "sea"], "dielectric");
        use tide_core::water::{IOR_SALINITY_RANGE as S, IOR_TEMPERATURE_RANGE as T};
        // values outside what the models take are named on the shader and replaced by the
        // defaults; a wind past the sea BSDF's range is held at its top
        let max_wind = tide_core::bsdf::sea::MAX_WIND_SPEED;
        let mut wind_speed = self.checked_f32(n, "windSpeed", d.wind_speed, |v| v.is_finite() && v >= 0.0, "[0, ∞) m/s");
        if wind_speed > max_wind {
            self.p.add(&format!("{}.inputs:windSpeed", n), format!("{} m/s is past the sea surface model's {} m/s; using {}", wind_speed, max_wind, max_wind));
            wind_speed = max_wind;
        }
        WaterDesc {
            ior: self.checked_f32(n, "ior", d.ior, |v| (1.0..10.0).contains(&v), "[1, 10)"),
            dispersion: self.nodes[n].inputs.get("dispersion").and_then(|v| v.as_bool()).unwrap_or(false),
            temperature: self.checked_f32(n, "temperature", d.temperature, |v| (T.0..=T.1).contains(&v), &format!("[{}, {}] °C", T.0, T.1)),
            salinity: self.checked_f32(n, "salinity", d.salinity, |v| (S.0..=S.1).contains(&v), &format!("[{}, {}] PSU", S.0, S.1)),
            roughness: self.checked_f32(n, "roughness", d.roughness, |v| (0.0..=1.0).contains(&v), "[0, 1]"),
            surface_model: if model == "sea" { SurfaceModel::Sea } else { SurfaceModel::Dielectric },
            wind_speed,
            wind_direction: self.input_f32(n, "windDirection", d.wind_direction),
            priority: self.input_f32(n, "priority", 0.0) as i32,
            ..d
        }
    }

    /// A float input that must satisfy `ok`; otherwise a problem and `default`.
    fn checked_f32(&mut self, node: &str, name: &str, default: f32, ok: impl Fn(f32) -> bool, expected: &str) -> f32 {
        let v = self.input_f32(node, name, default);
        if ok(v) {
            v
        } else {
            self.p.add(&format!("{}.inputs:{}", node, name), format!("{} is outside {}; using {}", v, expected, default));
            default
        }
    }

    /// TideMedium (contract §3). `salinity` is the enclosing TideWater's (PSU), for the
    /// scattering of pure seawater.
    ///
    /// * `jerlovType` set: the type's spectral IOPs from `jerlovSource` replace `absorption`
    ///   and `scattering` (authored non-zero RGB is reported and ignored). A type the source
    ///   does not tabulate (Williamson 2022 lacks I, IA, 7C, 9C) falls back to solonenko2015
    ///   with a problem.
    /// * `chlorophyll`, `cdom`, `spm` (and the chlorophyll profile `profileDepth/Width/Peak`,
    ///   depth in m below the water's top) switch on the bio-optical model: pure seawater (or
    ///   the Jerlov type) plus the constituents, added to the RGB coefficients.
    /// * `densityScale` multiplies everything. `phase` `hg`/`dualHG` stay analytic unless
    ///   `molecularWeight` > 0; `fournierForand` and `petzold` (and any molecular mixture) are
    ///   tabulated (`PhaseDesc::Tabulated`).
    /// * `method`: `volumetric` (default, path-traced) or `diffusion` (the classical dipole
    ///   over cached surface irradiance, for optically thick bodies; see `docs/diffusion.md`).
    ///
    /// Bad tokens and out-of-range numbers give a problem naming the attribute and the
    /// contract default.
    fn medium(&mut self, n: &str, name: &str, salinity: f32) -> MediumDesc {
        use tide_core::scene::{DepthProfileDesc, JerlovDesc, WaterIopDesc};
        use tide_core::water::{JerlovSource, JerlovType, ParticlePhase};
        let attr = |a: &str| format!("{}.inputs:{}", n, a);
        let nonneg = |v: f32| v.is_finite() && v >= 0.0;
        let sa = self.input_vec(n, "absorption", [0.0; 3]);
        let ss = self.input_vec(n, "scattering", [0.0; 3]);
        let (sa, ss) = {
            let fix = |c: [f32; 3], a: &str, p: &mut Problems| {
                if c.iter().all(|x| *x >= 0.0) {
                    c
                } else {
                    p.add(&attr(a), format!("negative coefficients {:?}; using (0, 0, 0)", c));
                    [0.0; 3]
                }
            };
            (fix(sa, "absorption", &mut self.p), fix(ss, "scattering", &mut self.p))
        };
        let scale = self.checked_f32(n, "densityScale", 1.0, nonneg, "[0, ∞)");

        // phase function
        // |g| = 1 is a delta lobe, which the phase functions do not take
        let unit = |v: f32| v.is_finite() && v.abs() < 1.0;
        let token = self.input_token(n, "phase", &["hg", "dualHG", "fournierForand", "petzold"], "hg");
        let g = self.checked_f32(n, "g", 0.0, unit, "(-1, 1)");
        let g2 = self.checked_f32(n, "g2", -0.3, unit, "(-1, 1)");
        let lobe_mix = self.checked_f32(n, "lobeMix", 0.9, |v| (0.0..=1.0).contains(&v), "[0, 1]");
        let w = self.checked_f32(n, "molecularWeight", 0.0, |v| (0.0..=1.0).contains(&v), "[0, 1]");
        let phase = ParticlePhase::from_contract(token, g, g2, lobe_mix)
            .and_then(|pp| tide_core::water::phase_desc(pp, w))
            .unwrap_or_else(|e| {
                self.p.add(&attr("phase"), format!("{}; using hg with g = {}", e, g));
                PhaseDesc::HenyeyGreenstein { g }
            });

        // Jerlov type
        let types: Vec<&str> = JerlovType::ALL.iter().map(|t| t.name()).collect();
        let jt = self.input_token(n, "jerlovType", &types, "");
        let source_token = self.input_token(n, "jerlovSource", &["williamson2022", "solonenko2015"], "williamson2022");
        let jerlov = JerlovType::parse(jt).ok().map(|water_type| {
            let mut source = JerlovSource::parse(source_token).unwrap_or_default();
            if !source.has_type(water_type) {
                self.p.add(&attr("jerlovSource"), format!("Jerlov type {} is not tabulated by {}; using solonenko2015", water_type.name(), source.name()));
                source = JerlovSource::Solonenko2015;
            }
            JerlovDesc { water_type, source }
        });
        let (sa, ss) = if jerlov.is_some() && (sa != [0.0; 3] || ss != [0.0; 3]) {
            let which = if sa != [0.0; 3] { "absorption" } else { "scattering" };
            self.p.add(&attr(which), "overridden by jerlovType; ignored");
            ([0.0; 3], [0.0; 3])
        } else {
            (sa, ss)
        };

        // bio-optical constituents
        let chlorophyll = self.checked_f32(n, "chlorophyll", 0.0, nonneg, "[0, ∞) mg/m³");
        let cdom = self.checked_f32(n, "cdom", 0.0, nonneg, "[0, ∞) g/m³");
        let spm = self.checked_f32(n, "spm", 0.0, nonneg, "[0, ∞) g/m³");
        let depth = self.input_f32(n, "profileDepth", 0.0);
        let width = self.checked_f32(n, "profileWidth", 0.0, nonneg, "[0, ∞) m");
        let peak = self.checked_f32(n, "profilePeak", 0.0, nonneg, "[0, ∞) (each constituent's unit)");
        let profile = if peak > 0.0 && width > 0.0 {
            Some(DepthProfileDesc { depth, width, peak })
        } else {
            if peak > 0.0 {
                self.p.add(&attr("profileWidth"), "is 0 while profilePeak is set: no depth profile (uniform concentration)");
            }
            None
        };
        let water = (jerlov.is_some() || chlorophyll > 0.0 || cdom > 0.0 || spm > 0.0 || profile.is_some()).then_some(WaterIopDesc {
            jerlov,
            chlorophyll,
            cdom,
            spm,
            profile,
            salinity,
            top: None,
            up: glam::Vec3::Y,
        });
        let method = match self.input_token(n, "method", &["volumetric", "diffusion"], "volumetric") {
            "diffusion" => tide_core::scene::MediumMethod::Diffusion,
            _ => tide_core::scene::MediumMethod::Volumetric,
        };
        MediumDesc { name: name.into(), sigma_a: SpectrumDesc::Rgb(sa), sigma_s: SpectrumDesc::Rgb(ss), scale, phase, water, method }
    }
}

/// The material attributes of `TideWetAPI` (contract §3).
const WET_ATTRS: [&str; 3] = ["tide:wet:amount", "tide:wet:ior", "tide:wet:waterCompliant"];

/// The material's wetness: present when any `tide:wet:` attribute arrived (the reader sends all
/// three, defaults included, for a material with `TideWetAPI` applied). `tide:wet:amount` may
/// be connected (`tide:wet:amount.connect`) to a UsdUVTexture or UsdPrimvarReader output of the
/// material: a wetness mask.
fn wetness(store: &AttrStore, ctx: &mut Ctx) -> Option<WetDesc> {
    let connect = format!("{}.connect", WET_ATTRS[0]);
    if !WET_ATTRS.iter().chain([&connect.as_str()]).any(|a| store.has(a)) {
        return None;
    }
    let p = &mut ctx.p;
    let d = WetDesc::default();
    let mut amount = store.f32_or(WET_ATTRS[0], 0.0, p);
    if !(0.0..=1.0).contains(&amount) {
        let clamped = amount.clamp(0.0, 1.0);
        p.add(WET_ATTRS[0], format!("{} is outside [0, 1]; using {}", amount, clamped));
        amount = clamped;
    }
    let mut ior = store.f32_or(WET_ATTRS[1], d.ior, p);
    if !(ior >= 1.0) {
        p.add(WET_ATTRS[1], format!("{} is below 1; using {}", ior, d.ior));
        ior = d.ior;
    }
    let water_compliant = store.bool_or(WET_ATTRS[2], d.water_compliant, p);
    let connected = store.str_opt(&connect).map(split_target);
    let source = connected.and_then(|(up, output)| ctx.connection(WET_ATTRS[0], &up, &output));
    Some(WetDesc { amount: float_input(amount, source), ior, water_compliant })
}

/// The node path of a terminal attribute (`surface`, `volume`), accepting `"/N.outputs:x"`.
fn terminal(store: &AttrStore, name: &str) -> Option<String> {
    let s = store.str_opt(name)?;
    let (node, _) = split_target(s);
    (!node.is_empty()).then_some(node)
}

/// Converts a material prim. `textures` answers what is known of an asset path.
pub fn convert_material(path: &str, store: &AttrStore, textures: &dyn Fn(&str) -> Option<TexState>, problems: &mut Problems) -> MaterialPiece {
    let nodes = parse_nodes(store);
    let mut ctx = Ctx { nodes: &nodes, textures, used: Vec::new(), p: Problems::new(problems.item), mtlx_nodes: 0, mtlx_ops: 0, mtlx_read: Default::default(), mtlx_oversized: Default::default(), mtlx_reading: Vec::new() };
    let mut desc = default_material(path);
    let surf = terminal(store, "surface");
    let vol = terminal(store, "volume");
    // the absorbing body a tinted transmission asks for (σa, RGB)
    let mut body = None;
    match &surf {
        None => {
            if vol.is_none() {
                ctx.p.add("surface", "the material has no surface or volume terminal; using the default material");
            }
        }
        Some(s) if !nodes.contains_key(s) => {
            ctx.p.add("surface", format!("terminal node '{}' has no attributes; using the default material", s));
        }
        Some(s) => match ctx.node_id(s) {
            Some("UsdPreviewSurface") => desc.surface = SurfaceDesc::Preview(ctx.preview(s)),
            Some("TideWater") => desc.surface = SurfaceDesc::Water(ctx.water(s)),
            Some("ND_standard_surface_surfaceshader") => (desc.surface, body) = ctx.pbr_surface(s, &mtlx::STANDARD_SURFACE),
            Some("ND_open_pbr_surface_surfaceshader") => (desc.surface, body) = ctx.pbr_surface(s, &mtlx::OPEN_PBR_SURFACE),
            other => {
                ctx.p.add(&format!("{}.info:id", s), format!("unknown shader id '{}'; using the default material", other.unwrap_or("")));
            }
        },
    }
    // A TideWater may name its medium through a connection of its `medium` input: the surface's
    // network then carries the medium (UsdImaging's scene delegate passes a material's volume
    // network only when it has no surface). The volume output wins where both are given.
    let linked = surf
        .as_deref()
        .filter(|s| ctx.node_id(s) == Some("TideWater"))
        .and_then(|s| nodes[s].connects.get("medium").map(|(up, _)| (s.to_string(), up.clone())));
    let vol = match (vol, linked) {
        (Some(v), Some((s, up))) => {
            if up != v {
                ctx.p.add(
                    &format!("{}.inputs:medium", s),
                    format!("connected to '{}', but the material's volume output is '{}'; using the volume output", up, v),
                );
            }
            Some(v)
        }
        (Some(v), None) => Some(v),
        (None, linked) => linked.map(|(_, up)| up),
    };
    if let Some(w) = wetness(store, &mut ctx) {
        match &mut desc.surface {
            SurfaceDesc::Preview(p) => p.wet = Some(w),
            _ if w.amount != FloatInput::Const(0.0) || !w.water_compliant => ctx.p.add(
                WET_ATTRS[0],
                "TideWetAPI covers a UsdPreviewSurface; this material's surface is not one, so it renders dry",
            ),
            _ => {}
        }
    }
    let mut medium = None;
    if let Some(v) = &vol {
        match ctx.node_id(v) {
            Some("TideMedium") => {
                let salinity = match &desc.surface {
                    SurfaceDesc::Water(w) => w.salinity,
                    _ => WaterDesc::default().salinity,
                };
                medium = Some(ctx.medium(v, path, salinity))
            }
            other => ctx.p.add(&format!("{}.info:id", v), format!("unknown volume shader id '{}'; the interior is left empty", other.unwrap_or(""))),
        }
    }
    match body {
        Some(b) if medium.is_some() => ctx.p.add(&b.attr, "the material's volume fills the body; this input is left out"),
        Some(b) => medium = Some(body_medium(path, &b)),
        None => {}
    }
    // the displacement, where it moves anything: a displacement terminal's MaterialX node, or
    // UsdPreviewSurface's own input
    let displacement = match terminal(store, "displacement").filter(|d| ctx.node_id(d) != Some("UsdPreviewSurface")) {
        Some(d) => ctx.mtlx_displacement(&d),
        None => surf.as_deref().filter(|s| ctx.node_id(s) == Some("UsdPreviewSurface")).map(|s| ctx.float(s, "displacement", 0.0)),
    }
    .filter(|d| *d != FloatInput::Const(0.0));
    problems.list.extend(ctx.p.list);
    MaterialPiece { desc, medium, textures: ctx.used, displacement }
}

/// The homogeneous medium that fills a body (path-traced).
fn body_medium(name: &str, b: &mtlx::Body) -> MediumDesc {
    MediumDesc {
        name: name.into(),
        sigma_a: SpectrumDesc::Rgb(b.sigma_a),
        sigma_s: SpectrumDesc::Rgb(b.sigma_s),
        scale: 1.0,
        phase: if b.g == 0.0 { PhaseDesc::Isotropic } else { PhaseDesc::HenyeyGreenstein { g: b.g } },
        water: None,
        method: Default::default(),
    }
}

/// Rewrites the texture indices of a graph's lookups (local list → scene list).
fn remap_graph(e: &mut Expr, map: &[usize]) {
    e.leaves_mut(&mut |leaf| {
        if let Expr::Texture(t) = leaf {
            t.texture = map[t.texture]
        }
    })
}

/// Rewrites the texture indices of a scalar input (local list → scene list).
pub fn remap_float(c: &mut FloatInput, map: &[usize]) {
    match c {
        FloatInput::Texture(t) => t.texture = map[t.texture],
        FloatInput::Graph(e) => remap_graph(e, map),
        _ => {}
    }
}

/// Rewrites texture indices of a material (local list → scene list).
pub fn remap_textures(desc: &mut MaterialDesc, map: &[usize]) {
    let fix = |t: &mut TexLookup| t.texture = map[t.texture];
    let col = |c: &mut ColorInput| match c {
        ColorInput::Texture(t) => fix(t),
        ColorInput::Graph(e) => remap_graph(e, map),
        _ => {}
    };
    let flt = |c: &mut FloatInput| remap_float(c, map);
    match &mut desc.surface {
        SurfaceDesc::Diffuse { color } => col(color),
        SurfaceDesc::Preview(p) => {
            col(&mut p.diffuse_color);
            col(&mut p.emissive_color);
            col(&mut p.specular_color);
            for f in [&mut p.metallic, &mut p.roughness, &mut p.clearcoat, &mut p.clearcoat_roughness, &mut p.opacity] {
                flt(f);
            }
            if let Some(n) = &mut p.normal {
                col(n);
            }
            if let Some(w) = &mut p.wet {
                flt(&mut w.amount);
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::value::Attr;
    use tide_core::scene::{DepthProfileDesc, JerlovDesc};
    use tide_core::shader_graph::Binary;
    use tide_core::water::{JerlovSource, JerlovType};

    pub(super) fn mat(pairs: &[(&str, Value)]) -> AttrStore {
        let mut s = AttrStore::default();
        for (n, v) in pairs {
            s.attrs.insert(normalize_name(n).to_string(), Attr { value: Some(v.clone()), samples: vec![] });
        }
        s
    }
    pub(super) fn tok(s: &str) -> Value {
        Value::Token(s.into())
    }
    /// Converts material `/M` of the attributes `base` and then `extra` (a later one wins):
    /// the piece and the attributes of the problems it raised.
    pub(super) fn convert(base: &[(&str, Value)], extra: &[(&str, Value)]) -> (MaterialPiece, Vec<String>) {
        let pairs: Vec<(&str, Value)> = base.iter().chain(extra).cloned().collect();
        let mut p = Problems::new("/M");
        let m = convert_material("/M", &mat(&pairs), &loaded(false), &mut p);
        (m, p.list.into_iter().map(|q| q.attribute).collect())
    }
    /// A hit whose primvar `x` is `x` and whose texture coordinates, positions, normals and
    /// tangents (in the object's space, then the world's) are the fields'; it reads no texture.
    pub(super) struct FixedHit {
        pub x: [f32; 4],
        pub uv: Vec2,
        pub object: glam::Vec3,
        pub world: glam::Vec3,
        pub normal: [glam::Vec3; 2],
        pub tangent: [glam::Vec3; 2],
    }

    impl tide_core::shader_graph::Lookups for FixedHit {
        fn texture(&self, _: &TexLookup, _: Vec2) -> [f32; 4] {
            unreachable!("no texture here")
        }
        fn primvar(&self, l: &PrimvarLookup) -> [f32; 4] {
            assert_eq!(l.name, "x");
            std::array::from_fn(|k| self.x[k] * l.scale[k])
        }
        fn uv(&self) -> Vec2 {
            self.uv
        }
        fn position(&self, world: bool) -> glam::Vec3 {
            if world { self.world } else { self.object }
        }
        fn normal(&self, world: bool) -> glam::Vec3 {
            self.normal[usize::from(world)]
        }
        fn tangent(&self, world: bool) -> glam::Vec3 {
            self.tangent[usize::from(world)]
        }
    }

    pub(super) fn loaded(srgb: bool) -> impl Fn(&str) -> Option<TexState> {
        move |a: &str| {
            (a == "/tex/albedo.png").then(|| TexState::Loaded { width: 2, height: 2, channels: 3, pixels: Default::default(), is_srgb: srgb, file_wrap: [None; 2] })
        }
    }

    /// A texture that cannot be read gives its fallback as it would its texel: each output its
    /// own channel (`a` feeding a float input or a colour, `g` a float).
    #[test]
    fn a_missing_textures_fallback_answers_each_output_with_its_channel() {
        let s = mat(&[
            ("surface", Value::Path("/M/PBR.outputs:surface".into())),
            ("/M/PBR.info:id", tok("UsdPreviewSurface")),
            ("/M/PBR.inputs:opacity.connect", tok("/M/Tex.outputs:a")),
            ("/M/PBR.inputs:roughness.connect", tok("/M/Tex.outputs:g")),
            ("/M/PBR.inputs:emissiveColor.connect", tok("/M/Tex.outputs:a")),
            ("/M/PBR.inputs:diffuseColor.connect", tok("/M/Tex.outputs:rgb")),
            ("/M/Tex.info:id", tok("UsdUVTexture")),
            ("/M/Tex.inputs:file", Value::Asset("/tex/missing.png".into())),
            ("/M/Tex.inputs:fallback", Value::Floats { data: vec![0.1, 0.2, 0.3, 0.4], tuple: 4 }),
        ]);
        let mut p = Problems::new("/M");
        let m = convert_material("/M", &s, &loaded(false), &mut p);
        let SurfaceDesc::Preview(ps) = &m.desc.surface else { panic!() };
        assert_eq!(ps.opacity, FloatInput::Const(0.4));
        assert_eq!(ps.roughness, FloatInput::Const(0.2));
        assert_eq!(ps.emissive_color, ColorInput::Const([0.4; 3]));
        assert_eq!(ps.diffuse_color, ColorInput::Const([0.1, 0.2, 0.3]));
    }

    /// A constant `normal` turns the shading frame as a texture's does; straight up (the
    /// fallback) is no normal at all.
    #[test]
    fn a_constant_tilted_normal_is_kept() {
        for (n, kept) in [([0.8, 0.0, 0.6], true), ([0.0, 0.0, 1.0], false)] {
            let s = mat(&[
                ("surface", Value::Path("/M/PBR.outputs:surface".into())),
                ("/M/PBR.info:id", tok("UsdPreviewSurface")),
                ("/M/PBR.inputs:normal", Value::Floats { data: n.to_vec(), tuple: 3 }),
            ]);
            let mut p = Problems::new("/M");
            let m = convert_material("/M", &s, &loaded(false), &mut p);
            let SurfaceDesc::Preview(ps) = &m.desc.surface else { panic!() };
            assert_eq!(ps.normal, kept.then_some(ColorInput::Const(n)));
            assert!(p.list.is_empty(), "{:?}", p.list);
        }
    }

    #[test]
    fn use_metadata_wrap_follows_the_files_metadata_else_black() {
        assert_eq!(file_wrap_modes(""), [None, None]);
        assert_eq!(file_wrap_modes("periodic"), [Some(WrapKey::Repeat); 2]);
        assert_eq!(file_wrap_modes("clamp,mirror"), [Some(WrapKey::Clamp), Some(WrapKey::Mirror)]);
        assert_eq!(file_wrap_modes("default,black"), [None, Some(WrapKey::Black)]);
        assert_eq!(file_wrap_modes("periodic_pow2,bogus"), [Some(WrapKey::Repeat), None]);
        let s = mat(&[
            ("surface", Value::Path("/M/PBR.outputs:surface".into())),
            ("/M/PBR.info:id", tok("UsdPreviewSurface")),
            ("/M/PBR.inputs:diffuseColor.connect", tok("/M/Tex.outputs:rgb")),
            ("/M/Tex.info:id", tok("UsdUVTexture")),
            ("/M/Tex.inputs:file", Value::Asset("/tex/albedo.png".into())),
            ("/M/Tex.inputs:wrapT", tok("mirror")),
        ]);
        // wrapS unauthored: the file's opinion; an authored wrapT overrides the file's
        for (metadata, want_s) in [("", WrapKey::Black), ("clamp,periodic", WrapKey::Clamp), ("periodic", WrapKey::Repeat), ("default,clamp", WrapKey::Black)] {
            let file_wrap = file_wrap_modes(metadata);
            let textures = |a: &str| {
                (a == "/tex/albedo.png").then(|| TexState::Loaded { width: 1, height: 1, channels: 3, pixels: Default::default(), is_srgb: false, file_wrap })
            };
            let m = convert_material("/M", &s, &textures, &mut Problems::new("/M"));
            assert_eq!((m.textures[0].wrap_s, m.textures[0].wrap_t), (want_s, WrapKey::Mirror), "metadata {metadata:?}");
        }
    }

    #[test]
    fn preview_surface_with_texture_connection_through_transform2d() {
        let s = mat(&[
            ("surface", Value::Path("/M/PBR.outputs:surface".into())),
            ("/M/PBR.info:id", tok("UsdPreviewSurface")),
            ("/M/PBR.inputs:diffuseColor.connect", tok("/M/Tex.outputs:rgb")),
            ("/M/PBR.inputs:roughness", Value::Float(0.25)),
            ("/M/PBR.inputs:metallic.connect", tok("/M/Tex.outputs:a")),
            ("/M/PBR.inputs:ior", Value::Float(1.4)),
            ("/M/Tex.info:id", tok("UsdUVTexture")),
            ("/M/Tex.inputs:file", Value::Asset("/tex/albedo.png".into())),
            ("/M/Tex.inputs:wrapS", tok("clamp")),
            ("/M/Tex.inputs:scale", Value::Floats { data: vec![2.0, 2.0, 2.0, 1.0], tuple: 4 }),
            ("/M/Tex.inputs:st.connect", tok("/M/Xf.outputs:result")),
            ("/M/Xf.info:id", tok("UsdTransform2d")),
            ("/M/Xf.inputs:rotation", Value::Float(90.0)),
            ("/M/Xf.inputs:scale", Value::Floats { data: vec![3.0, 4.0], tuple: 2 }),
            ("/M/Xf.inputs:in.connect", tok("/M/Uv.outputs:result")),
            ("/M/Uv.info:id", tok("UsdPrimvarReader_float2")),
            ("/M/Uv.inputs:varname", tok("st")),
        ]);
        let mut p = Problems::new("/M");
        let m = convert_material("/M", &s, &loaded(true), &mut p);
        assert!(p.list.is_empty(), "{:?}", p.list);
        // wrapT unauthored (useMetadata) on a file without wrap metadata: black
        assert_eq!(m.textures, vec![TexKey { asset: "/tex/albedo.png".into(), wrap_s: WrapKey::Clamp, wrap_t: WrapKey::Black, encoding: Encoding::Auto, dome: DomeFormat::LatLong, filter: Default::default() }]);
        let SurfaceDesc::Preview(ps) = &m.desc.surface else { panic!() };
        let ColorInput::Texture(t) = &ps.diffuse_color else { panic!("{:?}", ps.diffuse_color) };
        assert_eq!((t.texture, t.channel), (0, Channel::Rgb));
        // UsdTransform2d: (1, 0) scaled by (3, 4), turned 90° counter-clockwise
        assert!((t.transform.transform_vector2(Vec2::X) - Vec2::new(0.0, 3.0)).length() < 1e-6, "{:?}", t.transform);
        assert_eq!(t.tex_scale, [2.0, 2.0, 2.0, 1.0]);
        let FloatInput::Texture(tm) = &ps.metallic else { panic!() };
        assert_eq!((tm.texture, tm.channel), (0, Channel::A));
        assert_eq!(ps.roughness, FloatInput::Const(0.25));
        assert_eq!(ps.ior, 1.4);
    }

    #[test]
    fn unknown_shader_id_gives_default_material_and_problem() {
        let s = mat(&[("surface", Value::Path("/M/S".into())), ("/M/S.info:id", tok("ND_standard_surface"))]);
        let mut p = Problems::new("/M");
        let m = convert_material("/M", &s, &loaded(false), &mut p);
        assert_eq!(m.desc, default_material("/M"));
        assert_eq!(p.list.len(), 1);
        assert_eq!((p.list[0].item.as_str(), p.list[0].attribute.as_str()), ("/M", "/M/S.info:id"));
    }

    #[test]
    fn missing_texture_uses_fallback_with_problem() {
        let s = mat(&[
            ("surface", Value::Path("/M/PBR".into())),
            ("/M/PBR.info:id", tok("UsdPreviewSurface")),
            ("/M/PBR.inputs:diffuseColor.connect", tok("/M/Tex.outputs:rgb")),
            ("/M/Tex.info:id", tok("UsdUVTexture")),
            ("/M/Tex.inputs:file", Value::Asset("/tex/missing.png".into())),
            ("/M/Tex.inputs:fallback", Value::Floats { data: vec![0.5, 0.25, 0.125, 1.0], tuple: 4 }),
        ]);
        let mut p = Problems::new("/M");
        let m = convert_material("/M", &s, &loaded(false), &mut p);
        let SurfaceDesc::Preview(ps) = &m.desc.surface else { panic!() };
        assert_eq!(ps.diffuse_color, ColorInput::Const([0.5, 0.25, 0.125]));
        assert_eq!(p.list[0].attribute, "/M/Tex.inputs:file");
    }

    #[test]
    fn water_and_medium() {
        let s = mat(&[
            ("surface", Value::Path("/W/Water".into())),
            ("volume", Value::Path("/W/Med.outputs:volume".into())),
            ("/W/Water.info:id", tok("TideWater")),
            ("/W/Water.inputs:ior", Value::Float(1.34)),
            ("/W/Water.inputs:surfaceModel", tok("sea")),
            ("/W/Water.inputs:windSpeed", Value::Float(7.0)),
            ("/W/Water.inputs:priority", Value::Int(2)),
            ("/W/Water.inputs:dispersion", Value::Bool(true)),
            ("/W/Med.info:id", tok("TideMedium")),
            ("/W/Med.inputs:absorption", Value::Floats { data: vec![0.4, 0.05, 0.02], tuple: 3 }),
            ("/W/Med.inputs:phase", tok("dualHG")),
            ("/W/Med.inputs:g", Value::Float(0.9)),
            ("/W/Med.inputs:jerlovType", tok("IB")),
        ]);
        let mut p = Problems::new("/W");
        let m = convert_material("/W", &s, &loaded(false), &mut p);
        let SurfaceDesc::Water(w) = &m.desc.surface else { panic!() };
        assert_eq!((w.ior, w.surface_model, w.wind_speed, w.priority, w.dispersion), (1.34, SurfaceModel::Sea, 7.0, 2, true));
        let med = m.medium.unwrap();
        // jerlovType overrides the RGB coefficients (reported), the IOPs come from the type
        assert_eq!(med.sigma_a, SpectrumDesc::Rgb([0.0; 3]));
        assert_eq!(med.phase, PhaseDesc::DualHg { g1: 0.9, g2: -0.3, w: 0.9 });
        let water = med.water.expect("Jerlov IOPs");
        assert_eq!(water.jerlov, Some(JerlovDesc { water_type: JerlovType::IB, source: JerlovSource::Williamson2022 }));
        assert_eq!(p.list.len(), 1, "{:?}", p.list);
        assert_eq!(p.list[0].attribute, "/W/Med.inputs:absorption");
        assert!(p.list[0].message.contains("overridden by jerlovType"));
    }

    /// TideWetAPI's material attributes reach the preview surface; bad values are clamped or
    /// replaced and named; a TideWater surface renders dry and says so.
    #[test]
    fn wetness_from_the_material_attributes() {
        let conv = |surface: &str, extra: &[(&'static str, Value)]| {
            let mut pairs = vec![("surface", Value::Path("/M/S".into())), ("/M/S.info:id", tok(surface))];
            pairs.extend_from_slice(extra);
            let mut p = Problems::new("/M");
            let m = convert_material("/M", &mat(&pairs), &loaded(false), &mut p);
            let wet = match m.desc.surface {
                SurfaceDesc::Preview(ps) => ps.wet,
                _ => None,
            };
            (wet, p.list.into_iter().map(|q| (q.attribute, q.message)).collect::<Vec<_>>())
        };
        assert_eq!(conv("UsdPreviewSurface", &[]), (None, vec![]));
        let (w, p) = conv("UsdPreviewSurface", &[("tide:wet:amount", Value::Float(0.7))]);
        assert_eq!(w, Some(WetDesc { amount: FloatInput::Const(0.7), ..WetDesc::default() }));
        assert!(p.is_empty(), "{p:?}");
        let (w, p) = conv(
            "UsdPreviewSurface",
            &[("tide:wet:amount", Value::Float(1.5)), ("tide:wet:ior", Value::Float(0.5)), ("tide:wet:waterCompliant", Value::Bool(false))],
        );
        assert_eq!(w, Some(WetDesc { amount: FloatInput::Const(1.0), ior: 1.333, water_compliant: false }));
        let names: Vec<&str> = p.iter().map(|(a, _)| a.as_str()).collect();
        assert_eq!(names, ["tide:wet:amount", "tide:wet:ior"], "{p:?}");
        let (w, p) = conv("TideWater", &[("tide:wet:amount", Value::Float(0.5))]);
        assert_eq!(w, None);
        assert_eq!(p.len(), 1, "{p:?}");
        assert_eq!(p[0].0, "tide:wet:amount");
        // a mask: the amount connected to a texture channel or to a primvar reader
        let tex = [("/M/Mask.info:id", tok("UsdUVTexture")), ("/M/Mask.inputs:file", Value::Asset("/tex/albedo.png".into()))];
        let mut pairs = vec![("tide:wet:amount", Value::Float(0.2)), ("tide:wet:amount.connect", tok("/M/Mask.outputs:g"))];
        pairs.extend_from_slice(&tex);
        let (w, p) = conv("UsdPreviewSurface", &pairs);
        assert!(p.is_empty(), "{p:?}");
        match w.map(|w| w.amount) {
            Some(FloatInput::Texture(t)) => assert_eq!((t.texture, t.channel), (0, Channel::G)),
            other => panic!("{other:?}"),
        }
        let (w, p) = conv(
            "UsdPreviewSurface",
            &[
                ("tide:wet:amount.connect", tok("/M/Wet.outputs:result")),
                ("/M/Wet.info:id", tok("UsdPrimvarReader_float")),
                ("/M/Wet.inputs:varname", tok("wetness")),
                ("/M/Wet.inputs:fallback", Value::Float(0.25)),
            ],
        );
        assert!(p.is_empty(), "{p:?}");
        assert_eq!(w.map(|w| w.amount), Some(FloatInput::Primvar(PrimvarLookup::new("wetness", [0.25, 0.25, 0.25, 0.0]))));
        // a connection to no node of the material keeps the constant, and says so
        let (w, p) = conv("UsdPreviewSurface", &[("tide:wet:amount", Value::Float(0.4)), ("tide:wet:amount.connect", tok("/Elsewhere/T.outputs:r"))]);
        assert_eq!(w.map(|w| w.amount), Some(FloatInput::Const(0.4)));
        assert_eq!(p.iter().map(|(a, _)| a.as_str()).collect::<Vec<_>>(), ["tide:wet:amount"], "{p:?}");
    }

    /// MaterialX standard_surface: its inputs as UsdPreviewSurface's (weights folded into
    /// constants and texture scales), its nodes as lookups, what it cannot carry reported.
    /// Standard Surface by its versioned id renders as the unversioned one; a texcoord node's
    /// second uv set is named (the first is read).
    #[test]
    fn versioned_standard_surface_and_a_texcoord_index_are_handled() {
        let s = mat(&[
            ("surface", Value::Path("/M/SR".into())),
            ("/M/SR.info:id", tok("ND_standard_surface_surfaceshader_100")),
            ("/M/SR.inputs:base_color.connect", tok("/M/Uv3.outputs:out")),
            ("/M/Uv3.info:id", tok("ND_convert_vector2_color3")),
            ("/M/Uv3.inputs:in.connect", tok("/M/Uv.outputs:out")),
            ("/M/Uv.info:id", tok("ND_texcoord_vector2")),
            ("/M/Uv.inputs:index", Value::Int(1)),
        ]);
        let mut p = Problems::new("/M");
        let m = convert_material("/M", &s, &loaded(false), &mut p);
        assert!(matches!(m.desc.surface, SurfaceDesc::Preview(_)), "{:?}", m.desc.surface);
        assert_eq!(p.list.iter().map(|q| q.attribute.as_str()).collect::<Vec<_>>(), ["/M/Uv.inputs:index"], "{:?}", p.list);
    }

    #[test]
    fn materialx_standard_surface_maps_to_a_preview_surface() {
        let f = |x: f64| Value::Float(x);
        let c3 = |a: [f32; 3]| Value::Floats { data: a.to_vec(), tuple: 3 };
        let s = mat(&[
            ("surface", Value::Path("/M/SR".into())),
            ("/M/SR.info:id", tok("ND_standard_surface_surfaceshader")),
            ("/M/SR.inputs:base", f(0.5)),
            ("/M/SR.inputs:base_color.connect", tok("/M/Img.outputs:out")),
            ("/M/Img.info:id", tok("ND_tiledimage_color3")),
            ("/M/Img.inputs:file", Value::Asset("/tex/albedo.png".into())),
            ("/M/Img.inputs:uaddressmode", tok("clamp")),
            ("/M/Img.inputs:uvtiling", Value::Floats { data: vec![4.0, 2.0], tuple: 2 }),
            ("/M/Img.inputs:texcoord.connect", tok("/M/Uv.outputs:out")),
            ("/M/Uv.info:id", tok("ND_geompropvalue_vector2")),
            ("/M/Uv.inputs:geomprop", Value::String("st1".into())),
            ("/M/SR.inputs:metalness", f(0.3)),
            ("/M/SR.inputs:specular_roughness.connect", tok("/M/Dot.outputs:out")),
            ("/M/Dot.info:id", tok("ND_dot_float")),
            ("/M/Dot.inputs:in.connect", tok("/M/Rough.outputs:out")),
            ("/M/Rough.info:id", tok("ND_geompropvalue_float")),
            ("/M/Rough.inputs:geomprop", Value::String("rough".into())),
            ("/M/Rough.inputs:default", f(0.4)),
            ("/M/SR.inputs:specular_IOR", f(1.4)),
            ("/M/SR.inputs:coat", f(0.2)),
            ("/M/SR.inputs:emission", f(2.0)),
            ("/M/SR.inputs:emission_color", c3([0.1, 0.2, 0.3])),
            ("/M/SR.inputs:opacity", c3([0.5, 0.5, 0.5])),
            ("/M/SR.inputs:transmission_scatter", c3([0.5, 0.5, 0.5])),
        ]);
        let mut p = Problems::new("/M");
        let m = convert_material("/M", &s, &loaded(false), &mut p);
        let SurfaceDesc::Preview(ps) = &m.desc.surface else { panic!("{:?}", m.desc.surface) };
        let ColorInput::Texture(t) = &ps.diffuse_color else { panic!("{:?}", ps.diffuse_color) };
        assert_eq!((t.channel, t.transform, t.tex_scale), (Channel::Rgb, Affine2::from_scale(Vec2::new(4.0, 2.0)), [0.5, 0.5, 0.5, 1.0]));
        assert_eq!(t.uv_set.as_ref().map(|l| l.name.as_str()), Some("st1"));
        assert_eq!((m.textures[0].wrap_s, m.textures[0].wrap_t), (WrapKey::Clamp, WrapKey::Repeat));
        assert_eq!(ps.metallic, FloatInput::Const(0.3));
        assert_eq!(ps.roughness, FloatInput::Primvar(PrimvarLookup::new("rough", [0.4, 0.4, 0.4, 0.0])));
        assert_eq!((ps.ior, ps.use_specular_workflow), (1.4, false));
        assert_eq!(ps.clearcoat, FloatInput::Const(0.2));
        assert_eq!(ps.emissive_color, ColorInput::Const([0.2, 0.4, 0.6]));
        assert_eq!(ps.opacity, FloatInput::Const(0.5));
        let attrs: Vec<&str> = p.list.iter().map(|q| q.attribute.as_str()).collect();
        assert_eq!(attrs, ["/M/SR.inputs:transmission_scatter"], "{:?}", p.list);

        // no specular on a non-metal: a plain diffuse; transmission: a clear dielectric
        let plain = mat(&[("surface", Value::Path("/M/SR".into())), ("/M/SR.info:id", tok("ND_standard_surface_surfaceshader")), ("/M/SR.inputs:specular", f(0.0))]);
        let m = convert_material("/M", &plain, &loaded(false), &mut Problems::new("/M"));
        let SurfaceDesc::Preview(ps) = &m.desc.surface else { panic!() };
        assert!(ps.use_specular_workflow && ps.specular_color == ColorInput::Const([0.0; 3]));
        assert_eq!(ps.diffuse_color, ColorInput::Const([0.8; 3]));
        // base weighs a base_color read from a primvar through the lookup's scale
        let painted = mat(&[
            ("surface", Value::Path("/M/SR".into())),
            ("/M/SR.info:id", tok("ND_standard_surface_surfaceshader")),
            ("/M/SR.inputs:base", f(0.5)),
            ("/M/SR.inputs:base_color.connect", tok("/M/Cd.outputs:out")),
            ("/M/Cd.info:id", tok("ND_geompropvalue_color3")),
            ("/M/Cd.inputs:geomprop", Value::String("displayColor".into())),
        ]);
        let mut p = Problems::new("/M");
        let m = convert_material("/M", &painted, &loaded(false), &mut p);
        assert!(p.list.is_empty(), "{:?}", p.list);
        let SurfaceDesc::Preview(ps) = &m.desc.surface else { panic!() };
        assert_eq!(ps.diffuse_color, ColorInput::Primvar(PrimvarLookup { scale: [0.5, 0.5, 0.5, 1.0], ..PrimvarLookup::new("displayColor", [0.0; 4]) }));
        let glass = mat(&[
            ("surface", Value::Path("/M/SR".into())),
            ("/M/SR.info:id", tok("ND_standard_surface_surfaceshader")),
            ("/M/SR.inputs:transmission", f(0.7)),
            ("/M/SR.inputs:specular_IOR", f(1.45)),
            ("/M/SR.inputs:specular_roughness", f(0.05)),
            ("/M/SR.inputs:transmission_color", c3([0.9, 1.0, 1.0])),
        ]);
        let mut p = Problems::new("/M");
        let m = convert_material("/M", &glass, &loaded(false), &mut p);
        // a partial transmission: the interface over 0.7 of the surface, tinted at the
        // surface, the opaque stack over the rest
        let SurfaceDesc::Water(w) = &m.desc.surface else { panic!("{:?}", m.desc.surface) };
        assert_eq!((w.ior, w.roughness, &w.tint), (1.45, 0.05, &Some(ColorInput::Const([0.9, 1.0, 1.0]))));
        let b = w.blend.as_ref().expect("an opaque share");
        assert_eq!(b.transmission, FloatInput::Const(0.7));
        assert_eq!((&b.surface.diffuse_color, &b.surface.roughness, b.surface.ior), (&ColorInput::Const([0.8; 3]), &FloatInput::Const(0.05), 1.45));
        assert!(p.list.is_empty(), "{:?}", p.list);
        assert!(m.medium.is_none());
    }

    /// MaterialX arithmetic with all operands but one constant folds into the lookup; two
    /// varying operands, or an offset primvar, become a graph evaluated at each hit.
    #[test]
    fn materialx_arithmetic_folds_into_lookups() {
        let c3 = |a: [f32; 3]| Value::Floats { data: a.to_vec(), tuple: 3 };
        let s = mat(&[
            ("surface", Value::Path("/M/SR".into())),
            ("/M/SR.info:id", tok("ND_standard_surface_surfaceshader")),
            // base_color = image x (0.5, 0.25, 1)
            ("/M/SR.inputs:base_color.connect", tok("/M/Tint.outputs:out")),
            ("/M/Tint.info:id", tok("ND_multiply_color3")),
            ("/M/Tint.inputs:in1.connect", tok("/M/Img.outputs:out")),
            ("/M/Tint.inputs:in2", c3([0.5, 0.25, 1.0])),
            ("/M/Img.info:id", tok("ND_image_color3")),
            ("/M/Img.inputs:file", Value::Asset("/tex/albedo.png".into())),
            // emission_color = mix(image, grey 0.2, 0.25) = 0.25 image + 0.15
            ("/M/SR.inputs:emission", Value::Float(1.0)),
            ("/M/SR.inputs:emission_color.connect", tok("/M/Blend.outputs:out")),
            ("/M/Blend.info:id", tok("ND_mix_color3")),
            ("/M/Blend.inputs:fg.connect", tok("/M/Img.outputs:out")),
            ("/M/Blend.inputs:bg", c3([0.2; 3])),
            ("/M/Blend.inputs:mix", Value::Float(0.25)),
            // opacity = 1 - image (an inverted mask)
            ("/M/SR.inputs:opacity.connect", tok("/M/Inv.outputs:out")),
            ("/M/Inv.info:id", tok("ND_subtract_color3")),
            ("/M/Inv.inputs:in1", c3([1.0; 3])),
            ("/M/Inv.inputs:in2.connect", tok("/M/Img.outputs:out")),
            // roughness = 2 x 0.2, folded to a constant
            ("/M/SR.inputs:specular_roughness.connect", tok("/M/Twice.outputs:out")),
            ("/M/Twice.info:id", tok("ND_multiply_float")),
            ("/M/Twice.inputs:in1", Value::Float(2.0)),
            ("/M/Twice.inputs:in2", Value::Float(0.2)),
            // metalness = primvar + 0.1: an offset primvar cannot fold; a graph
            ("/M/SR.inputs:metalness.connect", tok("/M/Off.outputs:out")),
            ("/M/Off.info:id", tok("ND_add_float")),
            ("/M/Off.inputs:in1.connect", tok("/M/Pv.outputs:out")),
            ("/M/Off.inputs:in2", Value::Float(0.1)),
            ("/M/Pv.info:id", tok("ND_geompropvalue_float")),
            ("/M/Pv.inputs:geomprop", Value::String("metal".into())),
            // coat = image x image: two varying operands; a graph
            ("/M/SR.inputs:coat.connect", tok("/M/Sq.outputs:out")),
            ("/M/Sq.info:id", tok("ND_multiply_float")),
            ("/M/Sq.inputs:in1.connect", tok("/M/Img.outputs:out")),
            ("/M/Sq.inputs:in2.connect", tok("/M/Img.outputs:out")),
        ]);
        let mut p = Problems::new("/M");
        let m = convert_material("/M", &s, &loaded(false), &mut p);
        let SurfaceDesc::Preview(ps) = &m.desc.surface else { panic!("{:?}", m.desc.surface) };
        let ColorInput::Texture(t) = &ps.diffuse_color else { panic!("{:?}", ps.diffuse_color) };
        assert_eq!((t.tex_scale, t.bias), ([0.5, 0.25, 1.0, 1.0], [0.0; 4]));
        let ColorInput::Texture(t) = &ps.emissive_color else { panic!("{:?}", ps.emissive_color) };
        assert_eq!(t.tex_scale, [0.25; 4]);
        assert!(t.bias[..3].iter().all(|b| (b - 0.15).abs() < 1e-6), "{:?}", t.bias);
        // opacity = 1 - image: a colour's coverage is the mean of its channels
        let ColorInput::Texture(lookup) = &ps.diffuse_color else { unreachable!() };
        let inverted = TexLookup { channel: Channel::Rgb, tex_scale: [-1.0; 4], bias: [1.0; 4], fallback: [1.0, 1.0, 1.0, 0.0], ..lookup.clone() };
        let FloatInput::Graph(opacity) = &ps.opacity else { panic!("{:?}", ps.opacity) };
        assert_eq!(*opacity, mtlx::channel_mean(Expr::Texture(inverted)));
        assert!(matches!(ps.roughness, FloatInput::Const(r) if (r - 0.4).abs() < 1e-6), "{:?}", ps.roughness);
        let img = Expr::Texture(TexLookup { channel: Channel::Rgb, tex_scale: [1.0; 4], bias: [0.0; 4], fallback: [0.0, 0.0, 0.0, 1.0], ..lookup.clone() });
        let metal = Expr::binary(Binary::Add, Expr::Primvar(PrimvarLookup::new("metal", [0.0; 4])), Expr::Const([0.1; 4]));
        assert_eq!(ps.metallic, FloatInput::Graph(metal));
        assert_eq!(ps.clearcoat, FloatInput::Graph(Expr::binary(Binary::Mul, img.clone(), img)));
        assert!(p.list.is_empty(), "{:?}", p.list);
    }

    /// An image's texture coordinates through MaterialX nodes fold into the lookup's
    /// transform: arithmetic by constants, `place2d` in both orders, then `tiledimage`'s own
    /// tiling, offset and real-world sizes, each as MaterialX's graphs compute them (written
    /// out here as those formulas, point by point).
    #[test]
    fn materialx_texture_coordinates_fold_into_the_lookup() {
        let f = |x: f64| Value::Float(x);
        let v2 = |a: [f32; 2]| Value::Floats { data: a.to_vec(), tuple: 2 };
        // MaterialX's rotate2d: (c·x + s·y, −s·x + c·y) for `deg` degrees
        let rot = |p: Vec2, deg: f32| {
            let (s, c) = deg.to_radians().sin_cos();
            Vec2::new(c * p.x + s * p.y, -s * p.x + c * p.y)
        };
        let (pivot, scale, offset, deg) = (Vec2::new(0.5, 0.25), Vec2::new(2.0, 4.0), Vec2::new(0.1, -0.3), 30.0);
        let srt = |p: Vec2| rot((p - pivot) / scale, deg) - offset + pivot;
        let trs = |p: Vec2| rot(p - pivot - offset, deg) / scale + pivot;
        // the image: tiledimage with tiling (3, 2), offset (0.2, 0.1), image size 2, tile size 1
        let tiled = |p: Vec2| (p * Vec2::new(3.0, 2.0) - Vec2::new(0.2, 0.1)) / 2.0;
        for (order, place) in [(0, &srt as &dyn Fn(Vec2) -> Vec2), (1, &trs)] {
            let s = mat(&[
                ("surface", Value::Path("/M/S".into())),
                ("/M/S.info:id", tok("ND_standard_surface_surfaceshader")),
                ("/M/S.inputs:base_color.connect", tok("/M/Img.outputs:out")),
                ("/M/Img.info:id", tok("ND_tiledimage_color3")),
                ("/M/Img.inputs:file", Value::Asset("/tex/albedo.png".into())),
                ("/M/Img.inputs:uvtiling", v2([3.0, 2.0])),
                ("/M/Img.inputs:uvoffset", v2([0.2, 0.1])),
                ("/M/Img.inputs:realworldimagesize", v2([2.0, 2.0])),
                ("/M/Img.inputs:texcoord.connect", tok("/M/Place.outputs:out")),
                ("/M/Place.info:id", tok("ND_place2d_vector2")),
                ("/M/Place.inputs:texcoord.connect", tok("/M/Shift.outputs:out")),
                ("/M/Place.inputs:pivot", v2(pivot.into())),
                ("/M/Place.inputs:scale", v2(scale.into())),
                ("/M/Place.inputs:offset", v2(offset.into())),
                ("/M/Place.inputs:rotate", f(deg as f64)),
                ("/M/Place.inputs:operationorder", Value::Int(order)),
                // (0.5, 1) − 2 · uv1
                ("/M/Shift.info:id", tok("ND_subtract_vector2")),
                ("/M/Shift.inputs:in1", v2([0.5, 1.0])),
                ("/M/Shift.inputs:in2.connect", tok("/M/Twice.outputs:out")),
                ("/M/Twice.info:id", tok("ND_multiply_vector2FA")),
                ("/M/Twice.inputs:in1.connect", tok("/M/Uv.outputs:out")),
                ("/M/Twice.inputs:in2", f(2.0)),
                ("/M/Uv.info:id", tok("ND_geompropvalue_vector2")),
                ("/M/Uv.inputs:geomprop", Value::String("uv1".into())),
            ]);
            let mut p = Problems::new("/M");
            let m = convert_material("/M", &s, &loaded(false), &mut p);
            assert!(p.list.is_empty(), "{:?}", p.list);
            let SurfaceDesc::Preview(ps) = &m.desc.surface else { panic!() };
            let ColorInput::Texture(t) = &ps.diffuse_color else { panic!("{:?}", ps.diffuse_color) };
            assert_eq!(t.uv_set.as_ref().map(|l| l.name.as_str()), Some("uv1"));
            for uv in [Vec2::ZERO, Vec2::new(1.0, 0.0), Vec2::new(0.3, 0.7), Vec2::new(-2.0, 5.0)] {
                let want = tiled(place(Vec2::new(0.5, 1.0) - 2.0 * uv));
                let got = t.transform.transform_point2(uv);
                assert!((got - want).length() < 1e-5, "order {order}, uv {uv}: {got} vs {want}");
            }
        }
        // a texcoord that varies otherwise (a texture's value, a warp): the image is read at
        // the coordinates computed at each hit
        let s = mat(&[
            ("surface", Value::Path("/M/S".into())),
            ("/M/S.info:id", tok("ND_standard_surface_surfaceshader")),
            ("/M/S.inputs:base_color.connect", tok("/M/Img.outputs:out")),
            ("/M/Img.info:id", tok("ND_tiledimage_color3")),
            ("/M/Img.inputs:file", Value::Asset("/tex/albedo.png".into())),
            ("/M/Img.inputs:uvtiling", Value::Floats { data: vec![4.0, 2.0], tuple: 2 }),
            ("/M/Img.inputs:texcoord.connect", tok("/M/Warp.outputs:out")),
            ("/M/Warp.info:id", tok("ND_image_vector2")),
            ("/M/Warp.inputs:file", Value::Asset("/tex/albedo.png".into())),
        ]);
        let mut p = Problems::new("/M");
        let m = convert_material("/M", &s, &loaded(false), &mut p);
        assert!(p.list.is_empty(), "{:?}", p.list);
        let SurfaceDesc::Preview(ps) = &m.desc.surface else { panic!() };
        let ColorInput::Graph(Expr::TextureAt(image, st)) = &ps.diffuse_color else { panic!("{:?}", ps.diffuse_color) };
        // the tiling still applies to the computed coordinates; the warp reads the mesh's st
        assert!(matches!(&**image, Expr::Texture(t) if t.transform == Affine2::from_scale(Vec2::new(4.0, 2.0)) && t.uv_set.is_none()), "{image:?}");
        assert!(matches!(&**st, Expr::Texture(t) if t.transform == Affine2::IDENTITY), "{st:?}");
    }

    /// OpenPBR Surface maps as standard_surface does, under its own input names and defaults.
    #[test]
    fn materialx_open_pbr_surface_maps_to_a_preview_surface() {
        let f = |x: f64| Value::Float(x);
        let c3 = |a: [f32; 3]| Value::Floats { data: a.to_vec(), tuple: 3 };
        let open_pbr = |extra: &[(&str, Value)]| convert(&[("surface", Value::Path("/M/O".into())), ("/M/O.info:id", tok("ND_open_pbr_surface_surfaceshader"))], extra);
        let (m, p) = open_pbr(&[]);
        assert!(p.is_empty(), "{p:?}");
        let SurfaceDesc::Preview(ps) = &m.desc.surface else { panic!("{:?}", m.desc.surface) };
        assert_eq!((ps.diffuse_color.clone(), ps.roughness.clone(), ps.emissive_color.clone()), (ColorInput::Const([0.8; 3]), FloatInput::Const(0.3), ColorInput::Const([0.0; 3])));
        let (m, p) = open_pbr(&[
            ("/M/O.inputs:base_weight", f(0.5)),
            ("/M/O.inputs:base_color.connect", tok("/M/Img.outputs:out")),
            ("/M/Img.info:id", tok("ND_image_color3")),
            ("/M/Img.inputs:file", Value::Asset("/tex/albedo.png".into())),
            ("/M/O.inputs:base_metalness", f(0.3)),
            ("/M/O.inputs:specular_roughness", f(0.1)),
            ("/M/O.inputs:specular_ior", f(1.4)),
            ("/M/O.inputs:coat_weight", f(0.2)),
            ("/M/O.inputs:emission_luminance", f(2.0)),
            ("/M/O.inputs:emission_color", c3([0.1, 0.2, 0.3])),
            ("/M/O.inputs:geometry_opacity", f(0.5)),
            ("/M/O.inputs:transmission_scatter", c3([0.5, 0.5, 0.5])),
        ]);
        let SurfaceDesc::Preview(ps) = &m.desc.surface else { panic!("{:?}", m.desc.surface) };
        let ColorInput::Texture(t) = &ps.diffuse_color else { panic!("{:?}", ps.diffuse_color) };
        assert_eq!(t.tex_scale, [0.5, 0.5, 0.5, 1.0]);
        assert_eq!((ps.metallic.clone(), ps.roughness.clone(), ps.ior), (FloatInput::Const(0.3), FloatInput::Const(0.1), 1.4));
        assert_eq!((ps.clearcoat.clone(), ps.clearcoat_roughness.clone()), (FloatInput::Const(0.2), FloatInput::Const(0.0)));
        assert_eq!((ps.emissive_color.clone(), ps.opacity.clone()), (ColorInput::Const([0.2, 0.4, 0.6]), FloatInput::Const(0.5)));
        assert_eq!(p, ["/M/O.inputs:transmission_scatter"]);
    }

    /// The inputs UsdPreviewSurface lacks ride along as the surface's extras: the specular's
    /// weight and tint, the coat's colour, the anisotropy (and its turn) with its model's own
    /// mapping, the diffuse roughness, the sheen (OpenPBR's fuzz); a surface that leaves them
    /// neutral has none.
    #[test]
    fn materialx_extras_map_to_the_layered_surface() {
        let f = |x: f64| Value::Float(x);
        let c3 = |a: [f32; 3]| Value::Floats { data: a.to_vec(), tuple: 3 };
        let surface = |id: &str, extra: &[(&str, Value)]| {
            let (m, p) = convert(&[("surface", Value::Path("/M/S".into())), ("/M/S.info:id", tok(id))], extra);
            let SurfaceDesc::Preview(ps) = m.desc.surface else { panic!("{:?}", m.desc.surface) };
            (ps, p)
        };
        for id in ["ND_standard_surface_surfaceshader", "ND_open_pbr_surface_surfaceshader"] {
            let (ps, p) = surface(id, &[]);
            assert!(ps.extras.is_none() && p.is_empty(), "{id}: {:?} {p:?}", ps.extras);
        }
        let (ps, p) = surface(
            "ND_standard_surface_surfaceshader",
            &[
                ("/M/S.inputs:specular", f(0.6)),
                ("/M/S.inputs:specular_color", c3([1.0, 0.5, 0.25])),
                ("/M/S.inputs:coat", f(1.0)),
                ("/M/S.inputs:coat_color", c3([0.2, 0.4, 0.8])),
                ("/M/S.inputs:specular_anisotropy.connect", tok("/M/A.outputs:out")),
                ("/M/A.info:id", tok("ND_geompropvalue_float")),
                ("/M/A.inputs:geomprop", Value::String("aniso".into())),
                ("/M/S.inputs:specular_rotation", f(0.25)),
                ("/M/S.inputs:coat_anisotropy", f(0.6)),
                ("/M/S.inputs:coat_rotation", f(0.25)),
                ("/M/S.inputs:diffuse_roughness", f(0.4)),
                ("/M/S.inputs:sheen", f(0.8)),
                ("/M/S.inputs:sheen_color", c3([0.9, 0.8, 0.7])),
                ("/M/S.inputs:thin_film_thickness", f(350.0)),
            ],
        );
        assert!(p.is_empty(), "{p:?}");
        let x = ps.extras.expect("extras");
        assert_eq!((x.specular_weight, x.specular_tint), (FloatInput::Const(0.6), ColorInput::Const([1.0, 0.5, 0.25])));
        assert_eq!((x.coat_color, x.coat_anisotropy), (ColorInput::Const([0.2, 0.4, 0.8]), FloatInput::Const(0.6)));
        assert_eq!(x.anisotropy, FloatInput::Primvar(PrimvarLookup::new("aniso", [0.0; 4])));
        assert_eq!((x.flavour, x.anisotropy_rotation), (tide_core::bsdf::PbrFlavour::StandardSurface, FloatInput::Const(0.25)));
        assert!(!ps.use_specular_workflow);
        assert_eq!((x.diffuse_roughness, x.sheen_weight), (FloatInput::Const(0.4), FloatInput::Const(0.8)));
        assert_eq!((x.sheen_color, x.sheen_roughness), (ColorInput::Const([0.9, 0.8, 0.7]), FloatInput::Const(0.3)));
        // Standard Surface's film is there where it has a thickness, in nanometres
        assert_eq!((x.thin_film_weight, x.thin_film_thickness), (FloatInput::Const(1.0), FloatInput::Const(350.0)));
        assert_eq!((x.thin_film_unit_nm, x.thin_film_ior), (1.0, 1.5));
        // the coat turns with the specular; a turn of its own is reported where the coat is
        // there and stretched
        let (_, p) = surface("ND_standard_surface_surfaceshader", &[("/M/S.inputs:coat", f(1.0)), ("/M/S.inputs:coat_anisotropy", f(0.5)), ("/M/S.inputs:coat_rotation", f(0.1))]);
        assert_eq!(p, ["/M/S.inputs:coat_rotation"]);
        let (_, p) = surface("ND_standard_surface_surfaceshader", &[("/M/S.inputs:coat_anisotropy", f(0.5)), ("/M/S.inputs:specular_rotation", f(0.1))]);
        assert!(p.is_empty(), "{p:?}");
        let (ps, p) = surface(
            "ND_open_pbr_surface_surfaceshader",
            &[
                ("/M/S.inputs:specular_roughness_anisotropy", f(0.7)),
                ("/M/S.inputs:specular_color", c3([0.5, 0.5, 0.5])),
                ("/M/S.inputs:fuzz_weight", f(1.0)),
                ("/M/S.inputs:thin_film_weight", f(1.0)),
            ],
        );
        assert!(p.is_empty(), "{p:?}");
        let x = ps.extras.expect("extras");
        assert_eq!((x.anisotropy, x.flavour), (FloatInput::Const(0.7), tide_core::bsdf::PbrFlavour::OpenPbr));
        assert_eq!((x.specular_tint, x.anisotropy_rotation), (ColorInput::Const([0.5; 3]), FloatInput::Const(0.0)));
        // fuzz is the sheen, its roughness OpenPBR's default
        assert_eq!((x.sheen_weight, x.sheen_roughness), (FloatInput::Const(1.0), FloatInput::Const(0.5)));
        // OpenPBR's film: its own weight, micrometres (0.5 by default), index 1.4
        assert_eq!((x.thin_film_weight, x.thin_film_thickness), (FloatInput::Const(1.0), FloatInput::Const(0.5)));
        assert_eq!((x.thin_film_unit_nm, x.thin_film_ior), (1000.0, 1.4));
    }

    /// Standard Surface's coat darkens and saturates the base colour (raised to 1 + coat ×
    /// coat_affect_color) and roughens the specular (mixed towards 1 by coat_affect_roughness ×
    /// coat × coat_roughness), as its graph computes them; with no coat, neither.
    #[test]
    fn materialx_coat_affects_the_base_colour_and_roughness() {
        let f = |x: f64| Value::Float(x);
        let c3 = |a: [f32; 3]| Value::Floats { data: a.to_vec(), tuple: 3 };
        let surface = |extra: &[(&str, Value)]| {
            let base = [
                ("surface", Value::Path("/M/S".into())),
                ("/M/S.info:id", tok("ND_standard_surface_surfaceshader")),
                ("/M/S.inputs:base_color", c3([0.5, 0.25, 1.0])),
                ("/M/S.inputs:coat_affect_color", f(0.5)),
                ("/M/S.inputs:coat_affect_roughness", f(1.0)),
                ("/M/S.inputs:coat_roughness", f(0.1)),
            ];
            let (m, p) = convert(&base, extra);
            assert!(p.is_empty(), "{p:?}");
            let SurfaceDesc::Preview(ps) = m.desc.surface else { panic!("{:?}", m.desc.surface) };
            (ps.diffuse_color, ps.roughness)
        };
        let (color, roughness) = surface(&[("/M/S.inputs:coat", f(1.0))]);
        let ColorInput::Const(c) = color else { panic!("{color:?}") };
        for (got, base) in c.iter().zip([0.5f32, 0.25, 1.0]) {
            assert!((got - base.powf(1.5)).abs() < 1e-6, "{c:?}");
        }
        let FloatInput::Const(r) = roughness else { panic!("{roughness:?}") };
        assert!((r - (0.2 + 0.8 * 0.1)).abs() < 1e-6, "{r}");
        assert_eq!(surface(&[]), (ColorInput::Const([0.5, 0.25, 1.0]), FloatInput::Const(0.2)));
        // a coat weight from a primvar: both become graphs of it
        let (color, roughness) = surface(&[
            ("/M/S.inputs:coat.connect", tok("/M/Coat.outputs:out")),
            ("/M/Coat.info:id", tok("ND_geompropvalue_float")),
            ("/M/Coat.inputs:geomprop", Value::String("coat".into())),
        ]);
        assert!(matches!((&color, &roughness), (ColorInput::Graph(_), FloatInput::Graph(_))), "{color:?} {roughness:?}");
    }

    /// A transmission tinted over a depth fills the body with the absorption that keeps the
    /// colour at that depth (Beer–Lambert); without a depth it tints the surface; a material's
    /// own volume wins.
    #[test]
    fn materialx_tinted_transmission_fills_the_body_with_an_absorbing_medium() {
        let f = |x: f64| Value::Float(x);
        let c3 = |a: [f32; 3]| Value::Floats { data: a.to_vec(), tuple: 3 };
        let glass = |id: &str, weight: &str, depth: f64, extra: &[(&str, Value)]| {
            let base = [
                ("surface", Value::Path("/M/G".into())),
                ("/M/G.info:id", tok(id)),
                (weight, f(1.0)),
                ("/M/G.inputs:transmission_color", c3([0.5, 0.25, 1.0])),
                ("/M/G.inputs:transmission_depth", f(depth)),
            ];
            convert(&base, extra)
        };
        // σa = −ln(colour) / depth: exp(−σa · 2) is (0.5, 0.25, 1)
        let want = [std::f32::consts::LN_2 / 2.0, 2.0 * std::f32::consts::LN_2 / 2.0, 0.0];
        for (id, weight) in [("ND_open_pbr_surface_surfaceshader", "/M/G.inputs:transmission_weight"), ("ND_standard_surface_surfaceshader", "/M/G.inputs:transmission")] {
            let (m, p) = glass(id, weight, 2.0, &[]);
            assert!(p.is_empty(), "{id}: {p:?}");
            assert!(matches!(m.desc.surface, SurfaceDesc::Water(_)), "{id}");
            let med = m.medium.expect("an absorbing body");
            let SpectrumDesc::Rgb(sa) = med.sigma_a else { panic!() };
            for k in 0..3 {
                assert!((sa[k] - want[k]).abs() < 1e-6, "{id}: {sa:?}");
            }
            assert_eq!((med.sigma_s, med.scale), (SpectrumDesc::Rgb([0.0; 3]), 1.0));
            // no depth: a tint at the surface, and a clear body
            let (m, p) = glass(id, weight, 0.0, &[]);
            assert_eq!((&m.medium, p), (&None, vec![]), "{id}");
            let SurfaceDesc::Water(w) = &m.desc.surface else { panic!() };
            assert_eq!((&w.tint, &w.blend), (&Some(ColorInput::Const([0.5, 0.25, 1.0])), &None), "{id}");
            let (m, p) = glass(id, weight, 2.0, &[("volume", Value::Path("/M/V".into())), ("/M/V.info:id", tok("TideMedium")), ("/M/V.inputs:absorption", c3([0.1; 3]))]);
            assert_eq!(m.medium.map(|v| v.sigma_a), Some(SpectrumDesc::Rgb([0.1; 3])), "{id}");
            assert_eq!(p, ["/M/G.inputs:transmission_color"], "{id}");
        }
    }

    /// What a transmitting surface keeps beside its interface: a metal, an emission or a
    /// cut-out opacity make an opaque share even at full transmission; the coat and the other
    /// layers cover only that share (reported); the extra transmission roughness adds to the
    /// specular's; a varying tint is read as such.
    #[test]
    fn materialx_transmission_keeps_what_lies_beside_it() {
        let f = |x: f64| Value::Float(x);
        let glass = |inputs: &[(&str, Value)]| {
            let (m, p) = convert(&[("surface", Value::Path("/M/G".into())), ("/M/G.info:id", tok("ND_standard_surface_surfaceshader")), ("/M/G.inputs:transmission", f(1.0))], inputs);
            let SurfaceDesc::Water(w) = m.desc.surface else { panic!("{:?}", m.desc.surface) };
            (w, p)
        };
        let (w, p) = glass(&[]);
        assert_eq!((w.roughness, &w.tint, &w.blend, p.len()), (0.2, &None, &None, 0));
        let (w, p) = glass(&[("/M/G.inputs:metalness", f(0.5))]);
        assert_eq!(w.blend.map(|b| (b.transmission, b.surface.metallic)), Some((FloatInput::Const(1.0), FloatInput::Const(0.5))));
        assert!(p.is_empty(), "{p:?}");
        let (w, _) = glass(&[("/M/G.inputs:emission", f(1.0))]);
        assert!(w.blend.is_some_and(|b| b.surface.emissive_color == ColorInput::Const([1.0; 3])));
        let (w, p) = glass(&[("/M/G.inputs:coat", f(1.0)), ("/M/G.inputs:sheen", f(0.5)), ("/M/G.inputs:transmission_extra_roughness", f(0.3))]);
        assert_eq!((w.roughness, &w.blend), (0.5, &None));
        assert_eq!(p, ["/M/G.inputs:coat", "/M/G.inputs:sheen"]);
        let (w, p) = glass(&[("/M/G.inputs:transmission_color.connect", tok("/M/C.outputs:out")), ("/M/C.info:id", tok("ND_geompropvalue_color3")), ("/M/C.inputs:geomprop", Value::String("tint".into()))]);
        assert!(matches!(w.tint, Some(ColorInput::Primvar(_))), "{:?}", w.tint);
        assert!(p.is_empty(), "{p:?}");
    }

    /// A transmission's dispersion gives the interface an Abbe number: Standard Surface's input
    /// is the number, OpenPBR's number is divided by its scale; 0 is none, a negative one is
    /// reported.
    #[test]
    fn materialx_dispersion_is_an_abbe_number() {
        let f = |x: f64| Value::Float(x);
        let abbe = |id: &str, inputs: &[(&str, Value)]| {
            let weight = if id.contains("open_pbr") { "/M/G.inputs:transmission_weight" } else { "/M/G.inputs:transmission" };
            let (m, p) = convert(&[("surface", Value::Path("/M/G".into())), ("/M/G.info:id", tok(id)), (weight, f(1.0))], inputs);
            let SurfaceDesc::Water(w) = m.desc.surface else { panic!("{:?}", m.desc.surface) };
            (w.abbe, p)
        };
        let (ss, pbr) = ("ND_standard_surface_surfaceshader", "ND_open_pbr_surface_surfaceshader");
        assert_eq!(abbe(ss, &[]), (None, vec![]));
        assert_eq!(abbe(ss, &[("/M/G.inputs:transmission_dispersion", f(40.0))]), (Some(40.0), vec![]));
        assert_eq!(abbe(ss, &[("/M/G.inputs:transmission_dispersion", f(-3.0))]), (None, vec!["/M/G.inputs:transmission_dispersion".to_string()]));
        assert_eq!(abbe(pbr, &[]), (None, vec![]));
        assert_eq!(abbe(pbr, &[("/M/G.inputs:transmission_dispersion_scale", f(0.5))]), (Some(40.0), vec![]));
        assert_eq!(abbe(pbr, &[("/M/G.inputs:transmission_dispersion_scale", f(0.5)), ("/M/G.inputs:transmission_dispersion_abbe_number", f(30.0))]), (Some(60.0), vec![]));
        assert_eq!(abbe(pbr, &[("/M/G.inputs:transmission_dispersion_scale", f(-1.0))]), (None, vec!["/M/G.inputs:transmission_dispersion_scale".to_string()]));
        // a subsurface-only surface has no transmission to disperse
        let (m, _) = convert(&[("surface", Value::Path("/M/G".into())), ("/M/G.info:id", tok(ss)), ("/M/G.inputs:subsurface", f(1.0)), ("/M/G.inputs:transmission_dispersion", f(40.0))], &[]);
        let SurfaceDesc::Water(w) = m.desc.surface else { panic!() };
        assert_eq!(w.abbe, None);
    }

    /// A thin wall has no body: a Standard Surface pane passes its transmission straight
    /// through, tinted by its colour (a depth is reported: there is no inside), and an OpenPBR
    /// leaf splits its subsurface colour into half a reflection × (1 − g) and half a
    /// translucency × (1 + g).
    #[test]
    fn materialx_thin_walls_transmit_without_a_body() {
        let f = |x: f64| Value::Float(x);
        let c3 = |a: [f32; 3]| Value::Floats { data: a.to_vec(), tuple: 3 };
        let wall = |id: &str, inputs: &[(&str, Value)]| {
            let (m, p) = convert(&[("surface", Value::Path("/M/W".into())), ("/M/W.info:id", tok(id))], inputs);
            assert!(m.medium.is_none());
            let SurfaceDesc::Preview(ps) = m.desc.surface else { panic!("{:?}", m.desc.surface) };
            (ps.extras.and_then(|x| x.thin_walled), p)
        };
        let (t, p) = wall("ND_standard_surface_surfaceshader", &[("/M/W.inputs:thin_walled", Value::Bool(true)), ("/M/W.inputs:transmission", f(0.8)), ("/M/W.inputs:transmission_color", c3([0.2, 0.4, 0.6])), ("/M/W.inputs:transmission_depth", f(1.0))]);
        let t = t.expect("a thin wall");
        assert_eq!((t.transmission, t.tint, t.subsurface), (FloatInput::Const(0.8), ColorInput::Const([0.2, 0.4, 0.6]), FloatInput::Const(0.0)));
        assert_eq!(p, ["/M/W.inputs:transmission_depth"]);
        let (t, p) = wall("ND_open_pbr_surface_surfaceshader", &[("/M/W.inputs:geometry_thin_walled", Value::Bool(true)), ("/M/W.inputs:subsurface_weight", f(1.0)), ("/M/W.inputs:subsurface_color", c3([0.4, 0.8, 0.2])), ("/M/W.inputs:subsurface_scatter_anisotropy", f(0.5))]);
        let t = t.expect("a thin wall");
        assert!(p.is_empty(), "{p:?}");
        assert_eq!((t.reflect, t.transmit), (ColorInput::Const([0.1, 0.2, 0.05]), ColorInput::Const([0.3, 0.6, 0.15])));
        assert_eq!((t.transmission, t.subsurface), (FloatInput::Const(0.0), FloatInput::Const(1.0)));
    }

    /// A subsurface fills the body with a scattering medium: σt = 1 / (radius × scale) per
    /// channel, split by the single-scattering albedo that gives the colour as the body's
    /// multiple-scattering albedo; the surface is a dielectric of the specular IOR.
    #[test]
    fn materialx_subsurface_fills_the_body_with_a_scattering_medium() {
        // Christensen and Burley's inversion: 0 at 0 (to the fit's 1e-5), 1 at 1, 0.9117 at 0.5
        assert!(mtlx::single_scattering_albedo(0.0) < 1e-5 && mtlx::single_scattering_albedo(1.0) == 1.0);
        assert!((mtlx::single_scattering_albedo(0.5) - 0.911709).abs() < 1e-5);
        let f = |x: f64| Value::Float(x);
        let c3 = |a: [f32; 3]| Value::Floats { data: a.to_vec(), tuple: 3 };
        let skin = |id: &str, inputs: &[(&str, Value)]| convert(&[("surface", Value::Path("/M/S".into())), ("/M/S.info:id", tok(id))], inputs);
        let (m, p) = skin(
            "ND_standard_surface_surfaceshader",
            &[
                ("/M/S.inputs:subsurface", f(1.0)),
                ("/M/S.inputs:subsurface_color", c3([0.0, 0.5, 1.0])),
                ("/M/S.inputs:subsurface_radius", c3([1.0, 0.5, 0.25])),
                ("/M/S.inputs:subsurface_scale", f(0.1)),
                ("/M/S.inputs:subsurface_anisotropy", f(0.3)),
                ("/M/S.inputs:specular_IOR", f(1.4)),
            ],
        );
        assert!(p.is_empty(), "{p:?}");
        assert_eq!(m.desc.surface, SurfaceDesc::Water(WaterDesc { ior: 1.4, roughness: 0.2, ..WaterDesc::default() }));
        let med = m.medium.expect("a scattering body");
        let (SpectrumDesc::Rgb(sa), SpectrumDesc::Rgb(ss)) = (med.sigma_a, med.sigma_s) else { panic!() };
        let a = mtlx::single_scattering_albedo(0.5);
        let want_t = [10.0, 20.0, 40.0];
        let want_s = [0.0, a * 20.0, 40.0];
        for k in 0..3 {
            assert!((sa[k] + ss[k] - want_t[k]).abs() < 1e-4 && (ss[k] - want_s[k]).abs() < 1e-4, "{sa:?} {ss:?}");
        }
        assert_eq!(med.phase, PhaseDesc::HenyeyGreenstein { g: 0.3 });
        // OpenPBR: its defaults (colour 0.8, radius 1 × scale (1, 0.5, 0.25)); a partial weight
        // blends the interface over the body with the diffuse base
        let (m, p) = skin("ND_open_pbr_surface_surfaceshader", &[("/M/S.inputs:subsurface_weight", f(0.5))]);
        assert!(p.is_empty(), "{p:?}");
        let SurfaceDesc::Water(w) = &m.desc.surface else { panic!() };
        assert_eq!(w.blend.as_ref().map(|b| &b.transmission), Some(&FloatInput::Const(0.5)));
        let med = m.medium.expect("a scattering body");
        let a = mtlx::single_scattering_albedo(0.8);
        let SpectrumDesc::Rgb(ss) = med.sigma_s else { panic!() };
        for (k, mfp) in [1.0, 0.5, 0.25].into_iter().enumerate() {
            assert!((ss[k] - a / mfp).abs() < 1e-5, "{ss:?}");
        }
        assert_eq!(med.phase, PhaseDesc::Isotropic);
    }

    /// Every MaterialX arithmetic node, fed a primvar x = (0.3, 0.6, 0.9, 0.5), the texture
    /// coordinates (0.2, 0.7) or the position so that it cannot fold away, computes what the
    /// MaterialX specification says it does.
    #[test]
    fn materialx_nodes_compute_their_specified_values() {
        use tide_core::shader_graph::Lookups;
        const X: [f32; 4] = [0.3, 0.6, 0.9, 0.5];
        let at_x = FixedHit { x: X, uv: Vec2::new(0.2, 0.7), object: glam::Vec3::new(4.0, 5.0, 6.0), world: glam::Vec3::new(1.0, 2.0, 3.0), normal: [glam::Vec3::Y; 2], tangent: [glam::Vec3::X; 2] };
        let f = |x: f64| Value::Float(x);
        let c3 = |a: [f32; 3]| Value::Floats { data: a.to_vec(), tuple: 3 };
        let x = || tok("/M/X.outputs:out");
        let smooth = |t: f32| t * t * (3.0 - 2.0 * t);
        let lum = 0.2722287 * 0.3 + 0.6740818 * 0.6 + 0.0536895 * 0.9;
        #[rustfmt::skip]
        let cases: Vec<(&str, Vec<(&str, Value)>, &str, [f32; 4])> = vec![
            ("ND_multiply_color3", vec![("in1.connect", x()), ("in2", c3([2.0, 3.0, 4.0]))], "out", [0.6, 1.8, 3.6, 0.5]),
            ("ND_divide_color3", vec![("in1.connect", x()), ("in2", c3([2.0; 3]))], "out", [0.15, 0.3, 0.45, 0.5]),
            ("ND_divide_color3", vec![("in1", c3([1.0; 3])), ("in2.connect", x())], "out", [1.0 / 0.3, 1.0 / 0.6, 1.0 / 0.9, 2.0]),
            ("ND_min_color3FA", vec![("in1.connect", x()), ("in2", f(0.5))], "out", [0.3, 0.5, 0.5, 0.5]),
            ("ND_max_color3FA", vec![("in1.connect", x()), ("in2", f(0.5))], "out", [0.5, 0.6, 0.9, 0.5]),
            ("ND_power_color3FA", vec![("in1.connect", x()), ("in2", f(2.0))], "out", X.map(|v| v * v)),
            ("ND_modulo_color3FA", vec![("in1.connect", x()), ("in2", f(0.25))], "out", [0.05, 0.1, 0.15, 0.0]),
            ("ND_sqrt_color3", vec![("in.connect", x())], "out", X.map(f32::sqrt)),
            ("ND_clamp_color3FA", vec![("in.connect", x()), ("low", f(0.4)), ("high", f(0.8))], "out", [0.4, 0.6, 0.8, 0.5]),
            ("ND_invert_color3FA", vec![("in.connect", x())], "out", [0.7, 0.4, 0.1, 0.5]),
            ("ND_remap_color3FA", vec![("in.connect", x()), ("inlow", f(0.2)), ("outlow", f(1.0)), ("outhigh", f(3.0))], "out", [1.25, 2.0, 2.75, 1.75]),
            ("ND_smoothstep_color3FA", vec![("in.connect", x())], "out", X.map(smooth)),
            ("ND_luminance_color3", vec![("in.connect", x())], "out", [lum; 4]),
            ("ND_extract_color3", vec![("in.connect", x()), ("index", Value::Int(1))], "out", [0.6; 4]),
            ("ND_separate3_color3", vec![("in.connect", x())], "outb", [0.9; 4]),
            ("ND_combine3_color3", vec![("in1.connect", x()), ("in2", f(0.25)), ("in3", f(0.5))], "out", [0.3, 0.25, 0.5, 0.0]),
            ("ND_convert_float_color3", vec![("in.connect", x())], "out", [0.3; 4]),
            ("ND_mix_color3", vec![("fg.connect", x()), ("bg", c3([1.0; 3])), ("mix.connect", x())], "out", [0.79, 0.76, 0.91, 0.75]),
            // x's second component (0.6) > 0.5: in1
            ("ND_ifgreater_color3", vec![("value1.connect", tok("/M/E.outputs:out")), ("value2", f(0.5)), ("in1", c3([1.0, 2.0, 3.0])), ("in2.connect", x())], "out", [1.0, 2.0, 3.0, 1.0]),
            // 0.5 ≥ 0.6 is false: in2
            ("ND_ifgreatereq_color3", vec![("value1", f(0.5)), ("value2.connect", tok("/M/E.outputs:out")), ("in1", c3([1.0, 2.0, 3.0])), ("in2.connect", x())], "out", X),
            ("ND_floor_color3", vec![("in.connect", tok("/M/Ten.outputs:out"))], "out", [3.0, 6.0, 9.0, 5.0]),
            // over the mesh's texture coordinates, (0.2, 0.7) here, or x's
            ("ND_texcoord_vector2", vec![], "out", [0.2, 0.7, 0.0, 0.0]),
            // the position, (4, 5, 6) in the object's space and (1, 2, 3) in the world here
            ("ND_position_vector3", vec![], "out", [4.0, 5.0, 6.0, 0.0]),
            ("ND_position_vector3", vec![("space", Value::String("world".into()))], "out", [1.0, 2.0, 3.0, 0.0]),
            ("ND_ramplr_color3", vec![("valuel", c3([1.0, 0.0, 0.0])), ("valuer", c3([0.0, 0.0, 1.0]))], "out", [0.8, 0.0, 0.2, 1.0]),
            ("ND_ramplr_color3", vec![("valuel", c3([1.0, 0.0, 0.0])), ("valuer", c3([0.0, 0.0, 1.0])), ("texcoord.connect", x())], "out", [0.7, 0.0, 0.3, 1.0]),
            ("ND_ramptb_color3", vec![("valuet", c3([1.0; 3])), ("valueb", c3([0.0; 3]))], "out", [0.7, 0.7, 0.7, 1.0]),
            ("ND_splitlr_color3", vec![("valuel", c3([1.0, 0.0, 0.0])), ("valuer", c3([0.0, 1.0, 0.0]))], "out", [1.0, 0.0, 0.0, 1.0]),
            ("ND_splittb_color3", vec![("valuet", c3([1.0, 0.0, 0.0])), ("valueb", c3([0.0, 1.0, 0.0])), ("center", f(0.6))], "out", [1.0, 0.0, 0.0, 1.0]),
            ("ND_splittb_color3", vec![("valuet", c3([1.0, 0.0, 0.0])), ("valueb", c3([0.0, 1.0, 0.0])), ("center", f(0.8))], "out", [0.0, 1.0, 0.0, 1.0]),
            (
                "ND_ramp4_color3",
                vec![("valuetl", c3([1.0, 0.0, 0.0])), ("valuetr", c3([0.0, 1.0, 0.0])), ("valuebl", c3([0.0, 0.0, 1.0])), ("valuebr", c3([1.0; 3]))],
                "out",
                [0.62, 0.2, 0.3, 1.0],
            ),
        ];
        for (id, inputs, output, want) in cases {
            let mut pairs = vec![
                ("surface", Value::Path("/M/S".into())),
                ("/M/S.info:id", tok("UsdPreviewSurface")),
                ("/M/X.info:id", tok("ND_geompropvalue_color4")),
                ("/M/X.inputs:geomprop", Value::String("x".into())),
                ("/M/E.info:id", tok("ND_extract_color4")),
                ("/M/E.inputs:in.connect", x()),
                ("/M/E.inputs:index", Value::Int(1)),
                ("/M/Ten.info:id", tok("ND_multiply_color4FA")),
                ("/M/Ten.inputs:in1.connect", x()),
                ("/M/Ten.inputs:in2", f(10.0)),
                ("/M/N.info:id", tok(id)),
            ];
            let target = format!("/M/N.outputs:{output}");
            pairs.push(("/M/S.inputs:diffuseColor.connect", tok(&target)));
            let names: Vec<String> = inputs.iter().map(|(k, _)| format!("/M/N.inputs:{k}")).collect();
            pairs.extend(names.iter().map(String::as_str).zip(inputs.into_iter().map(|(_, v)| v)));
            let mut p = Problems::new("/M");
            let m = convert_material("/M", &mat(&pairs), &loaded(false), &mut p);
            assert!(p.list.is_empty(), "{id}: {:?}", p.list);
            let SurfaceDesc::Preview(ps) = &m.desc.surface else { panic!("{id}") };
            let got = match &ps.diffuse_color {
                ColorInput::Graph(e) => e.eval(&at_x),
                ColorInput::Primvar(l) => at_x.primvar(l),
                other => panic!("{id}: {other:?}"),
            };
            for k in 0..4 {
                assert!((got[k] - want[k]).abs() < 1e-5, "{id}: {got:?} vs {want:?}");
            }
        }
    }

    /// UsdPreviewSurface's displacement travels with the material piece (a texture's red, or a
    /// constant); 0 displaces nothing.
    #[test]
    fn preview_surface_displacement_is_carried() {
        let with = |extra: &[(&str, Value)]| {
            let (m, p) = convert(&[("surface", Value::Path("/M/S".into())), ("/M/S.info:id", tok("UsdPreviewSurface"))], extra);
            assert!(p.is_empty(), "{p:?}");
            m.displacement
        };
        assert_eq!(with(&[]), None);
        assert_eq!(with(&[("/M/S.inputs:displacement", Value::Float(0.0))]), None);
        assert_eq!(with(&[("/M/S.inputs:displacement", Value::Float(0.25))]), Some(FloatInput::Const(0.25)));
        let tex = with(&[
            ("/M/S.inputs:displacement.connect", tok("/M/H.outputs:r")),
            ("/M/H.info:id", tok("UsdUVTexture")),
            ("/M/H.inputs:file", Value::Asset("/tex/albedo.png".into())),
        ]);
        assert!(matches!(tex, Some(FloatInput::Texture(t)) if t.channel == Channel::R && t.texture == 0));
    }

    /// A displacement terminal's MaterialX node displaces by displacement × scale (a texture
    /// scaled in its lookup); a vector displacement or an unknown node is reported and displaces
    /// nothing; a UsdPreviewSurface there reads as its own input.
    #[test]
    fn materialx_displacement_node_is_carried() {
        let with = |extra: &[(&str, Value)]| {
            let base = [
                ("surface", Value::Path("/M/S".into())),
                ("/M/S.info:id", tok("ND_standard_surface_surfaceshader")),
                ("displacement", Value::Path("/M/D".into())),
                ("/M/D.info:id", tok("ND_displacement_float")),
            ];
            let (m, p) = convert(&base, extra);
            (m.displacement, p)
        };
        assert_eq!(with(&[]), (None, vec![]));
        assert_eq!(with(&[("/M/D.inputs:displacement", Value::Float(0.25)), ("/M/D.inputs:scale", Value::Float(2.0))]), (Some(FloatInput::Const(0.5)), vec![]));
        let (tex, p) = with(&[
            ("/M/D.inputs:displacement.connect", tok("/M/H.outputs:out")),
            ("/M/D.inputs:scale", Value::Float(0.1)),
            ("/M/H.info:id", tok("ND_image_float")),
            ("/M/H.inputs:file", Value::Asset("/tex/albedo.png".into())),
        ]);
        assert!(p.is_empty(), "{p:?}");
        let Some(FloatInput::Texture(t)) = tex else { panic!("{tex:?}") };
        assert_eq!((t.channel, t.tex_scale[0], t.bias[0]), (Channel::R, 0.1, 0.0));
        assert_eq!(with(&[("/M/D.info:id", tok("ND_displacement_vector3"))]), (None, vec!["/M/D.info:id".to_string()]));
        assert_eq!(with(&[("/M/D.info:id", tok("ND_bump_vector3"))]), (None, vec!["/M/D.info:id".to_string()]));
        let (d, p) = with(&[("surface", Value::Path("/M/D".into())), ("/M/D.info:id", tok("UsdPreviewSurface")), ("/M/D.inputs:displacement", Value::Float(0.3))]);
        assert_eq!((d, p), (Some(FloatInput::Const(0.3)), vec![]));
    }

    /// MaterialX's own UsdPreviewSurface nodes read as USD's.
    #[test]
    fn materialx_usd_preview_surface_nodes_read_as_the_usd_ones() {
        let usd = |surface: &str, tex: &str| {
            mat(&[
                ("surface", Value::Path("/M/S".into())),
                ("/M/S.info:id", tok(surface)),
                ("/M/S.inputs:roughness", Value::Float(0.3)),
                ("/M/S.inputs:diffuseColor.connect", tok("/M/T.outputs:rgb")),
                ("/M/T.info:id", tok(tex)),
                ("/M/T.inputs:file", Value::Asset("/tex/albedo.png".into())),
            ])
        };
        let a = convert_material("/M", &usd("UsdPreviewSurface", "UsdUVTexture"), &loaded(false), &mut Problems::new("/M"));
        let b = convert_material("/M", &usd("ND_UsdPreviewSurface_surfaceshader", "ND_UsdUVTexture"), &loaded(false), &mut Problems::new("/M"));
        assert!(matches!(&a.desc.surface, SurfaceDesc::Preview(p) if matches!(p.diffuse_color, ColorInput::Texture(_))));
        assert_eq!(a, b);
    }

    /// UsdPrimvarReader outputs feed any input: a colour from a float3 primvar, a scalar from a
    /// float primvar, and a texture's coordinates from a primvar other than st.
    #[test]
    fn primvar_readers_feed_inputs_and_texture_coordinates() {
        let s = mat(&[
            ("surface", Value::Path("/M/PBR".into())),
            ("/M/PBR.info:id", tok("UsdPreviewSurface")),
            ("/M/PBR.inputs:diffuseColor.connect", tok("/M/Cd.outputs:result")),
            ("/M/Cd.info:id", tok("UsdPrimvarReader_float3")),
            ("/M/Cd.inputs:varname", Value::String("displayColor".into())),
            ("/M/Cd.inputs:fallback", Value::Floats { data: vec![0.1, 0.2, 0.3], tuple: 3 }),
            ("/M/PBR.inputs:roughness.connect", tok("/M/R.outputs:result")),
            ("/M/R.info:id", tok("UsdPrimvarReader_float")),
            ("/M/R.inputs:varname", tok("rough")),
            ("/M/PBR.inputs:metallic.connect", tok("/M/R.outputs:rgb")),
            ("/M/PBR.inputs:opacity.connect", tok("/M/Tex.outputs:a")),
            ("/M/Tex.info:id", tok("UsdUVTexture")),
            ("/M/Tex.inputs:file", Value::Asset("/tex/albedo.png".into())),
            ("/M/Tex.inputs:st.connect", tok("/M/Uv1.outputs:result")),
            ("/M/Uv1.info:id", tok("UsdPrimvarReader_float2")),
            ("/M/Uv1.inputs:varname", tok("st1")),
            ("/M/PBR.inputs:clearcoat.connect", tok("/M/Tex2.outputs:r")),
            ("/M/Tex2.info:id", tok("UsdUVTexture")),
            ("/M/Tex2.inputs:file", Value::Asset("/tex/albedo.png".into())),
            ("/M/Tex2.inputs:st.connect", tok("/M/Uv0.outputs:result")),
            ("/M/Uv0.info:id", tok("UsdPrimvarReader_float2")),
            ("/M/Uv0.inputs:varname", tok("st")),
        ]);
        let mut p = Problems::new("/M");
        let m = convert_material("/M", &s, &loaded(false), &mut p);
        let SurfaceDesc::Preview(ps) = &m.desc.surface else { panic!() };
        assert_eq!(ps.diffuse_color, ColorInput::Primvar(PrimvarLookup::new("displayColor", [0.1, 0.2, 0.3, 0.0])));
        assert_eq!(ps.roughness, FloatInput::Primvar(PrimvarLookup::new("rough", [0.0; 4])));
        let FloatInput::Texture(t) = &ps.opacity else { panic!("{:?}", ps.opacity) };
        assert_eq!(t.uv_set, Some(PrimvarLookup::new("st1", [0.0; 4])));
        let FloatInput::Texture(t) = &ps.clearcoat else { panic!("{:?}", ps.clearcoat) };
        // st too is looked up by name: the mesh whose coordinates came from st answers it
        assert_eq!(t.uv_set, Some(PrimvarLookup::new("st", [0.0; 4])));
        // a reader's output other than `result` is named and the constant kept
        assert_eq!(ps.metallic, FloatInput::Const(0.0));
        let attrs: Vec<&str> = p.list.iter().map(|q| q.attribute.as_str()).collect();
        assert_eq!(attrs, ["/M/PBR.inputs:metallic"], "{:?}", p.list);
    }

    /// The medium named by TideWater's `medium` connection equals the one named by the volume
    /// output; given both, the volume output wins and a disagreement is reported.
    #[test]
    fn water_medium_through_its_medium_connection() {
        let base = |extra: &[(&'static str, Value)]| {
            let mut pairs = vec![
                ("surface", Value::Path("/W/Water".into())),
                ("/W/Water.info:id", tok("TideWater")),
                ("/W/Med.info:id", tok("TideMedium")),
                ("/W/Med.inputs:absorption", Value::Floats { data: vec![0.4, 0.05, 0.02], tuple: 3 }),
                ("/W/Med.inputs:g", Value::Float(0.8)),
                ("/W/Other.info:id", tok("TideMedium")),
                ("/W/Other.inputs:scattering", Value::Floats { data: vec![1.0, 1.0, 1.0], tuple: 3 }),
                ("/W/Tex.info:id", tok("UsdUVTexture")),
            ];
            pairs.extend_from_slice(extra);
            let mut p = Problems::new("/W");
            let m = convert_material("/W", &mat(&pairs), &loaded(false), &mut p);
            (m.medium, p.list.into_iter().map(|q| (q.attribute, q.message)).collect::<Vec<_>>())
        };
        let (by_output, p0) = base(&[("volume", Value::Path("/W/Med.outputs:volume".into()))]);
        let (by_link, p1) = base(&[("/W/Water.inputs:medium.connect", tok("/W/Med.outputs:volume"))]);
        assert!(p0.is_empty() && p1.is_empty(), "{p0:?} {p1:?}");
        assert!(by_output.is_some());
        assert_eq!(by_link, by_output);
        // both, the same node: no problem
        let (both, p2) = base(&[
            ("volume", Value::Path("/W/Med.outputs:volume".into())),
            ("/W/Water.inputs:medium.connect", tok("/W/Med.outputs:volume")),
        ]);
        assert_eq!((both, p2.len()), (by_output.clone(), 0));
        // both, different nodes: the volume output, and the connection is reported
        let (other, p3) = base(&[
            ("volume", Value::Path("/W/Other.outputs:volume".into())),
            ("/W/Water.inputs:medium.connect", tok("/W/Med.outputs:volume")),
        ]);
        assert_ne!(other, by_output);
        assert_eq!(other.unwrap().sigma_s, SpectrumDesc::Rgb([1.0; 3]));
        assert_eq!(p3.len(), 1, "{p3:?}");
        assert_eq!(p3[0].0, "/W/Water.inputs:medium");
        // a connection to a node that is not a TideMedium leaves the interior empty, reported
        let (none, p4) = base(&[("/W/Water.inputs:medium.connect", tok("/W/Tex.outputs:rgb"))]);
        assert_eq!(none, None);
        assert_eq!(p4.len(), 1, "{p4:?}");
        assert_eq!(p4[0].0, "/W/Tex.info:id");
    }

    fn medium_of(inputs: &[(&str, Value)]) -> (Option<MediumDesc>, Vec<(String, String)>) {
        let mut pairs = vec![
            ("surface", Value::Path("/W/Water".into())),
            ("volume", Value::Path("/W/Med.outputs:volume".into())),
            ("/W/Water.info:id", tok("TideWater")),
            ("/W/Water.inputs:salinity", Value::Float(35.0)),
            ("/W/Med.info:id", tok("TideMedium")),
        ];
        let names: Vec<String> = inputs.iter().map(|(n, _)| format!("/W/Med.inputs:{n}")).collect();
        for ((_, v), n) in inputs.iter().zip(&names) {
            pairs.push((n.as_str(), v.clone()));
        }
        let mut p = Problems::new("/W");
        let m = convert_material("/W", &mat(&pairs), &loaded(false), &mut p);
        (m.medium, p.list.into_iter().map(|q| (q.attribute, q.message)).collect())
    }

    #[test]
    fn bio_optical_inputs_with_profile_and_salinity_from_the_water() {
        let (med, problems) = medium_of(&[
            ("chlorophyll", Value::Float(0.3)),
            ("cdom", Value::Float(0.5)),
            ("spm", Value::Float(1.0)),
            ("profileDepth", Value::Float(20.0)),
            ("profileWidth", Value::Float(4.0)),
            ("profilePeak", Value::Float(2.0)),
            ("absorption", Value::Floats { data: vec![0.1, 0.0, 0.0], tuple: 3 }),
            ("densityScale", Value::Float(0.5)),
        ]);
        assert!(problems.is_empty(), "{problems:?}");
        let med = med.unwrap();
        // without a Jerlov type the RGB coefficients are added to the model
        assert_eq!(med.sigma_a, SpectrumDesc::Rgb([0.1, 0.0, 0.0]));
        assert_eq!(med.scale, 0.5);
        let w = med.water.unwrap();
        assert_eq!((w.jerlov, w.chlorophyll, w.cdom, w.spm, w.salinity, w.top), (None, 0.3, 0.5, 1.0, 35.0, None));
        assert_eq!(w.profile, Some(DepthProfileDesc { depth: 20.0, width: 4.0, peak: 2.0 }));
    }

    #[test]
    fn plain_rgb_medium_stays_homogeneous() {
        let (med, problems) = medium_of(&[("absorption", Value::Floats { data: vec![0.4, 0.05, 0.02], tuple: 3 })]);
        assert!(problems.is_empty());
        let med = med.unwrap();
        assert_eq!(med.water, None);
        assert_eq!(med.phase, PhaseDesc::HenyeyGreenstein { g: 0.0 });
    }

    #[test]
    fn ocean_phase_functions_are_tabulated() {
        for (phase, w) in [("fournierForand", 0.0), ("petzold", 0.0), ("hg", 0.2), ("dualHG", 0.5)] {
            let (med, problems) = medium_of(&[("phase", tok(phase)), ("g", Value::Float(0.8)), ("molecularWeight", Value::Float(w))]);
            assert!(problems.is_empty(), "{phase}: {problems:?}");
            let med = med.unwrap();
            let PhaseDesc::Tabulated { theta, value } = &med.phase else { panic!("{phase}: {:?}", med.phase) };
            assert!(theta.len() == value.len() && theta.len() > 10);
            // the description builds in the core
            tide_core::medium::PhaseFunction::from_desc(&med.phase).unwrap();
        }
    }

    #[test]
    fn medium_method_selects_diffusion_or_volumetric() {
        use tide_core::scene::MediumMethod;
        let (med, problems) = medium_of(&[("method", tok("diffusion"))]);
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(med.unwrap().method, MediumMethod::Diffusion);
        let (med, problems) = medium_of(&[("method", tok("volumetric"))]);
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(med.unwrap().method, MediumMethod::Volumetric);
        assert_eq!(medium_of(&[]).0.unwrap().method, MediumMethod::Volumetric);
    }

    #[test]
    fn bad_medium_tokens_and_values_name_the_attribute_and_use_the_defaults() {
        let cases: Vec<(&str, Value, &str)> = vec![
            ("jerlovType", tok("IX"), "using ''"),
            ("jerlovSource", tok("mobley1994"), "using 'williamson2022'"),
            ("method", tok("dipole"), "using 'volumetric'"),
            ("phase", tok("rayleigh"), "using 'hg'"),
            ("g", Value::Float(1.5), "using 0"),
            ("g2", Value::Float(-2.0), "using -0.3"),
            ("lobeMix", Value::Float(1.5), "using 0.9"),
            ("molecularWeight", Value::Float(-0.1), "using 0"),
            ("chlorophyll", Value::Float(-1.0), "using 0"),
            ("cdom", Value::Float(f64::NAN), "using 0"),
            ("spm", Value::Float(-3.0), "using 0"),
            ("profileWidth", Value::Float(-1.0), "using 0"),
            ("profilePeak", Value::Float(-1.0), "using 0"),
            ("densityScale", Value::Float(-2.0), "using 1"),
            ("absorption", Value::Floats { data: vec![-0.1, 0.0, 0.0], tuple: 3 }, "using (0, 0, 0)"),
        ];
        for (name, v, default) in cases {
            let (med, problems) = medium_of(&[(name, v)]);
            assert_eq!(problems.len(), 1, "{name}: {problems:?}");
            assert_eq!(problems[0].0, format!("/W/Med.inputs:{name}"));
            assert!(problems[0].1.contains(default), "{name}: {}", problems[0].1);
            let med = med.unwrap();
            // every default leaves the medium empty, homogeneous and path-traced
            assert_eq!(med.water, None, "{name}");
            assert_eq!(med.method, tide_core::scene::MediumMethod::Volumetric, "{name}");
        }
        // a type the default source lacks falls back to Solonenko & Mobley
        let (med, problems) = medium_of(&[("jerlovType", tok("9C"))]);
        assert_eq!(problems.len(), 1);
        assert_eq!(problems[0].0, "/W/Med.inputs:jerlovSource");
        assert_eq!(med.unwrap().water.unwrap().jerlov, Some(JerlovDesc { water_type: JerlovType::C9, source: JerlovSource::Solonenko2015 }));
        // a peak without a width is no profile
        let (med, problems) = medium_of(&[("profilePeak", Value::Float(3.0))]);
        assert_eq!(problems[0].0, "/W/Med.inputs:profileWidth");
        assert_eq!(med.unwrap().water, None);
        // |g| = 1 is no phase function: the default too
        let (med, problems) = medium_of(&[("g", Value::Float(1.0))]);
        assert_eq!(problems.iter().map(|q| q.0.as_str()).collect::<Vec<_>>(), ["/W/Med.inputs:g"]);
        assert_eq!(med.unwrap().phase, PhaseDesc::HenyeyGreenstein { g: 0.0 });
    }

    /// TideWater values outside what its models take are named on the shader and replaced by
    /// the defaults (salinity leaving dispersion on); a wind past the sea model's range is held
    /// at its top.
    #[test]
    fn bad_water_values_name_the_shader_input_and_use_the_defaults() {
        let max_wind = tide_core::bsdf::sea::MAX_WIND_SPEED;
        let cases: Vec<(&str, f64, fn(&WaterDesc) -> f32, f32)> = vec![
            ("salinity", -10.0, |w| w.salinity, 0.0),
            ("temperature", 90.0, |w| w.temperature, 20.0),
            ("ior", 0.5, |w| w.ior, 1.333),
            ("roughness", 2.0, |w| w.roughness, 0.0),
            ("windSpeed", -3.0, |w| w.wind_speed, 5.0),
            ("windSpeed", 500.0, |w| w.wind_speed, max_wind),
        ];
        for (name, v, get, want) in cases {
            let input = format!("/W/Water.inputs:{name}");
            let pairs = vec![
                ("surface", Value::Path("/W/Water".into())),
                ("/W/Water.info:id", tok("TideWater")),
                ("/W/Water.inputs:dispersion", Value::Bool(true)),
                ("/W/Water.inputs:surfaceModel", tok("sea")),
                (input.as_str(), Value::Float(v)),
            ];
            let mut p = Problems::new("/W");
            let m = convert_material("/W", &mat(&pairs), &loaded(false), &mut p);
            assert_eq!(p.list.iter().map(|q| q.attribute.as_str()).collect::<Vec<_>>(), [input.as_str()], "{name}");
            let SurfaceDesc::Water(w) = &m.desc.surface else { panic!() };
            assert_eq!((get(w), w.dispersion), (want, true), "{name} = {v}");
        }
    }
}
