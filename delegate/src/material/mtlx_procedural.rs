//! MaterialX's procedural nodes and geometric frame: `noise2d`, `noise3d`, `fractal2d`,
//! `fractal3d`, `cellnoise2d`, `cellnoise3d`, `worleynoise2d` and `worleynoise3d` (every
//! output type their nodedefs define, every input connected or constant), `normal`,
//! `tangent` and `bitangent` in the object's or the world's space, `unifiednoise2d` and
//! `unifiednoise3d`, and `triplanarprojection`, as node graph expressions evaluated at each hit
//! ([`tide_core::noise`] computes the noises as MaterialX's library does).
//!
//! A 2D noise reads the mesh's texture coordinates and a 3D one the object-space position,
//! unless its `texcoord` or `position` is connected or set. `noise2d`/`noise3d` give noise ×
//! amplitude + pivot, the fractals noise × amplitude; an `FA` variant's float amplitude
//! scales every component.

use super::{Ctx, Source, WrapKey};
use tide_core::noise::{Noise, NoiseKind, MAX_OCTAVES};
use tide_core::scene::Channel;
use tide_core::shader_graph::{Binary, Expr};

/// The node families read here.
pub(super) const PROCEDURAL: [&str; 14] = [
    "unifiednoise2d",
    "unifiednoise3d",
    "noise2d",
    "noise3d",
    "fractal2d",
    "fractal3d",
    "cellnoise2d",
    "cellnoise3d",
    "worleynoise2d",
    "worleynoise3d",
    "normal",
    "tangent",
    "bitangent",
    "triplanarprojection",
];

/// The components of each output type a noise node's id may name (`ND_noise2d_color3FA` →
/// `color3`).
const OUTPUTS: [(&str, u8); 6] = [("float", 1), ("vector2", 2), ("vector3", 3), ("color3", 3), ("vector4", 4), ("color4", 4)];

/// Scalar expressions as the components of one value (the rest 0): a constant where they all
/// are constants.
fn pack(parts: &[Expr]) -> Expr {
    let mut constant = [0.0; 4];
    let mut varying: Option<Expr> = None;
    for (k, part) in parts.iter().enumerate() {
        match part {
            Expr::Const(v) => constant[k] = v[0],
            e => {
                let mask = std::array::from_fn(|j| f32::from(u8::from(j == k)));
                let term = Expr::binary(Binary::Mul, e.clone(), Expr::Const(mask));
                varying = Some(match varying {
                    None => term,
                    Some(sum) => Expr::binary(Binary::Add, sum, term),
                });
            }
        }
    }
    match varying {
        None => Expr::Const(constant),
        Some(v) => Expr::binary(Binary::Add, v, Expr::Const(constant)),
    }
}

/// Whether `e` is a constant whose first `n` components are all `x`.
fn is_const(e: &Expr, n: u8, x: f32) -> bool {
    matches!(e, Expr::Const(v) if v[..n as usize].iter().all(|c| *c == x))
}

impl Ctx<'_> {
    /// A procedural or geometric node (family `name`, id `id`) as what it computes.
    pub(super) fn procedural(&mut self, name: &str, id: &str, node: &str, depth: u32) -> Result<Source, String> {
        match name {
            "normal" => return Ok(Source::Graph(Expr::Normal { world: self.world_space(node) })),
            "tangent" | "bitangent" => {
                let world = self.world_space(node);
                let index = self.input_f32(node, "index", 0.0);
                if index != 0.0 {
                    self.p.add(&format!("{}.inputs:index", node), format!("only the first texture coordinates' {name} is known; using index 0, not {index}"));
                }
                return Ok(Source::Graph(if name == "tangent" { Expr::Tangent { world } } else { Expr::Bitangent { world } }));
            }
            "triplanarprojection" => return self.triplanar(id, node, depth),
            "unifiednoise2d" | "unifiednoise3d" => return self.unified(name == "unifiednoise3d", id, node, depth),
            _ => {}
        }
        let space = name.ends_with("3d");
        let kind = match &name[..name.len() - 2] {
            "noise" => NoiseKind::Perlin,
            "fractal" => NoiseKind::Fractal,
            "cellnoise" => NoiseKind::Cell,
            _ => NoiseKind::Worley,
        };
        // the output type, and whether the amplitude is one float for all components
        let ty = id.strip_prefix("ND_").and_then(|r| r.strip_prefix(name)).and_then(|r| r.strip_prefix('_')).unwrap_or("");
        let (ty, float_amplitude) = match ty.strip_suffix("FA") {
            Some(t) => (t, true),
            None => (ty, false),
        };
        // the nodedefs: every type and its FA variant for the Perlin noises and the fractals
        // (no float FA), a float cell noise, float and vector2/3 Worley noises
        let defined = |n: u8| match kind {
            NoiseKind::Perlin | NoiseKind::Fractal => !(float_amplitude && n == 1),
            NoiseKind::Cell => n == 1 && !float_amplitude,
            NoiseKind::Worley => n <= 3 && !float_amplitude && !ty.starts_with("color"),
        };
        let channels = OUTPUTS.iter().find(|(t, n)| *t == ty && defined(*n)).map(|(_, n)| *n);
        let Some(channels) = channels else { return Err("is not a node MaterialX defines".into()) };
        let point = match space {
            true => self.coordinate(node, "position", Expr::Position { world: false }, depth)?,
            false => self.coordinate(node, "texcoord", Expr::TexCoord, depth)?,
        };
        let params = match kind {
            NoiseKind::Fractal => {
                let octaves = self.scalar_arg(node, "octaves", 3.0, depth)?;
                if let Expr::Const([n, ..]) = octaves {
                    if n > MAX_OCTAVES as f32 {
                        self.p.add(&format!("{}.inputs:octaves", node), format!("{n} octaves add nothing beyond {MAX_OCTAVES}; using {MAX_OCTAVES}"));
                    }
                }
                pack(&[octaves, self.scalar_arg(node, "lacunarity", 2.0, depth)?, self.scalar_arg(node, "diminish", 0.5, depth)?])
            }
            NoiseKind::Worley => {
                let style = self.scalar_arg(node, "style", 0.0, depth)?;
                if let Expr::Const([s, ..]) = style {
                    if s != 0.0 && s != 1.0 {
                        self.p.add(&format!("{}.inputs:style", node), format!("style {s} is neither 0 (distance) nor 1 (solid); using the distance"));
                    }
                }
                pack(&[self.scalar_arg(node, "jitter", 1.0, depth)?, style])
            }
            NoiseKind::Perlin | NoiseKind::Cell => Expr::Const([0.0; 4]),
        };
        let mut e = Expr::Noise { noise: Noise { kind, space, channels }, point: Box::new(point), params: Box::new(params) };
        if matches!(kind, NoiseKind::Perlin | NoiseKind::Fractal) {
            let amplitude = match float_amplitude || channels == 1 {
                true => self.scalar_arg(node, "amplitude", 1.0, depth)?,
                false => self.arg(node, "amplitude", 1.0, depth)?,
            };
            if !is_const(&amplitude, channels, 1.0) {
                e = Expr::binary(Binary::Mul, e, amplitude);
            }
        }
        if kind == NoiseKind::Perlin {
            let pivot = self.scalar_arg(node, "pivot", 0.0, depth)?;
            if !is_const(&pivot, channels, 0.0) {
                e = Expr::binary(Binary::Add, e, pivot);
            }
        }
        Ok(Source::from_expr(e))
    }

    /// `triplanarprojection`, as MaterialX's nodegraph computes it: images `filex`, `filey`
    /// and `filez` (periodic) read at two of the position's coordinates each (which two, and
    /// in what order, as `upaxis` says), weighted by the normal's |n| / (|n|·1) raised to
    /// 1 / clamp(blend, 0.03, 1) and renormalised. Position and normal default to the
    /// object's own.
    fn triplanar(&mut self, id: &str, node: &str, depth: u32) -> Result<Source, String> {
        let p = self.coordinate(node, "position", Expr::Position { world: false }, depth)?;
        let n = self.coordinate(node, "normal", Expr::Normal { world: false }, depth)?;
        let up = self.input_f32(node, "upaxis", 2.0);
        if ![0.0, 1.0, 2.0].contains(&up) {
            self.p.add(&format!("{}.inputs:upaxis", node), format!("upaxis {up} is none of 0 (X), 1 (Y), 2 (Z); using 2"));
        }
        let blend = self.scalar_arg(node, "blend", 1.0, depth)?;
        let fallback = self.value4(node, "default", [0.0; 4]);
        let c = |v: f32| Expr::Const([v; 4]);
        let bin = Expr::binary;
        let pick = |a: u8, b: u8| Expr::Swizzle(Box::new(p.clone()), [a, b, a, a]);
        // (x, y, z) = (0, 1, 2); the Z-facing image reads (−y, x) with X up
        let coordinates = match up as i64 {
            0 => [pick(2, 1), pick(2, 0), bin(Binary::Mul, pick(1, 0), Expr::Const([-1.0, 1.0, 1.0, 1.0]))],
            1 => [pick(2, 1), pick(0, 2), pick(0, 1)],
            _ => [pick(1, 2), pick(0, 2), pick(0, 1)],
        };
        let single = id.ends_with("_float");
        let filter = self.filter_type(node);
        let mut images = Vec::with_capacity(3);
        for (file, st) in ["filex", "filey", "filez"].into_iter().zip(coordinates) {
            let encoding = self.file_color_space(node, file);
            images.push(match self.texture_slot(node, file, encoding, Some(WrapKey::Repeat), Some(WrapKey::Repeat), filter) {
                Some(texture) => {
                    let mut l = self.plain_lookup(texture, fallback, None);
                    if single {
                        l.channel = Channel::R;
                    }
                    Expr::TextureAt(Box::new(Expr::Texture(l)), Box::new(st))
                }
                None => Expr::Const(if single { [fallback[0]; 4] } else { fallback }),
            });
        }
        let power = match blend {
            Expr::Const(b) => c(1.0 / b[0].clamp(0.03, 1.0)),
            b => bin(Binary::Div, c(1.0), bin(Binary::Min, bin(Binary::Max, b, c(0.03)), c(1.0))),
        };
        let [x, y, z]: [Expr; 3] = images.try_into().expect("three images");
        Ok(Source::from_expr(Expr::Blend3(Box::new([n, power, x, y, z]))))
    }

    /// `unifiednoise2d`/`unifiednoise3d`, as MaterialX's nodegraphs compute them: the point
    /// scaled by `freq` and moved by `offset`; turned by (jitter − 1) × 90000° (about (0.1, 1,
    /// 0) in space) for the Perlin, cell and (3D) fractal noises; Perlin as 0.5 noise + 0.5,
    /// a 2D fractal taking the turn as its third coordinate; mapped from [0, 1] to [outmin,
    /// outmax], clamped there unless `clampoutput` is false. The type and jitter are
    /// constants.
    fn unified(&mut self, space: bool, id: &str, node: &str, depth: u32) -> Result<Source, String> {
        if !id.ends_with("_float") {
            return Err("is not a node MaterialX defines".into());
        }
        let (c, bin) = (|v: f32| Expr::Const([v; 4]), Expr::binary);
        let p = match space {
            true => self.coordinate(node, "position", Expr::Position { world: false }, depth)?,
            false => self.coordinate(node, "texcoord", Expr::TexCoord, depth)?,
        };
        let q = bin(Binary::Add, bin(Binary::Mul, p, self.arg(node, "freq", 1.0, depth)?), self.arg(node, "offset", 0.0, depth)?);
        let kind = self.input_f32(node, "type", 0.0);
        let jitter = self.scalar_arg(node, "jitter", 1.0, depth)?;
        let Some([j, ..]) = jitter.constant_value() else { return Err("has a varying jitter, which is not supported".into()) };
        let turn = (j - 1.0) * 90000.0;
        let (s, co) = turn.to_radians().sin_cos();
        // the turned point, a linear map of q: Σ_k q_k · column_k
        let columns: Vec<[f32; 4]> = match space {
            // MaterialX's rotate2d: (c x + s y, −s x + c y)
            false => vec![[co, -s, 0.0, 0.0], [s, co, 0.0, 0.0]],
            // its rotate3d: v c + (v × a) s + a (a · v)(1 − c), a the unit axis
            true => {
                let a = glam::Vec3::new(0.1, 1.0, 0.0).normalize();
                (0..3)
                    .map(|k| {
                        let v = glam::Vec3::AXES[k];
                        let r = v * co + v.cross(a) * s + a * a.dot(v) * (1.0 - co);
                        [r.x, r.y, r.z, 0.0]
                    })
                    .collect()
            }
        };
        let turned = match turn == 0.0 {
            true => q.clone(),
            false => columns.iter().enumerate().map(|(k, col)| bin(Binary::Mul, Expr::splat(q.clone(), k as u8), Expr::Const(*col))).reduce(|a, b| bin(Binary::Add, a, b)).expect("two or three columns"),
        };
        let noise = |kind, space: bool, point: Expr, params: Expr| Expr::Noise { noise: Noise { kind, space, channels: 1 }, point: Box::new(point), params: Box::new(params) };
        let e = match kind as i64 {
            0 => bin(Binary::Add, bin(Binary::Mul, noise(NoiseKind::Perlin, space, turned, c(0.0)), c(0.5)), c(0.5)),
            1 => noise(NoiseKind::Cell, space, turned, c(0.0)),
            2 => {
                let style = self.scalar_arg(node, "style", 0.0, depth)?;
                noise(NoiseKind::Worley, space, q, pack(&[jitter, style]))
            }
            3 => {
                // always the 3D fractal: a 2D point takes the turn as its third coordinate
                let point = match space {
                    true => turned,
                    false => bin(Binary::Add, bin(Binary::Mul, q, Expr::Const([1.0, 1.0, 0.0, 0.0])), Expr::Const([0.0, 0.0, turn, 0.0])),
                };
                let params = pack(&[self.scalar_arg(node, "octaves", 3.0, depth)?, self.scalar_arg(node, "lacunarity", 2.0, depth)?, self.scalar_arg(node, "diminish", 0.5, depth)?]);
                noise(NoiseKind::Fractal, true, point, params)
            }
            _ => return Err(format!("has type {kind}, none of 0 (Perlin), 1 (cell), 2 (Worley), 3 (fractal)")),
        };
        let (low, high) = (self.scalar_arg(node, "outmin", 0.0, depth)?, self.scalar_arg(node, "outmax", 1.0, depth)?);
        let ranged = bin(Binary::Add, bin(Binary::Mul, e, bin(Binary::Sub, high.clone(), low.clone())), low.clone());
        let clamp = self.input_f32(node, "clampoutput", 1.0) != 0.0;
        Ok(Source::from_expr(match clamp {
            true => bin(Binary::Min, bin(Binary::Max, ranged, low), high),
            false => ranged,
        }))
    }

    /// An image node's `filtertype`: `linear` blends the four nearest texels, `closest` reads
    /// the one the coordinates fall in, `cubic` blends the 4×4 nearest by the cubic B-spline.
    pub(super) fn filter_type(&mut self, node: &str) -> tide_core::scene::Filter {
        use tide_core::scene::Filter;
        match self.input_token(node, "filtertype", &["linear", "closest", "cubic"], "linear") {
            "closest" => Filter::Closest,
            "cubic" => Filter::Cubic,
            _ => Filter::Linear,
        }
    }

    /// Whether a geometric node's `space` is the world's (`object`, the default, and `model`
    /// are the geometry's own).
    pub(super) fn world_space(&mut self, node: &str) -> bool {
        self.input_token(node, "space", &["object", "model", "world"], "object") == "world"
    }

    /// A scalar input as an expression: its constant, or its connection's first component.
    pub(super) fn scalar_arg(&mut self, node: &str, input: &str, default: f32, depth: u32) -> Result<Expr, String> {
        Ok(match self.operand(node, input, [default; 4], depth)? {
            Source::Fallback(v) => Expr::Const([v[0]; 4]),
            other => Expr::splat(other.scalar().into_expr(), 0),
        })
    }

    /// A coordinate input with a geometric default (`defaultgeomprop`): what it is connected
    /// to or set to, else `default`.
    fn coordinate(&mut self, node: &str, input: &str, default: Expr, depth: u32) -> Result<Expr, String> {
        let n = &self.nodes[node];
        match n.connects.contains_key(input) || n.inputs.contains_key(input) {
            true => self.arg(node, input, 0.0, depth),
            false => Ok(default),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{loaded, mat, tok, FixedHit};
    use crate::material::{convert_material, ColorInput, SurfaceDesc};
    use crate::value::{Problems, Value};
    use glam::{Vec2, Vec3};
    use tide_core::noise::{self, Metric, Noise, NoiseKind};
    use tide_core::shader_graph::Expr;

    const X: [f32; 4] = [0.3, 0.6, 0.9, 0.5];
    const UV: Vec2 = Vec2::new(0.37, 1.61);
    const OBJECT: Vec3 = Vec3::new(4.3, -5.2, 6.7);
    const WORLD: Vec3 = Vec3::new(1.1, 2.9, -3.4);

    /// A hit at texture coordinates [`UV`], at [`OBJECT`] in its own space and [`WORLD`] in
    /// the world, normal +Y there and +Z here, tangent +X there and (0.6, 0.8, 0) here; the
    /// primvar `x` is [`X`].
    const AT: FixedHit = FixedHit { x: X, uv: UV, object: OBJECT, world: WORLD, normal: [Vec3::Y, Vec3::Z], tangent: [Vec3::X, Vec3::new(0.6, 0.8, 0.0)] };

    /// A UsdPreviewSurface whose diffuseColor is node `/M/N` (`id`, `inputs`), beside a
    /// primvar `x` (`/M/X`), the world position (`/M/W`) and the texture coordinates × 8
    /// (`/M/Uv8`): the diffuse colour and the problems as (item, attribute, message).
    fn convert(id: &str, inputs: Vec<(&str, Value)>) -> (ColorInput, Vec<(String, String, String)>) {
        let mut pairs = vec![
            ("surface", Value::Path("/M/S".into())),
            ("/M/S.info:id", tok("UsdPreviewSurface")),
            ("/M/S.inputs:diffuseColor.connect", tok("/M/N.outputs:out")),
            ("/M/X.info:id", tok("ND_geompropvalue_color4")),
            ("/M/X.inputs:geomprop", Value::String("x".into())),
            ("/M/W.info:id", tok("ND_position_vector3")),
            ("/M/W.inputs:space", Value::String("world".into())),
            ("/M/Uv.info:id", tok("ND_texcoord_vector2")),
            ("/M/Uv8.info:id", tok("ND_multiply_vector2FA")),
            ("/M/Uv8.inputs:in1.connect", tok("/M/Uv.outputs:out")),
            ("/M/Uv8.inputs:in2", Value::Float(8.0)),
            ("/M/N.info:id", tok(id)),
        ];
        let names: Vec<String> = inputs.iter().map(|(k, _)| format!("/M/N.inputs:{k}")).collect();
        pairs.extend(names.iter().map(String::as_str).zip(inputs.into_iter().map(|(_, v)| v)));
        let mut p = Problems::new("/M");
        let m = convert_material("/M", &mat(&pairs), &loaded(false), &mut p);
        let SurfaceDesc::Preview(ps) = m.desc.surface else { panic!("{id}: {:?}", m.desc.surface) };
        (ps.diffuse_color, p.list.into_iter().map(|q| (q.item, q.attribute, q.message)).collect())
    }

    /// Each noise node, its defaults and its inputs set or connected, evaluates at the hit to
    /// MaterialX's noise of the point its nodedef names, times its amplitude, plus its pivot;
    /// the geometric nodes give the hit's frame in the space asked for.
    #[test]
    fn procedural_and_geometric_nodes_compute_their_specified_values() {
        let f = |x: f64| Value::Float(x);
        let floats = |a: &[f32]| Value::Floats { data: a.to_vec(), tuple: a.len() as u32 };
        let x = || tok("/M/X.outputs:out");
        let w = || tok("/M/W.outputs:out");
        let v4 = |v: Vec3, w: f32| [v.x, v.y, v.z, w];
        let (p2, p3, pw) = (noise::perlin2_vec3(UV), noise::perlin3_vec3(OBJECT), noise::perlin3_vec3(WORLD));
        let fr3 = |p: Vec3, d: f32| noise::fractal3(p, 3, 2.0, d);
        let fv3 = noise::fractal3_vec3(OBJECT, 3, 2.0, 0.3);
        let fr2 = |p: Vec2| noise::fractal2(p, 3, 2.0, 0.5);
        let wo2 = noise::worley2(UV, 0.5, Metric::Euclidean).distances;
        let wo3 = noise::worley3(OBJECT, 1.0, Metric::Euclidean).distances;
        let bitangent = Vec3::Z.cross(Vec3::new(0.6, 0.8, 0.0)).normalize();
        #[rustfmt::skip]
        let cases: Vec<(&str, Vec<(&str, Value)>, usize, [f32; 4])> = vec![
            // the mesh's texture coordinates, amplitude 1 and pivot 0 by default
            ("ND_noise2d_float", vec![], 4, [noise::perlin2(UV); 4]),
            ("ND_noise2d_vector3", vec![("amplitude", floats(&[2.0, 3.0, 4.0])), ("pivot", f(0.5))], 3, v4(p2 * Vec3::new(2.0, 3.0, 4.0) + 0.5, 0.0)),
            ("ND_noise2d_color4FA", vec![("amplitude", f(0.5))], 4, v4(p2 * 0.5, noise::perlin2(UV + Vec2::new(19.0, 73.0)) * 0.5)),
            // the object-space position by default
            ("ND_noise3d_color3FA", vec![("amplitude", f(0.5)), ("pivot", f(0.25))], 3, v4(p3 * 0.5 + 0.25, 0.0)),
            ("ND_noise3d_vector4", vec![("amplitude.connect", x())], 4, [p3.x * 0.3, p3.y * 0.6, p3.z * 0.9, noise::perlin3(OBJECT + Vec3::new(19.0, 73.0, 29.0)) * 0.5]),
            // a connected position and pivot (a scalar: x's first component)
            ("ND_noise3d_vector2FA", vec![("position.connect", w()), ("pivot.connect", x())], 2, [pw.x + 0.3, pw.y + 0.3, 0.0, 0.0]),
            ("ND_fractal3d_float", vec![("octaves", Value::Int(5)), ("lacunarity", f(1.5)), ("diminish", f(0.4)), ("position.connect", w())], 4, [noise::fractal3(WORLD, 5, 1.5, 0.4); 4]),
            ("ND_fractal3d_color4", vec![("amplitude", floats(&[1.0, 2.0, 3.0, 4.0])), ("diminish.connect", x())], 4, v4(fv3 * Vec3::new(1.0, 2.0, 3.0), 4.0 * fr3(OBJECT + Vec3::new(19.0, 193.0, 17.0), 0.3))),
            ("ND_fractal2d_vector2FA", vec![("amplitude", f(2.0))], 2, [2.0 * fr2(UV), 2.0 * fr2(UV + Vec2::new(19.0, 193.0)), 0.0, 0.0]),
            ("ND_cellnoise2d_float", vec![("texcoord.connect", tok("/M/Uv8.outputs:out"))], 4, [noise::cell2(UV * 8.0); 4]),
            ("ND_cellnoise3d_float", vec![], 4, [noise::cell3(OBJECT); 4]),
            ("ND_worleynoise2d_vector3", vec![("jitter", f(0.5))], 3, [wo2[0], wo2[1], wo2[2], 0.0]),
            ("ND_worleynoise3d_vector2", vec![], 2, [wo3[0], wo3[1], 0.0, 0.0]),
            // solid cells, the jitter connected (x's first component, 0.3)
            ("ND_worleynoise3d_float", vec![("style", Value::Int(1)), ("jitter.connect", x())], 4, [noise::cell3(noise::worley3(OBJECT, 0.3, Metric::Euclidean).nearest); 4]),
            // a point set rather than connected is that point: a constant
            ("ND_noise3d_float", vec![("position", floats(&[0.25, 0.5, 0.75]))], 3, [noise::perlin3(Vec3::new(0.25, 0.5, 0.75)); 4]),
            ("ND_normal_vector3", vec![], 3, [0.0, 1.0, 0.0, 0.0]),
            ("ND_normal_vector3", vec![("space", Value::String("world".into()))], 3, [0.0, 0.0, 1.0, 0.0]),
            ("ND_tangent_vector3", vec![("space", Value::String("model".into()))], 3, [1.0, 0.0, 0.0, 0.0]),
            ("ND_tangent_vector3", vec![("space", Value::String("world".into()))], 3, [0.6, 0.8, 0.0, 0.0]),
            ("ND_bitangent_vector3", vec![("space", Value::String("world".into()))], 3, v4(bitangent, 0.0)),
            ("ND_bitangent_vector3", vec![], 3, [0.0, 0.0, -1.0, 0.0]),
        ];
        for (id, inputs, n, want) in cases {
            let (color, problems) = convert(id, inputs);
            assert!(problems.is_empty(), "{id}: {problems:?}");
            let got = match color {
                ColorInput::Graph(e) => e.eval(&AT),
                ColorInput::Const(c) => [c[0], c[1], c[2], 0.0],
                other => panic!("{id}: {other:?}"),
            };
            for k in 0..n {
                assert!((got[k] - want[k]).abs() <= 1e-6 * (1.0 + want[k].abs()), "{id}: {got:?} vs {want:?}");
            }
        }
        // the defaults are the bare noise of the texture coordinates or the object's position
        let bare = |space: bool, point: Expr| {
            ColorInput::Graph(Expr::Noise { noise: Noise { kind: NoiseKind::Perlin, space, channels: 1 }, point: Box::new(point), params: Box::new(Expr::Const([0.0; 4])) })
        };
        assert_eq!(convert("ND_noise2d_float", vec![]).0, bare(false, Expr::TexCoord));
        assert_eq!(convert("ND_noise3d_float", vec![]).0, bare(true, Expr::Position { world: false }));
        // amplitude 0: the pivot, wherever the hit is
        let (color, _) = convert("ND_noise2d_float", vec![("amplitude", f(0.0)), ("pivot", f(0.625))]);
        let ColorInput::Graph(e) = color else { panic!() };
        assert_eq!(e.eval(&AT), [0.625; 4]);
    }

    /// What cannot be read, or reads otherwise than authored, is reported naming the material
    /// and the attribute; the rest of the node still reads.
    #[test]
    fn bad_procedural_inputs_are_reported_by_prim_and_attribute() {
        let cases: Vec<(&str, Vec<(&str, Value)>, &[&str], &str)> = vec![
            ("ND_fractal3d_float", vec![("octaves", Value::Int(100))], &["/M/N.inputs:octaves"], "using 64"),
            ("ND_worleynoise2d_float", vec![("style", Value::Int(2))], &["/M/N.inputs:style"], "using the distance"),
            ("ND_noise2d_float", vec![("amplitude", Value::String("loud".into()))], &["/M/N.inputs:amplitude"], "expected 1 to 4 finite numbers"),
            ("ND_noise3d_float", vec![("position.connect", tok("/Elsewhere/P.outputs:out"))], &["/M/N.inputs:position", "/M/S.inputs:diffuseColor"], "has an unusable position"),
            ("ND_cellnoise2d_vector3", vec![], &["/M/S.inputs:diffuseColor"], "is not a node MaterialX defines"),
            ("ND_worleynoise2d_color3", vec![], &["/M/S.inputs:diffuseColor"], "is not a node MaterialX defines"),
            ("ND_noise2d_floatFA", vec![], &["/M/S.inputs:diffuseColor"], "is not a node MaterialX defines"),
            ("ND_cellnoise3d_floatFA", vec![], &["/M/S.inputs:diffuseColor"], "is not a node MaterialX defines"),
            ("ND_tangent_vector3", vec![("index", Value::Int(1))], &["/M/N.inputs:index"], "using index 0"),
            ("ND_normal_vector3", vec![("space", Value::String("tangent".into()))], &["/M/N.inputs:space"], "using 'object'"),
        ];
        for (id, inputs, attrs, says) in cases {
            let (color, problems) = convert(id, inputs);
            assert_eq!(problems.iter().map(|(_, a, _)| a.as_str()).collect::<Vec<_>>(), attrs, "{id}: {problems:?}");
            assert!(problems.iter().all(|(item, _, _)| item == "/M"), "{id}: {problems:?}");
            assert!(problems.last().is_some_and(|(_, _, m)| m.contains(says)), "{id}: {problems:?}");
            // what still reads is a graph; an unusable node leaves the constant
            let unusable = attrs.contains(&"/M/S.inputs:diffuseColor");
            assert_eq!(matches!(color, ColorInput::Graph(_)), !unusable, "{id}: {color:?}");
        }
    }

    /// triplanarprojection: each image read at two of the object's coordinates (which two,
    /// and in what order, by `upaxis`), blended by the object's normal with the power
    /// 1 / blend; a missing image reads the default.
    #[test]
    fn triplanar_projection_reads_three_planes() {
        let file = || Value::Asset("/tex/albedo.png".into());
        let planes = |up: i64| {
            let (c, p) = convert("ND_triplanarprojection_color3", vec![("filex", file()), ("filey", file()), ("filez", file()), ("upaxis", Value::Int(up)), ("blend", Value::Float(0.25))]);
            assert!(p.is_empty(), "{p:?}");
            let ColorInput::Graph(Expr::Blend3(parts)) = c else { panic!("{c:?}") };
            let [n, power, images @ ..] = *parts;
            assert_eq!((n, power), (Expr::Normal { world: false }, Expr::Const([4.0; 4])));
            images.map(|e| match e {
                Expr::TextureAt(t, st) if matches!(*t, Expr::Texture(_)) => st.eval(&AT),
                other => panic!("{other:?}"),
            })
        };
        let (x, y, z) = (OBJECT.x, OBJECT.y, OBJECT.z);
        let st = |a: f32, b: f32| [a, b, a, a];
        assert_eq!(planes(2), [st(y, z), st(x, z), st(x, y)]);
        assert_eq!(planes(1), [st(z, y), st(x, z), st(x, y)]);
        let xup = planes(0);
        assert_eq!(&xup[..2], &[st(z, y), st(z, x)]);
        assert_eq!(&xup[2][..2], &[-y, x]);
        // no files: the default colour from every plane
        let (c, p) = convert("ND_triplanarprojection_color3", vec![("default", Value::Floats { data: vec![0.1, 0.2, 0.3], tuple: 3 })]);
        assert_eq!(p.iter().filter(|q| q.1.ends_with(":filex") || q.1.ends_with(":filey") || q.1.ends_with(":filez")).count(), 3, "{p:?}");
        let ColorInput::Graph(e) = c else { panic!("{c:?}") };
        let v = e.eval(&AT);
        assert!(v[..3].iter().zip([0.1, 0.2, 0.3]).all(|(a, b)| (a - b).abs() < 1e-6), "{v:?}");
    }

    /// unifiednoise2d/3d: each type of noise at the point scaled by `freq`, moved by `offset`
    /// and turned by (jitter − 1) × 90000° as MaterialX's rotate nodes turn it, mapped to
    /// [outmin, outmax] and clamped there unless told not to.
    #[test]
    fn unified_noise_follows_its_nodegraph() {
        let f = |x: f64| Value::Float(x);
        let floats = |a: &[f32]| Value::Floats { data: a.to_vec(), tuple: a.len() as u32 };
        let eval = |id: &str, inputs: Vec<(&str, Value)>| {
            let (c, p) = convert(id, inputs);
            assert!(p.is_empty(), "{id}: {p:?}");
            match c {
                ColorInput::Graph(e) => e.eval(&AT)[0],
                ColorInput::Const(v) => v[0],
                other => panic!("{other:?}"),
            }
        };
        let near = |a: f32, b: f32| assert!((a - b).abs() < 1e-5, "{a} vs {b}");
        // defaults: Perlin of the texture coordinates as 0.5 n + 0.5, in [0, 1]
        near(eval("ND_unifiednoise2d_float", vec![]), (0.5 * noise::perlin2(UV) + 0.5).clamp(0.0, 1.0));
        // a jitter of 0.9995 turns the point by −45° (rotate2d: (c x + s y, −s x + c y))
        let q = UV * Vec2::new(2.0, 3.0) + Vec2::new(0.1, 0.2);
        let turn = (0.9995f32 - 1.0) * 90000.0;
        assert!((turn + 45.0).abs() < 0.01, "{turn}");
        let (s, c) = turn.to_radians().sin_cos();
        let turned = Vec2::new(c * q.x + s * q.y, -s * q.x + c * q.y);
        let common = || vec![("freq", floats(&[2.0, 3.0])), ("offset", floats(&[0.1, 0.2])), ("jitter", f(0.9995)), ("outmin", f(-1.0)), ("outmax", f(2.0)), ("clampoutput", Value::Bool(false))];
        near(eval("ND_unifiednoise2d_float", common()), (0.5 * noise::perlin2(turned) + 0.5) * 3.0 - 1.0);
        let with = |kind: i64| {
            let mut v = common();
            v.push(("type", Value::Int(kind)));
            v
        };
        near(eval("ND_unifiednoise2d_float", with(1)), noise::cell2(turned) * 3.0 - 1.0);
        // Worley takes the point before the turn, with the jitter
        near(eval("ND_unifiednoise2d_float", with(2)), noise::worley2(q, 0.9995, Metric::Euclidean).distances[0] * 3.0 - 1.0);
        // the 2D fractal is the 3D one at (q, turn)
        near(eval("ND_unifiednoise2d_float", with(3)), noise::fractal3(q.extend(turn), 3, 2.0, 0.5) * 3.0 - 1.0);
        // the turn matters: unturned, the Perlin value differs
        assert!((eval("ND_unifiednoise2d_float", common()) - ((0.5 * noise::perlin2(q) + 0.5) * 3.0 - 1.0)).abs() > 1e-3);
        // 3D: the object's position, turned about (0.1, 1, 0) by about −90° (rotate3d: v c +
        // (v × a) s + a (a · v)(1 − c))
        let a = Vec3::new(0.1, 1.0, 0.0).normalize();
        let (s, c) = ((0.999f32 - 1.0) * 90000.0).to_radians().sin_cos();
        let v = OBJECT;
        let turned3 = v * c + v.cross(a) * s + a * a.dot(v) * (1.0 - c);
        // the two turn the point through different roundings (a few 1e-6 at |p| ≈ 9): allow
        // what the fractal changes by over 1e-5 along each axis
        let fr = |p: Vec3| noise::fractal3(p, 3, 2.0, 0.5);
        let slack = Vec3::AXES.iter().map(|e| (fr(turned3 + *e * 1e-5) - fr(turned3)).abs()).fold(1e-6f32, f32::max);
        let got = eval("ND_unifiednoise3d_float", vec![("jitter", f(0.999)), ("type", Value::Int(3)), ("clampoutput", Value::Bool(false))]);
        assert!((got - fr(turned3)).abs() < 3.0 * slack, "{got} vs {} (slack {slack})", fr(turned3));
        assert!((got - fr(OBJECT)).abs() > 1e-3 && (got - fr(v * c - v.cross(a) * s + a * a.dot(v) * (1.0 - c))).abs() > 1e-3, "the turn and its sense matter");
        // clamped by default
        let clamped = eval("ND_unifiednoise3d_float", vec![("type", Value::Int(3)), ("outmin", f(0.2)), ("outmax", f(0.3))]);
        near(clamped, (noise::fractal3(OBJECT, 3, 2.0, 0.5) * 0.1 + 0.2).clamp(0.2, 0.3));
        // an unknown type and a varying jitter are reported at the node
        for inputs in [vec![("type", Value::Int(7))], vec![("jitter.connect", tok("/M/X.outputs:out"))]] {
            let (_, p) = convert("ND_unifiednoise3d_float", inputs);
            assert_eq!(p.len(), 1, "{p:?}");
        }
    }
}
