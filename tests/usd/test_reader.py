"""The scene reader against the recording fake: what reaches the delegate for each piece of
contract section 2, checked against values computed here independently of the reader."""
import math

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade, Vt

from conftest import bind, camera, floats, load, matrix, preview_material, settings
from tide import fake


def _quad(stage, path, orientation=None):
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)])
    m.CreateFaceVertexCountsAttr([4])
    m.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    if orientation:
        m.CreateOrientationAttr(orientation)
    return m


# -- meshes -----------------------------------------------------------------------------------
def test_mesh_topology_and_orientation(stage, delegate):
    camera(stage)
    m = UsdGeom.Mesh.Define(stage, "/Ngon")
    pts = [(math.cos(2 * math.pi * k / 5), math.sin(2 * math.pi * k / 5), 0) for k in range(5)]
    m.CreatePointsAttr(pts + [(0, 0, 1), (1, 0, 1), (0, 1, 1)])
    m.CreateFaceVertexCountsAttr([5, 3])
    m.CreateFaceVertexIndicesAttr([0, 1, 2, 3, 4, 5, 6, 7])
    m.CreateHoleIndicesAttr([1])
    m.CreateOrientationAttr("leftHanded")
    m.CreateSubdivisionSchemeAttr("none")
    m.CreateDoubleSidedAttr(True)
    _, problems = load(stage, delegate)
    assert problems == []
    assert delegate.prims["/Ngon"] == "mesh"
    v = lambda k: delegate.value("/Ngon", k)  # noqa: E731
    assert floats(v("points")).shape == (8, 3)
    assert np.allclose(floats(v("points"))[:5], pts, atol=1e-6)
    assert floats(v("faceVertexCounts")).tolist() == [5, 3]
    assert floats(v("faceVertexIndices")).tolist() == list(range(8))
    assert floats(v("holeIndices")).tolist() == [1]
    assert v("orientation") == ("token", "leftHanded")
    assert v("subdivisionScheme") == ("token", "none")
    assert v("doubleSided") is True


@pytest.mark.parametrize("interp,count", [("constant", 1), ("uniform", 1), ("vertex", 4),
                                          ("faceVarying", 4)])
@pytest.mark.parametrize("as_primvar", [False, True])
def test_normals_every_interpolation(stage, delegate, interp, count, as_primvar):
    camera(stage)
    m = _quad(stage, "/Q")
    normals = [(0, 0, 1)] * count
    if as_primvar:
        pv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("normals", Sdf.ValueTypeNames.Normal3fArray,
                                                  interp)
        pv.Set(normals)
    else:
        m.CreateNormalsAttr(normals)
        m.SetNormalsInterpolation(interp)
    load(stage, delegate)
    got_interp, data, tsize, idx = delegate.primvars["/Q"]["normals"]
    assert got_interp == interp and tsize == 3 and idx is None
    assert np.allclose(np.reshape(data, (-1, 3)), normals)


def test_indexed_st_and_display_color(stage, delegate):
    camera(stage)
    m = _quad(stage, "/Q")
    api = UsdGeom.PrimvarsAPI(m)
    st = api.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "faceVarying")
    st.Set([(0, 0), (1, 0), (1, 1), (0, 1)])
    st.SetIndices(Vt.IntArray([0, 1, 2, 3]))
    m.CreateDisplayColorPrimvar("constant").Set([(1, 0, 0)])
    load(stage, delegate)
    interp, data, tsize, idx = delegate.primvars["/Q"]["st"]
    assert (interp, tsize, idx) == ("faceVarying", 2, [0, 1, 2, 3])
    assert np.allclose(np.reshape(data, (-1, 2)), [(0, 0), (1, 0), (1, 1), (0, 1)])
    assert delegate.primvars["/Q"]["displayColor"][:3] == ("constant", [1.0, 0.0, 0.0], 3)


def test_catmull_clark_mesh_is_sent(stage, delegate):
    camera(stage)
    _quad(stage, "/Q").CreateSubdivisionSchemeAttr("catmullClark")
    _, problems = load(stage, delegate)
    assert problems == [] and delegate.value("/Q", "subdivisionScheme") == \
        ("token", "catmullClark")


def test_subdivision_tags_and_level_are_sent(stage, delegate):
    camera(stage)
    q = _quad(stage, "/Q")
    q.CreateCreaseIndicesAttr([0, 1, 1, 2])
    q.CreateCreaseLengthsAttr([2, 2])
    q.CreateCreaseSharpnessesAttr([10.0, 2.5])
    q.CreateCornerIndicesAttr([3])
    q.CreateCornerSharpnessesAttr([10.0])
    q.CreateInterpolateBoundaryAttr("edgeOnly")
    q.GetPrim().CreateAttribute("tide:subdivision:level", Sdf.ValueTypeNames.Int).Set(2)
    _quad(stage, "/Plain")
    q2 = _quad(stage, "/Odd")
    q2.CreateInterpolateBoundaryAttr("everywhere")
    _, problems = load(stage, delegate)
    assert [(p.prim, p.attribute) for p in problems] == [("/Odd", "interpolateBoundary")]
    v = lambda k: delegate.value("/Q", k)  # noqa: E731
    assert floats(v("creaseIndices")).tolist() == [0, 1, 1, 2]
    assert floats(v("creaseLengths")).tolist() == [2, 2]
    assert floats(v("creaseSharpnesses")).tolist() == [10.0, 2.5]
    assert floats(v("cornerIndices")).tolist() == [3]
    assert floats(v("cornerSharpnesses")).tolist() == [10.0]
    assert v("interpolateBoundary") == ("token", "edgeOnly")
    assert v("tide:subdivision:level") == 2
    assert delegate.value("/Plain", "interpolateBoundary") == ("token", "edgeAndCorner")
    assert delegate.value("/Plain", "creaseIndices") is None
    assert delegate.value("/Odd", "interpolateBoundary") == ("token", "edgeAndCorner")


# -- implicit gprims --------------------------------------------------------------------------
def test_implicit_dimensions_and_axis(stage, delegate):
    camera(stage)
    UsdGeom.Sphere.Define(stage, "/S").CreateRadiusAttr(2.5)
    UsdGeom.Cube.Define(stage, "/C").CreateSizeAttr(3.0)
    cy = UsdGeom.Cylinder.Define(stage, "/Cy")
    cy.CreateRadiusAttr(0.5)
    cy.CreateHeightAttr(4.0)
    cy.CreateAxisAttr("X")
    UsdGeom.Cone.Define(stage, "/Co")
    UsdGeom.Capsule.Define(stage, "/Ca").CreateAxisAttr("Y")
    pl = UsdGeom.Plane.Define(stage, "/Pl")
    pl.CreateWidthAttr(7.0)
    load(stage, delegate)
    assert delegate.prims["/S"] == "sphere" and delegate.value("/S", "radius") == 2.5
    assert delegate.value("/C", "size") == 3.0
    assert (delegate.value("/Cy", "radius"), delegate.value("/Cy", "height"),
            delegate.value("/Cy", "axis")) == (0.5, 4.0, ("token", "X"))
    # USD fallbacks for the unauthored cone: radius 1, height 2, axis Z
    assert (delegate.value("/Co", "radius"), delegate.value("/Co", "height"),
            delegate.value("/Co", "axis")) == (1.0, 2.0, ("token", "Z"))
    assert delegate.prims["/Ca"] == "capsule" and delegate.value("/Ca", "axis") == ("token", "Y")
    assert delegate.prims["/Pl"] == "plane" and delegate.value("/Pl", "width") == 7.0
    assert delegate.value("/Pl", "length") == 2.0


def test_points_widths_and_motion_attrs(stage, delegate):
    camera(stage)
    p = UsdGeom.Points.Define(stage, "/P")
    p.CreatePointsAttr([(0, 0, 0), (1, 0, 0)])
    p.CreateWidthsAttr([0.1, 0.2])
    p.SetWidthsInterpolation("vertex")
    p.CreateVelocitiesAttr([(1, 0, 0), (0, 1, 0)])
    p.GetPrim().CreateAttribute("accelerations", Sdf.ValueTypeNames.Vector3fArray).Set(
        [(0, -9.8, 0), (0, -9.8, 0)])
    q = UsdGeom.Points.Define(stage, "/Q")
    q.CreatePointsAttr([(0, 0, 0)] * 3)
    q.CreateWidthsAttr([0.5])
    b = UsdGeom.Points.Define(stage, "/Blobs")
    b.CreatePointsAttr([(0, 0, 0)])
    b.GetPrim().ApplyAPI("TideBlobbyAPI")
    load(stage, delegate)
    interp, data, _, _ = delegate.primvars["/P"]["widths"]
    assert interp == "vertex" and np.allclose(data, [0.1, 0.2])
    assert np.allclose(floats(delegate.value("/P", "velocities")), [(1, 0, 0), (0, 1, 0)])
    assert np.allclose(floats(delegate.value("/P", "accelerations"))[:, 1], -9.8)
    assert delegate.primvars["/Q"]["widths"][:2] == ("constant", [0.5])
    assert delegate.value("/Blobs", "tide:blobby:threshold") == 0.5


def test_ocean_prim(stage, delegate):
    camera(stage)
    o = stage.DefinePrim("/Ocean", "TideOcean")
    o.GetAttribute("windSpeed").Set(12.0)
    stage.SetTimeCodesPerSecond(24)
    load(stage, delegate, frame=48)
    assert delegate.prims["/Ocean"] == "tideOcean"
    assert delegate.value("/Ocean", "windSpeed") == 12.0
    assert delegate.value("/Ocean", "extent") == 1000.0
    assert delegate.value("/Ocean", "spectrum") == ("token", "piersonMoskowitz")
    # unauthored time = stage time: frame 48 at 24 fps
    assert delegate.value("/Ocean", "time") == pytest.approx(2.0)


# -- transforms, visibility, purposes ---------------------------------------------------------
def test_xform_stack_and_reset(stage, delegate):
    camera(stage)
    parent = UsdGeom.Xform.Define(stage, "/A")
    parent.AddTranslateOp().Set(Gf.Vec3d(10, 0, 0))
    s = UsdGeom.Sphere.Define(stage, "/A/S")
    s.AddTranslateOp().Set(Gf.Vec3d(1, 2, 3))
    s.AddRotateZOp().Set(90)
    s.AddScaleOp().Set(Gf.Vec3f(2, 2, 2))
    r = UsdGeom.Sphere.Define(stage, "/A/R")
    r.SetResetXformStack(True)
    r.AddTranslateOp().Set(Gf.Vec3d(0, 5, 0))
    load(stage, delegate)
    m = matrix(delegate.value("/A/S", "transform"))
    # p' = p * M (row vectors): scale 2, rotate +90 about Z, translate (1,2,3), then parent
    p = np.array([1, 0, 0, 1]) @ m
    assert np.allclose(p[:3], [10 + 1, 2 + 2, 3])
    mr = matrix(delegate.value("/A/R", "transform"))
    assert np.allclose(mr[3, :3], [0, 5, 0])   # the parent's translation is reset


def test_inherited_visibility_and_purposes(stage, delegate):
    camera(stage)
    hidden = UsdGeom.Xform.Define(stage, "/Hidden")
    hidden.CreateVisibilityAttr("invisible")
    UsdGeom.Sphere.Define(stage, "/Hidden/S")
    UsdGeom.Sphere.Define(stage, "/Visible")
    for name, purpose in (("Render", "render"), ("Proxy", "proxy"), ("Guide", "guide")):
        UsdGeom.Sphere.Define(stage, "/" + name).CreatePurposeAttr(purpose)
    g = UsdGeom.Xform.Define(stage, "/GuideGroup")
    g.CreatePurposeAttr("guide")
    UsdGeom.Sphere.Define(stage, "/GuideGroup/Child")
    load(stage, delegate)
    assert sorted(delegate.of_type("sphere")) == ["/Render", "/Visible"]
    assert delegate.value("/Render", "purpose") == ("token", "render")


def test_an_authored_purpose_overrides_the_inherited_one(stage, delegate):
    # USD: a prim's own authored purpose wins over the purpose its ancestors pass down, so a
    # render-purpose child of a proxy group is drawn and its default-purpose sibling is not
    camera(stage)
    UsdGeom.Xform.Define(stage, "/F").CreatePurposeAttr("proxy")
    UsdGeom.Sphere.Define(stage, "/F/Own").CreatePurposeAttr("render")
    UsdGeom.Sphere.Define(stage, "/F/Inherits")
    UsdGeom.Xform.Define(stage, "/F/G")
    UsdGeom.Sphere.Define(stage, "/F/G/Deep").CreatePurposeAttr("default")
    load(stage, delegate)
    assert sorted(delegate.of_type("sphere")) == ["/F/G/Deep", "/F/Own"]
    assert [UsdGeom.Imageable(stage.GetPrimAtPath(p)).ComputePurpose()
            for p in ("/F/Own", "/F/Inherits", "/F/G/Deep")] == ["render", "proxy", "default"]


def test_included_purposes_from_settings(stage, delegate):
    camera(stage)
    for name, purpose in (("Render", "render"), ("Proxy", "proxy"), ("Default", "default")):
        UsdGeom.Sphere.Define(stage, "/" + name).CreatePurposeAttr(purpose)
    s = settings(stage)
    s.CreateIncludedPurposesAttr(["default", "proxy"])
    load(stage, delegate)
    assert sorted(delegate.of_type("sphere")) == ["/Default", "/Proxy"]


def test_cameras_and_lights_are_not_chosen_by_purpose_and_cameras_not_by_visibility(stage, delegate):
    # includedPurposes chooses geometry (UsdRenderSettings: "which geometry is present"; in
    # Hydra render tags filter rprims only): a guide-purpose camera, a camera under an invisible
    # parent and a light of the default purpose all stay when only guides are included, while
    # an invisible light is off
    camera(stage, "/Hidden/Cam")
    UsdGeom.Imageable(stage.GetPrimAtPath("/Hidden")).CreateVisibilityAttr("invisible")
    camera(stage, "/GuideCam").GetPrim().GetAttribute("purpose").Set("guide")
    UsdLux.DomeLight.Define(stage, "/Dome")
    UsdLux.SphereLight.Define(stage, "/Off").CreateVisibilityAttr("invisible")
    UsdGeom.Sphere.Define(stage, "/Ball")
    UsdGeom.Sphere.Define(stage, "/Guide").CreatePurposeAttr("guide")
    s = settings(stage, cam="/Hidden/Cam")
    s.CreateIncludedPurposesAttr(["guide"])
    reader, problems = load(stage, delegate)
    assert reader.camera_path == "/Hidden/Cam"
    assert {"/Hidden/Cam", "/GuideCam"} <= set(delegate.of_type("camera"))
    assert "/Dome" in delegate.prims and "/Off" not in delegate.prims
    assert sorted(delegate.of_type("sphere")) == ["/Guide"]
    assert not [p for p in problems if "camera" in p[1]], problems


def test_material_binding_purposes_of_the_settings(stage, delegate):
    # UsdRenderSettings.materialBindingPurposes: the first purpose in the list with a binding
    # wins, "" being the all-purpose binding (default ["full", ""])
    camera(stage)
    mats = {k: preview_material(stage, "/Looks/" + k) for k in ("Full", "Preview", "All")}
    s = UsdGeom.Sphere.Define(stage, "/S")
    api = UsdShade.MaterialBindingAPI.Apply(s.GetPrim())
    api.Bind(mats["Full"], UsdShade.Tokens.fallbackStrength, UsdShade.Tokens.full)
    api.Bind(mats["Preview"], UsdShade.Tokens.fallbackStrength, UsdShade.Tokens.preview)
    api.Bind(mats["All"])
    t = UsdGeom.Sphere.Define(stage, "/T")
    UsdShade.MaterialBindingAPI.Apply(t.GetPrim()).Bind(mats["All"])
    rs = settings(stage)
    for purposes, want_s, want_t in ((None, "Full", "All"), (["preview", ""], "Preview", "All"),
                                     ([""], "All", "All"), (["preview"], "Preview", None),
                                     (["full"], "Full", None)):
        d = fake.RenderDelegate()
        if purposes is not None:
            rs.CreateMaterialBindingPurposesAttr(purposes)
        load(stage, d)
        assert d.value("/S", "material") == ("path", "/Looks/" + want_s), purposes
        assert d.value("/T", "material") == ("path", "/Looks/" + want_t if want_t else ""), \
            purposes


def test_instantaneous_shutter_and_clipping_planes(stage, delegate):
    # instantaneousShutter (deprecated) closes the shutter as it opens; clipping planes are
    # sent as float4s
    _moving_sphere(stage)
    cam = UsdGeom.Camera(stage.GetPrimAtPath("/Cam"))
    cam.CreateClippingPlanesAttr([Gf.Vec4f(1, 0, 0, 0), Gf.Vec4f(0, 0, 1, 7)])
    settings(stage).CreateInstantaneousShutterAttr(True)
    _, problems = load(stage, delegate, frame=0)
    assert delegate.value("/Cam", "shutter:close") == delegate.value("/Cam", "shutter:open")
    assert len(delegate.samples("/S", "transform")) == 1
    assert floats(delegate.value("/Cam", "clippingPlanes")).reshape(-1).tolist() == [1, 0, 0, 0, 0, 0, 1, 7]
    assert not problems, problems


def test_exposure_f_number_is_read_as_the_f_stop(stage, delegate):
    # newer OpenUSD spells UsdGeomCamera's exposure:fStop as exposure:fNumber
    cam = camera(stage)
    cam.GetPrim().CreateAttribute("exposure:fNumber", Sdf.ValueTypeNames.Float).Set(2.8)
    load(stage, delegate)
    assert delegate.value("/Cam", "exposure:fStop") == pytest.approx(2.8)


def test_render_settings_are_read_at_the_frame(stage, delegate):
    # time-sampled UsdRenderSettings attributes take their value at the frame rendered
    camera(stage)
    s = settings(stage)
    s.GetResolutionAttr().Set(Gf.Vec2i(64, 8), 0)
    s.GetResolutionAttr().Set(Gf.Vec2i(32, 16), 10)
    s.CreateDisableMotionBlurAttr().Set(True, 0)
    reader, _ = load(stage, delegate, frame=0)
    assert reader.resolution == (64, 8)
    assert delegate.value("/Render/Settings", "disableMotionBlur") is True
    reader, _ = load(stage, fake.RenderDelegate(), frame=10)
    assert reader.resolution == (32, 16)


def test_an_applied_caustics_api_leaves_unauthored_roles_untagged(stage, delegate):
    # TideCausticsAPI's fallback caster/emitter `false` is no explicit `false`: applying the API
    # to author only a transparency (or nothing) must not exclude the object or the light
    camera(stage)
    ball = UsdGeom.Sphere.Define(stage, "/Ball").GetPrim()
    ball.ApplyAPI("TideCausticsAPI")
    ball.CreateAttribute("tide:caustics:transparency", Sdf.ValueTypeNames.Token).Set("off")
    sun = UsdLux.DistantLight.Define(stage, "/Sun").GetPrim()
    sun.ApplyAPI("TideCausticsAPI")
    tagged = UsdGeom.Sphere.Define(stage, "/Tagged").GetPrim()
    tagged.ApplyAPI("TideCausticsAPI")
    tagged.CreateAttribute("tide:caustics:caster", Sdf.ValueTypeNames.Bool).Set(False)
    load(stage, delegate)
    assert "/Ball" in delegate.prims and "/Sun" in delegate.prims
    assert delegate.value("/Ball", "tide:caustics:caster") is None
    assert delegate.value("/Sun", "tide:caustics:emitter") is None
    assert delegate.value("/Tagged", "tide:caustics:caster") is False


def _moving_sphere(stage, open_=-0.25, close=0.25):
    camera(stage, **{"shutter__open": open_, "shutter__close": close})
    s = UsdGeom.Sphere.Define(stage, "/S")
    op = s.AddTranslateOp()
    op.Set(Gf.Vec3d(0, 0, 0), 0)
    op.Set(Gf.Vec3d(4, 0, 0), 1)
    return s


@pytest.mark.parametrize("scale, on_parent", [(0.5, False), (0.5, True), (2.0, False)])
def test_motion_blur_scale_samples_a_scaled_window(stage, delegate, scale, on_parent):
    """motion:blurScale s (inherited) samples the prim over the shutter scaled by s and hands
    each sample on at its time over s (UsdGeomMotionAPI's guidance): x = 4 t (t in [0, 1],
    held before 0) over a ±0.25 shutter has x = 4 · 0.25 s at the shutter's close."""
    _moving_sphere(stage)
    holder = stage.DefinePrim("/G", "Xform") if on_parent else stage.GetPrimAtPath("/S")
    if on_parent:
        UsdGeom.Sphere.Define(stage, "/G/S2").AddTranslateOp().Set(Gf.Vec3d(4, 0, 0), 1)
        UsdGeom.Xformable(stage.GetPrimAtPath("/G/S2")).GetOrderedXformOps()[0].Set(Gf.Vec3d(0, 0, 0), 0)
    UsdGeom.MotionAPI.Apply(holder).CreateMotionBlurScaleAttr(scale)
    _, problems = load(stage, delegate, frame=0)
    assert problems == [], problems
    path = "/G/S2" if on_parent else "/S"
    samples = delegate.samples(path, "transform")
    assert sorted(samples) == [-0.25, 0.0, 0.25]
    assert matrix(samples[0.25])[3, 0] == pytest.approx(4 * 0.25 * scale)
    assert matrix(samples[-0.25])[3, 0] == 0.0
    if on_parent:
        # the prim outside the scaled namespace blurs over the whole shutter
        assert matrix(delegate.samples("/S", "transform")[0.25])[3, 0] == pytest.approx(1.0)


def test_motion_blur_scale_zero_holds_still_and_a_negative_one_is_named(stage, delegate):
    _moving_sphere(stage)
    api = UsdGeom.MotionAPI.Apply(stage.GetPrimAtPath("/S"))
    api.CreateMotionBlurScaleAttr(0.0)
    load(stage, delegate, frame=0)
    assert list(delegate.samples("/S", "transform")) == [None]
    api.GetMotionBlurScaleAttr().Set(-1.0)
    _, problems = load(stage, delegate, frame=0)
    assert [(p.prim, p.attribute) for p in problems] == [("/S", "motion:blurScale")], problems
    assert matrix(delegate.samples("/S", "transform")[0.25])[3, 0] == pytest.approx(1.0)


def test_motion_blur_scale_scales_velocities_and_accelerations(stage, delegate):
    camera(stage, **{"shutter__open": -0.25, "shutter__close": 0.25})
    pts = UsdGeom.Points.Define(stage, "/P")
    pts.CreatePointsAttr([(0, 0, 0)])
    pts.CreateWidthsAttr([0.1])
    pts.CreateVelocitiesAttr([(1, 2, 3)])
    pts.CreateAccelerationsAttr([(0, -10, 0)])
    UsdGeom.MotionAPI.Apply(pts.GetPrim()).CreateMotionBlurScaleAttr(2.0)
    load(stage, delegate, frame=0)
    assert floats(delegate.value("/P", "velocities")).tolist() == [[2, 4, 6]]
    assert floats(delegate.value("/P", "accelerations")).tolist() == [[0, -40, 0]]


def test_motion_samples_over_shutter(stage, delegate):
    _moving_sphere(stage)
    load(stage, delegate, frame=0)
    samples = delegate.samples("/S", "transform")
    assert sorted(samples) == [-0.25, 0.0, 0.25]   # shutter ends + the authored sample at 0
    # linear interpolation of the authored samples: x = 4 t, held before t = 0
    assert matrix(samples[-0.25])[3, 0] == pytest.approx(0.0)
    assert matrix(samples[0.25])[3, 0] == pytest.approx(1.0)


def test_motion_includes_authored_samples_inside_shutter(stage, delegate):
    _moving_sphere(stage, -0.5, 0.5)
    load(stage, delegate, frame=0.75)
    samples = delegate.samples("/S", "transform")
    assert sorted(samples) == [-0.5, 0.25, 0.5]   # 0.25 = the authored sample at frame 1
    assert matrix(samples[0.25])[3, 0] == pytest.approx(4.0)


def test_no_motion_when_shutter_closed_or_disabled(stage, delegate):
    _moving_sphere(stage)
    s = settings(stage)
    s.GetPrim().CreateAttribute("disableMotionBlur", Sdf.ValueTypeNames.Bool).Set(True)
    load(stage, delegate, frame=0.5)
    samples = delegate.samples("/S", "transform")
    assert list(samples) == [None] and matrix(samples[None])[3, 0] == pytest.approx(2.0)


def test_points_time_samples_in_shutter(stage, delegate):
    camera(stage, **{"shutter__open": 0.0, "shutter__close": 0.5})
    p = UsdGeom.Points.Define(stage, "/P")
    p.CreatePointsAttr().Set([(0, 0, 0)], 0)
    p.GetPointsAttr().Set([(2, 0, 0)], 1)
    load(stage, delegate, frame=0)
    s = delegate.samples("/P", "points")
    assert sorted(s) == [0.0, 0.5] and floats(s[0.5])[0, 0] == pytest.approx(1.0)


# -- instancing -------------------------------------------------------------------------------
def test_native_instancing_groups_by_prototype(stage, delegate):
    camera(stage)
    proto = stage.DefinePrim("/Proto", "Xform")
    stage.GetRootLayer().GetPrimAtPath("/Proto").specifier = Sdf.SpecifierClass
    UsdGeom.Sphere.Define(stage, "/Proto/Ball")
    c = UsdGeom.Cube.Define(stage, "/Proto/Box")
    c.AddTranslateOp().Set(Gf.Vec3d(0, 1, 0))
    offsets = [(i * 3.0, 0, -i) for i in range(4)]
    for i, off in enumerate(offsets):
        p = stage.DefinePrim("/I%d" % i, "Xform")
        p.GetInherits().AddInherit("/Proto")
        p.SetInstanceable(True)
        UsdGeom.Xformable(p).AddTranslateOp().Set(Gf.Vec3d(*off))
    del proto
    load(stage, delegate)
    spheres, cubes = delegate.of_type("sphere"), delegate.of_type("cube")
    assert len(spheres) == 1 and len(cubes) == 1     # one rprim per prototype gprim
    xf = floats(delegate.value(cubes[0], "instanceTransforms")).reshape(-1, 4, 4)
    assert len(xf) == 4
    assert sorted(map(tuple, xf[:, 3, :3])) == sorted(offsets)
    # world = transform (relative to the instance) then the instance matrix
    rel = matrix(delegate.value(cubes[0], "transform"))
    worlds = sorted(tuple((np.array([0, 0, 0, 1]) @ rel @ m)[:3]) for m in xf)
    assert np.allclose(worlds, sorted((x, y + 1, z) for x, y, z in offsets))


def _quat_matrix(axis, deg):
    a = math.radians(deg)
    x, y, z = axis
    c, s = math.cos(a), math.sin(a)
    # rotation of row vectors about a unit axis (right-handed)
    r = np.array([[c + x * x * (1 - c), x * y * (1 - c) + z * s, x * z * (1 - c) - y * s],
                  [y * x * (1 - c) - z * s, c + y * y * (1 - c), y * z * (1 - c) + x * s],
                  [z * x * (1 - c) + y * s, z * y * (1 - c) - x * s, c + z * z * (1 - c)]])
    return r


def test_point_instancer(stage, delegate):
    camera(stage)
    inst = UsdGeom.PointInstancer.Define(stage, "/Inst")
    inst.AddTranslateOp().Set(Gf.Vec3d(0, 0, -10))
    UsdGeom.Sphere.Define(stage, "/Inst/Protos/Ball")
    box = UsdGeom.Cube.Define(stage, "/Inst/Protos/Box")
    box.AddTranslateOp().Set(Gf.Vec3d(0, 0.5, 0))   # the prototype root's own transform
    inst.CreatePrototypesRel().SetTargets(["/Inst/Protos/Ball", "/Inst/Protos/Box"])
    inst.CreateProtoIndicesAttr([0, 1, 0, 1, 0])
    pos = [(i, 0, 0) for i in range(5)]
    inst.CreatePositionsAttr(pos)
    h = math.sqrt(0.5)
    inst.CreateOrientationsAttr([Gf.Quath(h, 0, 0, h)] * 5)      # 90 deg about Z
    inst.CreateScalesAttr([(2, 2, 2)] * 5)
    inst.CreateIdsAttr([10, 11, 12, 13, 14])
    inst.CreateInvisibleIdsAttr([12])
    load(stage, delegate)
    assert delegate.of_type("sphere") == ["/Inst/proto0_Ball"]
    assert delegate.of_type("cube") == ["/Inst/proto1_Box"]
    # the prototypes under the instancer are not drawn on their own
    assert "/Inst/Protos/Ball" not in delegate.prims
    ball = floats(delegate.value("/Inst/proto0_Ball", "instanceTransforms")).reshape(-1, 4, 4)
    box_x = floats(delegate.value("/Inst/proto1_Box", "instanceTransforms")).reshape(-1, 4, 4)
    assert len(ball) == 2 and len(box_x) == 2            # instance 2 is invisible
    rot = _quat_matrix((0, 0, 1), 90)
    # orientations are half floats: 11-bit mantissa, so sqrt(0.5) carries a relative error up
    # to 2^-11 ~ 4.9e-4, times the scale 2 and the unit offset: 2e-3 bounds the error
    tol = 2e-3
    for m, i in zip(ball, (0, 4)):
        p = np.array([1, 0, 0, 1]) @ m
        expect = (np.array([1, 0, 0]) * 2) @ rot + np.array(pos[i]) + np.array([0, 0, -10])
        assert np.allclose(p[:3], expect, atol=tol)
    rel = matrix(delegate.value("/Inst/proto1_Box", "transform"))
    p = np.array([0, 0, 0, 1]) @ rel @ box_x[0]
    expect = np.array([0, 0.5, 0]) * 2 @ rot + np.array(pos[1]) + np.array([0, 0, -10])
    assert np.allclose(p[:3], expect, atol=tol)


def _drawn(stage, delegate):
    """The spheres and cubes a load of `stage` sends (with a camera added)."""
    camera(stage)
    load(stage, delegate)
    return delegate.of_type("sphere"), delegate.of_type("cube")


def test_point_instancer_prototypes_under_an_over_are_drawn(stage, delegate):
    # prototypes often live under an `over` (or a class) so that they are not drawn on their
    # own; UsdImaging walks a prototype whether or not it is defined (active, loaded and not
    # abstract), and so does the reader
    stage.GetRootLayer().ImportFromString("""#usda 1.0
def PointInstancer "PI"
{
    point3f[] positions = [(-6, 0, 0), (-2, 0, 0), (2, 0, 0), (6, 0, 0)]
    int[] protoIndices = [0, 1, 0, 1]
    rel prototypes = [</PI/Protos/Ball>, </Hidden/Box>]
    over "Protos"
    {
        def Sphere "Ball"
        {
            double radius = 0.8
        }
    }
}
over "Hidden"
{
    def Cube "Box"
    {
        double size = 1.2
    }
}
""")
    assert _drawn(stage, delegate) == (["/PI/proto0_Ball"], ["/PI/proto1_Box"])
    for path in ("/PI/proto0_Ball", "/PI/proto1_Box"):
        assert len(floats(delegate.value(path, "instanceTransforms")).reshape(-1, 4, 4)) == 2
    # and not on their own
    assert "/Hidden/Box" not in delegate.prims and "/PI/Protos/Ball" not in delegate.prims


def test_visibility_and_purpose_above_a_prototype_do_not_hide_its_instances(stage, delegate):
    # UsdImaging takes a prototype's visibility and purpose from its own root down: an invisible
    # (or guide) scope holding the prototypes keeps them from drawing in place only; an
    # invisible prim inside a prototype is hidden in every instance
    stage.GetRootLayer().ImportFromString("""#usda 1.0
def PointInstancer "PI"
{
    point3f[] positions = [(-2, 0, 0), (2, 0, 0)]
    int[] protoIndices = [0, 1]
    rel prototypes = [</Protos/Ball>, </Guides/Box>]
}
def Scope "Protos"
{
    token visibility = "invisible"
    def Xform "Ball"
    {
        def Sphere "Shown"
        {
            double radius = 0.5
        }
        def Sphere "Hidden"
        {
            token visibility = "invisible"
        }
    }
}
def Scope "Guides"
{
    uniform token purpose = "guide"
    def Cube "Box"
    {
        double size = 1
    }
}
""")
    assert _drawn(stage, delegate) == (["/PI/proto0_Ball/Shown"], ["/PI/proto1_Box"])
    assert "/Protos/Ball/Shown" not in delegate.prims and "/Guides/Box" not in delegate.prims


def test_nested_point_instancers_place_every_inner_instance_under_every_outer_one(stage, delegate):
    """An instancer whose prototype holds another: each of the outer instances (translated
    along x, turned 90 degrees about Y) places the inner instancer's, which sits 1 above its
    prototype's origin and places balls along z. The inner balls' per-instance colours repeat
    under each outer instance, each inner ball takes its outer instance's tint, and a masked
    inner instance stays out everywhere."""
    camera(stage)
    outer = UsdGeom.PointInstancer.Define(stage, "/Field")
    outer.AddTranslateOp().Set(Gf.Vec3d(0, 0, -10))
    cluster = UsdGeom.Xform.Define(stage, "/Field/Protos/Cluster")
    inner = UsdGeom.PointInstancer.Define(stage, "/Field/Protos/Cluster/Row")
    inner.AddTranslateOp().Set(Gf.Vec3d(0, 1, 0))
    UsdGeom.Sphere.Define(stage, "/Field/Protos/Cluster/Row/Protos/Ball")
    inner.CreatePrototypesRel().SetTargets(["/Field/Protos/Cluster/Row/Protos/Ball"])
    inner.CreateProtoIndicesAttr([0, 0, 0])
    inner.CreatePositionsAttr([(0, 0, 0), (0, 0, 1), (0, 0, 2)])
    inner.CreateIdsAttr([0, 1, 2])
    inner.CreateInvisibleIdsAttr([1])
    UsdGeom.PrimvarsAPI(inner.GetPrim()).CreatePrimvar(
        "displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.vertex).Set(
        [(1, 0, 0), (0, 1, 0), (0, 0, 1)])
    outer.CreatePrototypesRel().SetTargets([cluster.GetPath()])
    outer.CreateProtoIndicesAttr([0, 0])
    outer.CreatePositionsAttr([(0, 0, 0), (10, 0, 0)])
    # the outer level's own per-instance primvars reach the inner instances too
    UsdGeom.PrimvarsAPI(outer.GetPrim()).CreatePrimvar(
        "tint", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex).Set([0.25, 0.75])
    h = math.sqrt(0.5)
    outer.CreateOrientationsAttr([Gf.Quath(h, 0, h, 0)] * 2)      # 90 deg about Y
    _, problems = load(stage, delegate)
    assert problems == [], problems
    ball = "/Field/Protos/Cluster/Row/proto0_Ball"
    assert delegate.of_type("sphere") == [ball]
    mats = floats(delegate.value(ball, "instanceTransforms")).reshape(-1, 4, 4)
    rot = _quat_matrix((0, 1, 0), 90)
    want = [np.array([0, 1, z]) @ rot + np.array([x, 0, -10]) for x in (0, 10) for z in (0, 2)]
    assert np.allclose([m[3, :3] for m in mats], want, atol=2e-3)
    interp, data, tsize, _ = delegate.primvars[ball]["displayColor"]
    assert (interp, tsize) == ("instance", 3)
    assert np.allclose(np.asarray(data).reshape(-1, 3), [(1, 0, 0), (0, 0, 1)] * 2)
    interp, data, tsize, _ = delegate.primvars[ball]["tint"]
    assert (interp, tsize) == ("instance", 1)
    assert np.allclose(data, [0.25, 0.25, 0.75, 0.75])


# -- materials --------------------------------------------------------------------------------
def test_material_network_and_connections(stage, delegate, tmp_path):
    camera(stage)
    tex_file = tmp_path / "t.png"
    tex_file.write_bytes(b"not really a png")
    mat = preview_material(stage, "/Looks/M")
    tex = UsdShade.Shader.Define(stage, "/Looks/M/Tex")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(str(tex_file))
    tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("sRGB")
    tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    surf = UsdShade.Shader(stage.GetPrimAtPath("/Looks/M/Surface"))
    surf.GetInput("diffuseColor").ConnectToSource(tex.ConnectableAPI(), "rgb")
    # an interface input on the material drives the roughness
    mat.CreateInput("rough", Sdf.ValueTypeNames.Float).Set(0.25)
    surf.CreateInput("roughness", Sdf.ValueTypeNames.Float).ConnectToSource(
        mat.GetInput("rough"))
    s = UsdGeom.Sphere.Define(stage, "/S")
    bind(s.GetPrim(), mat)
    _, problems = load(stage, delegate)
    assert problems == []
    assert delegate.value("/S", "material") == ("path", "/Looks/M")
    v = lambda k: delegate.value("/Looks/M", k)  # noqa: E731
    assert v("surface") == ("path", "/Looks/M/Surface")
    assert v("/Looks/M/Surface.info:id") == ("token", "UsdPreviewSurface")
    assert v("/Looks/M/Surface.inputs:diffuseColor.connect") == \
        ("token", "/Looks/M/Tex.outputs:rgb")
    assert v("/Looks/M/Surface.inputs:roughness") == 0.25
    assert v("/Looks/M/Tex.inputs:file") == ("asset", str(tex_file))
    assert delegate.textures == {str(tex_file)}
    assert v("/Looks/M/Tex.inputs:sourceColorSpace") == ("token", "sRGB")
    # the texture is loaded before the material's values are set
    calls = [c[0] for c in delegate.calls]
    assert calls.index("load_texture") < max(i for i, c in enumerate(delegate.calls)
                                             if c[1] == "/Looks/M")


def test_binding_purpose_full_preferred(stage, delegate):
    camera(stage)
    full = preview_material(stage, "/Looks/Full")
    prev = preview_material(stage, "/Looks/Preview")
    s = UsdGeom.Sphere.Define(stage, "/S")
    api = UsdShade.MaterialBindingAPI.Apply(s.GetPrim())
    api.Bind(prev, UsdShade.Tokens.fallbackStrength, UsdShade.Tokens.preview)
    api.Bind(full, UsdShade.Tokens.fallbackStrength, UsdShade.Tokens.full)
    t = UsdGeom.Sphere.Define(stage, "/T")
    UsdShade.MaterialBindingAPI.Apply(t.GetPrim()).Bind(
        prev, UsdShade.Tokens.fallbackStrength, UsdShade.Tokens.preview)
    load(stage, delegate)
    assert delegate.value("/S", "material") == ("path", "/Looks/Full")
    assert delegate.value("/T", "material") == ("path", "")   # preview-only is not for us
    assert "/Looks/Preview" not in delegate.prims


def test_collection_binding_and_inherited_binding(stage, delegate):
    camera(stage)
    red = preview_material(stage, "/Looks/Red", (1, 0, 0))
    blue = preview_material(stage, "/Looks/Blue", (0, 0, 1))
    UsdGeom.Xform.Define(stage, "/G")
    UsdGeom.Sphere.Define(stage, "/G/A")
    UsdGeom.Sphere.Define(stage, "/G/B")
    bind(stage.GetPrimAtPath("/G"), blue)
    coll = Usd.CollectionAPI.Apply(stage.GetPrimAtPath("/G"), "reds")
    coll.CreateIncludesRel().AddTarget("/G/A")
    api = UsdShade.MaterialBindingAPI(stage.GetPrimAtPath("/G"))
    api.Bind(coll, red, "reds", UsdShade.Tokens.strongerThanDescendants)
    load(stage, delegate)
    assert delegate.value("/G/A", "material") == ("path", "/Looks/Red")
    assert delegate.value("/G/B", "material") == ("path", "/Looks/Blue")


def test_water_material(stage, delegate):
    camera(stage)
    mat = UsdShade.Material.Define(stage, "/Looks/Water")
    w = UsdShade.Shader.Define(stage, "/Looks/Water/W")
    w.CreateIdAttr("TideWater")
    w.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.34)
    med = UsdShade.Shader.Define(stage, "/Looks/Water/V")
    med.CreateIdAttr("TideMedium")
    med.CreateInput("jerlovType", Sdf.ValueTypeNames.Token).Set("IB")
    mat.CreateSurfaceOutput().ConnectToSource(w.ConnectableAPI(), "surface")
    mat.CreateVolumeOutput().ConnectToSource(med.ConnectableAPI(), "volume")
    cam = stage.GetPrimAtPath("/Cam")
    cam.CreateRelationship("tide:medium").SetTargets(["/Looks/Water"])
    c = UsdGeom.Cube.Define(stage, "/Pool")
    bind(c.GetPrim(), mat)
    _, problems = load(stage, delegate)
    assert problems == []
    assert delegate.value("/Looks/Water", "volume") == ("path", "/Looks/Water/V")
    assert delegate.value("/Looks/Water", "/Looks/Water/V.inputs:jerlovType") == ("token", "IB")
    assert delegate.value("/Looks/Water", "/Looks/Water/W.inputs:ior") == pytest.approx(1.34)
    assert delegate.value("/Cam", "tide:medium") == ("path", "/Looks/Water")


# -- lights, camera, settings -----------------------------------------------------------------
def test_lights_and_light_linking(stage, delegate):
    camera(stage)
    UsdGeom.Sphere.Define(stage, "/A")
    sun = UsdLux.DistantLight.Define(stage, "/Sun")
    sun.CreateAngleAttr(1.0)
    sun.CreateIntensityAttr(3.0)
    sun.GetPrim().ApplyAPI("TideCausticsAPI")
    sun.GetPrim().GetAttribute("tide:caustics:emitter").Set(True)
    UsdLux.LightAPI(sun).GetLightLinkCollectionAPI().CreateIncludesRel().AddTarget("/A")
    UsdLux.LightAPI(sun).GetLightLinkCollectionAPI().CreateIncludeRootAttr(False)
    rect = UsdLux.RectLight.Define(stage, "/Rect")
    rect.CreateWidthAttr(2.0)
    UsdLux.SphereLight.Define(stage, "/Ball").CreateTreatAsPointAttr(True)
    UsdLux.DiskLight.Define(stage, "/Disk")
    UsdLux.CylinderLight.Define(stage, "/Tube")
    dome = UsdLux.DomeLight.Define(stage, "/Dome")
    dome.GetPrim().ApplyAPI("TideSkyAPI")
    dome.GetPrim().GetRelationship("tide:sky:sun").SetTargets(["/Sun"])
    load(stage, delegate)
    assert delegate.prims["/Sun"] == "distantLight"
    assert delegate.value("/Sun", "inputs:angle") == 1.0
    assert delegate.value("/Sun", "inputs:intensity") == 3.0
    assert delegate.value("/Sun", "tide:caustics:emitter") is True
    assert delegate.value("/Sun", "collection:lightLink:includes") == ("paths", ["/A"])
    assert delegate.value("/Sun", "collection:lightLink:includeRoot") is False
    assert delegate.value("/Rect", "inputs:width") == 2.0
    assert delegate.value("/Rect", "inputs:height") == 1.0          # USD fallback
    assert delegate.value("/Ball", "treatAsPoint") is True
    assert {delegate.prims[p] for p in ("/Disk", "/Tube", "/Dome")} == \
        {"diskLight", "cylinderLight", "domeLight"}
    assert delegate.value("/Dome", "tide:sky:sun") == ("path", "/Sun")
    assert delegate.value("/Dome", "tide:sky:turbidity") == 3.0
    assert floats(delegate.value("/Dome", "inputs:color")).tolist() == [[1.0, 1.0, 1.0]]


def test_camera_attributes(stage, delegate):
    cam = camera(stage, focal=35.0, aperture=(24.0, 18.0))
    cam.CreateFStopAttr(2.8)
    cam.CreateFocusDistanceAttr(5.0)
    cam.CreateExposureAttr(1.0)
    load(stage, delegate)
    v = lambda k: delegate.value("/Cam", k)  # noqa: E731
    assert (v("focalLength"), v("horizontalAperture"), v("verticalAperture")) == (35.0, 24.0, 18.0)
    assert v("fStop") == pytest.approx(2.8) and v("focusDistance") == 5.0
    assert v("projection") == ("token", "perspective")
    assert v("exposure") == 1.0
    assert floats(v("clippingRange"))[0].tolist() == pytest.approx([0.01, 10000])
    for k in ("exposure:fStop", "exposure:time", "exposure:iso", "exposure:responsivity",
              "shutter:open", "shutter:close", "tide:camera:filter"):
        assert v(k) is not None, k


def test_settings_products_and_camera_selection(stage, delegate):
    camera(stage, "/CamA")
    camera(stage, "/CamB")
    settings(stage, "/Render/A", cam="/CamA", res=(64, 48), vars_=("color", "depth"),
             samples=16, integrator="path")
    settings(stage, "/Render/B", cam="/CamB", res=(10, 10))
    stage.SetMetadata("renderSettingsPrimPath", "/Render/A")
    r, problems = load(stage, delegate)
    assert problems == []
    assert r.settings_path == "/Render/A" and r.camera_path == "/CamA"
    v = lambda k: delegate.value("/Render/A", k)  # noqa: E731
    assert floats(v("resolution")).tolist() == [64, 48]
    assert v("tide:samples") == 16 and v("tide:integrator") == ("token", "path")
    assert v("tide:maxDepth") == 64 and v("camera") == ("path", "/CamA")
    assert [a for a, _ in r.products[0].vars] == ["color", "depth"]
    assert r.products[0].name == "out.exr"
    for _, buf in r.bindings():
        assert delegate.prims[buf] == "renderBuffer"
        assert floats(delegate.value(buf, "dimensions")).tolist() == [64, 48]
    # command-line overrides: --settings, --camera, --spp, --width, --seed
    d2 = type(delegate)()
    r2, _ = load(stage, d2, settings="/Render/B", camera="/CamA", spp=3, width=20, seed=7)
    assert r2.settings_path == "/Render/B" and r2.camera_path == "/CamA"
    assert d2.value("/Render/B", "tide:samples") == 3 and d2.value("/Render/B", "tide:seed") == 7
    assert floats(d2.value("/Render/B", "resolution")).tolist() == [20, 20]


def test_products_vars_names_and_frames_are_checked(stage, delegate):
    # a var repeated, a var of an unsupported sourceType, a product with no usable var, two
    # products of one name, and a productName sampled per frame
    from pxr import UsdRender
    camera(stage)
    s = settings(stage, vars_=("color", "depth", "depth"))
    first = UsdRender.Product(stage.GetPrimAtPath("/Render/Settings_Product"))
    first.GetProductNameAttr().Set("shot.0001.exr", 1)
    first.GetProductNameAttr().Set("shot.0002.exr", 2)
    UsdRender.Var(stage.GetPrimAtPath("/Render/Settings_Var0")).CreateSourceTypeAttr("lpe")
    other = UsdRender.Product.Define(stage, "/Render/Other")
    other.CreateProductNameAttr("shot.0002.exr")
    bad = UsdRender.Var.Define(stage, "/Render/Bad")
    bad.CreateSourceNameAttr("nothing")
    other.CreateOrderedVarsRel().SetTargets([bad.GetPath()])
    s.GetProductsRel().SetTargets([first.GetPath(), other.GetPath()])
    r, problems = load(stage, delegate, frame=2)
    named = {(p.prim, p.attribute) for p in problems}
    assert ("/Render/Settings_Var2", "sourceName") in named          # depth twice: once
    assert ("/Render/Settings_Var0", "sourceType") in named
    assert ("/Render/Bad", "sourceName") in named and ("/Render/Other", "orderedVars") in named
    assert ("/Render/Other", "productName") in named
    assert [(p.name, [a for a, _ in p.vars]) for p in r.products] == [
        ("shot.0002.exr", ["color", "depth"]), ("shot.0002_2.exr", ["color"])]


def _products_stage(stage):
    camera(stage, "/CamA")
    camera(stage, "/CamB")
    s = settings(stage, "/Render/S", cam="/CamA", res=(64, 48))
    prod = UsdRender.Product(stage.GetPrimAtPath("/Render/S_Product"))
    prod.CreateResolutionAttr(Gf.Vec2i(40, 20))
    prod.CreateCameraRel().SetTargets(["/CamB"])
    prod.CreatePixelAspectRatioAttr(2.0)
    prod.CreateAspectRatioConformPolicyAttr("cropAperture")
    prod.GetPrim().CreateAttribute("disableMotionBlur", Sdf.ValueTypeNames.Bool).Set(True)
    prod.GetPrim().CreateAttribute("tide:samples", Sdf.ValueTypeNames.Int).Set(5)
    other = UsdRender.Product.Define(stage, "/Render/Other")
    other.CreateProductNameAttr("other.exr")
    other.CreateResolutionAttr(Gf.Vec2i(8, 8))
    var = UsdRender.Var.Define(stage, "/Render/OtherDepth")
    var.CreateSourceNameAttr("depth")
    other.CreateOrderedVarsRel().SetTargets([var.GetPath()])
    s.GetProductsRel().AddTarget("/Render/Other")
    # the same settings as the first product, authored apart: rendered with it
    twin = UsdRender.Product.Define(stage, "/Render/Twin")
    twin.CreateProductNameAttr("twin.exr")
    for name in ("resolution", "pixelAspectRatio", "aspectRatioConformPolicy",
                 "disableMotionBlur", "tide:samples"):
        a = prod.GetPrim().GetAttribute(name)
        twin.GetPrim().CreateAttribute(name, a.GetTypeName()).Set(a.Get())
    twin.CreateCameraRel().SetTargets(["/CamB"])
    twin.CreateOrderedVarsRel().SetTargets([var.GetPath()])
    s.GetProductsRel().AddTarget("/Render/Twin")
    return s


def test_a_products_own_settings_override_the_settings(stage, delegate):
    # UsdRenderSettingsBase attributes a product authors override the settings' for it;
    # products whose settings differ are rendered apart, those that agree together
    _products_stage(stage)
    r, problems = load(stage, delegate)
    assert problems == []
    assert [[p.path for p in g] for g in r.renders] == [
        ["/Render/S_Product", "/Render/Twin"], ["/Render/Other"]]
    v = lambda k: delegate.value("/Render/S", k)  # noqa: E731
    assert floats(v("resolution")).tolist() == [40, 20]
    assert r.camera_path == "/CamB" and v("camera") == ("path", "/CamB")
    assert v("pixelAspectRatio") == 2.0 and v("aspectRatioConformPolicy") == ("token", "cropAperture")
    assert v("disableMotionBlur") is True and v("tide:samples") == 5
    assert [a for a, _ in r.bindings()] == ["color", "depth"]
    for _, buf in r.bindings():
        assert floats(delegate.value(buf, "dimensions")).tolist() == [40, 20]
    # the second render: the settings' own values where the product authors none
    assert r.select_render(1) == []
    assert floats(v("resolution")).tolist() == [8, 8]
    assert r.camera_path == "/CamA" and v("camera") == ("path", "/CamA")
    assert v("pixelAspectRatio") == 1.0
    assert v("aspectRatioConformPolicy") == ("token", "expandAperture")
    assert v("disableMotionBlur") is False and v("tide:samples") == 64
    assert [a for a, _ in r.bindings()] == ["depth"]
    assert floats(delegate.value(r.bindings()[0][1], "dimensions")).tolist() == [8, 8]
    r.select_render(0)
    assert floats(v("resolution")).tolist() == [40, 20] and r.camera_path == "/CamB"


def test_one_image_for_every_product_reports_the_differences(stage, delegate):
    # `tide render -o` writes every product's vars into one image at the first's settings
    _products_stage(stage)
    r, problems = load(stage, delegate, single_image=True)
    assert len(r.renders) == 1 and [a for a, _ in r.bindings(every_product=True)] == [
        "color", "depth"]
    assert floats(delegate.value("/Render/S", "resolution")).tolist() == [40, 20]
    assert sorted((p.prim, p.attribute) for p in problems) == [
        ("/Render/Other", "camera"), ("/Render/Other", "resolution")]


def test_command_line_overrides_do_not_split_products(stage, delegate):
    # products that differ only in what a flag overrides for all of them render together
    camera(stage, "/CamA")
    s = settings(stage, "/Render/S", cam="/CamA")
    second = UsdRender.Product.Define(stage, "/Render/P2")
    second.GetPrim().CreateAttribute("tide:samples", Sdf.ValueTypeNames.Int).Set(9)
    s.GetProductsRel().AddTarget("/Render/P2")
    assert len(load(stage, delegate)[0].renders) == 2
    assert len(load(stage, type(delegate)(), spp=3)[0].renders) == 1


def test_render_pass_binds_buffers(stage, delegate):
    camera(stage)
    settings(stage, vars_=("color", "normal", "tide:diffuse"))
    r, _ = load(stage, delegate)
    rp = r.render_pass()
    cam, bindings, sp = rp.executed[0]
    # the camera is the settings sprim's (the reader sends it there), so that an edit of the
    # settings' camera reaches the running pass
    assert cam == "" and sp == "/Render/Settings"
    assert delegate.value(sp, "camera") == ("path", "/Cam")
    assert [a for a, _ in bindings] == ["color", "normal", "tide:diffuse"]
    assert delegate.value(bindings[1][1], "format") == ("token", "float3")


def test_retargeting_the_settings_camera_reaches_the_delegate(stage, delegate):
    camera(stage)
    camera(stage, "/Cam2", pos=(0, 1, 0))
    st = settings(stage)
    r, _ = load(stage, delegate)
    r.render_pass()
    st.GetCameraRel().SetTargets(["/Cam2"])
    r.update()
    assert r.camera_path == "/Cam2"
    assert delegate.value("/Render/Settings", "camera") == ("path", "/Cam2")


def test_no_settings_prim_uses_defaults_and_first_camera(stage, delegate):
    camera(stage, "/Z/Cam")
    r, problems = load(stage, delegate)
    assert problems == [] and r.camera_path == "/Z/Cam"
    assert delegate.value(r.settings_path, "tide:samples") == 64
    assert delegate.value(r.settings_path, "tide:integrator") == ("token", "caustics")


def test_composition_references_and_variants(stage, delegate, tmp_path):
    asset = Usd.Stage.CreateNew(str(tmp_path / "asset.usda"))
    root = UsdGeom.Xform.Define(asset, "/Asset")
    vs = root.GetPrim().GetVariantSets().AddVariantSet("shape")
    for name, t in (("ball", UsdGeom.Sphere), ("box", UsdGeom.Cube)):
        vs.AddVariant(name)
        vs.SetVariantSelection(name)
        with vs.GetVariantEditContext():
            t.Define(asset, "/Asset/Geo")
    asset.SetDefaultPrim(root.GetPrim())
    asset.GetRootLayer().Save()
    camera(stage)
    p = stage.DefinePrim("/Ref")
    p.GetReferences().AddReference(str(tmp_path / "asset.usda"))
    p.GetVariantSets().GetVariantSet("shape").SetVariantSelection("ball")
    load(stage, delegate)
    assert delegate.prims["/Ref/Geo"] == "sphere"


def test_a_files_only_render_leaves_the_other_aovs_buffers_unfilled(stage, delegate):
    """`files_only` (as `tide render` reads): the buffers of AOVs other than colour are told
    not to publish (their AOVs go to files from the film); by default every buffer publishes."""
    camera(stage)
    settings(stage, vars_=("color", "depth", "tide:diffuse"))
    for files_only in (True, False):
        d = fake.RenderDelegate()
        r, problems = load(stage, d, files_only=files_only)
        assert problems == []
        told = {aov: d.value(buf, "tide:publish") for aov, buf in r.bindings()}
        if files_only:
            assert told == {"color": None, "depth": False, "tide:diffuse": False}
        else:
            assert set(told.values()) == {None}
