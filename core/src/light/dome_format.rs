//! Dome light images in UsdLux's other `texture:format`s, resampled to the lat-long layout the
//! dome light renders from ([`to_latlong`]).
//!
//! Directions are in the dome's own frame (+Y up, image layouts as UsdLux describes them):
//!
//! - `mirroredBall`: a mirrored sphere photographed orthographically by a camera on its +Z side
//!   looking along −Z, image right = +X and up = +Y. A pixel at (x, y) in the unit disk sees
//!   the ball's normal n = (x, y, √(1 − x² − y²)), which reflects the view direction −Z into
//!   r = −Z + 2 n_z n: the centre shows +Z (back towards the camera), the rim −Z.
//! - `angular`: the centre shows the forward direction −Z and the radius grows linearly with
//!   the angle from it, r = θ / π, so the rim is +Z; image right = +X and up = +Y.
//! - `cubeMapVerticalCross`: a 3 × 4 grid of square faces,
//!   ```text
//!         [+Y]
//!     [-X][-Z][+X]
//!         [-Y]
//!         [+Z]
//!   ```
//!   each seen from the centre with up = +Y for the middle row (up = +Z for +Y's face and
//!   −Z for −Y's), the +Z face at the bottom turned 180° so that it continues the cross.
//!
//! The lat-long image keeps the resolution of the source (width 2h for a height h of 2·(disk
//! radius) or 4 faces), and each lat-long texel takes the bilinear average of a 2 × 2 grid of
//! lookups in the source, so that shrinking a large probe does not alias badly. Lookups near a
//! disk format's rim stay two texels inside it, so the black outside the circle never mixes in.

use glam::Vec3;

use super::latlong_direction;
use crate::scene::TextureDesc;

/// UsdLux `texture:format` of a dome light's image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub enum DomeFormat {
    /// `automatic` or `latlong`.
    #[default]
    LatLong,
    MirroredBall,
    Angular,
    CubeMapVerticalCross,
}

impl DomeFormat {
    /// The format of a `texture:format` token; None for an unknown token.
    pub fn from_token(t: &str) -> Option<DomeFormat> {
        Some(match t {
            "automatic" | "latlong" | "" => DomeFormat::LatLong,
            "mirroredBall" => DomeFormat::MirroredBall,
            "angular" => DomeFormat::Angular,
            "cubeMapVerticalCross" => DomeFormat::CubeMapVerticalCross,
            _ => return None,
        })
    }

    /// Where direction `d` (unit, the dome's frame) is found in an image of this format:
    /// (u, v) in [0, 1]², v = 0 at the top row.
    pub fn lookup(&self, d: Vec3) -> (f32, f32) {
        match self {
            DomeFormat::LatLong => {
                let (u, t, _) = super::latlong_coords(d);
                (u, t)
            }
            DomeFormat::MirroredBall => {
                // r = −Z + 2 n_z n  ⇒  n ∝ r + Z (the half vector of r and the view back +Z)
                let h = d + Vec3::Z;
                let n = h.try_normalize().unwrap_or(Vec3::X);
                disk_uv(n.x, n.y)
            }
            DomeFormat::Angular => {
                let theta = (-d.z).clamp(-1.0, 1.0).acos();
                let s = (d.x * d.x + d.y * d.y).sqrt();
                let r = theta / std::f32::consts::PI;
                if s > 0.0 {
                    disk_uv(r * d.x / s, r * d.y / s)
                } else {
                    disk_uv(0.0, if d.z > 0.0 { 1.0 } else { 0.0 })
                }
            }
            DomeFormat::CubeMapVerticalCross => cross_uv(d),
        }
    }

    /// The source image size that makes a lat-long of this resolution: (width, height).
    fn latlong_size(&self, w: u32, h: u32) -> (u32, u32) {
        match self {
            DomeFormat::LatLong => (w, h),
            DomeFormat::MirroredBall | DomeFormat::Angular => (2 * h.max(1), h.max(1)),
            // a face is h/4 texels: a lat-long of 4 faces' width around
            DomeFormat::CubeMapVerticalCross => (w.max(3) / 3 * 4, (w.max(3) / 3 * 2).max(1)),
        }
    }
}

/// Disk coordinates (x right, y up, unit radius) → image (u, v).
#[inline]
fn disk_uv(x: f32, y: f32) -> (f32, f32) {
    let l = (x * x + y * y).sqrt();
    let (x, y) = if l > 1.0 { (x / l, y / l) } else { (x, y) };
    (0.5 * (x + 1.0), 0.5 * (1.0 - y))
}

/// The vertical cross's (u, v) of direction `d`.
fn cross_uv(d: Vec3) -> (f32, f32) {
    let a = d.abs();
    // (column, row) of the face, and the face's (s, t) in [−1, 1] with t up
    let (col, row, s, t) = if a.y >= a.x && a.y >= a.z {
        if d.y > 0.0 {
            // +Y sits above −Z: its bottom edge (t = −1) meets −Z's top edge (z = −|y|)
            (1, 0, d.x / a.y, d.z / a.y)
        } else {
            (1, 2, d.x / a.y, -d.z / a.y)
        }
    } else if a.x >= a.z {
        if d.x > 0.0 {
            (2, 1, d.z / a.x, d.y / a.x)
        } else {
            (0, 1, -d.z / a.x, d.y / a.x)
        }
    } else if d.z < 0.0 {
        (1, 1, d.x / a.z, d.y / a.z)
    } else {
        // +Z at the bottom, below −Y, turned 180°: its top edge meets −Y's bottom edge
        (1, 3, d.x / a.z, -d.y / a.z)
    };
    let fu = 0.5 * (s + 1.0);
    let fv = 0.5 * (1.0 - t);
    ((col as f32 + fu.clamp(0.0, 1.0)) / 3.0, (row as f32 + fv.clamp(0.0, 1.0)) / 4.0)
}

/// Bilinear lookup of a texture at (u, v), kept within the texels of the region (a cross's
/// face, or the whole image) that (u, v) falls in.
fn bilinear(tex: &TextureDesc, format: DomeFormat, u: f32, v: f32, out: &mut [f32]) {
    let (w, h, ch) = (tex.width as usize, tex.height as usize, tex.channels as usize);
    let (x_lo, x_hi, y_lo, y_hi) = if format == DomeFormat::CubeMapVerticalCross {
        let (col, row) = (((u * 3.0) as usize).min(2), ((v * 4.0) as usize).min(3));
        let (fw, fh) = (w as f32 / 3.0, h as f32 / 4.0);
        let lo = |i: usize, f: f32| (i as f32 * f).ceil();
        let hi = |i: usize, f: f32| ((i + 1) as f32 * f).floor() - 1.0;
        (lo(col, fw), hi(col, fw), lo(row, fh), hi(row, fh))
    } else {
        (0.0, (w - 1) as f32, 0.0, (h - 1) as f32)
    };
    // a disk's rim: kept two texels inside, so that no texel outside the circle mixes in
    let (u, v) = if matches!(format, DomeFormat::MirroredBall | DomeFormat::Angular) {
        let (x, y) = (2.0 * u - 1.0, 1.0 - 2.0 * v);
        let l = (x * x + y * y).sqrt();
        let lim = (1.0 - 4.0 / w.min(h) as f32).max(0.0);
        if l > lim {
            let k = lim / l;
            (0.5 * (x * k + 1.0), 0.5 * (1.0 - y * k))
        } else {
            (u, v)
        }
    } else {
        (u, v)
    };
    let x = (u * w as f32 - 0.5).clamp(x_lo, x_hi.max(x_lo));
    let y = (v * h as f32 - 0.5).clamp(y_lo, y_hi.max(y_lo));
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(x_hi.max(x_lo) as usize), (y0 + 1).min(y_hi.max(y_lo) as usize));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    for (c, o) in out.iter_mut().enumerate().take(ch) {
        let p = |xx: usize, yy: usize| tex.pixels.value((yy * w + xx) * ch + c, ch);
        *o = (p(x0, y0) * (1.0 - fx) + p(x1, y0) * fx) * (1.0 - fy) + (p(x0, y1) * (1.0 - fx) + p(x1, y1) * fx) * fy;
    }
}

/// `tex` (in `format`) resampled to a lat-long texture of the same channels; a lat-long
/// texture is returned unchanged. Errors name the texture when its data is malformed.
pub fn to_latlong(tex: &TextureDesc, format: DomeFormat) -> Result<TextureDesc, String> {
    if format == DomeFormat::LatLong {
        return Ok(tex.clone());
    }
    let (w, h, ch) = (tex.width as usize, tex.height as usize, tex.channels as usize);
    if w == 0 || h == 0 || ch == 0 || tex.pixels.len() != w * h * ch {
        return Err(format!("'{}' has {} values for {w}×{h}×{ch}", tex.name, tex.pixels.len()));
    }
    let (ow, oh) = format.latlong_size(tex.width, tex.height);
    let (ow, oh) = (ow as usize, oh as usize);
    let mut pixels = vec![0.0f32; ow * oh * ch];
    let mut texel = vec![0.0f32; ch];
    for y in 0..oh {
        for x in 0..ow {
            let out = &mut pixels[(y * ow + x) * ch..(y * ow + x + 1) * ch];
            for (sx, sy) in [(0.25f32, 0.25f32), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
                let d = latlong_direction((x as f32 + sx) / ow as f32, (y as f32 + sy) / oh as f32);
                let (u, v) = format.lookup(d);
                bilinear(tex, format, u, v, &mut texel);
                for (o, t) in out.iter_mut().zip(&texel) {
                    *o += 0.25 * t;
                }
            }
        }
    }
    Ok(TextureDesc { name: tex.name.clone(), width: ow as u32, height: oh as u32, channels: tex.channels, pixels: pixels.into(), wrap_s: tex.wrap_s, wrap_t: tex.wrap_t, filter: tex.filter })
}

#[cfg(test)]
#[path = "dome_format/tests.rs"]
mod tests;
