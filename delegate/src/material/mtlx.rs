//! MaterialX networks (USD's `mtlx` render context): `standard_surface` as the surfaces Tide
//! has, and the MaterialX nodes that feed its inputs.
//!
//! `ND_standard_surface_surfaceshader` becomes a UsdPreviewSurface: `base` × `base_color`
//! (diffuse), `metalness`, `specular_roughness`, `specular_IOR`, `coat` / `coat_roughness`
//! (clearcoat), `emission` × `emission_color`, `opacity` and `normal` (through `normalmap`);
//! `specular` 0 on a non-metal leaves the diffuse alone. With `transmission` it becomes a clear
//! dielectric (as TideWater: `specular_IOR`, `specular_roughness`), which is what glass and
//! water made in a DCC are. What the mapping cannot carry (subsurface, sheen, thin film, a
//! tinted or partial transmission, a tinted coat or specular, diffuse roughness) is reported
//! and left out.
//!
//! Nodes: `image` / `tiledimage` (file, default, u/vaddressmode, texcoord, uvtiling /
//! uvoffset), `geompropvalue` (a primvar, as UsdPrimvarReader), `texcoord` (the mesh's uvs),
//! `normalmap`, `constant` and `dot`, and `multiply`, `add`, `subtract` and `mix` where all
//! operands but one are constants (a tint, a gain, an offset: folded into the lookup);
//! MaterialX's UsdPreviewSurface nodes (`ND_UsdUVTexture`, ...) are read as the USD ones.

use super::{uv_set, Ctx, Source, WrapKey};
use glam::Vec2;
use tide_core::scene::{Channel, ColorInput, FloatInput, PreviewSurfaceDesc, PrimvarLookup, SurfaceDesc, TexLookup, WaterDesc};

/// A MaterialX node id as the USD node it stands for (MaterialX's UsdPreviewSurface library),
/// or itself.
pub(super) fn canonical_id(id: &str) -> &str {
    match id {
        "ND_UsdPreviewSurface_surfaceshader" => "UsdPreviewSurface",
        _ => id.strip_prefix("ND_").filter(|r| r.starts_with("Usd")).unwrap_or(id),
    }
}

/// The MaterialX node families that [`Ctx::mtlx_source`] reads.
fn family(id: &str) -> Option<&'static str> {
    ["ND_image_", "ND_tiledimage_", "ND_geompropvalue_", "ND_texcoord_", "ND_constant_", "ND_dot_", "ND_normalmap", "ND_multiply_", "ND_add_", "ND_subtract_", "ND_mix_"]
        .into_iter()
        .find(|f| id.starts_with(f))
}

/// Whether `id` is a MaterialX node this module reads.
pub(super) fn is_mtlx_node(id: &str) -> bool {
    family(id).is_some()
}

/// `source` × `mul` + `add`, per component, folded into the source: a constant, a texture's
/// scale and bias (its fallback too), or a primvar's scale (an offset cannot be: Err).
fn affine(source: Source, mul: [f32; 4], add: [f32; 4]) -> Result<Source, String> {
    let map = |v: [f32; 4]| -> [f32; 4] { std::array::from_fn(|k| v[k] * mul[k] + add[k]) };
    Ok(match source {
        Source::Fallback(v) => Source::Fallback(map(v)),
        Source::Texture(mut t) => {
            t.tex_scale = std::array::from_fn(|k| t.tex_scale[k] * mul[k]);
            t.bias = map(t.bias);
            t.fallback = map(t.fallback);
            Source::Texture(t)
        }
        Source::Primvar(mut l) if add == [0.0; 4] => {
            l.scale = std::array::from_fn(|k| l.scale[k] * mul[k]);
            Source::Primvar(l)
        }
        Source::Primvar(_) => return Err("offsets a primvar, which is not supported".into()),
    })
}

impl Ctx<'_> {
    /// What MaterialX node `up` supplies to the attribute `attr` (None: unusable, reported).
    /// `depth` bounds chains of `dot` nodes.
    pub(super) fn mtlx_source(&mut self, attr: &str, up: &str, depth: u32) -> Option<Source> {
        let id = self.node_id(up).unwrap_or("").to_string();
        match family(&id) {
            Some("ND_image_") | Some("ND_tiledimage_") => Some(match self.mtlx_image(up) {
                Ok(mut t) => {
                    if id.ends_with("_float") {
                        t.channel = Channel::R;
                    }
                    Source::Texture(t)
                }
                Err(fb) => Source::Fallback(fb),
            }),
            Some("ND_geompropvalue_") => Some(Source::Primvar(self.geomprop(up))),
            Some("ND_constant_") => Some(Source::Fallback(self.value4(up, "value", [0.0; 4]))),
            Some(op @ ("ND_multiply_" | "ND_add_" | "ND_subtract_" | "ND_mix_")) => match self.arithmetic(op, up, depth) {
                Ok(source) => Some(source),
                Err(why) => {
                    self.p.add(attr, format!("a MaterialX '{}' node {}; using the constant value", id, why));
                    None
                }
            },
            Some("ND_dot_") => match self.nodes[up].connects.get("in").cloned() {
                Some((next, output)) if depth < 16 => self.connection_at(attr, &next, &output, depth + 1),
                Some(_) => {
                    self.p.add(attr, "a chain of more than 16 dot nodes; using the constant value");
                    None
                }
                None => Some(Source::Fallback(self.value4(up, "in", [0.0; 4]))),
            },
            _ => {
                self.p.add(attr, format!("a MaterialX '{}' node is not supported here; using the constant value", id));
                None
            }
        }
    }

    /// An operand of an arithmetic node: what its connection supplies, or its constant.
    fn operand(&mut self, node: &str, input: &str, default: [f32; 4], depth: u32) -> Result<Source, String> {
        match self.nodes[node].connects.get(input).cloned() {
            None => Ok(Source::Fallback(self.value4(node, input, default))),
            Some(_) if depth >= 16 => Err("chains more than 16 nodes".into()),
            Some((up, output)) => self.connection_at(&format!("{}.inputs:{}", node, input), &up, &output, depth + 1).ok_or_else(|| format!("has an unusable {input}")),
        }
    }

    /// `multiply`, `add`, `subtract` and `mix` where all but one operand are constants: folded
    /// into the other operand's lookup (a texture's scale and bias, a primvar's scale) or into
    /// a constant. Two varying operands cannot be folded (Err says why).
    fn arithmetic(&mut self, op: &str, node: &str, depth: u32) -> Result<Source, String> {
        let both = "combines two textures or primvars, which is not supported".to_string();
        let cst = |s: &Source| match s {
            Source::Fallback(v) => Some(*v),
            _ => None,
        };
        match op {
            "ND_mix_" => {
                let fg = self.operand(node, "fg", [0.0; 4], depth)?;
                let bg = self.operand(node, "bg", [0.0; 4], depth)?;
                let Source::Fallback(m) = self.operand(node, "mix", [0.0; 4], depth)? else { return Err("has a connected mix amount, which is not supported".into()) };
                let m = m[0];
                match (cst(&fg), cst(&bg)) {
                    (_, Some(b)) => affine(fg, [m; 4], b.map(|x| x * (1.0 - m))),
                    (Some(f), None) => affine(bg, [1.0 - m; 4], f.map(|x| x * m)),
                    (None, None) => Err(both),
                }
            }
            _ => {
                let in2_default = if op == "ND_multiply_" { [1.0; 4] } else { [0.0; 4] };
                let a = self.operand(node, "in1", [0.0; 4], depth)?;
                let b = self.operand(node, "in2", in2_default, depth)?;
                match (op, cst(&a), cst(&b)) {
                    ("ND_multiply_", _, Some(c)) => affine(a, c, [0.0; 4]),
                    ("ND_multiply_", Some(c), None) => affine(b, c, [0.0; 4]),
                    ("ND_add_", _, Some(c)) => affine(a, [1.0; 4], c),
                    ("ND_add_", Some(c), None) => affine(b, [1.0; 4], c),
                    ("ND_subtract_", _, Some(c)) => affine(a, [1.0; 4], c.map(|x| -x)),
                    ("ND_subtract_", Some(c), None) => affine(b, [-1.0; 4], c),
                    _ => Err(both),
                }
            }
        }
    }

    /// An input's value as four components (a scalar fills three, as a colour's alpha is 1).
    fn value4(&mut self, node: &str, input: &str, default: [f32; 4]) -> [f32; 4] {
        match self.nodes[node].inputs.get(input).map(|v| v.to_f32s()) {
            None => default,
            Some(Some(v)) if !v.is_empty() && v.len() <= 4 && v.iter().all(|x| x.is_finite()) => match v[..] {
                [x] => [x, x, x, 1.0],
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
    fn mtlx_image(&mut self, node: &str) -> Result<TexLookup, [f32; 4]> {
        let modes = [("periodic", WrapKey::Repeat), ("clamp", WrapKey::Clamp), ("mirror", WrapKey::Mirror), ("constant", WrapKey::Black)];
        let wrap_s = self.wrap_input(node, "uaddressmode", &modes, "periodic");
        let wrap_t = self.wrap_input(node, "vaddressmode", &modes, "periodic");
        let fallback = self.value4(node, "default", [0.0, 0.0, 0.0, 1.0]);
        // tiledimage: uv' = uv · uvtiling − uvoffset
        let tiling = Vec2::from(self.input_vec(node, "uvtiling", [1.0, 1.0]));
        let offset = Vec2::from(self.input_vec(node, "uvoffset", [0.0, 0.0]));
        let uv_set = match self.nodes[node].connects.get("texcoord").cloned() {
            None => None,
            Some((up, _)) => match self.node_id(&up).unwrap_or("") {
                id if id.starts_with("ND_texcoord_") => None,
                id if id.starts_with("ND_geompropvalue_") => uv_set(self.geomprop(&up)),
                id if id.starts_with("UsdPrimvarReader_") => uv_set(self.primvar_reader(&up)),
                id => {
                    self.p.add(&format!("{}.inputs:texcoord", node), format!("texcoord comes from a '{}' node; using the mesh's st", id));
                    None
                }
            },
        };
        let Some(texture) = self.texture_slot(node, "file", "auto", wrap_s, wrap_t) else { return Err(fallback) };
        Ok(TexLookup {
            texture,
            channel: Channel::Rgb,
            scale: tiling,
            rotation_deg: 0.0,
            translation: -offset,
            tex_scale: [1.0; 4],
            bias: [0.0; 4],
            fallback,
            uv_set,
        })
    }

    /// A colour input scaled by a weight (`base` × `base_color`).
    fn weighted_color(&mut self, node: &str, color: &str, default: [f32; 3], weight: &str, weight_default: f32) -> ColorInput {
        let w = self.constant_only(node, weight, weight_default);
        match self.color(node, color, default) {
            ColorInput::Const(c) => ColorInput::Const(c.map(|x| x * w)),
            ColorInput::Texture(mut t) => {
                for k in 0..3 {
                    t.tex_scale[k] *= w;
                    t.bias[k] *= w;
                }
                ColorInput::Texture(t)
            }
            ColorInput::Primvar(mut l) => {
                for k in 0..3 {
                    l.scale[k] *= w;
                }
                ColorInput::Primvar(l)
            }
        }
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

    /// The normal map behind a `normal` input: `normalmap` over an image (its [0, 1] texels
    /// remapped to [−1, 1]), or a UsdUVTexture as UsdPreviewSurface takes it.
    fn mtlx_normal(&mut self, node: &str) -> Option<TexLookup> {
        let (up, _) = self.nodes[node].connects.get("normal").cloned()?;
        if self.node_id(&up) != Some("ND_normalmap") {
            self.p.add(&format!("{}.inputs:normal", node), "a normal not from a normalmap node is not supported; the surface's own normal is used");
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

    /// `ND_standard_surface_surfaceshader` as a surface Tide has (see the module's text).
    pub(super) fn standard_surface(&mut self, n: &str) -> SurfaceDesc {
        for (input, neutral, what) in [
            ("subsurface", &[0.0][..], "subsurface scattering"),
            ("sheen", &[0.0], "sheen"),
            ("thin_film_thickness", &[0.0], "a thin film"),
            ("diffuse_roughness", &[0.0], "diffuse roughness"),
            ("coat_color", &[1.0], "a tinted coat"),
            ("specular_anisotropy", &[0.0], "anisotropy"),
        ] {
            self.unsupported(n, input, neutral, what);
        }
        let ior = self.constant_only(n, "specular_IOR", 1.5);
        let transmission = self.constant_only(n, "transmission", 0.0);
        if transmission > 0.0 {
            if transmission < 1.0 {
                self.p.add(&format!("{}.inputs:transmission", n), format!("partial transmission ({}) renders as a clear dielectric", transmission));
            }
            self.unsupported(n, "transmission_color", &[1.0], "a tinted transmission (give the body a TideMedium)");
            self.unsupported(n, "thin_walled", &[0.0], "a thin-walled transmission");
            let roughness = self.constant_only(n, "specular_roughness", 0.2);
            return SurfaceDesc::Water(WaterDesc { ior, roughness, ..WaterDesc::default() });
        }
        let metallic = self.float(n, "metalness", 0.0);
        let specular = self.constant_only(n, "specular", 1.0);
        if specular != 0.0 && specular != 1.0 {
            self.p.add(&format!("{}.inputs:specular", n), format!("a specular weight of {} renders as 1", specular));
        }
        self.unsupported(n, "specular_color", &[1.0], "a tinted specular");
        // no specular on a non-metal: UsdPreviewSurface's specular workflow with black specular
        let plain_diffuse = specular == 0.0 && metallic == FloatInput::Const(0.0);
        let opacity = match self.color(n, "opacity", [1.0; 3]) {
            ColorInput::Const(c) => FloatInput::Const((c[0] + c[1] + c[2]) / 3.0),
            ColorInput::Texture(mut t) => {
                t.channel = Channel::R;
                FloatInput::Texture(t)
            }
            ColorInput::Primvar(l) => FloatInput::Primvar(l),
        };
        let normal = self.mtlx_normal(n);
        SurfaceDesc::Preview(PreviewSurfaceDesc {
            diffuse_color: self.weighted_color(n, "base_color", [0.8; 3], "base", 1.0),
            emissive_color: self.weighted_color(n, "emission_color", [1.0; 3], "emission", 0.0),
            use_specular_workflow: plain_diffuse,
            specular_color: ColorInput::Const([0.0; 3]),
            metallic,
            roughness: self.float(n, "specular_roughness", 0.2),
            clearcoat: self.float(n, "coat", 0.0),
            clearcoat_roughness: self.float(n, "coat_roughness", 0.1),
            opacity,
            opacity_threshold: 0.0,
            ior,
            normal,
            wet: None,
        })
    }
}
