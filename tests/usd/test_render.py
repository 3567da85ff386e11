"""Rendering through the real module (tide._tide + the core renderer), checked against values
computed here from the camera model and radiometry, not from the renderer.

These need the bridge module and a core that renders; the `renderer` fixture skips them with
the reason (module not built, or a probe render that does not yet return a dome's colour).

Camera model used for expectations (USD's): focal length and apertures in tenths of a scene
unit, the camera looks down -Z, a point (x, y, z) projects to NDC x = (f x / -z) / (ha / 2).
"""
import math
import os
import subprocess

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdRender, UsdShade

from conftest import (ROOT, bind, camera, darkness, diffuse_reflectances, fresnel, fwhm, near, preview_material,
                      lambert_material, render, settings)

F, AP = 50.0, 36.0            # focal length, square aperture: tan(half fov) = 18/50


def _project(x, y, z, w, h):
    """Pixel coordinates (column, row from the top) of a camera-space point."""
    ndc_x = (F * x / -z) / (AP / 2)
    ndc_y = (F * y / -z) / (AP / 2)
    return (ndc_x + 1) / 2 * w, (1 - ndc_y) / 2 * h


def _px_per_unit_at(z, w):
    return F / -z / (AP / 2) * w / 2


def _white_dome(stage):
    dome = UsdLux.DomeLight.Define(stage, "/Dome")
    dome.CreateIntensityAttr(1.0)
    dome.CreateColorAttr(Gf.Vec3f(1, 1, 1))


def _black(stage):
    return lambert_material(stage, "/Looks/Black", (0, 0, 0))


def _ball(stage, path, pos, radius, mat):
    s = UsdGeom.Sphere.Define(stage, path)
    s.CreateRadiusAttr(radius)
    s.AddTranslateOp().Set(Gf.Vec3d(*pos))
    bind(s.GetPrim(), mat)
    return s


def _components(mask):
    """Number of 4-connected components of a boolean image."""
    seen = np.zeros_like(mask, dtype=bool)
    count = 0
    h, w = mask.shape
    for y in range(h):
        for x in range(w):
            if mask[y, x] and not seen[y, x]:
                count += 1
                stack = [(y, x)]
                seen[y, x] = True
                while stack:
                    cy, cx = stack.pop()
                    for ny, nx in ((cy + 1, cx), (cy - 1, cx), (cy, cx + 1), (cy, cx - 1)):
                        if 0 <= ny < h and 0 <= nx < w and mask[ny, nx] and not seen[ny, nx]:
                            seen[ny, nx] = True
                            stack.append((ny, nx))
    return count


def test_sphere_projects_where_the_camera_says(renderer, stage):
    w = h = 64
    camera(stage, focal=F, aperture=(AP, AP))
    _white_dome(stage)
    _ball(stage, "/Ball", (1.0, 0.5, -10.0), 0.5, _black(stage))
    settings(stage, res=(w, h), samples=16)
    img = render(renderer, stage)["color"]
    d = darkness(img)
    ys, xs = np.mgrid[0:h, 0:w]
    cx, cy = (d * (xs + 0.5)).sum() / d.sum(), (d * (ys + 0.5)).sum() / d.sum()
    ex, ey = _project(1.0, 0.5, -10.0, w, h)
    # the centroid of a ~4.4 px radius antialiased disk is exact up to sampling noise
    # (16 spp: < 0.1 px); the ellipse-vs-centre offset of a sphere at this distance is
    # r^2/z^2 ~ 0.25% of its offset from the axis: 0.5 px is a generous, still sharp, bound
    assert abs(cx - ex) < 0.5 and abs(cy - ey) < 0.5, ((cx, cy), (ex, ey))
    # covered area = projected disk area pi (r f/z / (ap/2) * w/2)^2 within 10 %
    # (perspective makes the silhouette 1/(1 - r^2/z^2) larger: 0.25 %; noise ~2 %)
    r_px = 0.5 * _px_per_unit_at(-10.0, w)
    assert d.sum() == pytest.approx(math.pi * r_px ** 2, rel=0.10)


@pytest.mark.parametrize("rgb", [(0.5, 0.5, 0.5), (0.8, 0.2, 0.2), (0.1, 0.4, 0.9)])
def test_the_albedo_aov_reads_the_diffuse_colour(renderer, stage, rgb):
    """A Lambertian panel filling the view: the albedo AOV is its diffuse colour (a reflectance,
    read under the colour space's white, so grey stays grey), to the spectral round trip."""
    from conftest import RES, lambert_material, near, panel, top_camera
    top_camera(stage)
    m = panel(stage, "/Panel", columns=1)
    bind(m.GetPrim(), lambert_material(stage, "/Looks/C", rgb))
    settings(stage, res=(RES, RES), samples=4, vars_=("color", "albedo"), integrator="path")
    albedo = render(renderer, stage)["albedo"][..., :3].astype(np.float64)
    ok, why = near(albedo, rgb)
    assert ok, why
    # a grey reads the same in every pixel, without the wavelengths' noise (a grey of 0.5
    # spread 0.36-0.65 over the pixels at 4 spp)
    if len(set(rgb)) == 1:
        assert np.ptp(albedo) < 1e-6, (albedo.min(), albedo.max())


@pytest.mark.parametrize("schema", ["Cylinder_1", "Capsule_1"])
def test_tapered_cylinder_and_capsule_silhouettes(renderer, stage, schema):
    """Cylinder_1 and Capsule_1 with different end radii, axis Y, seen side-on through an
    orthographic camera: their alpha covers the trapezoid between the end radii (the
    cylinder) or the hull of the two end spheres (the capsule), computed here by 8 x 8
    supersampling each pixel: the covered area to 1.5 % and every row's width to 0.35 px."""
    n, extent = 64, 8.0                       # pixels, units across
    cam = camera(stage, pos=(0, 0, 10), aperture=(10 * extent, 10 * extent),
                 projection="orthographic")
    assert cam
    prim = stage.DefinePrim("/Shape", schema)
    rb, rt, height = (1.5, 0.3, 3.0) if schema == "Cylinder_1" else (1.4, 0.5, 3.0)
    prim.GetAttribute("radiusBottom").Set(rb)
    prim.GetAttribute("radiusTop").Set(rt)
    prim.GetAttribute("height").Set(height)
    prim.GetAttribute("axis").Set("Y")
    settings(stage, res=(n, n), samples=16)
    alpha = render(renderer, stage, pixel_filter="box")["color"][..., 3].astype(np.float64)
    # pixel (row j from the top, column i) covers x in [-4 + i/8, ...], y in [4 - (j+1)/8, ...]
    sub = (np.arange(n * 8) + 0.5) / (n * 8) * extent - extent / 2
    x, y = np.meshgrid(sub, -sub)
    if schema == "Cylinder_1":
        r = rb + (rt - rb) * (y + height / 2) / height
        inside = (np.abs(y) <= height / 2) & (np.abs(x) <= r)
    else:
        # the hull of two disks is the union of the disks between them (centres and radii
        # interpolated together)
        inside = np.zeros_like(x, dtype=bool)
        for t in np.linspace(0.0, 1.0, 801):
            cy, cr = -height / 2 + height * t, rb + (rt - rb) * t
            inside |= x ** 2 + (y - cy) ** 2 <= cr ** 2
    want = inside.reshape(n, 8, n, 8).mean(axis=(1, 3))
    assert alpha.sum() == pytest.approx(want.sum(), rel=0.015), (alpha.sum(), want.sum())
    rows = np.abs(alpha.sum(axis=1) - want.sum(axis=1))
    assert rows.max() < 0.35, (rows.max(), int(rows.argmax()))


@pytest.mark.parametrize("policy,shown", [
    ("expandAperture", (36.0, 36.0)), ("cropAperture", (24.0, 24.0)),
    ("adjustApertureWidth", (24.0, 24.0)), ("adjustApertureHeight", (36.0, 36.0)),
    ("adjustPixelAspectRatio", (36.0, 24.0))])
def test_aspect_ratio_conform_policy(renderer, stage, policy, shown):
    # a 36 x 24 aperture onto a square image: the film the image shows is `shown` (UsdRender's
    # aspectRatioConformPolicy), so a ball at (1, 0.6, -10) lands at f x / z over half of it
    w = h = 64
    camera(stage, focal=F, aperture=(36.0, 24.0))
    _white_dome(stage)
    _ball(stage, "/Ball", (1.0, 0.6, -10.0), 0.3, _black(stage))
    st = settings(stage, res=(w, h), samples=16)
    st.CreateAspectRatioConformPolicyAttr(policy)
    d = darkness(render(renderer, stage)["color"])
    # the small ball's centroid: the white background's few-% noise would pull it to the centre
    d = np.where(d > 0.1, d, 0.0)
    ys, xs = np.mgrid[0:h, 0:w]
    cx, cy = (d * (xs + 0.5)).sum() / d.sum(), (d * (ys + 0.5)).sum() / d.sum()
    ex = (0.5 + F * 1.0 / 10.0 / shown[0]) * w
    ey = (0.5 - F * 0.6 / 10.0 / shown[1]) * h
    assert abs(cx - ex) < 0.5 and abs(cy - ey) < 0.5, ((cx, cy), (ex, ey))


def _sunlit_wall(stage, mat, tilt=0.0):
    """A 20 x 20 wall at z = -5 facing the camera, bound to `mat`, under a sun of pi lux on a
    perpendicular surface, tilted `tilt` degrees about X from the wall's normal."""
    m = UsdGeom.Mesh.Define(stage, "/Wall")
    m.CreatePointsAttr([(-10, -10, -5), (10, -10, -5), (10, 10, -5), (-10, 10, -5)])
    m.CreateFaceVertexCountsAttr([4])
    m.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    bind(m.GetPrim(), mat)
    sun = UsdLux.DistantLight.Define(stage, "/Sun")
    sun.CreateIntensityAttr(math.pi / 2)
    sun.CreateExposureAttr(1.0)
    sun.CreateNormalizeAttr(True)
    sun.CreateAngleAttr(0.53)
    if tilt:
        sun.AddRotateXOp().Set(tilt)


def test_diffuse_patch_under_a_known_sun(renderer, stage):
    w = h = 32
    camera(stage, focal=F, aperture=(AP, AP))
    # an unrotated DistantLight shines along -Z: straight onto the wall. With normalize on,
    # the illuminance on a perpendicular surface is intensity * 2^exposure = pi lux, so a
    # Lambertian albedo of 0.5 leaves with radiance 0.5 / pi * pi = 0.5.
    _sunlit_wall(stage, lambert_material(stage, "/Looks/Grey", (0.5, 0.5, 0.5)))
    settings(stage, res=(w, h), samples=16, integrator="path", maxDepth=1)
    img = render(renderer, stage)["color"]
    centre = img[8:24, 8:24, :3].reshape(-1, 3).mean(axis=0)
    # grey albedo and a white light survive the RGB -> spectrum -> RGB round trip to ~1 %;
    # the noise of a 256-pixel mean of direct sun light is far below that: 3 %
    assert centre == pytest.approx([0.5, 0.5, 0.5], rel=0.03)


@pytest.mark.parametrize("orientation,sign", [("rightHanded", 1.0), ("leftHanded", -1.0)])
def test_ngon_normals_follow_orientation(renderer, stage, orientation, sign):
    w = h = 16
    camera(stage, focal=F, aperture=(AP, AP))
    _white_dome(stage)
    m = UsdGeom.Mesh.Define(stage, "/Ngon")
    # a pentagon counter-clockwise as seen from the camera (+Z side)
    m.CreatePointsAttr([(3 * math.cos(2 * math.pi * k / 5), 3 * math.sin(2 * math.pi * k / 5),
                         -5) for k in range(5)])
    m.CreateFaceVertexCountsAttr([5])
    m.CreateFaceVertexIndicesAttr([0, 1, 2, 3, 4])
    m.CreateOrientationAttr(orientation)
    m.CreateDoubleSidedAttr(True)
    settings(stage, res=(w, h), vars_=("color", "normal"), samples=1)
    n = render(renderer, stage)["normal"]
    centre = n[h // 2, w // 2, :3]
    # right-handed: counter-clockwise winding faces +Z; left-handed flips it to -Z
    assert centre == pytest.approx([0, 0, sign], abs=1e-3)


def test_native_instances_and_point_instancer_counts(renderer, stage):
    w, h = 96, 32
    camera(stage, focal=F, aperture=(AP * 3, AP))
    _white_dome(stage)
    black = _black(stage)
    proto = stage.CreateClassPrim("/Proto")
    UsdGeom.Sphere.Define(stage, "/Proto/Ball").CreateRadiusAttr(0.6)
    bind(stage.GetPrimAtPath("/Proto/Ball"), black)
    for i, x in enumerate((-8.0, -5.0)):
        p = stage.DefinePrim("/I%d" % i, "Xform")
        p.GetInherits().AddInherit(proto.GetPath())
        p.SetInstanceable(True)
        UsdGeom.Xformable(p).AddTranslateOp().Set(Gf.Vec3d(x, 0, -20))
    inst = UsdGeom.PointInstancer.Define(stage, "/PI")
    _ball(stage, "/PI/Protos/Ball", (0, 0, 0), 0.6, black)
    inst.CreatePrototypesRel().SetTargets(["/PI/Protos/Ball"])
    inst.CreateProtoIndicesAttr([0, 0, 0, 0])
    inst.CreatePositionsAttr([(x, 0, -20) for x in (-1.0, 2.0, 5.0, 8.0)])
    inst.CreateInvisibleIdsAttr([1])
    settings(stage, res=(w, h), samples=8)
    d = darkness(render(renderer, stage)["color"])
    # 2 native instances + 3 visible point instances, well separated: 3 units = 6.7 px apart,
    # each ball ~1.3 px in radius
    assert _components(d > 0.5) == 5


def _streak_fwhm(renderer, stage, disable_motion=False, blur_scale=None):
    w, h = 128, 16
    camera(stage, focal=F, aperture=(AP, AP * h / w),
           **{"shutter__open": 0.0, "shutter__close": 1.0})
    _white_dome(stage)
    s = _ball(stage, "/Ball", (0, 0, 0), 0.25, _black(stage))
    op = s.GetOrderedXformOps()[0]
    op.Set(Gf.Vec3d(-1, 0, -10), 0)
    op.Set(Gf.Vec3d(1, 0, -10), 1)
    if blur_scale is not None:
        UsdGeom.MotionAPI.Apply(s.GetPrim()).CreateMotionBlurScaleAttr(blur_scale)
    st = settings(stage, res=(w, h), samples=256)
    if disable_motion:
        st.GetPrim().CreateAttribute("disableMotionBlur", Sdf.ValueTypeNames.Bool).Set(True)
    d = darkness(render(renderer, stage, frame=0)["color"])
    return fwhm(d[h // 2 - 1:h // 2 + 1].mean(axis=0)), w


def test_motion_blur_streak_length(renderer, stage):
    length, w = _streak_fwhm(renderer, stage)
    # a sphere of diameter D swept over a distance L >= D darkens a trapezoid whose full width
    # at half maximum is L: 2 units at z = -10
    expect = 2.0 * _px_per_unit_at(-10.0, w)
    # 256 spp: per-pixel coverage noise ~2.7 %, slope of the ramps ~3 %/px: crossings to
    # ~1 px each side
    assert length == pytest.approx(expect, abs=1.5)


def test_motion_blur_scale_scales_the_streak(renderer, stage):
    """motion:blurScale 0.5 samples the ball over half the shutter (UsdGeomMotionAPI): it
    sweeps from x = -1 to 0, a streak of 1 unit."""
    length, w = _streak_fwhm(renderer, stage, blur_scale=0.5)
    assert length == pytest.approx(1.0 * _px_per_unit_at(-10.0, w), abs=1.5)


def test_no_streak_when_motion_blur_disabled(renderer, stage):
    length, w = _streak_fwhm(renderer, stage, disable_motion=True)
    # a still disk (at frame 0, x = -1): FWHM of its centre rows ~ its diameter 0.5 units
    assert length == pytest.approx(0.5 * _px_per_unit_at(-10.0, w), abs=1.5)


def _blur_radius(renderer, stage, fstop, disable=False):
    w = h = 128
    cam = camera(stage, focal=F, aperture=(AP, AP))
    cam.CreateFStopAttr(fstop)
    cam.CreateFocusDistanceAttr(10.0)
    _white_dome(stage)
    _ball(stage, "/Dot", (0, 0, -5), 0.05, _black(stage))
    st = settings(stage, res=(w, h), samples=512)
    if disable:
        st.GetPrim().CreateAttribute("disableDepthOfField", Sdf.ValueTypeNames.Bool).Set(True)
    d = darkness(render(renderer, stage)["color"])
    # The dot is on the optical axis, so its image is centred on the frame. The moments are
    # taken over a 32x32 window around the centre: it holds the whole blur disk (radius
    # < 6 px) plus the dot (1.8 px) with room to spare. Over the full frame, the white dome's
    # per-pixel spectral noise (~1e-4 in luminance at 512 spp), weighted by (x - cx)^2 up to
    # 64^2 over 16k pixels, would outweigh the ~10 px of darkness of the dot itself.
    lo, hi = w // 2 - 16, w // 2 + 16
    d = d[lo:hi, lo:hi]
    ys, xs = np.mgrid[lo:hi, lo:hi] + 0.5
    m = d.sum()
    cx = (d * xs).sum() / m
    var_x = (d * (xs - cx) ** 2).sum() / m
    r_sphere = 0.05 * _px_per_unit_at(-5.0, w)
    # variances add under convolution; a uniform disk of radius R has per-axis variance R^2/4.
    # The pixel filter (a Gaussian of sigma 0.5 px truncated at 3 sigma, core/src/render.rs)
    # adds its per-axis variance 0.25 * (1 - 6 phi(3) / (1 - 2 Phi(-3))) = 0.2433 px^2.
    filter_var = 0.25 * (1 - 6 * math.exp(-4.5) / math.sqrt(2 * math.pi) / math.erf(3 / math.sqrt(2)))
    return math.sqrt(max(0.0, 4 * (var_x - filter_var) - r_sphere ** 2)), w


def test_depth_of_field_blur_of_an_off_focus_point(renderer, stage):
    radius, w = _blur_radius(renderer, stage, fstop=8.0)
    # thin lens: focal length 50 tenths = 5 units, aperture radius f / 2N; a point at 5 units
    # with focus at 10 spreads over a disk of radius R_lens |5 - 10| / 5 on the focal plane,
    # whose half-width there is 10 * tan(half fov)
    r_lens = 0.1 * F / (2 * 8.0)
    r_focal = r_lens * abs(5.0 - 10.0) / 5.0
    expect = r_focal / (10.0 * (AP / 2) / F) * w / 2
    # the moment estimate at 512 spp carries ~5 % noise on the radius: 10 %
    assert radius == pytest.approx(expect, rel=0.10)


def test_depth_of_field_disabled(renderer, stage):
    radius, _ = _blur_radius(renderer, stage, fstop=8.0, disable=True)
    # without DOF nothing is left once the dot and the pixel filter are taken out; 1 px (a
    # fifth of the f/8 blur) bounds the window's noise (~0.2 px^2 on R^2)
    assert radius < 1.0


def _tide(args, cwd):
    return subprocess.run([os.path.join(ROOT, "tide")] + args, cwd=cwd, capture_output=True,
                          text=True, stdin=subprocess.DEVNULL, timeout=300)


def test_clipping_planes_cut_away_what_the_camera_sees(renderer, stage):
    # UsdGeomCamera.clippingPlanes (a, b, c, d) cut away camera-space points where
    # a x + b y + c z + d < 0: with (1, 0, 0, 0) the black ball's left half is gone and the
    # white dome shows there; its right half stays
    cam = camera(stage)
    cam.CreateClippingPlanesAttr([Gf.Vec4f(1, 0, 0, 0)])
    _white_dome(stage)
    _ball(stage, "/Ball", (0, 0, -5), 1.0, _black(stage))
    settings(stage, res=(16, 16), samples=16, integrator="path")
    img = render(renderer, stage)["color"]
    # the ball spans 4.4 pixels either side of the centre (8 + (50/5)/18·8 x)
    assert img[7:9, 5:7, :3].min() > 0.9, img[7:9, 5:7, 0]
    assert img[7:9, 9:11, :3].max() < 0.05, img[7:9, 9:11, 0]


def _aov_stage(stage, tmp_path):
    """A black ball 5 units in front of the camera under a white dome, with four AOVs."""
    camera(stage)
    _white_dome(stage)
    _ball(stage, "/Ball", (0, 0, -5), 1.0, _black(stage))
    settings(stage, res=(16, 16), vars_=("color", "depth", "normal", "tide:diffuse"),
             product=str(tmp_path / "aovs.exr"), samples=2)


@pytest.mark.parametrize("window", [None, (-0.25, 0.0, 1.0, 1.0), (0.0, -0.125, 1.125, 1.0)])
def test_overscan_renders_past_the_image(renderer, stage, tmp_path, window):
    """dataWindowNDC past [0, 1] renders overscan: the EXR's data window reaches past its
    display window (negative coordinates left and top) and shows what lies there. A black ball
    left of the frame (x = -4.5 at depth 10, the frame ±3.6 wide: its centre 4 pixels left of
    the image, x = -4) shows only in the left overscan; a ball at the centre stays put."""
    camera(stage, focal=50.0, aperture=(36.0, 36.0))
    _white_dome(stage)
    _ball(stage, "/Out", (-4.5, 0, -10), 0.5, _black(stage))
    _ball(stage, "/In", (0, 0, -10), 0.5, _black(stage))
    st = settings(stage, res=(32, 32), vars_=("color",), product=str(tmp_path / "o.exr"), samples=4,
                  integrator="path")
    if window:
        st.CreateDataWindowNDCAttr(Gf.Vec4f(*window))
    path = str(tmp_path / "scene.usda")
    stage.GetRootLayer().Export(path)
    out = _tide(["render", path], tmp_path)
    assert out.returncode == 0, out.stderr
    assert "dataWindowNDC" not in out.stdout + out.stderr
    chans, header = _exr(str(tmp_path / "o.exr"))
    (dx0, dy0), (dx1, dy1) = (tuple(v) for v in header["dataWindow"])
    assert tuple(tuple(v) for v in header["displayWindow"]) == ((0, 0), (31, 31))
    # pixel centres (i + 1/2)/32 in the window: -0.25 -> from -8, 1.125 -> to 35 (y up:
    # the bottom -0.125 adds 4 rows below)
    want = {None: (0, 0, 31, 31), (-0.25, 0.0, 1.0, 1.0): (-8, 0, 31, 31), (0.0, -0.125, 1.125, 1.0): (0, 0, 35, 35)}
    assert (dx0, dy0, dx1, dy1) == want[window]
    dark = darkness(np.dstack([chans["R"], chans["G"], chans["B"]]))
    dark[dark < 0.3] = 0.0           # the balls' cover, the dome's colour noise left out
    cols, rows = np.arange(dx0, dx1 + 1) + 0.5, np.arange(dy0, dy1 + 1) + 0.5

    def centre(in_cols):
        d = dark[:, in_cols]
        return (d.sum(axis=0) * cols[in_cols]).sum() / d.sum(), (d.sum(axis=1) * rows).sum() / d.sum()

    # the centre ball at (16, 16) in the display window's pixels, whatever the overscan
    assert centre((cols > 8) & (cols < 24)) == pytest.approx((16.0, 16.0), abs=0.3)
    if window and window[0] < 0:
        assert centre(cols < 0) == pytest.approx((-4.0, 16.0), abs=0.3)
    # nothing else inside the image: the left ball lies wholly outside it
    assert dark[:, (cols > 0) & (cols < 8)].max() == 0.0


def test_exr_channels_and_header(renderer, stage, tmp_path):
    _aov_stage(stage, tmp_path)
    path = str(tmp_path / "scene.usda")
    stage.GetRootLayer().Export(path)
    out = _tide(["render", path], tmp_path)
    assert out.returncode == 0, out.stderr
    import OpenEXR
    with OpenEXR.File(str(tmp_path / "aovs.exr"), separate_channels=True) as f:
        chans = set(f.channels().keys())
        header = dict(f.header())
        depth = np.asarray(f.channels()["depth.Z"].pixels)
    assert {"R", "G", "B", "A", "depth.Z"} <= chans
    assert {"normal.X", "normal.Y", "normal.Z"} <= chans or \
        {"normal.R", "normal.G", "normal.B"} <= chans
    assert {"tide:diffuse.R", "tide:diffuse.G", "tide:diffuse.B"} <= chans
    assert header["tide:spp"] == "2" and "tide:renderSeconds" in header
    # the centre pixel sees the sphere's front at camera-space depth 5 - 1 = 4
    assert depth[8, 8] == pytest.approx(4.0, abs=0.05)
    assert os.path.exists(tmp_path / "aovs.png")


def test_a_render_vars_half_data_type_writes_halves(renderer, stage, tmp_path):
    # UsdRenderVar.dataType: a half type (color4h, half) is stored as 16-bit halves, a float
    # type or an unauthored one as 32-bit floats; a token that is no value type is named
    _aov_stage(stage, tmp_path)
    floats = str(tmp_path / "floats.usda")
    stage.GetRootLayer().Export(floats)
    for i, t in {0: "color4h", 1: "half", 3: "banana"}.items():
        UsdRender.Var(stage.GetPrimAtPath("/Render/Settings_Var%d" % i)).CreateDataTypeAttr(t)
    halves = str(tmp_path / "halves.usda")
    stage.GetRootLayer().Export(halves)
    out = _tide(["render", floats, "-o", str(tmp_path / "floats.exr")], tmp_path)
    assert out.returncode == 0, out.stderr
    out = _tide(["render", halves], tmp_path)
    assert out.returncode == 0, out.stderr
    assert "/Render/Settings_Var3" in out.stderr and "dataType" in out.stderr, out.stderr
    import OpenEXR
    with OpenEXR.File(str(tmp_path / "aovs.exr"), separate_channels=True) as f:
        got = {k: np.asarray(c.pixels) for k, c in f.channels().items()}
    want, _ = _exr(str(tmp_path / "floats.exr"))
    assert set(got) == set(want)
    for c in got:
        half = c in ("R", "G", "B", "A", "depth.Z")
        assert got[c].dtype == (np.float16 if half else np.float32), (c, got[c].dtype)
        # the same render, its values rounded to the nearest half where halves were asked for
        assert np.array_equal(got[c], want[c].astype(got[c].dtype)), c


def _exr(path):
    import OpenEXR
    with OpenEXR.File(path, separate_channels=True) as f:
        return {k: np.asarray(c.pixels) for k, c in f.channels().items()}, dict(f.header())


def _centroid(d):
    h, w = d.shape
    ys, xs = np.mgrid[0:h, 0:w]
    return (d * (xs + 0.5)).sum() / d.sum(), (d * (ys + 0.5)).sum() / d.sum()


def test_products_render_with_their_own_camera_and_resolution(renderer, stage, tmp_path):
    # contract: one EXR per product; a product's own camera and resolution (UsdRender) make it
    # a render of its own, and products that agree share one
    camera(stage, "/CamA")
    camera(stage, "/CamB", pos=(1.0, 0.0, 0.0))
    _white_dome(stage)
    _ball(stage, "/Ball", (0, 0, -10), 0.5, _black(stage))
    s = settings(stage, cam="/CamA", res=(64, 64), product=str(tmp_path / "a.exr"), samples=8)
    from pxr import UsdRender
    side = UsdRender.Product.Define(stage, "/Render/Side")
    side.CreateProductNameAttr(str(tmp_path / "b.exr"))
    side.CreateCameraRel().SetTargets(["/CamB"])
    side.CreateResolutionAttr(Gf.Vec2i(32, 32))
    depth = UsdRender.Var.Define(stage, "/Render/Depth")
    depth.CreateSourceNameAttr("depth")
    same = UsdRender.Product.Define(stage, "/Render/Same")
    same.CreateProductNameAttr(str(tmp_path / "c.exr"))
    same.CreateOrderedVarsRel().SetTargets([depth.GetPath()])
    s.GetProductsRel().SetTargets(["/Render/Settings_Product", "/Render/Side", "/Render/Same"])
    path = str(tmp_path / "scene.usda")
    stage.GetRootLayer().Export(path)
    out = _tide(["render", path], tmp_path)
    assert out.returncode == 0, out.stderr
    assert "problem" not in out.stderr, out.stderr
    assert "render 1 of 2" in out.stderr and "render 2 of 2" in out.stderr
    a, ha = _exr(str(tmp_path / "a.exr"))
    b, hb = _exr(str(tmp_path / "b.exr"))
    c, hc = _exr(str(tmp_path / "c.exr"))
    assert a["R"].shape == (64, 64) and b["R"].shape == (32, 32)
    assert ha["tide:camera"] == "/CamA" and hb["tide:camera"] == "/CamB"
    assert hc["tide:camera"] == "/CamA" and sorted(c) == ["depth.Z"]
    assert c["depth.Z"].shape == (64, 64) and c["depth.Z"][32, 32] == pytest.approx(9.5, abs=0.05)
    for img, w, x in ((a, 64, 0.0), (b, 32, -1.0)):
        d = 1.0 - np.stack([img["R"], img["G"], img["B"]], -1).mean(-1)
        d = np.where(d > 0.1, d, 0.0)
        ex, ey = _project(x, 0.0, -10.0, w, w)
        cx, cy = _centroid(d)
        assert abs(cx - ex) < 0.5 and abs(cy - ey) < 0.5, (w, (cx, cy), (ex, ey))


def test_default_scene_renders(renderer, tmp_path):
    out = _tide(["render", "--spp", "2", "--width", "48"], tmp_path)
    assert out.returncode == 0, out.stderr
    import OpenEXR
    with OpenEXR.File(str(tmp_path / "tide.exr"), separate_channels=True) as f:
        r = np.asarray(f.channels()["R"].pixels)
    assert r.shape == (27, 48) and np.isfinite(r).all() and r.mean() > 0


def test_bad_prim_dropped_rest_renders(renderer, stage):
    w = h = 32
    camera(stage, focal=F, aperture=(AP, AP))
    _white_dome(stage)
    _ball(stage, "/Ball", (0, 0, -10), 1.0, _black(stage))
    m = UsdGeom.Mesh.Define(stage, "/Broken")
    m.CreatePointsAttr([(0, 0, -3), (1, 0, -3), (0, 1, -3)])
    m.CreateFaceVertexCountsAttr([3])
    m.CreateFaceVertexIndicesAttr([0, 1, 5])
    settings(stage, res=(w, h), samples=4)
    d = darkness(render(renderer, stage)["color"])
    r_px = _px_per_unit_at(-10.0, w)
    # the ball is there (area within 15 %: 4 spp noise on a ~45 px disk)
    assert d.sum() == pytest.approx(math.pi * r_px ** 2, rel=0.15)


def _unrefracting_water(stage):
    """A TideWater material of ior 1 (no refraction, no reflection) and its TideMedium shader,
    not yet connected: (material, water shader, medium shader)."""
    mat = UsdShade.Material.Define(stage, "/Looks/Water")
    w = UsdShade.Shader.Define(stage, "/Looks/Water/Surface")
    w.CreateIdAttr("TideWater")
    w.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.0)
    mat.CreateSurfaceOutput().ConnectToSource(w.ConnectableAPI(), "surface")
    med = UsdShade.Shader.Define(stage, "/Looks/Water/Medium")
    med.CreateIdAttr("TideMedium")
    med.CreateOutput("volume", Sdf.ValueTypeNames.Token)
    return mat, w, med


def _water_tank(stage, link):
    """A 1-unit TideWater cube (ior 1: no refraction, no reflection) holding a grey absorber
    σa = 1/m, seen against a white dome through a narrow field (path lengths within 2e-4).
    `link`: how the medium is given: "volume" (the material's output), "medium" (TideWater's
    medium input connected to it), "both", or None (no medium)."""
    camera(stage, pos=(0, 0, 5), focal=50.0, aperture=(2.0, 2.0))
    settings(stage, res=(16, 16), samples=64)
    _white_dome(stage)
    mat, w, med = _unrefracting_water(stage)
    med.CreateInput("absorption", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(1, 1, 1))
    if link in ("volume", "both"):
        mat.CreateVolumeOutput().ConnectToSource(med.ConnectableAPI(), "volume")
    if link in ("medium", "both"):
        w.CreateInput("medium", Sdf.ValueTypeNames.Token).ConnectToSource(med.ConnectableAPI(), "volume")
    cube = UsdGeom.Cube.Define(stage, "/Tank")
    cube.CreateSizeAttr(1.0)
    bind(cube.GetPrim(), mat)


@pytest.mark.parametrize("link", ["medium", "both"])
def test_water_medium_through_its_medium_input(renderer, stage, link):
    """TideWater's optional `medium` connection fills the water like the material's volume
    output: the same image, bit for bit, and Beer–Lambert's exp(-1) through the unit cube."""
    _water_tank(stage, link)
    img = render(renderer, stage)["color"]
    from pxr import Usd
    ref_stage = Usd.Stage.CreateInMemory()
    _water_tank(ref_stage, "volume")
    ref = render(renderer, ref_stage)["color"]
    assert np.array_equal(img, ref)
    rgb = img[..., :3].reshape(-1, 3).astype(np.float64)
    mean, se = rgb.mean(axis=0), rgb.std(axis=0, ddof=1) / math.sqrt(len(rgb))
    # 4 standard errors, plus 2e-3 for the grey absorber's uplifted spectrum and f32 sums
    assert np.all(np.abs(mean - math.exp(-1.0)) < 4 * se + 2e-3), (mean, se)
    # without a medium the tank is clear: the test can tell
    empty_stage = Usd.Stage.CreateInMemory()
    _water_tank(empty_stage, None)
    assert render(renderer, empty_stage)["color"][..., :3].mean() > 0.95


@pytest.mark.parametrize("meters_per_unit", [None, 1.0, 0.5, 0.01])
def test_coefficients_per_metre_follow_the_stages_meters_per_unit(renderer, stage, meters_per_unit):
    """σa is per metre (contract §3): through the 1-unit tank, exp(-σa · metersPerUnit). A
    stage that does not author metersPerUnit is in metres (not USD's fallback, centimetres)."""
    _water_tank(stage, "volume")
    if meters_per_unit is not None:
        UsdGeom.SetStageMetersPerUnit(stage, meters_per_unit)
    rgb = render(renderer, stage)["color"][..., :3].reshape(-1, 3).astype(np.float64)
    mean, se = rgb.mean(axis=0), rgb.std(axis=0, ddof=1) / math.sqrt(len(rgb))
    want = math.exp(-1.0 * (meters_per_unit or 1.0))
    assert np.all(np.abs(mean - want) < 4 * se + 2e-3), (mean, se, want)


def _layered_tank(stage, z_up):
    """A 2 m TideWater tank (ior 1: straight rays) of clear water with a chlorophyll layer 1 m
    below its top (σ 0.1 m, 300 mg/m³ at its peak), seen from the side against a white dome:
    the layer is a dark band across the middle rows. With `z_up`, the same scene on a Z-up stage: every root turned
    +90° about X, so that what was up (+Y) is +Z."""
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z if z_up else UsdGeom.Tokens.y)
    camera(stage, pos=(0, 0, 6), focal=50.0, aperture=(16.0, 16.0))
    settings(stage, res=(16, 16), samples=16, integrator="path")
    _white_dome(stage)
    mat, _, med = _unrefracting_water(stage)
    for name, value in (("profileDepth", 1.0), ("profileWidth", 0.1), ("profilePeak", 300.0)):
        med.CreateInput(name, Sdf.ValueTypeNames.Float).Set(value)
    mat.CreateVolumeOutput().ConnectToSource(med.ConnectableAPI(), "volume")
    tank = UsdGeom.Cube.Define(stage, "/Tank")
    tank.CreateSizeAttr(2.0)
    bind(tank.GetPrim(), mat)
    if z_up:
        for path in ("/Cam", "/Dome", "/Tank"):
            x = UsdGeom.Xformable(stage.GetPrimAtPath(path))
            ops = x.GetOrderedXformOps()
            turn = x.AddRotateXOp(opSuffix="up")
            turn.Set(90.0)
            x.SetXformOpOrder([turn] + list(ops))


def test_water_depth_is_measured_down_the_stages_up_axis(renderer):
    """The depth profile's depth runs down the stage's up axis: the layered tank on a Z-up
    stage renders the Y-up image (it used to measure depth down Y there, along the view, and
    the band was gone)."""
    from pxr import Usd
    rows = []
    for z_up, seed in ((False, 0), (False, 1), (True, 0)):
        s = Usd.Stage.CreateInMemory()
        _layered_tank(s, z_up)
        problems = []
        img = render(renderer, s, problems, seed=seed)["color"][..., :3].astype(np.float64)
        assert problems == [], problems
        rows.append(img.mean(axis=(1, 2)))
    y_rows, other_seed, z_rows = rows
    # the band: the middle rows (the layer's depth) clearly darker than the top and bottom
    assert y_rows[7:9].mean() < 0.8 * min(y_rows[1:3].mean(), y_rows[-3:-1].mean()), y_rows
    # the same seed follows the same paths where rounding lets it (the layer scatters, so some
    # part ways): no row further off than another seed's rows are
    assert np.abs(z_rows - y_rows).max() <= np.abs(other_seed - y_rows).max(), (z_rows, y_rows, other_seed)


# linear Rec.709 → the rendering space, as published (ACES' Bradford-adapted AP1 matrix; ITU-R
# BT.2087 for Rec.2020), 4 decimals
_FROM_REC709 = {"ACEScg": [[0.6131, 0.3395, 0.0474], [0.0702, 0.9164, 0.0134], [0.0206, 0.1096, 0.8698]],
                "lin_rec2020_scene": [[0.6274, 0.3293, 0.0433], [0.0691, 0.9195, 0.0114], [0.0164, 0.0880, 0.8956]],
                "lin_rec709_scene": np.eye(3).tolist()}


@pytest.mark.parametrize("space", sorted(_FROM_REC709))
def test_the_rendering_colour_space_converts_authored_rec709(renderer, stage, space):
    """An emitter authored (0.2, 0.6, 0.9) and a white dome (1, 0.5, 0.25), seen directly:
    `color` holds them converted from linear Rec.709 (USD's default colour space of authored
    values) to the settings' renderingColorSpace."""
    camera(stage, pos=(0, 0, 5), focal=50.0, aperture=(2.0, 2.0))
    UsdLux.DomeLight.Define(stage, "/Dome").CreateColorAttr(Gf.Vec3f(1, 0.5, 0.25))
    glow = (0.2, 0.6, 0.9)
    card = UsdGeom.Mesh.Define(stage, "/Card")
    card.CreatePointsAttr([(-1, -1, 0), (0, -1, 0), (0, 1, 0), (-1, 1, 0)])
    card.CreateFaceVertexCountsAttr([4])
    card.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    bind(card.GetPrim(), preview_material(stage, "/Looks/Glow", (0, 0, 0), emissiveColor=Gf.Vec3f(*glow),
                                          specularColor=Gf.Vec3f(0, 0, 0), useSpecularWorkflow=1.0))
    st = settings(stage, res=(16, 16), samples=16, integrator="path")
    st.CreateRenderingColorSpaceAttr(space)
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3].astype(np.float64)
    assert problems == [], problems
    m = np.array(_FROM_REC709[space])
    for part, authored in ((img[2:-2, 1:6], glow), (img[2:-2, -6:-1], (1, 0.5, 0.25))):
        ok, why = near(part, m @ np.array(authored))
        assert ok, (space, why)


def _wet_wall(stage, wet):
    """The grey wall of the sun test, lit by a sun 30 degrees off its normal (so that the film's
    mirror image of the sun misses the camera); `wet`: TideWetAPI attributes, or None."""
    camera(stage, focal=F, aperture=(AP, AP))
    mat = lambert_material(stage, "/Looks/Grey", (0.5, 0.5, 0.5))
    if wet is not None:
        mat.GetPrim().ApplyAPI("TideWetAPI")
        for name, value in wet.items():
            mat.GetPrim().GetAttribute("tide:wet:" + name).Set(value)
    _sunlit_wall(stage, mat, tilt=30.0)
    settings(stage, res=(16, 16), samples=16, integrator="path", maxDepth=1)


def test_wet_patch_darkens_as_a_film_over_a_diffuse_base(renderer, stage):
    """TideWetAPI (contract §3): a water film of index n over a diffuse base of albedo a lets
    (1 - F(mu_o)) (1 - F(mu_i)) / n^2 / (1 - a r_i) of the dry diffuse radiance out, r_i being
    the film underside's reflectance for diffuse light (computed here from Fresnel's equations);
    half the amount wets half the surface; the API with its defaults changes nothing in air."""
    from pxr import Usd

    def wall(wet):
        s = Usd.Stage.CreateInMemory()
        _wet_wall(s, wet)
        return render(renderer, s)["color"][..., :3].reshape(-1, 3).astype(np.float64).mean(axis=0)

    n, a = 1.333, 0.5
    dry = wall(None)
    _, r_i = diffuse_reflectances(n)
    ratio = (1 - fresnel(1.0, n)) * (1 - fresnel(math.cos(math.radians(30)), n)) \
        / (n * n * (1 - a * r_i))
    assert 0.6 < ratio < 0.8
    wet = wall({"amount": 1.0})
    # the base's black specular layer (Schlick's grazing term) and spectral round trips: 3 %
    assert wet / dry == pytest.approx([ratio] * 3, rel=0.03), (wet, dry, ratio)
    half = wall({"amount": 0.5})
    assert half / dry == pytest.approx([(1 + ratio) / 2] * 3, rel=0.03), (half, dry)
    # a denser film darkens more
    dense = wall({"amount": 1.0, "ior": 1.6})
    assert np.all(dense < wet * 0.97), (dense, wet)
    # the API alone (amount 0) renders dry, bit for bit
    s = Usd.Stage.CreateInMemory()
    _wet_wall(s, {})
    s2 = Usd.Stage.CreateInMemory()
    _wet_wall(s2, None)
    assert np.array_equal(render(renderer, s)["color"], render(renderer, s2)["color"])
