"""Bad input (contract section 7): each problem names the prim and the attribute, is reported
once, and the offending prim or input is dropped or replaced while the rest is read."""
import math

import numpy as np
import pytest
from pxr import Sdf, UsdGeom, UsdLux, UsdShade

from conftest import bind, camera, lambert_material, load, matrix, preview_material, render, settings
from tide import usd_reader


def _good(stage):
    camera(stage)
    UsdGeom.Sphere.Define(stage, "/Good")


def _mesh(stage, path, points, counts, indices):
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreatePointsAttr(points)
    m.CreateFaceVertexCountsAttr(counts)
    m.CreateFaceVertexIndicesAttr(indices)
    return m


TRI = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]


def _nan_points(stage):
    _mesh(stage, "/Bad", [(0, 0, 0), (float("nan"), 0, 0), (0, 1, 0)], [3], [0, 1, 2])
    return "/Bad", "points", "Bad"


def _inf_points(stage):
    p = UsdGeom.Points.Define(stage, "/Bad")
    p.CreatePointsAttr([(0, 0, math.inf)])
    return "/Bad", "points", "Bad"


def _index_out_of_range(stage):
    _mesh(stage, "/Bad", TRI, [3], [0, 1, 7])
    return "/Bad", "faceVertexIndices", "Bad"


def _short_face(stage):
    _mesh(stage, "/Bad", TRI, [2, 1], [0, 1, 2])
    return "/Bad", "faceVertexCounts", "Bad"


def _count_mismatch(stage):
    _mesh(stage, "/Bad", TRI, [3, 3], [0, 1, 2])
    return "/Bad", "faceVertexIndices", "Bad"


def _unknown_token(stage):
    m = _mesh(stage, "/Odd", TRI, [3], [0, 1, 2])
    m.GetPrim().GetAttribute("orientation").Set("sideways")
    return "/Odd", "orientation", None


def _unknown_shader(stage):
    mat = UsdShade.Material.Define(stage, "/Looks/M")
    sh = UsdShade.Shader.Define(stage, "/Looks/M/S")
    sh.CreateIdAttr("NoSuchShader")
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    bind(UsdGeom.Cube.Define(stage, "/Box").GetPrim(), mat)
    return "/Looks/M/S", "info:id", None


def _missing_texture(stage):
    mat = preview_material(stage, "/Looks/T")
    tex = UsdShade.Shader.Define(stage, "/Looks/T/Tex")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("/no/such/texture.png")
    tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    UsdShade.Shader(stage.GetPrimAtPath("/Looks/T/Surface")).GetInput(
        "diffuseColor").ConnectToSource(tex.ConnectableAPI(), "rgb")
    bind(UsdGeom.Cube.Define(stage, "/Box").GetPrim(), mat)
    return "/Looks/T/Tex", "inputs:file", None


def _unknown_purpose(stage):
    UsdGeom.Sphere.Define(stage, "/Odd").GetPrim().CreateAttribute(
        "purpose", Sdf.ValueTypeNames.Token).Set("weird")
    return "/Odd", "purpose", None


def _unknown_visibility(stage):
    UsdGeom.Sphere.Define(stage, "/Odd").GetPrim().CreateAttribute(
        "visibility", Sdf.ValueTypeNames.Token).Set("sometimes")
    return "/Odd", "visibility", None


def _zero_area_rect(stage):
    UsdLux.RectLight.Define(stage, "/Bad").CreateWidthAttr(0.0)
    return "/Bad", "inputs:width", "Bad"


def _zero_radius_disk(stage):
    UsdLux.DiskLight.Define(stage, "/Bad").CreateRadiusAttr(0.0)
    return "/Bad", "inputs:radius", "Bad"


def _zero_aperture(stage):
    camera(stage, "/BadCam").CreateHorizontalApertureAttr(0.0)
    return "/BadCam", "horizontalAperture", None


def _unknown_integrator(stage):
    settings(stage, integrator="bogus")
    return "/Render/Settings", "tide:integrator", None


def _bad_proto_index(stage):
    inst = UsdGeom.PointInstancer.Define(stage, "/Bad")
    UsdGeom.Sphere.Define(stage, "/Bad/P")
    inst.CreatePrototypesRel().SetTargets(["/Bad/P"])
    inst.CreateProtoIndicesAttr([0, 3])
    inst.CreatePositionsAttr([(0, 0, 0), (1, 0, 0)])
    return "/Bad", "protoIndices", None


def _missing_material(stage):
    s = UsdGeom.Sphere.Define(stage, "/Orphan")
    UsdShade.MaterialBindingAPI.Apply(s.GetPrim())
    s.GetPrim().CreateRelationship("material:binding").SetTargets(["/Looks/Nothing"])
    return "/Orphan", "material:binding", None


def _missing_dome_texture(stage):
    UsdLux.DomeLight.Define(stage, "/Dome").CreateTextureFileAttr("/no/sky.exr")
    return "/Dome", "inputs:texture:file", None


def _unknown_aov(stage):
    settings(stage, vars_=("color", "notAnAov"))
    return "/Render/Settings_Var1", "sourceName", None


def _negative_radius(stage):
    UsdGeom.Sphere.Define(stage, "/Neg").CreateRadiusAttr(-1.0)
    return "/Neg", "radius", None


def _missing_vdb(stage):
    from pxr import UsdVol
    vol = UsdVol.Volume.Define(stage, "/Cloud")
    field = UsdVol.OpenVDBAsset.Define(stage, "/Cloud/density")
    field.CreateFilePathAttr("/no/such/cloud.vdb")
    field.CreateFieldNameAttr("density")
    vol.CreateFieldRelationship("density", field.GetPath())
    return "/Cloud/density", "filePath", None


def _mistyped(stage, path, name, type_name, value):
    """An attribute authored with another type than its schema declares (USD's API refuses
    that; a layer written by another tool may hold it)."""
    spec = Sdf.AttributeSpec(stage.GetRootLayer().GetPrimAtPath(path), name, type_name)
    spec.default = value


def _mistyped_radius(stage):
    UsdGeom.Sphere.Define(stage, "/Odd")
    _mistyped(stage, "/Odd", "radius", Sdf.ValueTypeNames.String, "big")
    return "/Odd", "radius", None


def _mistyped_points(stage):
    m = _mesh(stage, "/Bad", TRI, [3], [0, 1, 2])
    m.GetPrim().RemoveProperty("points")
    _mistyped(stage, "/Bad", "points", Sdf.ValueTypeNames.FloatArray, [0.0, 1.0, 2.0, 3.0])
    return "/Bad", "points", "Bad"


def _mistyped_xform_op(stage):
    g = UsdGeom.Xform.Define(stage, "/Moved")
    g.GetPrim().CreateAttribute("xformOpOrder", Sdf.ValueTypeNames.TokenArray).Set(
        ["xformOp:translate"])
    _mistyped(stage, "/Moved", "xformOp:translate", Sdf.ValueTypeNames.String, "left")
    UsdGeom.Sphere.Define(stage, "/Moved/Ball")
    # the op is skipped, as USD skips it (see test_an_op_usd_skips_is_skipped_and_named)
    return "/Moved", "xformOp:translate", None


def _mistyped_light(stage):
    UsdLux.SphereLight.Define(stage, "/Lamp")
    _mistyped(stage, "/Lamp", "inputs:intensity", Sdf.ValueTypeNames.String, "bright")
    return "/Lamp", "inputs:intensity", None


def _mistyped_tide_attribute(stage):
    UsdGeom.Sphere.Define(stage, "/Odd").GetPrim().ApplyAPI("TideCausticsAPI")
    _mistyped(stage, "/Odd", "tide:caustics:receiver", Sdf.ValueTypeNames.Int, 7)
    return "/Odd", "tide:caustics:receiver", None


def _mistyped_schema_primvar(stage):
    p = UsdGeom.Points.Define(stage, "/Odd")
    p.CreatePointsAttr([(0, 0, -5)])
    p.GetPrim().ApplyAPI("TideBubbleAPI")
    _mistyped(stage, "/Odd", "primvars:tide:bubble:top", Sdf.ValueTypeNames.StringArray, ["high"])
    return "/Odd", "primvars:tide:bubble:top", None


def _mistyped_camera(stage):
    stage.GetRootLayer().GetPrimAtPath("/Cam").RemoveProperty(
        stage.GetRootLayer().GetPropertyAtPath("/Cam.focalLength"))
    _mistyped(stage, "/Cam", "focalLength", Sdf.ValueTypeNames.String, "long")
    return "/Cam", "focalLength", None


def _mistyped_setting(stage):
    settings(stage)
    _mistyped(stage, "/Render/Settings", "tide:samples", Sdf.ValueTypeNames.String, "many")
    return "/Render/Settings", "tide:samples", None


CASES = [_missing_vdb, _nan_points, _inf_points, _index_out_of_range, _short_face, _count_mismatch,
         _unknown_token, _unknown_shader, _missing_texture, _zero_area_rect, _zero_radius_disk,
         _zero_aperture, _unknown_integrator, _bad_proto_index, _missing_material,
         _missing_dome_texture, _unknown_aov, _negative_radius, _mistyped_radius,
         _mistyped_points, _mistyped_xform_op, _mistyped_light, _mistyped_setting,
         _mistyped_tide_attribute, _mistyped_schema_primvar, _mistyped_camera,
         _unknown_purpose, _unknown_visibility]


@pytest.mark.parametrize("case", CASES, ids=[c.__name__.strip("_") for c in CASES])
def test_problem_named_once_rest_renders(stage, delegate, case):
    _good(stage)
    prim, attribute, dropped = case(stage)
    reader, problems = load(stage, delegate)
    keys = [(p.prim, p.attribute) for p in problems]
    assert (prim, attribute) in keys, problems
    assert len(keys) == len(set(keys))                       # each problem once
    assert all(str(p).startswith(p.prim + ": " + p.attribute + ": ") for p in problems)
    assert delegate.prims["/Good"] == "sphere"                # the rest is read
    if dropped:
        assert "/" + dropped not in delegate.prims
    # a later update that touches the same prim does not report it again
    target = stage.GetPrimAtPath(prim) or stage.GetPrimAtPath("/Good")
    target.SetCustomDataByKey("touched", 1)
    assert [p for p in reader.update() if (p.prim, p.attribute) == (prim, attribute)] == []
    assert len(reader.problems) == len({(p.prim, p.attribute) for p in reader.problems})


@pytest.mark.parametrize("bad", ["bogus", "xformOp:bogus", "xformOp:translate:none", "size",
                                 "xformOp:translate:text"])
def test_an_op_usd_skips_is_skipped_and_named(stage, delegate, bad):
    """An `xformOpOrder` entry naming no xform op of its prim (no attribute, an unknown op type,
    an attribute that is no op), or an op whose value does not fit it: USD's transform
    computation skips it with a warning (its Python binding raises), and so does the reader,
    naming it. The prim, its moving sibling op and its child are placed as a prim holding the
    other ops alone is (by USD), over the shutter (the child: Xform prims are not sent)."""
    from pxr import Gf
    camera(stage, **{"shutter__open": 0.0, "shutter__close": 1.0})
    settings(stage)
    UsdGeom.Sphere.Define(stage, "/Good")

    def placed(path, order):
        x = UsdGeom.Xform.Define(stage, path)
        t = x.AddTranslateOp()
        t.Set(Gf.Vec3d(1, 2, 3), 0)
        t.Set(Gf.Vec3d(3, 2, 3), 1)
        x.AddRotateYOp().Set(30.0)
        x.AddScaleOp().Set(Gf.Vec3f(2, 1, 1))
        x.GetPrim().CreateAttribute("size", Sdf.ValueTypeNames.Double).Set(2.0)
        x.GetPrim().CreateAttribute("xformOp:translate:text", Sdf.ValueTypeNames.String).Set("left")
        x.GetPrim().GetAttribute("xformOpOrder").Set(order)
        UsdGeom.Sphere.Define(stage, path + "/Ball").AddTranslateOp().Set(Gf.Vec3d(0, 0, -1))
        return x

    good = ["xformOp:translate", "xformOp:rotateY", "xformOp:scale"]
    placed("/Bad", good[:1] + [bad] + good[1:])
    twin = placed("/Twin", good)
    reader, problems = load(stage, delegate, frame=0)
    where = (("/Bad", "xformOp:translate:text") if bad == "xformOp:translate:text" else ("/Bad", "xformOpOrder"))
    named = [p for p in problems if (p.prim, p.attribute) == where]
    if bad == "xformOp:translate:none":
        # an op of a known type without its attribute: usd-core skips it itself (with a
        # warning on stderr), so the reader never sees it
        assert named == [], problems
    else:
        assert len(named) == 1 and named[0].message.endswith("; the op is skipped, as USD skips it"), problems
        assert "'%s'" % bad in named[0].message or bad == "xformOp:translate:text", named[0].message
    assert not [p for p in problems if p.prim.startswith("/Twin")], problems
    sent = delegate.samples("/Bad/Ball", "transform")
    want = delegate.samples("/Twin/Ball", "transform")
    assert sorted(sent) == sorted(want) and len(sent) >= 2, (sent, want)
    for t in sent:
        usd = UsdGeom.Xformable(twin.GetPrim().GetChild("Ball")).ComputeLocalToWorldTransform(t)
        assert np.allclose(matrix(sent[t]), matrix(want[t])) and \
            np.allclose(matrix(sent[t]), np.asarray(usd), atol=1e-6), t


def test_replaced_by_default(stage, delegate):
    _good(stage)
    _unknown_token(stage)
    _zero_aperture(stage)
    _unknown_integrator(stage)
    load(stage, delegate)
    assert delegate.value("/Odd", "orientation") == ("token", "rightHanded")
    assert delegate.value("/BadCam", "horizontalAperture") == pytest.approx(20.955)
    assert delegate.value("/Render/Settings", "tide:integrator") == ("token", "caustics")


@pytest.mark.parametrize("case", [_unknown_purpose, _unknown_visibility])
def test_an_unknown_purpose_or_visibility_reads_as_the_default(stage, delegate, case):
    _good(stage)
    case(stage)
    load(stage, delegate)
    assert delegate.prims.get("/Odd") == "sphere"


def test_mistyped_values_are_replaced_by_their_defaults(stage, delegate):
    _good(stage)
    _mistyped_radius(stage)
    _mistyped_light(stage)
    _mistyped_setting(stage)
    reader, _ = load(stage, delegate)
    assert delegate.value("/Odd", "radius") == 1.0
    assert delegate.value("/Lamp", "inputs:intensity") == 1.0
    assert delegate.value("/Render/Settings", "tide:samples") == 64
    assert reader.sample_target == 64


def test_a_camera_with_a_mistyped_lens_keeps_rendering_with_the_default(stage, delegate):
    _good(stage)
    _mistyped_camera(stage)
    reader, _ = load(stage, delegate)
    assert reader.camera_path == "/Cam"
    assert delegate.value("/Cam", "focalLength") == 50.0


def test_a_mistyped_tide_attribute_is_not_sent(stage, delegate):
    _good(stage)
    _mistyped_tide_attribute(stage)
    load(stage, delegate)
    assert delegate.prims["/Odd"] == "sphere"
    assert delegate.value("/Odd", "tide:caustics:receiver") is None    # its default, true


def test_a_fault_the_reader_and_the_delegate_both_find_is_reported_once(renderer, stage):
    # the delegate names a material's node input as (material, "/node.input"): the reader
    # reads that as the node's prim and input, as it names them itself
    from conftest import load
    _good(stage)
    _unknown_shader(stage)
    _, problems = load(stage, renderer.RenderDelegate())
    ids = [p for p in problems if p.attribute == "info:id"]
    assert [(p.prim, p.attribute) for p in ids] == [("/Looks/M/S", "info:id")], problems


def test_a_primvar_the_delegate_rejects_is_named_as_authored(renderer, stage):
    from conftest import load
    _good(stage)
    m = _mesh(stage, "/Quad", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [4], [0, 1, 2, 3])
    UsdGeom.PrimvarsAPI(m.GetPrim()).CreatePrimvar(
        "displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.vertex).Set([(1, 0, 0)] * 2)
    _, problems = load(stage, renderer.RenderDelegate())
    assert ("/Quad", "primvars:displayColor") in [(p.prim, p.attribute) for p in problems], problems


def test_delegate_problems_are_merged_once(stage, delegate):
    _good(stage)
    reader, _ = load(stage, delegate)
    delegate._problems.append(("/Good", "radius", "a problem found by the core"))
    delegate._problems.append(("/Good", "radius", "a problem found by the core"))
    UsdGeom.Sphere(stage.GetPrimAtPath("/Good")).GetRadiusAttr().Set(2.0)
    new = reader.update()
    assert [(p.prim, p.attribute) for p in new] == [("/Good", "radius")]


def test_every_usdgeom_gprim_type_is_read_or_reported(stage, delegate):
    # UsdGeom's own gprims are all read; any other concrete gprim type usd-core defines (e.g.
    # gaussian-splat particle fields in recent versions) is reported by name, never silently
    # dropped
    from pxr import Tf, Usd
    from tide import usd_reader
    registry = Usd.SchemaRegistry()
    concrete = {registry.GetSchemaTypeName(t) for t in Tf.Type.FindByName("UsdGeomGprim")
                .GetAllDerivedTypes() if registry.IsConcrete(t)}
    geom = {"Mesh", "TetMesh", "BasisCurves", "NurbsCurves", "HermiteCurves", "NurbsPatch",
            "Points", "Sphere", "Cube", "Cylinder", "Cone", "Capsule", "Plane", "Volume"}
    assert geom <= concrete and geom <= set(usd_reader.GPRIMS)
    other = sorted(concrete - set(usd_reader.GPRIMS))
    _good(stage)
    for name in other:
        stage.DefinePrim("/Other_" + name, name)
    _, problems = load(stage, delegate)
    reported = {p.prim for p in problems if p.attribute == "type"}
    assert reported == {"/Other_" + n for n in other}


def test_unknown_gprim_type_is_reported(stage, delegate, monkeypatch):
    from tide import usd_reader
    monkeypatch.setattr(usd_reader, "GPRIMS", {k: v for k, v in usd_reader.GPRIMS.items()
                                              if k != "NurbsPatch"})
    _good(stage)
    UsdGeom.NurbsPatch.Define(stage, "/Patch")
    _, problems = load(stage, delegate)
    assert ("/Patch", "type") in [(p.prim, p.attribute) for p in problems]
    assert "/Patch" not in delegate.prims


def test_no_camera(stage, delegate):
    # reported, and seen through a default camera (test_default_view.py)
    UsdGeom.Sphere.Define(stage, "/S")
    reader, problems = load(stage, delegate)
    assert reader.camera_path == usd_reader.DEFAULT_CAMERA_PATH
    assert [p.attribute for p in problems] == ["camera"]
    reader.render_pass()


def test_bad_camera_override(stage, delegate):
    _good(stage)
    with pytest.raises(LookupError):
        load(stage, delegate, camera="/Nope")
    with pytest.raises(LookupError):
        load(stage, delegate, settings="/Nope")



def test_value_rejected_by_the_delegate(stage, delegate):
    _good(stage)
    UsdGeom.Sphere.Define(stage, "/Other").CreateRadiusAttr(3.0)
    real_set = delegate.set

    def picky_set(path, key, value, time=None):
        if path == "/Other" and key == "radius":
            raise TypeError("radius refused")
        return real_set(path, key, value, time)

    delegate.set = picky_set
    _, problems = load(stage, delegate)
    assert [(p.prim, p.attribute) for p in problems] == [("/Other", "radius")]
    assert "radius refused" in problems[0].message
    assert delegate.prims["/Other"] == "sphere" and delegate.value("/Good", "radius") == 1.0


def test_a_portal_of_zero_area_is_reported_and_the_dome_still_lights(renderer, stage):
    """A portal of zero width is reported on its width; the dome lights the scene as it would
    with no portal: a diffuse panel under it shows its albedo."""
    from pxr import UsdLux
    from conftest import near, panel, top_camera, white_dome
    top_camera(stage)
    white_dome(stage)
    bind(panel(stage, "/Panel").GetPrim(), lambert_material(stage, "/Looks/Grey", (0.5, 0.5, 0.5)))
    UsdLux.PortalLight.Define(stage, "/Window").CreateWidthAttr(0.0)
    settings(stage, res=(8, 8), samples=16, integrator="path", maxDepth=1)
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3]
    assert [(p.prim, p.attribute) for p in problems] == [("/Window", "width")], problems
    ok, why = near(img, (0.5, 0.5, 0.5))
    assert ok, why


def test_bad_stage_metadata_without_a_settings_prim_is_named_on_the_stage_root(renderer, stage):
    """metersPerUnit -2 and timeCodesPerSecond 0 on a stage with no RenderSettings: the
    problems name the stage's root (where its metadata lives), not a prim it does not have,
    and the scene renders."""
    _good(stage)
    UsdGeom.SetStageMetersPerUnit(stage, -2.0)
    stage.SetTimeCodesPerSecond(0.0)
    problems = []
    img = render(renderer, stage, problems, spp=1, width=16)["color"]
    got = sorted((p.prim, p.attribute) for p in problems)
    assert got == [("/", "metersPerUnit"), ("/", "timeCodesPerSecond")], problems
    assert img.shape[0] > 0


def test_sublayers_references_and_payloads_that_cannot_be_opened_are_named(tmp_path, delegate):
    """A sublayer, a reference and a payload whose files are missing are named on the stage
    root (subLayers) and on the prims that bring them in (references, payload), once each; the
    rest renders. Writing the referenced file and referencing it again brings the prim in and
    names nothing new."""
    from pxr import Usd
    root = Sdf.Layer.CreateNew(str(tmp_path / "shot.usda"))
    root.subLayerPaths.append("./lighting_v2.usda")
    stage = Usd.Stage.Open(root)
    _good(stage)
    boat = stage.DefinePrim("/Boat")
    boat.GetReferences().AddReference("./boat.usda")
    stage.DefinePrim("/Spray").GetPayloads().AddPayload("./spray.usdc")
    reader, problems = load(stage, delegate)
    keys = sorted((p.prim, p.attribute) for p in problems)
    assert keys == [("/", "subLayers"), ("/Boat", "references"), ("/Spray", "payload")], problems
    assert all("boat.usda" in p.message for p in problems if p.prim == "/Boat")
    assert delegate.prims["/Good"] == "sphere"
    # the asset arrives
    asset = Usd.Stage.CreateNew(str(tmp_path / "boat.usda"))
    UsdGeom.Sphere.Define(asset, "/Hull")
    asset.SetDefaultPrim(asset.GetPrimAtPath("/Hull"))
    asset.Save()
    boat.GetReferences().ClearReferences()
    boat.GetReferences().AddReference("./boat.usda")
    assert reader.update() == []
    assert delegate.prims["/Boat"] == "sphere"
