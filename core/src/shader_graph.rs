//! Per-hit arithmetic over texture and primvar lookups: what a shading node graph computes
//! where it cannot be folded into one lookup (a texture times a texture, a mask mixing two
//! textures, a primvar remapped through a chain of nodes). The delegate builds an [`Expr`]
//! from MaterialX nodes; the core evaluates it at each hit, and over emissive triangles that
//! are sampled as lights.
//!
//! Every value has four components. A colour reads the first three, a scalar the first; the
//! builder broadcasts scalars to all four where a node mixes the two.
//!
//! Besides lookups, a graph reads the geometry where it is evaluated (its texture coordinates,
//! position, normal and tangent) and MaterialX's procedural noises of any point it computes
//! ([`crate::noise`]).

use crate::noise::Noise;
use crate::scene::{PrimvarLookup, TexLookup};
use crate::texture::channel_rgba;

/// A value computed at a point of a surface.
#[derive(Clone, Debug, PartialEq)]
pub enum Expr {
    Const([f32; 4]),
    /// A texture's scaled and biased RGBA; a single-channel lookup (`channel` R, G, B or A)
    /// gives that channel in all four components.
    Texture(TexLookup),
    /// A primvar's value, or the lookup's fallback where the geometry lacks it, times the
    /// lookup's scale.
    Primvar(PrimvarLookup),
    /// The geometry's texture coordinates (u, v, 0, 0).
    TexCoord,
    /// The point's position (x, y, z, 0): in the world, or in the geometry's own space.
    Position { world: bool },
    /// The unit shading normal (x, y, z, 0), in the world or in the geometry's own space.
    Normal { world: bool },
    /// The unit tangent (x, y, z, 0), the direction of increasing u (∂p/∂u), in the world or
    /// in the geometry's own space.
    Tangent { world: bool },
    /// The unit bitangent (x, y, z, 0): normal × tangent, normalised, in that space (as
    /// MaterialX's generated shaders compute it).
    Bitangent { world: bool },
    /// The texture lookup (an [`Expr::Texture`]) read at the coordinates the second operand
    /// computes (its x and y) instead of its own.
    TextureAt(Box<Expr>, Box<Expr>),
    /// Three values blended by a direction's weights: of [n, s, a, b, c], the weights are
    /// w = |n| / (|n|·1) over n's x, y and z, raised to the power s (the first component) and
    /// renormalised to sum 1, and the result w_x a + w_y b + w_z c (MaterialX's triplanar
    /// blend).
    Blend3(Box<[Expr; 5]>),
    /// A MaterialX noise ([`Noise::eval`]) of `point` (its x, y and, for a noise in space, z),
    /// with the parameters `params` (components as [`crate::noise::NoiseKind`] lists them).
    Noise { noise: Noise, point: Box<Expr>, params: Box<Expr> },
    Unary(Unary, Box<Expr>),
    Binary(Binary, Box<Expr>, Box<Expr>),
    /// Component k of the result is component `pick[k]` (0..4) of the operand.
    Swizzle(Box<Expr>, [u8; 4]),
}

/// Per-component functions of one operand.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unary {
    Abs,
    Floor,
    Ceil,
    Sqrt,
    Exp,
    Ln,
    Sin,
    Cos,
    Sign,
}

/// Per-component functions of two operands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Binary {
    Add,
    Sub,
    Mul,
    Div,
    Min,
    Max,
    /// `a` to the power `b`.
    Pow,
    /// `a − b·⌊a / b⌋` (GLSL's `mod`, MaterialX's `modulo`).
    Modulo,
    /// 1 where `a > b`, else 0.
    Greater,
}

/// What an [`Expr`]'s leaves read where it is evaluated.
pub trait Lookups {
    /// A texture lookup's scaled and biased RGBA (channel not applied) at texture coordinates
    /// `st` (before the lookup's own transform).
    fn texture(&self, l: &TexLookup, st: glam::Vec2) -> [f32; 4];
    /// A primvar lookup's value (fallback and scale applied).
    fn primvar(&self, l: &PrimvarLookup) -> [f32; 4];
    /// The geometry's texture coordinates.
    fn uv(&self) -> glam::Vec2;
    /// The point's position in the world (`world`) or in the geometry's own space.
    fn position(&self, world: bool) -> glam::Vec3;
    /// The unit shading normal there, in the world or in the geometry's own space.
    fn normal(&self, world: bool) -> glam::Vec3;
    /// The unit tangent there (the direction of increasing u), in the world or in the
    /// geometry's own space.
    fn tangent(&self, world: bool) -> glam::Vec3;

    /// The coordinates a lookup reads by itself: its uv set's primvar, or the geometry's own.
    fn st(&self, l: &TexLookup) -> glam::Vec2 {
        match &l.uv_set {
            Some(set) => {
                let v = self.primvar(set);
                glam::Vec2::new(v[0], v[1])
            }
            None => self.uv(),
        }
    }
}

impl Unary {
    fn apply(self, x: f32) -> f32 {
        match self {
            Unary::Abs => x.abs(),
            Unary::Floor => x.floor(),
            Unary::Ceil => x.ceil(),
            Unary::Sqrt => x.sqrt(),
            Unary::Exp => x.exp(),
            Unary::Ln => x.ln(),
            Unary::Sin => x.sin(),
            Unary::Cos => x.cos(),
            Unary::Sign => {
                if x > 0.0 {
                    1.0
                } else if x < 0.0 {
                    -1.0
                } else {
                    0.0
                }
            }
        }
    }
}

impl Binary {
    fn apply(self, a: f32, b: f32) -> f32 {
        match self {
            Binary::Add => a + b,
            Binary::Sub => a - b,
            Binary::Mul => a * b,
            Binary::Div => a / b,
            Binary::Min => a.min(b),
            Binary::Max => a.max(b),
            Binary::Pow => a.powf(b),
            Binary::Modulo => a - b * (a / b).floor(),
            Binary::Greater => f32::from(u8::from(a > b)),
        }
    }
}

impl Expr {
    /// `op(a, b)`.
    pub fn binary(op: Binary, a: Expr, b: Expr) -> Expr {
        Expr::Binary(op, Box::new(a), Box::new(b))
    }

    /// `op(a)`.
    pub fn unary(op: Unary, a: Expr) -> Expr {
        Expr::Unary(op, Box::new(a))
    }

    /// Component `k` of `a` in all four components.
    pub fn splat(a: Expr, k: u8) -> Expr {
        Expr::Swizzle(Box::new(a), [k; 4])
    }

    /// `bg + (fg − bg) · mix`, per component.
    pub fn mix(fg: Expr, bg: Expr, mix: Expr) -> Expr {
        let d = Expr::binary(Binary::Sub, fg, bg.clone());
        Expr::binary(Binary::Add, bg, Expr::binary(Binary::Mul, d, mix))
    }

    /// The value where `at` answers the lookups. A component that is not finite (a division
    /// by zero, a root or logarithm of a negative) is 0, at each node: what follows never sees
    /// an infinity or a NaN.
    pub fn eval(&self, at: &dyn Lookups) -> [f32; 4] {
        let finite = |v: [f32; 4]| v.map(|x| if x.is_finite() { x } else { 0.0 });
        finite(match self {
            Expr::Const(v) => *v,
            Expr::Texture(l) => channel_rgba(at.texture(l, at.st(l)), l.channel),
            Expr::TextureAt(lookup, st) => match &**lookup {
                Expr::Texture(l) => {
                    let st = st.eval(at);
                    channel_rgba(at.texture(l, glam::Vec2::new(st[0], st[1])), l.channel)
                }
                // a lookup made constant (a missing texture's fallback)
                other => other.eval(at),
            },
            Expr::Primvar(l) => at.primvar(l),
            Expr::TexCoord => {
                let uv = at.uv();
                [uv.x, uv.y, 0.0, 0.0]
            }
            Expr::Position { world } => at.position(*world).extend(0.0).to_array(),
            Expr::Normal { world } => at.normal(*world).extend(0.0).to_array(),
            Expr::Tangent { world } => at.tangent(*world).extend(0.0).to_array(),
            Expr::Bitangent { world } => at.normal(*world).cross(at.tangent(*world)).normalize_or_zero().extend(0.0).to_array(),
            Expr::Noise { noise, point, params } => noise.eval(point.eval(at), params.eval(at)),
            Expr::Blend3(parts) => {
                let [n, s, values @ ..] = &**parts;
                let (n, s) = (n.eval(at), s.eval(at)[0]);
                let a = [n[0].abs(), n[1].abs(), n[2].abs()];
                let sum = a[0] + a[1] + a[2];
                let q = a.map(|x| (x / sum).powf(s));
                let total = q[0] + q[1] + q[2];
                let mut out = [0.0; 4];
                for (w, v) in q.iter().zip(values) {
                    let v = v.eval(at);
                    for k in 0..4 {
                        out[k] += w / total * v[k];
                    }
                }
                out
            }
            Expr::Unary(op, a) => a.eval(at).map(|x| op.apply(x)),
            Expr::Binary(op, a, b) => {
                let (a, b) = (a.eval(at), b.eval(at));
                std::array::from_fn(|k| op.apply(a[k], b[k]))
            }
            Expr::Swizzle(a, pick) => {
                let a = a.eval(at);
                pick.map(|k| a[(k as usize).min(3)])
            }
        })
    }

    /// The value, where the expression reads no texture, primvar or geometry.
    pub fn constant_value(&self) -> Option<[f32; 4]> {
        struct Nothing;
        impl Lookups for Nothing {
            fn texture(&self, l: &TexLookup, _st: glam::Vec2) -> [f32; 4] {
                l.fallback
            }
            fn primvar(&self, l: &PrimvarLookup) -> [f32; 4] {
                l.fallback
            }
            fn uv(&self) -> glam::Vec2 {
                glam::Vec2::ZERO
            }
            fn position(&self, _: bool) -> glam::Vec3 {
                glam::Vec3::ZERO
            }
            fn normal(&self, _: bool) -> glam::Vec3 {
                glam::Vec3::ZERO
            }
            fn tangent(&self, _: bool) -> glam::Vec3 {
                glam::Vec3::ZERO
            }
        }
        let mut leaves = 0;
        self.leaves(&mut |_| leaves += 1);
        (leaves == 0 && !self.reads_geometry()).then(|| self.eval(&Nothing))
    }

    /// Whether the expression reads the geometry itself: its texture coordinates, position,
    /// normal or tangent.
    pub fn reads_geometry(&self) -> bool {
        match self {
            Expr::TexCoord | Expr::Position { .. } | Expr::Normal { .. } | Expr::Tangent { .. } | Expr::Bitangent { .. } => true,
            Expr::Const(_) | Expr::Texture(_) | Expr::Primvar(_) => false,
            Expr::Unary(_, a) | Expr::Swizzle(a, _) => a.reads_geometry(),
            Expr::Binary(_, a, b) | Expr::TextureAt(a, b) | Expr::Noise { point: a, params: b, .. } => a.reads_geometry() || b.reads_geometry(),
            Expr::Blend3(parts) => parts.iter().any(Expr::reads_geometry),
        }
    }

    /// The number of operations and leaves in the expression, or None where it passes
    /// `limit` (counted no further).
    pub fn size_within(&self, limit: usize) -> Option<usize> {
        fn count(e: &Expr, left: &mut usize) -> bool {
            if *left == 0 {
                return false;
            }
            *left -= 1;
            match e {
                Expr::Const(_) | Expr::Texture(_) | Expr::Primvar(_) | Expr::TexCoord | Expr::Position { .. } | Expr::Normal { .. } | Expr::Tangent { .. } | Expr::Bitangent { .. } => true,
                Expr::Unary(_, a) | Expr::Swizzle(a, _) => count(a, left),
                Expr::Binary(_, a, b) | Expr::TextureAt(a, b) | Expr::Noise { point: a, params: b, .. } => count(a, left) && count(b, left),
                Expr::Blend3(parts) => parts.iter().all(|p| count(p, left)),
            }
        }
        let mut left = limit;
        count(self, &mut left).then_some(limit - left)
    }

    /// Calls `f` on every texture and primvar leaf, left to right.
    pub fn leaves_mut(&mut self, f: &mut dyn FnMut(&mut Expr)) {
        match self {
            Expr::Const(_) | Expr::TexCoord | Expr::Position { .. } | Expr::Normal { .. } | Expr::Tangent { .. } | Expr::Bitangent { .. } => {}
            Expr::Texture(_) | Expr::Primvar(_) => f(self),
            Expr::Unary(_, a) | Expr::Swizzle(a, _) => a.leaves_mut(f),
            Expr::Binary(_, a, b) | Expr::TextureAt(a, b) | Expr::Noise { point: a, params: b, .. } => {
                a.leaves_mut(f);
                b.leaves_mut(f);
            }
            Expr::Blend3(parts) => parts.iter_mut().for_each(|p| p.leaves_mut(f)),
        }
    }

    /// Calls `f` on every texture and primvar leaf, left to right.
    pub fn leaves(&self, f: &mut dyn FnMut(&Expr)) {
        match self {
            Expr::Const(_) | Expr::TexCoord | Expr::Position { .. } | Expr::Normal { .. } | Expr::Tangent { .. } | Expr::Bitangent { .. } => {}
            Expr::Texture(_) | Expr::Primvar(_) => f(self),
            Expr::Unary(_, a) | Expr::Swizzle(a, _) => a.leaves(f),
            Expr::Binary(_, a, b) | Expr::TextureAt(a, b) | Expr::Noise { point: a, params: b, .. } => {
                a.leaves(f);
                b.leaves(f);
            }
            Expr::Blend3(parts) => parts.iter().for_each(|p| p.leaves(f)),
        }
    }

    /// Every primvar the expression reads: its own lookups' and its textures' uv sets', each
    /// name once, in order of first use.
    pub fn primvar_names(&self) -> Vec<String> {
        let mut names: Vec<String> = Vec::new();
        self.leaves(&mut |leaf| {
            let name = match leaf {
                Expr::Primvar(l) => Some(&l.name),
                Expr::Texture(t) => t.uv_set.as_ref().map(|s| &s.name),
                _ => None,
            };
            if let Some(n) = name.filter(|n| !names.contains(n)) {
                names.push(n.clone());
            }
        });
        names
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Channel;

    #[test]
    fn an_expressions_size_is_counted_up_to_a_limit() {
        let leaf = Expr::TexCoord;
        let sum = Expr::binary(Binary::Add, leaf.clone(), Expr::Unary(Unary::Abs, Box::new(leaf.clone())));
        assert_eq!(sum.size_within(4), Some(4));
        assert_eq!(sum.size_within(3), None);
        assert_eq!(leaf.size_within(1), Some(1));
        assert_eq!(leaf.size_within(0), None);
        // a chain of 20 doublings spells 2^21 - 1 nodes; counting stops at the limit
        let mut e = leaf;
        for _ in 0..20 {
            e = Expr::binary(Binary::Mul, e.clone(), e);
        }
        assert_eq!(e.size_within(1 << 22), Some((1 << 21) - 1));
        assert_eq!(e.size_within(1000), None);
    }

    /// Textures answer `texture · 10 + row`, primvars `fallback + 100`.
    struct Fixed;
    impl Lookups for Fixed {
        fn texture(&self, l: &TexLookup, _st: glam::Vec2) -> [f32; 4] {
            [1.0, 2.0, 3.0, 4.0].map(|v| v + 10.0 * l.texture as f32)
        }
        fn primvar(&self, l: &PrimvarLookup) -> [f32; 4] {
            l.fallback.map(|v| v + 100.0)
        }
        fn uv(&self) -> glam::Vec2 {
            glam::Vec2::new(0.25, 0.75)
        }
        fn position(&self, world: bool) -> glam::Vec3 {
            if world { glam::Vec3::new(1.0, 2.0, 3.0) } else { glam::Vec3::new(-1.0, -2.0, -3.0) }
        }
        /// +Z in the world, +Y in the geometry's space.
        fn normal(&self, world: bool) -> glam::Vec3 {
            if world { glam::Vec3::Z } else { glam::Vec3::Y }
        }
        /// Not perpendicular to the normal in the geometry's space.
        fn tangent(&self, world: bool) -> glam::Vec3 {
            if world { glam::Vec3::X } else { glam::Vec3::new(0.6, 0.8, 0.0) }
        }
    }

    fn tex(i: usize, channel: Channel) -> Expr {
        Expr::Texture(TexLookup {
            texture: i,
            channel,
            transform: glam::Affine2::IDENTITY,
            tex_scale: [1.0; 4],
            bias: [0.0; 4],
            fallback: [0.0; 4],
            uv_set: None,
        })
    }

    fn c(v: [f32; 4]) -> Expr {
        Expr::Const(v)
    }

    #[test]
    fn arithmetic_per_component() {
        let a = c([1.0, -2.0, 9.0, 7.5]);
        let b = c([4.0, 3.0, 2.0, 2.0]);
        let cases = [
            (Binary::Add, [5.0, 1.0, 11.0, 9.5]),
            (Binary::Sub, [-3.0, -5.0, 7.0, 5.5]),
            (Binary::Mul, [4.0, -6.0, 18.0, 15.0]),
            (Binary::Div, [0.25, -2.0 / 3.0, 4.5, 3.75]),
            (Binary::Min, [1.0, -2.0, 2.0, 2.0]),
            (Binary::Max, [4.0, 3.0, 9.0, 7.5]),
            (Binary::Pow, [1.0, -8.0, 81.0, 56.25]),
            (Binary::Modulo, [1.0, 1.0, 1.0, 1.5]),
            (Binary::Greater, [0.0, 0.0, 1.0, 1.0]),
        ];
        for (op, want) in cases {
            let got = Expr::binary(op, a.clone(), b.clone()).eval(&Fixed);
            for k in 0..4 {
                assert!((got[k] - want[k]).abs() < 1e-6, "{:?}: {:?} vs {:?}", op, got, want);
            }
        }
        let u = c([-1.5, 0.0, 2.25, 1.0]);
        assert_eq!(Expr::unary(Unary::Abs, u.clone()).eval(&Fixed), [1.5, 0.0, 2.25, 1.0]);
        assert_eq!(Expr::unary(Unary::Floor, u.clone()).eval(&Fixed), [-2.0, 0.0, 2.0, 1.0]);
        assert_eq!(Expr::unary(Unary::Ceil, u.clone()).eval(&Fixed), [-1.0, 0.0, 3.0, 1.0]);
        assert_eq!(Expr::unary(Unary::Sign, u.clone()).eval(&Fixed), [-1.0, 0.0, 1.0, 1.0]);
        assert_eq!(Expr::unary(Unary::Exp, c([0.0; 4])).eval(&Fixed), [1.0; 4]);
        assert_eq!(Expr::unary(Unary::Cos, c([0.0; 4])).eval(&Fixed), [1.0; 4]);
        assert_eq!(Expr::unary(Unary::Sin, c([0.0; 4])).eval(&Fixed), [0.0; 4]);
    }

    #[test]
    fn non_finite_components_become_zero() {
        // √−2.25 and ln 0 and 1/0 are not numbers; the rest stays
        assert_eq!(Expr::unary(Unary::Sqrt, c([-1.5, 0.0, 2.25, 4.0])).eval(&Fixed), [0.0, 0.0, 1.5, 2.0]);
        assert_eq!(Expr::unary(Unary::Ln, c([0.0, -1.0, 1.0, 1.0])).eval(&Fixed), [0.0, 0.0, 0.0, 0.0]);
        assert_eq!(Expr::binary(Binary::Div, c([1.0; 4]), c([0.0, 2.0, 0.0, 4.0])).eval(&Fixed), [0.0, 0.5, 0.0, 0.25]);
        // a NaN met inside does not spread: 0 · (1/0) is 0, not NaN
        let inner = Expr::binary(Binary::Div, c([1.0; 4]), c([0.0; 4]));
        assert_eq!(Expr::binary(Binary::Mul, c([0.0; 4]), inner).eval(&Fixed), [0.0; 4]);
    }

    #[test]
    fn leaves_swizzles_and_mix() {
        // texture 0 answers (1, 2, 3, 4), texture 1 (11, 12, 13, 14); G gives 2 everywhere
        assert_eq!(tex(0, Channel::G).eval(&Fixed), [2.0; 4]);
        assert_eq!(Expr::Swizzle(Box::new(tex(1, Channel::Rgb)), [3, 2, 1, 0]).eval(&Fixed), [14.0, 13.0, 12.0, 11.0]);
        assert_eq!(Expr::splat(tex(1, Channel::Rgb), 2).eval(&Fixed), [13.0; 4]);
        let pv = Expr::Primvar(PrimvarLookup::new("mask", [0.25, 0.5, 0.75, 1.0]));
        assert_eq!(pv.eval(&Fixed), [100.25, 100.5, 100.75, 101.0]);
        // mix(fg, bg, m) = fg·m + bg·(1 − m)
        let m = c([0.0, 0.25, 1.0, 0.5]);
        let got = Expr::mix(tex(0, Channel::Rgb), tex(1, Channel::Rgb), m).eval(&Fixed);
        assert_eq!(got, [11.0, 12.0 * 0.75 + 2.0 * 0.25, 3.0, 9.0]);
    }

    #[test]
    fn primvar_names_include_uv_sets_once() {
        let mut t = tex(0, Channel::Rgb);
        if let Expr::Texture(l) = &mut t {
            l.uv_set = Some(PrimvarLookup::new("st1", [0.0; 4]));
        }
        let e = Expr::binary(
            Binary::Mul,
            Expr::binary(Binary::Add, Expr::Primvar(PrimvarLookup::new("dirt", [0.0; 4])), t),
            Expr::Primvar(PrimvarLookup::new("dirt", [1.0; 4])),
        );
        assert_eq!(e.primvar_names(), vec!["dirt".to_string(), "st1".to_string()]);
        assert_eq!(e.constant_value(), None);
        // texture coordinates are no constant either
        let uv = Expr::binary(Binary::Mul, Expr::TexCoord, c([2.0; 4]));
        assert_eq!((uv.constant_value(), uv.eval(&Fixed)), (None, [0.5, 1.5, 0.0, 0.0]));
        let p = Expr::binary(Binary::Add, Expr::Position { world: true }, Expr::Position { world: false });
        assert_eq!((p.constant_value(), p.eval(&Fixed)), (None, [0.0; 4]));
        let mut n = 0;
        let mut e2 = e.clone();
        e2.leaves_mut(&mut |leaf| {
            n += 1;
            *leaf = Expr::Const([n as f32; 4]);
        });
        // (1 + 2) · 3 once the three leaves are replaced
        assert_eq!(e2.eval(&Fixed), [9.0; 4]);
        assert_eq!(e2.constant_value(), Some([9.0; 4]));
    }

    /// Normal, tangent and bitangent in both spaces: the bitangent is normal × tangent,
    /// normalised, also where the tangent leans on the normal; none is a constant.
    #[test]
    fn normals_and_tangents_in_both_spaces() {
        let at = |e: Expr| (e.constant_value(), e.reads_geometry(), e.eval(&Fixed));
        assert_eq!(at(Expr::Normal { world: true }), (None, true, [0.0, 0.0, 1.0, 0.0]));
        assert_eq!(at(Expr::Normal { world: false }), (None, true, [0.0, 1.0, 0.0, 0.0]));
        assert_eq!(at(Expr::Tangent { world: true }), (None, true, [1.0, 0.0, 0.0, 0.0]));
        assert_eq!(at(Expr::Tangent { world: false }), (None, true, [0.6, 0.8, 0.0, 0.0]));
        // Z × X = Y; Y × (0.6, 0.8, 0) = (0, 0, −0.6), normalised to −Z
        assert_eq!(at(Expr::Bitangent { world: true }), (None, true, [0.0, 1.0, 0.0, 0.0]));
        assert_eq!(at(Expr::Bitangent { world: false }), (None, true, [0.0, 0.0, -1.0, 0.0]));
        // they are no texture or primvar leaves
        let e = Expr::binary(Binary::Add, Expr::Normal { world: true }, Expr::Bitangent { world: false });
        let mut n = 0;
        e.leaves(&mut |_| n += 1);
        assert_eq!((n, e.primvar_names().len()), (0, 0));
    }

    /// A noise evaluates its point's sub-expression where the graph is evaluated: its leaves
    /// are walked, it reads the geometry through its point, and a noise of a constant point is
    /// a constant.
    #[test]
    fn noise_of_a_computed_point() {
        use crate::noise::{Noise, NoiseKind};
        let perlin = Noise { kind: NoiseKind::Perlin, space: true, channels: 1 };
        let noise = |point: Expr, params: Expr| Expr::Noise { noise: perlin, point: Box::new(point), params: Box::new(params) };
        // the point: position × 0.5 + a primvar (fallback (0.25, 0.5, 0.75), +100 here)
        let pv = Expr::Primvar(PrimvarLookup::new("offset", [0.25, 0.5, 0.75, 0.0]));
        let point = Expr::binary(Binary::Add, Expr::binary(Binary::Mul, Expr::Position { world: true }, c([0.5; 4])), pv);
        let e = noise(point, c([0.0; 4]));
        let want = crate::noise::perlin3(glam::Vec3::new(0.5 + 100.25, 1.0 + 100.5, 1.5 + 100.75));
        assert_eq!(e.eval(&Fixed), [want; 4]);
        assert!(want != 0.0);
        assert_eq!((e.reads_geometry(), e.constant_value(), e.primvar_names()), (true, None, vec!["offset".to_string()]));
        // a texture in the parameters is a leaf too, after the point's
        let mut e2 = noise(Expr::Primvar(PrimvarLookup::new("p", [0.0; 4])), tex(3, Channel::R));
        let mut order = Vec::new();
        e2.leaves_mut(&mut |leaf| {
            order.push(matches!(leaf, Expr::Texture(_)));
            *leaf = Expr::Const([2.5; 4]);
        });
        assert_eq!(order, [false, true]);
        // now of the constant point (2.5, 2.5, 2.5): a constant, the noise there
        assert_eq!(e2.constant_value(), Some([crate::noise::perlin3(glam::Vec3::splat(2.5)); 4]));
        // of the texture coordinates: reads the geometry without any leaf
        let uv = noise(Expr::TexCoord, c([0.0; 4]));
        assert!(uv.reads_geometry() && uv.constant_value().is_none());
    }

    /// A lookup read at computed coordinates sees those coordinates, not the geometry's; its
    /// leaves are still visited (so that texture indices are remapped), and one made constant
    /// (a missing texture) is that constant.
    #[test]
    fn a_texture_read_at_computed_coordinates() {
        /// Textures answer (s, t, index, 1) of the coordinates they are read at.
        struct Echo;
        impl Lookups for Echo {
            fn texture(&self, l: &TexLookup, st: glam::Vec2) -> [f32; 4] {
                [st.x, st.y, l.texture as f32, 1.0]
            }
            fn primvar(&self, l: &PrimvarLookup) -> [f32; 4] {
                Fixed.primvar(l)
            }
            fn uv(&self) -> glam::Vec2 {
                Fixed.uv()
            }
            fn position(&self, world: bool) -> glam::Vec3 {
                Fixed.position(world)
            }
            fn normal(&self, world: bool) -> glam::Vec3 {
                Fixed.normal(world)
            }
            fn tangent(&self, world: bool) -> glam::Vec3 {
                Fixed.tangent(world)
            }
        }
        let plain = tex(3, Channel::Rgb);
        assert_eq!(plain.eval(&Echo), [0.25, 0.75, 3.0, 1.0]);
        // read at 2 uv + the position's (x, y)
        let st = Expr::binary(Binary::Add, Expr::binary(Binary::Mul, Expr::TexCoord, Expr::Const([2.0; 4])), Expr::Position { world: true });
        let mut warped = Expr::TextureAt(Box::new(tex(3, Channel::Rgb)), Box::new(st));
        assert_eq!(warped.eval(&Echo), [1.5, 3.5, 3.0, 1.0]);
        assert!(warped.constant_value().is_none() && warped.reads_geometry());
        let mut seen = 0;
        warped.leaves_mut(&mut |leaf| {
            if let Expr::Texture(l) = leaf {
                l.texture = 7;
                seen += 1;
            }
        });
        assert_eq!((seen, warped.eval(&Echo)), (1, [1.5, 3.5, 7.0, 1.0]));
        let gone = Expr::TextureAt(Box::new(Expr::Const([0.5; 4])), Box::new(Expr::TexCoord));
        assert_eq!(gone.eval(&Echo), [0.5; 4]);
    }

    /// The triplanar blend: one axis's value where the direction lies along it, the weights'
    /// power and renormalisation elsewhere.
    #[test]
    fn blend3_weights_by_the_direction() {
        let c = |v: [f32; 4]| Expr::Const(v);
        let blend = |n: [f32; 4], s: f32| Expr::Blend3(Box::new([c(n), c([s; 4]), c([1.0; 4]), c([10.0; 4]), c([100.0; 4])])).eval(&Fixed)[0];
        assert_eq!(blend([0.0, -3.0, 0.0, 0.0], 1.0), 10.0);
        assert!((blend([1.0, -1.0, 0.0, 0.0], 1.0) - 5.5).abs() < 1e-5);
        // w = (1/3, 2/3, 0), squared (1/9, 4/9, 0), renormalised (0.2, 0.8, 0)
        assert!((blend([-1.0, 2.0, 0.0, 0.0], 2.0) - (0.2 + 8.0)).abs() < 1e-4);
        // no direction: nothing, not a NaN
        assert_eq!(blend([0.0; 4], 1.0), 0.0);
    }
}
