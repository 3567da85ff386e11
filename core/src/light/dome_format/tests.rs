//! Tests of the dome image formats: known directions land where the layouts put them, the
//! cross's faces meet along their shared edges, and images made from a smooth function of
//! direction through each layout's own forward mapping (written here from the module's
//! description, independently of `lookup`) resample to that function in lat-long.

use super::*;
use crate::scene::Wrap;

fn close(a: (f32, f32), b: (f32, f32), tol: f32) -> bool {
    (a.0 - b.0).abs() <= tol && (a.1 - b.1).abs() <= tol
}

#[test]
fn known_directions_land_where_the_layouts_put_them() {
    let ball = DomeFormat::MirroredBall;
    assert!(close(ball.lookup(Vec3::Z), (0.5, 0.5), 1e-6));
    // the ball's normal at 45° up reflects the view straight up: (0, sin 45°) in the disk
    let up = ball.lookup(Vec3::Y);
    assert!(close(up, (0.5, 0.5 * (1.0 - std::f32::consts::FRAC_1_SQRT_2)), 1e-5), "{up:?}");
    let ang = DomeFormat::Angular;
    assert!(close(ang.lookup(-Vec3::Z), (0.5, 0.5), 1e-6));
    // 90° off forward: half-way out, to the right for +X
    assert!(close(ang.lookup(Vec3::X), (0.75, 0.5), 1e-6));
    assert!(close(ang.lookup(Vec3::Y), (0.5, 0.25), 1e-6));
    let cross = DomeFormat::CubeMapVerticalCross;
    for (d, uv) in [(-Vec3::Z, (0.5, 0.375)), (Vec3::Y, (0.5, 0.125)), (-Vec3::Y, (0.5, 0.625)), (Vec3::Z, (0.5, 0.875)), (Vec3::X, (2.5 / 3.0, 0.375)), (-Vec3::X, (0.5 / 3.0, 0.375))] {
        assert!(close(cross.lookup(d), uv, 1e-6), "{d}: {:?}", cross.lookup(d));
    }
    assert_eq!(DomeFormat::from_token("mirroredBall"), Some(ball));
    assert_eq!(DomeFormat::from_token("automatic"), Some(DomeFormat::LatLong));
    assert_eq!(DomeFormat::from_token("sphericalHarmonics"), None);
}

#[test]
fn the_crosss_faces_meet_along_their_edges() {
    // pairs of directions a hair apart across an edge whose faces touch in the layout
    let e = 1e-4;
    let seams = [
        (Vec3::new(0.3, 1.0 - e, -1.0), Vec3::new(0.3, 1.0 + e, -1.0)),   // front | top
        (Vec3::new(1.0 - e, 0.2, -1.0), Vec3::new(1.0 + e, 0.2, -1.0)),   // front | right
        (Vec3::new(-1.0 + e, 0.2, -1.0), Vec3::new(-1.0 - e, 0.2, -1.0)), // front | left
        (Vec3::new(0.3, -1.0 + e, -1.0), Vec3::new(0.3, -1.0 - e, -1.0)), // front | bottom
        (Vec3::new(0.3, -1.0, 1.0 - e), Vec3::new(0.3, -1.0, 1.0 + e)),   // bottom | back
    ];
    for (a, b) in seams {
        let (ua, ub) = (DomeFormat::CubeMapVerticalCross.lookup(a.normalize()), DomeFormat::CubeMapVerticalCross.lookup(b.normalize()));
        assert!(close(ua, ub, 1e-3), "{a} → {ua:?}, {b} → {ub:?}");
    }
}

/// A smooth function of direction to paint the test images with.
fn f(d: Vec3) -> f32 {
    1.0 + 0.5 * d.x + 0.3 * d.y - 0.2 * d.z + 0.1 * d.x * d.y
}

/// The image of `f` in `format`, `n` texels per unit of the layout, painted through the
/// layouts' forward mappings (pixel → direction).
fn painted(format: DomeFormat, w: usize, h: usize) -> TextureDesc {
    let mut pixels = vec![0.0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let (u, v) = ((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
            let d = match format {
                DomeFormat::MirroredBall | DomeFormat::Angular => {
                    let (px, py) = (2.0 * u - 1.0, 1.0 - 2.0 * v);
                    let r2 = px * px + py * py;
                    if r2 > 1.0 {
                        continue;
                    }
                    if format == DomeFormat::MirroredBall {
                        let n = Vec3::new(px, py, (1.0 - r2).sqrt());
                        -Vec3::Z + 2.0 * n.z * n
                    } else {
                        let theta = r2.sqrt() * std::f32::consts::PI;
                        let phi = py.atan2(px);
                        Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), -theta.cos())
                    }
                }
                _ => {
                    let (col, row) = ((u * 3.0) as usize, (v * 4.0) as usize);
                    let (s, t) = ((u * 3.0).fract() * 2.0 - 1.0, 1.0 - (v * 4.0).fract() * 2.0);
                    match (col, row) {
                        (1, 0) => Vec3::new(s, 1.0, t),
                        (0, 1) => Vec3::new(-1.0, t, -s),
                        (1, 1) => Vec3::new(s, t, -1.0),
                        (2, 1) => Vec3::new(1.0, t, s),
                        (1, 2) => Vec3::new(s, -1.0, -t),
                        (1, 3) => Vec3::new(s, -t, 1.0),
                        _ => continue,
                    }
                }
            };
            pixels[y * w + x] = f(d.normalize());
        }
    }
    TextureDesc { name: "probe".into(), width: w as u32, height: h as u32, channels: 1, pixels: pixels.into(), wrap_s: Wrap::Clamp, wrap_t: Wrap::Clamp, filter: crate::scene::Filter::Linear }
}

#[test]
fn resampled_images_are_the_function_they_were_painted_with() {
    for (format, w, h, skip) in [
        // the mirrored ball squeezes the back half into a thin ring at the rim: judged away from -Z
        (DomeFormat::MirroredBall, 512, 512, -0.7f32),
        (DomeFormat::Angular, 512, 512, 2.0),
        (DomeFormat::CubeMapVerticalCross, 384, 512, 2.0),
    ] {
        let ll = to_latlong(&painted(format, w, h), format).unwrap();
        assert_eq!((ll.width, ll.height), if format == DomeFormat::CubeMapVerticalCross { (512, 256) } else { (1024, 512) });
        let (lw, lh) = (ll.width as usize, ll.height as usize);
        let mut worst = 0.0f32;
        for y in 0..lh {
            for x in 0..lw {
                let d = latlong_direction((x as f32 + 0.5) / lw as f32, (y as f32 + 0.5) / lh as f32);
                if d.z < skip && format == DomeFormat::MirroredBall {
                    continue;
                }
                // angular: the rim (+Z) is a single direction spread round a circle
                if format == DomeFormat::Angular && d.z > 0.98 {
                    continue;
                }
                worst = worst.max((ll.pixels.value(y * lw + x, 1) - f(d)).abs());
            }
        }
        assert!(worst < 5e-3, "{format:?}: worst {worst}");
    }
    // a lat-long image is returned as it is
    let t = painted(DomeFormat::Angular, 8, 4);
    assert_eq!(to_latlong(&t, DomeFormat::LatLong).unwrap(), t);
}
