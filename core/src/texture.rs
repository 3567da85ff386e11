//! Texture evaluation for material inputs: UsdUVTexture (bilinear or closest-texel lookup, wrap modes, scale,
//! bias, fallback, channel selection) after a UsdTransform2d of the st coordinates.

use crate::scene::{Channel, Filter, TexLookup, TextureDesc, Wrap};
use glam::Vec2;

#[path = "texture/texels.rs"]
mod texels;
pub use texels::{half_to_f32, CodeValues, CodeValues16, Texels, CODES16};

#[inline]
fn wrap_coord(i: i64, n: i64, wrap: Wrap) -> Option<i64> {
    match wrap {
        Wrap::Repeat => Some(i.rem_euclid(n)),
        Wrap::Clamp | Wrap::Default => Some(i.clamp(0, n - 1)),
        Wrap::Mirror => {
            let p = i.rem_euclid(2 * n);
            Some(if p < n { p } else { 2 * n - 1 - p })
        }
        Wrap::Black => (0..n).contains(&i).then_some(i),
    }
}

/// The lookup's texture coordinates for `st`: its transform applied.
#[inline]
pub fn transform_st(l: &TexLookup, st: Vec2) -> Vec2 {
    l.transform.transform_point2(st)
}

/// The texel values (4 channels; missing ones filled: grey → RGB, alpha → 1) at (x, y); black
/// (zero, alpha included) outside the image under `black` wrapping, as UsdUVTexture says.
#[inline]
fn texel(t: &TextureDesc, x: i64, y: i64) -> [f32; 4] {
    let (w, h) = (t.width as i64, t.height as i64);
    let (Some(x), Some(y)) = (wrap_coord(x, w, t.wrap_s), wrap_coord(y, h, t.wrap_t)) else {
        return [0.0; 4];
    };
    let c = t.channels as usize;
    let i = (y as usize * t.width as usize + x as usize) * c;
    let p = t.pixels.texel(i, c);
    match c {
        1 => [p[0], p[0], p[0], 1.0],
        2 => [p[0], p[0], p[0], p[1]],
        3 => [p[0], p[1], p[2], 1.0],
        _ => [p[0], p[1], p[2], p[3]],
    }
}

/// Bilinearly filtered, scaled and biased RGBA at texture coordinates `st` (before transform).
pub fn lookup_rgba(textures: &[TextureDesc], l: &TexLookup, st: Vec2) -> [f32; 4] {
    lookup_rgba_in(textures.get(l.texture), l, st)
}

/// [`lookup_rgba`] in texture `t` (the lookup's index not read); the fallback where `t` is None.
pub fn lookup_rgba_in(t: Option<&TextureDesc>, l: &TexLookup, st: Vec2) -> [f32; 4] {
    let Some(t) = t else {
        return l.fallback;
    };
    let uv = transform_st(l, st);
    let outside = |c: f32, wrap: Wrap| wrap == Wrap::Default && !(0.0..=1.0).contains(&c);
    if outside(uv.x, t.wrap_s) || outside(uv.y, t.wrap_t) {
        return l.fallback;
    }
    // st (0,0) is the bottom-left of the image; rows are stored from the top
    let x = uv.x * t.width as f32 - 0.5;
    let y = (1.0 - uv.y) * t.height as f32 - 0.5;
    if !(x.is_finite() && y.is_finite()) {
        return l.fallback;
    }
    if t.filter == Filter::Closest {
        // the texel whose square holds the coordinates (texel k spans [k, k + 1) of x + 0.5)
        let v = texel(t, (x + 0.5).floor() as i64, (y + 0.5).floor() as i64);
        return std::array::from_fn(|k| v[k] * l.tex_scale[k] + l.bias[k]);
    }
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (xi, yi) = (x0 as i64, y0 as i64);
    if t.filter == Filter::Cubic {
        let (wx, wy) = (bspline_weights(fx), bspline_weights(fy));
        let mut v = [0.0f32; 4];
        for (j, wyj) in wy.iter().enumerate() {
            for (i, wxi) in wx.iter().enumerate() {
                let s = texel(t, xi - 1 + i as i64, yi - 1 + j as i64);
                let w = wxi * wyj;
                for k in 0..4 {
                    v[k] += s[k] * w;
                }
            }
        }
        return std::array::from_fn(|k| v[k] * l.tex_scale[k] + l.bias[k]);
    }
    let a = texel(t, xi, yi);
    let b = texel(t, xi + 1, yi);
    let c = texel(t, xi, yi + 1);
    let d = texel(t, xi + 1, yi + 1);
    std::array::from_fn(|k| {
        let v = (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy;
        v * l.tex_scale[k] + l.bias[k]
    })
}

/// The uniform cubic B-spline's weights of the texels at −1, 0, 1 and 2 from the one before
/// a lookup at fraction `f` (0–1) past it: they sum to 1 and reproduce linear ramps.
fn bspline_weights(f: f32) -> [f32; 4] {
    let (f2, f3) = (f * f, f * f * f);
    let g = 1.0 - f;
    [g * g * g / 6.0, (3.0 * f3 - 6.0 * f2 + 4.0) / 6.0, (-3.0 * f3 + 3.0 * f2 + 3.0 * f + 1.0) / 6.0, f3 / 6.0]
}

/// `v` as a lookup's channel gives it: RGBA, or one channel in all four components.
pub fn channel_rgba(v: [f32; 4], channel: Channel) -> [f32; 4] {
    match channel {
        Channel::Rgb => v,
        Channel::R => [v[0]; 4],
        Channel::G => [v[1]; 4],
        Channel::B => [v[2]; 4],
        Channel::A => [v[3]; 4],
    }
}

/// An RGB value of a lookup (single-channel outputs are replicated).
pub fn lookup_rgb(textures: &[TextureDesc], l: &TexLookup, st: Vec2) -> [f32; 3] {
    let v = channel_rgba(lookup_rgba(textures, l, st), l.channel);
    [v[0], v[1], v[2]]
}

/// A scalar value of a lookup (`Rgb` reads the red channel, as UsdPreviewSurface float
/// inputs connected to `outputs:rgb` do).
pub fn lookup_float(textures: &[TextureDesc], l: &TexLookup, st: Vec2) -> f32 {
    channel_rgba(lookup_rgba(textures, l, st), l.channel)[0]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tex(wrap: Wrap) -> TextureDesc {
        // 2×2 RGB: top row red, green; bottom row blue, white
        TextureDesc {
            name: "t".into(),
            width: 2,
            height: 2,
            channels: 3,
            pixels: vec![1., 0., 0., 0., 1., 0., 0., 0., 1., 1., 1., 1.].into(),
            wrap_s: wrap,
            wrap_t: wrap,
            filter: crate::scene::Filter::Linear,
        }
    }

    fn lookup() -> TexLookup {
        TexLookup { texture: 0, channel: Channel::Rgb, transform: glam::Affine2::IDENTITY, tex_scale: [1.0; 4], bias: [0.0; 4], fallback: [0.5, 0.5, 0.5, 1.0], uv_set: None }
    }

    #[test]
    fn texel_centres_orientation_and_wrapping() {
        let t = [tex(Wrap::Repeat)];
        let l = lookup();
        // st (0.25, 0.75) is the top-left texel centre (red); (0.25, 0.25) bottom-left (blue)
        assert_eq!(lookup_rgb(&t, &l, Vec2::new(0.25, 0.75)), [1.0, 0.0, 0.0]);
        assert_eq!(lookup_rgb(&t, &l, Vec2::new(0.25, 0.25)), [0.0, 0.0, 1.0]);
        // repeat: one period further is the same texel
        assert_eq!(lookup_rgb(&t, &l, Vec2::new(1.25, -0.75)), [0.0, 0.0, 1.0]);
        // black wrap reads black outside [0, 1] (UsdUVTexture: "returns black outside unit
        // square"), not the fallback, which is for a texture that cannot be read
        let tb = [tex(Wrap::Black)];
        assert_eq!(lookup_rgb(&tb, &l, Vec2::new(-3.0, 0.5)), [0.0, 0.0, 0.0]);
        // midway between red and green: bilinear average
        let m = lookup_rgb(&t, &l, Vec2::new(0.5, 0.75));
        assert!((m[0] - 0.5).abs() < 1e-6 && (m[1] - 0.5).abs() < 1e-6);
    }

    /// A one-row texture of `values` (grey), `filter`, clamped at its ends.
    fn row(values: &[f32], filter: Filter) -> TextureDesc {
        TextureDesc {
            name: "row".into(),
            width: values.len() as u32,
            height: 1,
            channels: 1,
            pixels: values.to_vec().into(),
            wrap_s: Wrap::Clamp,
            wrap_t: Wrap::Clamp,
            filter,
        }
    }

    #[test]
    fn cubic_is_the_b_spline_over_the_nearest_texels() {
        let l = TexLookup { channel: Channel::R, ..lookup() };
        let at = |t: &TextureDesc, x: f32| lookup_float(std::slice::from_ref(t), &l, Vec2::new((x + 0.5) / t.width as f32, 0.5));
        // one lit texel among dark ones: the B-spline kernel, B(0) = 4/6, B(±1) = 1/6,
        // B(±0.5) = 23/48, B(±1.5) = 1/48, B(±2) = 0 (x: texel positions, centres at integers)
        let spike = row(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0], Filter::Cubic);
        for (x, want) in [(3.0, 4.0 / 6.0), (2.0, 1.0 / 6.0), (4.0, 1.0 / 6.0), (3.5, 23.0 / 48.0), (1.5, 1.0 / 48.0), (1.0, 0.0), (5.0, 0.0)] {
            assert!((at(&spike, x) - want).abs() < 1e-6, "x {x}: {} vs {want}", at(&spike, x));
        }
        // the kernel sums to one and reproduces a ramp (away from the clamped ends) where
        // bilinear does too; between texels it is smooth: its slope has no step at a texel
        // centre (bilinear's jumps from one neighbour's difference to the next)
        let ramp = row(&[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0], Filter::Cubic);
        for x in [2.0, 2.3, 2.5, 3.9, 4.0] {
            assert!((at(&ramp, x) - x).abs() < 1e-5, "x {x}: {}", at(&ramp, x));
        }
        let bumps = [0.0, 0.0, 1.0, 4.0, 2.0, 0.0, 0.0];
        let slope = |t: &TextureDesc, x: f32| (at(t, x + 1e-2) - at(t, x - 1e-2)) / 2e-2;
        let (cubic, linear) = (row(&bumps, Filter::Cubic), row(&bumps, Filter::Linear));
        let jump = |t: &TextureDesc| (slope(t, 3.0 + 0.03) - slope(t, 3.0 - 0.03)).abs();
        assert!(jump(&cubic) < 0.3 && jump(&linear) > 4.0, "{} {}", jump(&cubic), jump(&linear));
        // wrap modes as for the other filters: black beyond the image
        let black = TextureDesc { wrap_s: Wrap::Black, ..row(&[1.0; 4], Filter::Cubic) };
        assert!((at(&black, 0.0) - 5.0 / 6.0).abs() < 1e-6, "{}", at(&black, 0.0));
    }

    #[test]
    fn closest_reads_the_texel_the_coordinates_fall_in() {
        let t = [TextureDesc { filter: Filter::Closest, ..tex(Wrap::Repeat) }];
        let l = TexLookup { tex_scale: [2.0; 4], bias: [0.25; 4], ..lookup() };
        // anywhere in the top-left quarter is red (bilinear would blend its neighbours in
        // everywhere but at the centre); scale and bias still apply
        for st in [Vec2::new(0.01, 0.99), Vec2::new(0.26, 0.74), Vec2::new(0.49, 0.51)] {
            assert_eq!(lookup_rgba(&t, &l, st), [2.25, 0.25, 0.25, 2.25], "{st}");
        }
        // the squares' edges: [0.5, 1) is the right column, [0, 0.5) the lower row
        assert_eq!(lookup_rgb(&t, &lookup(), Vec2::new(0.5, 0.75)), [0.0, 1.0, 0.0]);
        assert_eq!(lookup_rgb(&t, &lookup(), Vec2::new(0.75, 0.4999)), [1.0, 1.0, 1.0]);
        // wrapping as for bilinear: one period on is the same texel, black outside
        assert_eq!(lookup_rgb(&t, &lookup(), Vec2::new(1.3, -0.7)), [0.0, 0.0, 1.0]);
        let tb = [TextureDesc { filter: Filter::Closest, ..tex(Wrap::Black) }];
        assert_eq!(lookup_rgb(&tb, &lookup(), Vec2::new(1.1, 0.5)), [0.0, 0.0, 0.0]);
    }

    /// Texels held as 8- or 16-bit codes are read as the values their codes stand for, per
    /// channel, by every filter and wrap mode and for 1 to 4 channels.
    #[test]
    fn coded_texels_read_as_their_code_values() {
        let mut rng = crate::testing::chi2::TestRng::new(7);
        for (channels, sixteen) in (1..=4u32).flat_map(|c| [(c, false), (c, true)]) {
            let (w, h) = (5u32, 3u32);
            let codes: Vec<u16> = (0..w * h * channels).map(|_| (rng.next_u64() & if sixteen { 65535 } else { 255 }) as u16).collect();
            // each channel its own curve, so a code read through another channel's would show
            let coded = if sixteen {
                let values = (0..4 * CODES16).map(|i| ((i % CODES16) as f32 / 65535.0).powf(1.0 + (i / CODES16) as f32)).collect();
                Texels::U16 { codes: std::sync::Arc::new(codes), values: std::sync::Arc::new(values) }
            } else {
                let values: CodeValues = std::array::from_fn(|c| std::array::from_fn(|b| (b as f32 / 255.0).powf(1.0 + c as f32)));
                Texels::U8 { codes: std::sync::Arc::new(codes.iter().map(|&b| b as u8).collect()), values: std::sync::Arc::new(values) }
            };
            let float = Texels::from(coded.to_f32(channels as usize));
            assert!((0..float.len()).any(|i| float.value(i, channels as usize) != coded.to_f32(1)[i]) == (channels > 1));
            for filter in [Filter::Linear, Filter::Closest, Filter::Cubic] {
                for wrap in [Wrap::Repeat, Wrap::Clamp, Wrap::Mirror, Wrap::Black] {
                    let t = |pixels: &Texels| TextureDesc { name: "t".into(), width: w, height: h, channels, pixels: pixels.clone(), wrap_s: wrap, wrap_t: wrap, filter };
                    let (a, b) = ([t(&coded)], [t(&float)]);
                    for _ in 0..200 {
                        let st = Vec2::new(rng.next_f32() * 3.0 - 1.0, rng.next_f32() * 3.0 - 1.0);
                        assert_eq!(lookup_rgba(&a, &lookup(), st), lookup_rgba(&b, &lookup(), st), "{channels} channels, 16-bit {sixteen}, {filter:?} {wrap:?} {st}");
                    }
                }
            }
        }
    }

    #[test]
    fn transform2d_scale_rotate_translate() {
        let mut l = lookup();
        // UsdTransform2d: scale (2, 1), rotate 90°, translate (0.5, 0)
        l.transform = glam::Affine2::from_scale_angle_translation(Vec2::new(2.0, 1.0), 90f32.to_radians(), Vec2::new(0.5, 0.0));
        // (0.25, 0.1) → scale (0.5, 0.1) → rotate 90° (−0.1, 0.5) → translate (0.4, 0.5)
        let r = transform_st(&l, Vec2::new(0.25, 0.1));
        assert!((r - Vec2::new(0.4, 0.5)).length() < 1e-6);
    }
}
