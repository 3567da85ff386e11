//! The camera as UsdGeomCamera defines it: perspective (thin lens with `fStop` and
//! `focusDistance`) or orthographic, film-back apertures and offsets, clipping range, shutter,
//! and exposure (including the physical exposure attributes).
//!
//! # Exposure
//!
//! The physical exposure is USD's linear exposure scale, `responsivity` × `time` × `iso`/100 /
//! `fStop`², times 2^`exposure`; it multiplies the radiance before colour conversion. Seed 000
//! §3.3 (Fascione's sensor equation) gives a pixel Y = π Δt S / (C N²) · L_v for a luminance
//! L_v in cd m⁻², with calibration constant C = [`EXPOSURE_CALIBRATION`] (312.5): that is
//! USD's scale with `exposure:responsivity` = 100π / C = [`seed_responsivity`] (≈ 1.0053) when
//! Tide luminance is in cd m⁻², as the sky's is ([`crate::sky::nits_per_model_unit`]). Exposed
//! for an illuminance E_v = C N² / (Δt S) lux (seed eq. 3.3; [`exposure_time_for_illuminance`])
//! a diffuse surface of albedo k lit by E_v reads k: the sunny-16 rule (f/16, 1/125 s, ISO 100)
//! is E_v = 10⁵ lx.
//!
//! # Filters
//!
//! `tide:camera:filter` puts a spectral filter in front of the sensor: the radiance reaching
//! the film is multiplied by [`filter_transmission`] at each wavelength before conversion to
//! colour (every colour AOV and the light-path split see it; albedo, depth and normals do not).
//!
//! Units follow USD: focal length and apertures are in tenths of a scene unit (millimetres
//! for a centimetre scene), `focusDistance` in scene units. The aperture is conformed to the
//! image's aspect as UsdRenderSettings' `aspectRatioConformPolicy` says ([`AspectConform`];
//! by default `expandAperture`).

use crate::accel::motion::MotionTransform;
use crate::math::sample_concentric_disk;
use crate::scene::{CameraDesc, CameraFilter, Projection};
use crate::spectrum::{Spectrum, LAMBDA_MAX, LAMBDA_MIN};
use glam::{Vec2, Vec3};
use std::sync::OnceLock;

/// Calibration constant C of the exposure equation of seed 000 §3.3 (eq. 3.2–3.3).
pub const EXPOSURE_CALIBRATION: f32 = 312.5;

/// The `exposure:responsivity` that makes USD's linear exposure scale equal seed 000's sensor
/// equation for luminance in cd m⁻²: 100π / C.
pub fn seed_responsivity() -> f32 {
    100.0 * std::f32::consts::PI / EXPOSURE_CALIBRATION
}

/// Seed 000 eq. 3.3 solved for the shutter time: the `exposure:time` (s) at which, with
/// `f_stop` N, `iso` S and [`seed_responsivity`], a diffuse surface of albedo k under an
/// illuminance of `illuminance_lux` E_v reads k: Δt = C N² / (E_v S).
pub fn exposure_time_for_illuminance(illuminance_lux: f32, f_stop: f32, iso: f32) -> f32 {
    EXPOSURE_CALIBRATION * f_stop * f_stop / (illuminance_lux * iso)
}

/// Transmission of the `underwaterRed` filter before normalisation: a smooth long-pass edge,
/// T₀(λ) = 0.2 + 0.8 / (1 + e^{−(λ − 590 nm)/12 nm}): about 0.2 through the blue-green
/// (400–560 nm), 0.6 at 590 nm, above 0.95 from 625 nm. The shape is that of the orange-red
/// correction filters used for ambient-light underwater photography in blue water (they pass
/// the red that a few metres of water absorb and hold back the blue-green that dominates); it
/// is a generic curve, not a particular product's.
pub fn underwater_red_raw(lambda: f32) -> f32 {
    0.2 + 0.8 / (1.0 + (-(lambda - 590.0) / 12.0).exp())
}

/// Spectral transmission of a camera filter (None for `none`). `underwaterRed` is
/// [`underwater_red_raw`] divided by its luminance-weighted mean ∫T₀ȳ dλ / ∫ȳ dλ, so the
/// filter keeps the luminance of an equal-energy white: it changes colour, not exposure (the
/// physical filter plus the exposure compensation of its filter factor). The red/blue balance
/// shifts by the ratio of T over the red and blue responses.
pub fn filter_transmission(filter: CameraFilter) -> Option<&'static Spectrum> {
    static RED: OnceLock<Spectrum> = OnceLock::new();
    match filter {
        CameraFilter::None => None,
        CameraFilter::UnderwaterRed => Some(RED.get_or_init(|| {
            let y = crate::spectrum::cie::cie().integrate_xyz(|l| underwater_red_raw(l as f32) as f64)[1];
            let lambda: Vec<f32> = (LAMBDA_MIN as u32..=LAMBDA_MAX as u32).map(|l| l as f32).collect();
            let value: Vec<f32> = lambda.iter().map(|&l| (underwater_red_raw(l) as f64 / y) as f32).collect();
            Spectrum::tabulated(&lambda, &value).expect("filter table is well formed")
        })),
    }
}

/// USD's aperture and focal-length unit in scene units.
pub const LENS_UNIT: f32 = 0.1;

#[derive(Clone, Debug)]
pub struct Camera {
    xf: MotionTransform,
    projection: Projection,
    focal: f32,
    /// Conformed aperture (film units).
    aperture: Vec2,
    offset: Vec2,
    near: f32,
    far: f32,
    /// Clipping planes (camera space), as (normal, offset).
    planes: Vec<glam::Vec4>,
    lens_radius: f32,
    focus_distance: f32,
    pub shutter: (f32, f32),
    /// Multiplier applied to radiance: 2^exposure × physical exposure.
    pub exposure_scale: f32,
    pub width: u32,
    pub height: u32,
    pub medium: Option<usize>,
    /// Spectral transmission in front of the sensor (`tide:camera:filter`).
    pub filter: Option<&'static Spectrum>,
}

/// A camera ray in world space; `t_min..t_max` is the clipped interval.
#[derive(Clone, Copy, Debug)]
pub struct CameraRay {
    pub o: Vec3,
    pub d: Vec3,
    pub t_max: f32,
    pub time: f32,
    /// Distance along the camera's view axis per unit t.
    pub depth_per_t: f32,
    /// The view-axis distance of the ray's origin (the near plane, or a clipping plane past
    /// it): depth = depth_at_origin + t · depth_per_t.
    pub depth_at_origin: f32,
}

/// UsdRenderSettings' `aspectRatioConformPolicy`: how an aperture whose aspect differs from
/// the image's (width × pixel aspect / height) is made to fit it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum AspectConform {
    /// Grow the aperture in the dimension that falls short, showing more of the scene.
    #[default]
    ExpandAperture,
    /// Shrink the aperture in the dimension that overflows, cropping the scene.
    CropAperture,
    /// Change the aperture's width to the image's aspect.
    AdjustApertureWidth,
    /// Change the aperture's height to the image's aspect.
    AdjustApertureHeight,
    /// Keep the aperture: the pixels take the aspect that makes the image cover it exactly
    /// (the settings' `pixelAspectRatio` is disregarded).
    AdjustPixelAspectRatio,
}

impl AspectConform {
    /// The policy of a UsdRender token; None for an unknown one.
    pub fn from_token(t: &str) -> Option<AspectConform> {
        Some(match t {
            "expandAperture" => AspectConform::ExpandAperture,
            "cropAperture" => AspectConform::CropAperture,
            "adjustApertureWidth" => AspectConform::AdjustApertureWidth,
            "adjustApertureHeight" => AspectConform::AdjustApertureHeight,
            "adjustPixelAspectRatio" => AspectConform::AdjustPixelAspectRatio,
            _ => return None,
        })
    }

    /// The aperture `ap` (width, height) made to fit an image of aspect `image_aspect`.
    pub fn conform(&self, ap: Vec2, image_aspect: f32) -> Vec2 {
        let wider = image_aspect > ap.x / ap.y;
        match self {
            AspectConform::ExpandAperture if wider => Vec2::new(ap.y * image_aspect, ap.y),
            AspectConform::ExpandAperture => Vec2::new(ap.x, ap.x / image_aspect),
            AspectConform::CropAperture if wider => Vec2::new(ap.x, ap.x / image_aspect),
            AspectConform::CropAperture => Vec2::new(ap.y * image_aspect, ap.y),
            AspectConform::AdjustApertureWidth => Vec2::new(ap.y * image_aspect, ap.y),
            AspectConform::AdjustApertureHeight => Vec2::new(ap.x, ap.x / image_aspect),
            AspectConform::AdjustPixelAspectRatio => ap,
        }
    }
}

impl Camera {
    /// The aperture (width, height) after conforming to the image.
    pub fn aperture(&self) -> Vec2 {
        self.aperture
    }

    /// Builds the camera for an image of `width`×`height` pixels with the given pixel aspect,
    /// its aperture expanded to the image's aspect. The description must be validated.
    pub fn new(desc: &CameraDesc, width: u32, height: u32, pixel_aspect: f32, disable_dof: bool, disable_motion: bool) -> Camera {
        Camera::with_conform(desc, width, height, pixel_aspect, AspectConform::ExpandAperture, disable_dof, disable_motion)
    }

    /// [`Camera::new`] with the aperture made to fit the image by `conform`.
    pub fn with_conform(desc: &CameraDesc, width: u32, height: u32, pixel_aspect: f32, conform: AspectConform, disable_dof: bool, disable_motion: bool) -> Camera {
        let image_aspect = width as f32 * pixel_aspect.max(1e-6) / height.max(1) as f32;
        let ap = conform.conform(Vec2::new(desc.horizontal_aperture, desc.vertical_aperture), image_aspect);
        let lens_radius = if disable_dof || desc.f_stop <= 0.0 || desc.projection == Projection::Orthographic {
            0.0
        } else {
            0.5 * desc.focal_length * LENS_UNIT / desc.f_stop
        };
        let shutter = if disable_motion { (0.0, 0.0) } else { (desc.shutter_open, desc.shutter_close.max(desc.shutter_open)) };
        let physical = desc.exposure_responsivity * desc.exposure_time * desc.exposure_iso / 100.0
            / (desc.exposure_f_stop * desc.exposure_f_stop).max(1e-12);
        Camera {
            xf: MotionTransform::new(&desc.transforms, &desc.times),
            projection: desc.projection,
            focal: desc.focal_length,
            aperture: ap,
            offset: Vec2::new(desc.horizontal_aperture_offset, desc.vertical_aperture_offset),
            near: desc.clipping_range[0].max(0.0),
            far: desc.clipping_range[1],
            planes: desc.clipping_planes.iter().map(|p| glam::Vec4::from_array(*p)).collect(),
            lens_radius,
            focus_distance: desc.focus_distance,
            shutter,
            exposure_scale: 2f32.powf(desc.exposure) * physical,
            width,
            height,
            medium: desc.medium,
            filter: filter_transmission(desc.filter),
        }
    }

    /// The camera a render with `settings` sees through: `desc` conformed to the image (or
    /// framed by the settings' film window), seeing past the image where the settings' data
    /// window reaches past it (overscan).
    pub fn for_settings(desc: &CameraDesc, s: &crate::render::RenderSettings) -> Camera {
        let mut cam = Camera::with_conform(desc, s.width, s.height, s.pixel_aspect_ratio, s.aspect_conform, s.disable_depth_of_field, s.disable_motion_blur);
        if let Some([ox, oy, ax, ay]) = s.film_window {
            cam.offset = Vec2::new(ox, oy);
            cam.aperture = Vec2::new(ax, ay);
        }
        cam.extend(crate::render::framing(s).pad);
        cam
    }

    /// The camera seeing `pad` pixels more past each side of its image (left, top, right,
    /// bottom: overscan): an image of that many more pixels whose pixel (x + left, y + top) is
    /// the one (x, y) was, every other ray as before.
    pub fn extend(&mut self, pad: [u32; 4]) {
        if pad == [0; 4] {
            return;
        }
        let [l, t, r, b] = pad.map(|v| v as f32);
        let (w, h) = (self.width as f32, self.height as f32);
        self.offset += Vec2::new(self.aperture.x * (r - l) / (2.0 * w), self.aperture.y * (t - b) / (2.0 * h));
        self.aperture *= Vec2::new((w + l + r) / w, (h + t + b) / h);
        self.width += pad[0] + pad[2];
        self.height += pad[1] + pad[3];
    }

    /// Film position (film units) of an image position in pixels (x right, y down).
    #[inline]
    fn film(&self, raster: Vec2) -> Vec2 {
        let ndc = Vec2::new(raster.x / self.width as f32, raster.y / self.height as f32);
        Vec2::new(self.offset.x + (ndc.x - 0.5) * self.aperture.x, self.offset.y + (0.5 - ndc.y) * self.aperture.y)
    }

    /// Generates a ray through `raster` (pixels) using the lens sample `u_lens` and time sample.
    pub fn generate_ray(&self, raster: Vec2, u_lens: Vec2, u_time: f32) -> CameraRay {
        let f = self.film(raster);
        let time = self.shutter.0 + (self.shutter.1 - self.shutter.0) * u_time;
        let (o_cam, d_cam) = match self.projection {
            Projection::Perspective => {
                let d = Vec3::new(f.x, f.y, -self.focal).normalize();
                if self.lens_radius > 0.0 && self.focus_distance > 0.0 {
                    let p_focus = d * (self.focus_distance / -d.z);
                    let l = sample_concentric_disk(u_lens) * self.lens_radius;
                    let o = Vec3::new(l.x, l.y, 0.0);
                    (o, (p_focus - o).normalize())
                } else {
                    (Vec3::ZERO, d)
                }
            }
            Projection::Orthographic => (Vec3::new(f.x * LENS_UNIT, f.y * LENS_UNIT, 0.0), Vec3::new(0.0, 0.0, -1.0)),
        };
        // clip: start on the near plane (or where the clipping planes let the ray in), stop on
        // the far plane (or where they cut it off); a ray they cut away entirely sees nothing
        let dz = -d_cam.z;
        let (mut t_near, mut t_far) = (self.near / dz, self.far / dz);
        for p in &self.planes {
            let (c0, c1) = (p.truncate().dot(o_cam) + p.w, p.truncate().dot(d_cam));
            if c1 > 0.0 {
                t_near = t_near.max(-c0 / c1);
            } else if c1 < 0.0 {
                t_far = t_far.min(-c0 / c1);
            } else if c0 < 0.0 {
                t_far = t_near;
            }
        }
        let t_far = t_far.max(t_near);
        let o_cam = o_cam + d_cam * t_near;
        let m = self.xf.at(time);
        let d = m.transform_vector3(d_cam);
        let len = d.length();
        CameraRay {
            o: m.transform_point3(o_cam),
            d: d / len,
            t_max: (t_far - t_near) * len,
            time,
            depth_per_t: dz / len,
            depth_at_origin: t_near * dz,
        }
    }

    /// Whether a camera-space point is kept by every clipping plane.
    #[inline]
    fn unclipped(&self, q: Vec3) -> bool {
        self.planes.iter().all(|p| p.truncate().dot(q) + p.w >= 0.0)
    }

    /// Pixel position (x right, y down) where a world point projects at `time` (pinhole), or
    /// None when it is behind the camera.
    pub fn project(&self, p: Vec3, time: f32) -> Option<Vec2> {
        self.raster_of(self.xf.at(time).inverse().transform_point3(p))
    }

    /// Pixel position of a camera-space point (None behind a perspective camera).
    #[inline]
    fn raster_of(&self, q: Vec3) -> Option<Vec2> {
        let f = match self.projection {
            Projection::Perspective => {
                if q.z >= 0.0 {
                    return None;
                }
                Vec2::new(q.x, q.y) * (self.focal / -q.z)
            }
            Projection::Orthographic => Vec2::new(q.x, q.y) / LENS_UNIT,
        };
        let ndc = Vec2::new((f.x - self.offset.x) / self.aperture.x + 0.5, 0.5 - (f.y - self.offset.y) / self.aperture.y);
        Some(Vec2::new(ndc.x * self.width as f32, ndc.y * self.height as f32))
    }

    /// Camera position at a time.
    pub fn position(&self, time: f32) -> Vec3 {
        self.xf.at(time).transform_point3(Vec3::ZERO)
    }

    /// Whether the camera is a pinhole (perspective, no depth of field): the only camera light
    /// paths can be connected to.
    pub fn is_pinhole(&self) -> bool {
        self.projection == Projection::Perspective && self.lens_radius == 0.0
    }

    /// Where a light-path vertex at `p` lands on a pinhole camera at `time`: its raster
    /// position and the raster area per unit solid angle there, `dA_raster/dω = s_x s_y f² /
    /// cos³θ` (s pixels per film unit, f the focal length, θ off the view axis), so a radiance
    /// `L` arriving from `p` adds `L · filter(raster − pixel) · dA/dω · dω` to a pixel. None when
    /// the camera is not a pinhole or `p` is outside the near–far range. The camera transform is
    /// taken as rigid (a scaled camera would change solid angles).
    pub fn connect(&self, p: Vec3, time: f32) -> Option<(Vec2, f32)> {
        if !self.is_pinhole() {
            return None;
        }
        let q = self.xf.at(time).inverse().transform_point3(p);
        let depth = -q.z;
        if !(depth >= self.near && depth <= self.far) || depth <= 0.0 || !self.unclipped(q) {
            return None;
        }
        let raster = self.raster_of(q)?;
        let cos = depth / q.length();
        let sx = self.width as f32 / self.aperture.x;
        let sy = self.height as f32 / self.aperture.y;
        Some((raster, sx * sy * self.focal * self.focal / (cos * cos * cos)))
    }

    /// The part `[t0, t1]` of the segment `o + t·d` whose points project inside the raster
    /// rectangle `[x0, x1] × [y0, y1]` (pixels) of a pinhole camera at `time`, between its near
    /// and far planes; None when empty.
    pub fn frustum_interval(&self, o: Vec3, d: Vec3, t0: f32, t1: f32, time: f32, rect: [f32; 4]) -> Option<(f32, f32)> {
        if !self.is_pinhole() {
            return None;
        }
        let inv = self.xf.at(time).inverse();
        let (qo, qd) = (inv.transform_point3(o), inv.transform_vector3(d));
        // film coordinates of the rectangle's edges
        let fx = |x: f32| self.offset.x + (x / self.width as f32 - 0.5) * self.aperture.x;
        let fy = |y: f32| self.offset.y + (0.5 - y / self.height as f32) * self.aperture.y;
        let (fx0, fx1, fy0, fy1) = (fx(rect[0]), fx(rect[2]), fy(rect[3]), fy(rect[1]));
        let f = self.focal;
        let (mut a, mut b) = (t0, t1);
        // every constraint is linear in t: c0 + c1·t ≥ 0 (with depth = −z > 0,
        // film x = f·x/depth ≥ fx0 ⟺ f·x − fx0·depth ≥ 0)
        let cons = [
            (f * qo.x + fx0 * qo.z, f * qd.x + fx0 * qd.z),
            (-(f * qo.x) - fx1 * qo.z, -(f * qd.x) - fx1 * qd.z),
            (f * qo.y + fy0 * qo.z, f * qd.y + fy0 * qd.z),
            (-(f * qo.y) - fy1 * qo.z, -(f * qd.y) - fy1 * qd.z),
            (-qo.z - self.near, -qd.z),
            (self.far + qo.z, qd.z),
        ];
        // and the clipping planes: n·q + w ≥ 0
        let planes = self.planes.iter().map(|p| (p.truncate().dot(qo) + p.w, p.truncate().dot(qd)));
        for (c0, c1) in cons.into_iter().chain(planes) {
            if c1 == 0.0 {
                if c0 < 0.0 {
                    return None;
                }
            } else {
                let t = -c0 / c1;
                if c1 > 0.0 {
                    a = a.max(t);
                } else {
                    b = b.min(t);
                }
            }
        }
        (a < b && a.is_finite() && b.is_finite()).then_some((a, b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat4;

    #[test]
    fn connections_cover_the_raster_once_per_steradian_and_clip_to_the_frustum() {
        // ∫ dA/dω over the directions a pinhole sees = the raster's area W·H: estimated with
        // directions uniform on the sphere, E[dA/dω · 1(seen)] · 4π
        let xf = Mat4::from_rotation_y(0.4) * Mat4::from_translation(Vec3::new(0.1, 0.2, 0.3));
        let cam = Camera::new(&CameraDesc { transforms: vec![xf], times: vec![0.0], ..desc() }, 64, 48, 1.0, false, false);
        let eye = cam.position(0.0);
        let mut rng = crate::testing::chi2::TestRng::new(5);
        let n = 400_000;
        let mut sum = 0.0f64;
        let mut sum2 = 0.0f64;
        for _ in 0..n {
            let z = 1.0 - 2.0 * rng.next_f32();
            let phi = std::f32::consts::TAU * rng.next_f32();
            let r = (1.0 - z * z).max(0.0).sqrt();
            let d = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let v = match cam.connect(eye + d * 10.0, 0.0) {
                Some((p, a)) if p.x >= 0.0 && p.x < 64.0 && p.y >= 0.0 && p.y < 48.0 => a as f64 * 4.0 * std::f64::consts::PI,
                _ => 0.0,
            };
            sum += v;
            sum2 += v * v;
        }
        let mean = sum / n as f64;
        let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
        assert!((mean - 64.0 * 48.0).abs() < 4.0 * se, "{mean} ± {se} vs {}", 64 * 48);
        // the frustum interval of a segment crossing the view: its ends project onto the edges
        let o = eye + xf.transform_vector3(Vec3::new(-30.0, 1.0, -20.0));
        let d = xf.transform_vector3(Vec3::X);
        let (a, b) = cam.frustum_interval(o, d, 0.0, 100.0, 0.0, [0.0, 0.0, 64.0, 48.0]).unwrap();
        let pa = cam.project(o + d * a, 0.0).unwrap();
        let pb = cam.project(o + d * b, 0.0).unwrap();
        assert!(pa.x.abs() < 1e-2 && (pb.x - 64.0).abs() < 1e-2, "{pa} {pb}");
        for t in [a + 0.01, 0.5 * (a + b), b - 0.01] {
            let p = cam.project(o + d * t, 0.0).unwrap();
            assert!(p.x > 0.0 && p.x < 64.0 && p.y > 0.0 && p.y < 48.0);
        }
        // behind the camera: nothing
        let o2 = eye + xf.transform_vector3(Vec3::new(-30.0, 0.0, 20.0));
        assert!(cam.frustum_interval(o2, d, 0.0, 100.0, 0.0, [0.0, 0.0, 64.0, 48.0]).is_none());
        // a lens (depth of field) cannot be connected to
        let dof = Camera::new(&CameraDesc { f_stop: 2.8, focus_distance: 5.0, ..desc() }, 64, 48, 1.0, false, false);
        assert!(!dof.is_pinhole() && dof.connect(Vec3::new(0.0, 0.0, -5.0), 0.0).is_none());
    }

    fn desc() -> CameraDesc {
        CameraDesc { focal_length: 50.0, horizontal_aperture: 36.0, vertical_aperture: 24.0, clipping_range: [0.1, 1000.0], ..Default::default() }
    }

    /// UsdGeomCamera clippingPlanes: a camera ray starts where every plane lets it in and ends
    /// where one cuts it off (its depth counted from the camera), rays wholly cut away see
    /// nothing, and light paths connect only to points the planes keep.
    #[test]
    fn clipping_planes_cut_the_camera_rays() {
        // camera at (0, 0, 10) looking down −Z; keep x ≥ 0 and z ≥ −7 (camera space: depth ≤ 7)
        let mut d = desc();
        d.transforms = vec![Mat4::from_translation(Vec3::new(0.0, 0.0, 10.0))];
        d.clipping_planes = vec![[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 7.0]];
        let cam = Camera::new(&d, 360, 240, 1.0, false, false);
        // the centre column's ray runs from the near plane to depth 7
        let r = cam.generate_ray(Vec2::new(180.0, 120.0), Vec2::ZERO, 0.0);
        assert!((r.depth_at_origin - 0.1).abs() < 1e-5 && (r.depth_at_origin + r.t_max * r.depth_per_t - 7.0).abs() < 1e-4, "{r:?}");
        // a ray to the left of the axis is cut away entirely
        let left = cam.generate_ray(Vec2::new(90.0, 120.0), Vec2::ZERO, 0.0);
        assert_eq!(left.t_max, 0.0);
        // a plane across the view: x ≥ z + 8 (camera space) lets the right ray in past its
        // crossing, at the depth the plane meets it
        d.clipping_planes = vec![[1.0, 0.0, -1.0, -8.0]];
        let cam = Camera::new(&d, 360, 240, 1.0, false, false);
        let r = cam.generate_ray(Vec2::new(270.0, 120.0), Vec2::ZERO, 0.0);
        // the ray's camera-space direction is (9, 0, −50) / |·| (film x = 9 of 18): it meets
        // x = z + 8 where 9s = −50s + 8, s = 8/59, depth 50·8/59
        assert!((r.depth_at_origin - 400.0 / 59.0).abs() < 1e-3, "{r:?}");
        let q = r.o + r.d * 1e-3;
        assert!((q.x - 9.0 * 8.0 / 59.0).abs() < 1e-2, "{q}");
        // connections: a kept point projects, a cut one does not
        assert!(cam.connect(Vec3::new(9.0, 0.0, 0.0), 0.0).is_some());
        // (1, 0, 7) is (1, 0, −3) to the camera: 1 + 3 − 8 < 0, cut
        assert!(cam.connect(Vec3::new(1.0, 0.0, 7.0), 0.0).is_none());
    }

    /// Overscan: the extended camera's pixel (x + left, y + top) sees what the image's (x, y)
    /// saw, for pixels inside the image and past it, and projects back there.
    #[test]
    fn an_extended_camera_keeps_every_ray_and_adds_the_overscan() {
        for conform in [AspectConform::ExpandAperture, AspectConform::CropAperture] {
            let mut d = desc();
            d.horizontal_aperture_offset = 1.5;
            d.vertical_aperture_offset = -0.5;
            let plain = Camera::with_conform(&d, 40, 30, 1.0, conform, true, true);
            let mut wide = plain.clone();
            wide.extend([8, 6, 20, 4]);
            assert_eq!((wide.width, wide.height), (68, 40));
            for p in [Vec2::new(0.0, 0.0), Vec2::new(17.3, 9.1), Vec2::new(40.0, 30.0), Vec2::new(-8.0, -6.0), Vec2::new(59.5, 33.2)] {
                let a = plain.generate_ray(p, Vec2::ZERO, 0.0);
                let b = wide.generate_ray(p + Vec2::new(8.0, 6.0), Vec2::ZERO, 0.0);
                assert!((a.d - b.d).length() < 1e-6 && (a.o - b.o).length() < 1e-6, "{p}: {a:?} vs {b:?}");
                let back = wide.project(a.o + a.d * 5.0, 0.0).unwrap();
                assert!((back - (p + Vec2::new(8.0, 6.0))).length() < 1e-3, "{p}: {back}");
            }
        }
    }

    #[test]
    fn known_points_project_to_the_expected_pixels() {
        // camera at (0,0,10) looking down -Z; a point 10 units ahead at (x, y) lands at
        // film = (x, y)·50/10 in mm-units, i.e. pixel = (0.5 + film_x/36)·W, (0.5 − film_y/24)·H
        let mut d = desc();
        d.transforms = vec![Mat4::from_translation(Vec3::new(0.0, 0.0, 10.0))];
        let cam = Camera::new(&d, 360, 240, 1.0, false, false);
        let p = cam.project(Vec3::new(1.8, -1.2, 0.0), 0.0).unwrap();
        let expect = Vec2::new((0.5 + 1.8 * 5.0 / 36.0) * 360.0, (0.5 + 1.2 * 5.0 / 24.0) * 240.0);
        assert!((p - expect).length() < 1e-3, "{p} vs {expect}");
        // and the ray through that pixel passes through the point
        let r = cam.generate_ray(expect, Vec2::splat(0.5), 0.0);
        let t = (0.0 - r.o.z) / r.d.z;
        assert!((r.o + r.d * t - Vec3::new(1.8, -1.2, 0.0)).length() < 1e-4);
    }

    #[test]
    fn every_aspect_conform_policy_fits_the_aperture_as_usd_says() {
        // a 36 × 24 aperture (1.5) onto a square image and onto a 2:1 image: where a point at
        // the aperture's right edge (x = 18 film units at the focal distance) and one at its top
        // edge (y = 12) land, in the image's NDC (0.5 = the centre, 1 = the edge)
        let mut d = desc();
        d.horizontal_aperture = 36.0;
        d.vertical_aperture = 24.0;
        let f = d.focal_length;
        let edge = |cam: &Camera, x: f32, y: f32, w: u32, h: u32| {
            let p = cam.project(Vec3::new(x / f * 10.0, y / f * 10.0, -10.0), 0.0).unwrap();
            (p.x / w as f32, 1.0 - p.y / h as f32)
        };
        use AspectConform::*;
        // (policy, image w, h, the aperture the image shows)
        for (c, w, h, shown) in [
            (ExpandAperture, 100, 100, (36.0, 36.0)),
            (CropAperture, 100, 100, (24.0, 24.0)),
            (AdjustApertureWidth, 100, 100, (24.0, 24.0)),
            (AdjustApertureHeight, 100, 100, (36.0, 36.0)),
            (AdjustPixelAspectRatio, 100, 100, (36.0, 24.0)),
            (ExpandAperture, 200, 100, (48.0, 24.0)),
            (CropAperture, 200, 100, (36.0, 18.0)),
            (AdjustApertureWidth, 200, 100, (48.0, 24.0)),
            (AdjustApertureHeight, 200, 100, (36.0, 18.0)),
            (AdjustPixelAspectRatio, 200, 100, (36.0, 24.0)),
        ] {
            let cam = Camera::with_conform(&d, w, h, 1.0, c, false, false);
            let (u, _) = edge(&cam, 18.0, 0.0, w, h);
            let (_, v) = edge(&cam, 0.0, 12.0, w, h);
            let (su, sv) = (0.5 + 0.5 * 36.0 / shown.0, 0.5 + 0.5 * 24.0 / shown.1);
            assert!((u - su).abs() < 1e-4 && (v - sv).abs() < 1e-4, "{c:?} {w}×{h}: edges at ({u}, {v}), expected ({su}, {sv})");
        }
        for t in ["expandAperture", "cropAperture", "adjustApertureWidth", "adjustApertureHeight", "adjustPixelAspectRatio"] {
            assert!(AspectConform::from_token(t).is_some());
        }
        assert_eq!(AspectConform::from_token("stretch"), None);
    }

    #[test]
    fn aperture_offsets_and_non_square_apertures_shift_the_image() {
        let mut d = desc();
        d.horizontal_aperture = 20.0;
        d.vertical_aperture = 10.0;
        d.horizontal_aperture_offset = 2.0; // film units: the window moves right
        d.vertical_aperture_offset = -1.0;
        let cam = Camera::new(&d, 200, 100, 1.0, false, false);
        // the optical axis point now lands left of centre by 2/20 of the width, and below... 
        let p = cam.project(Vec3::new(0.0, 0.0, -5.0), 0.0).unwrap();
        assert!((p - Vec2::new(100.0 - 0.1 * 200.0, 50.0 - 0.1 * 100.0)).length() < 1e-3, "{p}");
        // image aspect 2:1 equal to the aperture's: no conform; a 4:1 image expands horizontally
        let wide = Camera::new(&d, 400, 100, 1.0, false, false);
        assert!((wide.aperture - Vec2::new(40.0, 10.0)).length() < 1e-5);
        let tall = Camera::new(&d, 100, 100, 1.0, false, false);
        assert!((tall.aperture - Vec2::new(20.0, 20.0)).length() < 1e-5);
    }

    #[test]
    fn thin_lens_rays_converge_on_the_focus_plane() {
        let mut d = desc();
        d.f_stop = 2.0;
        d.focus_distance = 7.0;
        let cam = Camera::new(&d, 100, 100, 1.0, false, false);
        assert!((cam.lens_radius - 0.5 * 5.0 / 2.0).abs() < 1e-6);
        let raster = Vec2::new(30.0, 70.0);
        let hit = |u: Vec2| {
            let r = cam.generate_ray(raster, u, 0.0);
            let t = (-7.0 - r.o.z) / r.d.z;
            r.o + r.d * t
        };
        let a = hit(Vec2::new(0.1, 0.2));
        let b = hit(Vec2::new(0.9, 0.6));
        assert!((a - b).length() < 1e-4, "{a} {b}");
        // off-focus plane (z = -3.5): the blur circle diameter is lens_diameter × |1 − 3.5/7|
        let at = |u: Vec2| {
            let r = cam.generate_ray(raster, u, 0.0);
            let t = (-3.5 - r.o.z) / r.d.z;
            r.o + r.d * t
        };
        let spread = (at(Vec2::new(0.0, 0.5)) - at(Vec2::new(1.0, 0.5))).length();
        assert!((spread - 2.0 * cam.lens_radius * 0.5).abs() < 1e-3, "{spread}");
    }

    #[test]
    fn clipping_and_exposure() {
        let mut d = desc();
        d.clipping_range = [2.0, 5.0];
        d.exposure = 1.0;
        d.exposure_f_stop = 2.0;
        d.exposure_time = 0.5;
        d.exposure_iso = 400.0;
        let cam = Camera::new(&d, 10, 10, 1.0, false, false);
        let r = cam.generate_ray(Vec2::new(5.0, 5.0), Vec2::ZERO, 0.0);
        assert!((r.o.z + 2.0).abs() < 1e-3 && (r.t_max - 3.0).abs() < 1e-3);
        // 2^1 × (0.5 · 400/100) / 2² = 1
        assert!((cam.exposure_scale - 1.0).abs() < 1e-6);
    }

    #[test]
    fn seed_exposure_maps_the_illuminance_to_a_grey_card_value() {
        // sunny 16: f/16, ISO 100, E_v = 10⁵ lx → 1/125 s (C = 312.5)
        let t = exposure_time_for_illuminance(1.0e5, 16.0, 100.0);
        assert!((t - 1.0 / 125.0).abs() < 1e-7, "{t}");
        let d = CameraDesc { exposure_f_stop: 16.0, exposure_time: t, exposure_iso: 100.0, exposure_responsivity: seed_responsivity(), ..desc() };
        let cam = Camera::new(&d, 10, 10, 1.0, false, false);
        // a card of albedo 0.18 under E_v has luminance 0.18 E_v / π cd m⁻²
        let y = cam.exposure_scale * 0.18 * 1.0e5 / std::f32::consts::PI;
        assert!((y - 0.18).abs() < 1e-6, "{y}");
    }

    #[test]
    fn underwater_red_filter_keeps_white_luminance_and_favours_red() {
        assert!(filter_transmission(CameraFilter::None).is_none());
        let f = filter_transmission(CameraFilter::UnderwaterRed).unwrap();
        let c = crate::spectrum::cie::cie();
        let y = c.integrate_xyz(|l| f.eval(l as f32) as f64)[1];
        // the 1 nm table and the 1 nm quadrature share their nodes: exact up to f32 rounding
        assert!((y - 1.0).abs() < 1e-5, "{y}");
        assert!(f.eval(650.0) > 4.0 * f.eval(480.0));
        assert!(f.eval(400.0) > 0.0 && f.eval(830.0) < 3.0);
    }
}
