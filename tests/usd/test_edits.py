"""Edit and resync: after an edit through usd-core, Reader.update() re-sets only the affected
prims, the delegate syncs only those, and a running pass restarts."""
import os

from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdRender, UsdShade, UsdVol

from conftest import bind, camera, floats, load, matrix, preview_material


def _scene(stage):
    camera(stage)
    UsdGeom.Xform.Define(stage, "/World")
    for name in ("A", "B", "C"):
        UsdGeom.Sphere.Define(stage, "/World/" + name).AddTranslateOp().Set(Gf.Vec3d(0, 0, -5))
    UsdLux.DistantLight.Define(stage, "/Sun")
    red = preview_material(stage, "/Looks/Red", (1, 0, 0))
    preview_material(stage, "/Looks/Blue", (0, 0, 1))
    bind(stage.GetPrimAtPath("/World/A"), red)
    bind(stage.GetPrimAtPath("/World/B"), red)


def test_move_a_prim(stage, delegate):
    _scene(stage)
    reader, _ = load(stage, delegate)
    rp = reader.render_pass()
    UsdGeom.Xformable(stage.GetPrimAtPath("/World/B")).GetOrderedXformOps()[0].Set(
        Gf.Vec3d(1, 2, -5))
    reader.update()
    assert delegate.last_synced() == ["/World/B"]
    assert matrix(delegate.value("/World/B", "transform"))[3, :3].tolist() == [1, 2, -5]
    assert rp.restarts == 1


def test_moving_a_parent_resyncs_its_children_only(stage, delegate):
    _scene(stage)
    reader, _ = load(stage, delegate)
    UsdGeom.Xformable(stage.GetPrimAtPath("/World")).AddTranslateOp().Set(Gf.Vec3d(0, 1, 0))
    reader.update()
    assert delegate.last_synced() == ["/World/A", "/World/B", "/World/C"]


def test_change_a_light(stage, delegate):
    _scene(stage)
    reader, _ = load(stage, delegate)
    UsdLux.DistantLight(stage.GetPrimAtPath("/Sun")).GetIntensityAttr().Set(7.0)
    reader.update()
    assert delegate.last_synced() == ["/Sun"]
    assert delegate.value("/Sun", "inputs:intensity") == 7.0
    sets = [c for c in delegate.calls if c[0] == "set"]
    assert sets[-1] == ("set", "/Sun", "inputs:intensity")   # only the changed attribute


def test_rebind_a_material(stage, delegate):
    _scene(stage)
    reader, _ = load(stage, delegate)
    blue = UsdShade.Material(stage.GetPrimAtPath("/Looks/Blue"))
    UsdShade.MaterialBindingAPI(stage.GetPrimAtPath("/World/A")).Bind(blue)
    reader.update()
    assert delegate.last_synced() == ["/Looks/Blue", "/World/A"]
    assert delegate.value("/World/A", "material") == ("path", "/Looks/Blue")


def test_edit_a_shader_input(stage, delegate):
    _scene(stage)
    reader, _ = load(stage, delegate)
    sh = UsdShade.Shader(stage.GetPrimAtPath("/Looks/Red/Surface"))
    sh.GetInput("diffuseColor").Set(Gf.Vec3f(0.5, 0, 0))
    reader.update()
    assert delegate.last_synced() == ["/Looks/Red"]


def test_deleting_or_deactivating_a_material_or_its_shader_reaches_the_delegate(stage, delegate):
    # removed, deactivated, or left without its surface shader: the delegate no longer holds
    # the material as it was (its gprims then take the default, with a problem)
    for edit in ("delete", "deactivate", "delete shader"):
        stage.RemovePrim("/Looks")
        stage.RemovePrim("/World")
        _scene(stage)
        reader, _ = load(stage, delegate)
        assert "/Looks/Red" in delegate.prims
        if edit == "delete":
            stage.RemovePrim("/Looks/Red")
        elif edit == "deactivate":
            stage.GetPrimAtPath("/Looks/Red").SetActive(False)
        else:
            stage.RemovePrim("/Looks/Red/Surface")
        reader.update()
        if edit == "delete shader":
            assert "/Looks/Red" in delegate.last_synced(), edit
            assert delegate.value("/Looks/Red", "surface") in (None, ("path", "")), edit
        else:
            assert "/Looks/Red" not in delegate.prims, edit
        reader.close()


def test_a_material_taken_away_and_brought_back_is_sent_again(stage, delegate):
    # deactivated, removed (its layer content then restored, as an undo does) or both: once it
    # is back, the delegate holds it again as first sent, for the prims still bound to it
    for edit in ("deactivate", "restore layer"):
        stage.RemovePrim("/Looks")
        stage.RemovePrim("/World")
        _scene(stage)
        reader, _ = load(stage, delegate)
        first = dict(delegate.values["/Looks/Red"])
        saved = Sdf.Layer.CreateAnonymous(".usda")
        saved.TransferContent(stage.GetRootLayer())
        if edit == "deactivate":
            stage.GetPrimAtPath("/Looks/Red").SetActive(False)
        else:
            stage.RemovePrim("/Looks")
        reader.update()
        assert "/Looks/Red" not in delegate.prims, edit
        if edit == "deactivate":
            stage.GetPrimAtPath("/Looks/Red").SetActive(True)
        else:
            stage.GetRootLayer().TransferContent(saved)
        reader.update()
        assert delegate.prims.get("/Looks/Red") == "material", edit
        assert delegate.values["/Looks/Red"] == first, edit
        assert delegate.value("/World/A", "material") == ("path", "/Looks/Red"), edit
        reader.close()


def test_a_shutter_edit_samples_every_prim_anew(stage, delegate):
    # motion blur off, then the shutter opened by a live edit: a moving prim the edit did not
    # touch gets its transform samples over the new shutter
    _scene(stage)
    op = UsdGeom.Xformable(stage.GetPrimAtPath("/World/C")).GetOrderedXformOps()[0]
    op.Set(Gf.Vec3d(0, 0, -5), 0)
    op.Set(Gf.Vec3d(1, 0, -5), 1)
    reader, _ = load(stage, delegate)
    assert sorted(delegate.samples("/World/C", "transform")) == [None]
    stage.GetPrimAtPath("/Cam").GetAttribute("shutter:close").Set(1.0)
    reader.update()
    assert sorted(delegate.samples("/World/C", "transform"), key=str) == [0.0, 1.0]


def test_wet_a_material(stage, delegate):
    """Applying TideWetAPI to a material and editing its amount re-syncs that material only."""
    _scene(stage)
    reader, _ = load(stage, delegate)
    red = stage.GetPrimAtPath("/Looks/Red")
    red.ApplyAPI("TideWetAPI")
    reader.update()
    assert delegate.last_synced() == ["/Looks/Red"]
    assert delegate.value("/Looks/Red", "tide:wet:amount") == 0.0
    red.GetAttribute("tide:wet:amount").Set(0.75)
    reader.update()
    assert delegate.last_synced() == ["/Looks/Red"]
    assert delegate.value("/Looks/Red", "tide:wet:amount") == 0.75


def test_add_and_remove_prims(stage, delegate):
    _scene(stage)
    reader, _ = load(stage, delegate)
    UsdGeom.Cube.Define(stage, "/World/New")
    reader.update()
    assert delegate.last_synced() == ["/World/New"]
    assert delegate.prims["/World/New"] == "cube"
    stage.RemovePrim("/World/C")
    reader.update()
    assert "/World/C" not in delegate.prims
    assert delegate.last_synced() == ["/World/C"]
    UsdGeom.Imageable(stage.GetPrimAtPath("/World/A")).MakeInvisible()
    reader.update()
    assert "/World/A" not in delegate.prims


def test_no_edit_no_sync(stage, delegate):
    _scene(stage)
    reader, _ = load(stage, delegate)
    rp = reader.render_pass()
    commits = delegate.commits
    assert reader.update() == []
    assert delegate.commits == commits and rp.restarts == 0


def test_edit_to_same_value_syncs_nothing(stage, delegate):
    _scene(stage)
    reader, _ = load(stage, delegate)
    rp = reader.render_pass()
    attr = stage.GetPrimAtPath("/World/C").GetAttribute("radius")
    attr.Set(1.0)   # the fallback value, now authored: nothing the delegate sees changes
    reader.update()
    assert delegate.last_synced() == [] and rp.restarts == 0


def test_instancing_edit_resyncs_instances(stage, delegate):
    camera(stage)
    proto = stage.CreateClassPrim("/Proto")
    UsdGeom.Sphere.Define(stage, "/Proto/Ball")
    for i in range(2):
        p = stage.DefinePrim("/I%d" % i, "Xform")
        p.GetInherits().AddInherit(proto.GetPath())
        p.SetInstanceable(True)
    reader, _ = load(stage, delegate)
    sphere = delegate.of_type("sphere")[0]
    UsdGeom.Xformable(stage.GetPrimAtPath("/I1")).AddTranslateOp().Set(Gf.Vec3d(3, 0, 0))
    reader.update()
    assert delegate.last_synced() == [sphere]
    assert stage.GetPrimAtPath("/I1").GetAttribute("xformOp:translate").GetTypeName() == \
        Sdf.ValueTypeNames.Double3


def test_widening_included_purposes_reads_the_prims_now_included(stage, delegate):
    _scene(stage)
    UsdGeom.Sphere.Define(stage, "/World/Proxy").CreatePurposeAttr(UsdGeom.Tokens.proxy)
    st = UsdRender.Settings.Define(stage, "/Render/S")
    st.CreateIncludedPurposesAttr(["default", "render"])
    stage.SetMetadata("renderSettingsPrimPath", "/Render/S")
    reader, _ = load(stage, delegate)
    assert "/World/Proxy" not in delegate.prims
    st.GetIncludedPurposesAttr().Set(["default", "render", "proxy"])
    reader.update()
    assert delegate.prims.get("/World/Proxy") == "sphere"


def test_an_edit_to_a_shader_outside_its_material_reads_the_material_again(stage, delegate):
    _scene(stage)
    mat = UsdShade.Material.Define(stage, "/Looks/T")
    sh = UsdShade.Shader.Define(stage, "/Looks/T/S")
    sh.CreateIdAttr("UsdPreviewSurface")
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    outside = UsdShade.Shader.Define(stage, "/Graphs/Glow")
    outside.CreateIdAttr("UsdPrimvarReader_float3")
    outside.CreateInput("fallback", Sdf.ValueTypeNames.Float3).Set(Gf.Vec3f(0.1, 0.2, 0.3))
    sh.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        outside.CreateOutput("result", Sdf.ValueTypeNames.Float3))
    bind(stage.GetPrimAtPath("/World/C"), mat)
    reader, _ = load(stage, delegate)
    outside.GetInput("fallback").Set(Gf.Vec3f(0.5, 0.5, 0.5))
    reader.update()
    assert delegate.last_synced() == ["/Looks/T"]
    assert floats(delegate.value("/Looks/T", "/Graphs/Glow.inputs:fallback")).tolist() == [[0.5, 0.5, 0.5]]


def test_an_edit_to_a_point_instancer_prototype_outside_it_places_it_anew(stage, delegate):
    camera(stage)
    protos = UsdGeom.Scope.Define(stage, "/Protos")
    protos.MakeInvisible()
    ball = UsdGeom.Sphere.Define(stage, "/Protos/Ball")
    inst = UsdGeom.PointInstancer.Define(stage, "/World/PI")
    inst.CreatePrototypesRel().SetTargets([ball.GetPath()])
    inst.CreateProtoIndicesAttr([0, 0])
    inst.CreatePositionsAttr([(0, 0, -5), (2, 0, -5)])
    reader, _ = load(stage, delegate)
    (proto,) = [p for p, t in delegate.prims.items() if t == "sphere"]
    ball.CreateRadiusAttr(0.25)
    reader.update()
    assert delegate.value(proto, "radius") == 0.25


def test_an_edit_to_a_volumes_field_prim_reads_the_volume_again(stage, delegate, tmp_path):
    camera(stage)
    vdbs = []
    for name in ("a.vdb", "b.vdb"):
        vdbs.append(str(tmp_path / name))
        open(vdbs[-1], "wb").close()
    vol = UsdVol.Volume.Define(stage, "/Cloud")
    field = UsdVol.OpenVDBAsset.Define(stage, "/Cloud/density")
    field.CreateFilePathAttr(vdbs[0])
    field.CreateFieldNameAttr("density")
    vol.CreateFieldRelationship("density", field.GetPath())
    reader, _ = load(stage, delegate)
    field.GetFilePathAttr().Set(vdbs[1])
    reader.update()
    assert delegate.last_synced() == ["/Cloud"]
    assert delegate.value("/Cloud", "field:density")[1] == vdbs[1]


def test_a_texture_rewritten_on_disk_is_read_again(stage, delegate, tmp_path):
    _scene(stage)
    tex_file = str(tmp_path / "t.png")
    with open(tex_file, "wb") as f:
        f.write(b"one")
    mat = preview_material(stage, "/Looks/T")
    tex = UsdShade.Shader.Define(stage, "/Looks/T/Tex")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(tex_file)
    UsdShade.Shader(stage.GetPrimAtPath("/Looks/T/Surface")).CreateInput(
        "diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3))
    bind(stage.GetPrimAtPath("/World/C"), mat)
    reader, _ = load(stage, delegate)
    reads = lambda: [c for c in delegate.calls if c == ("load_texture", tex_file)]
    assert len(reads()) == 1
    reader.update()
    assert len(reads()) == 1, "unchanged: not read again"
    st = os.stat(tex_file)
    with open(tex_file, "wb") as f:
        f.write(b"two")
    os.utime(tex_file, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    reader.update()
    assert len(reads()) == 2


def test_set_frame_reads_the_stage_at_another_time_and_start_time_code_moves_the_frame(stage, delegate):
    _scene(stage)
    op = UsdGeom.Xformable(stage.GetPrimAtPath("/World/A")).GetOrderedXformOps()[0]
    op.Set(Gf.Vec3d(0, 0, -5), 1)
    op.Set(Gf.Vec3d(9, 0, -5), 10)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(10)
    reader, _ = load(stage, delegate)
    x = lambda: matrix(delegate.value("/World/A", "transform"))[3, 0]
    assert x() == 0.0
    stage.SetStartTimeCode(10)
    reader.update()
    assert reader.frame == 10.0 and x() == 9.0
    reader.set_frame(4)
    assert x() == 3.0
    assert delegate.last_synced() == ["/World/A"], "only what differs at the new time"


def test_prim_ids_are_the_same_after_edits_as_on_a_fresh_load(stage, delegate):
    """A prim's primId does not depend on what else the stage holds or held: after /World/A is
    deactivated and /World/AA (read before B) is added, B keeps its id, and a fresh load of the
    edited stage gives every prim the id the edited session gives it (the frames of a
    sequence whose prims come and go keep their ids too)."""
    _scene(stage)
    reader, _ = load(stage, delegate)
    ids = lambda d: {p: d.value(p, "primId") for p, kind in d.prims.items()
                     if p.startswith("/World/")}
    before = ids(delegate)
    assert len(set(before.values())) == len(before) == 3, before
    stage.GetPrimAtPath("/World/A").SetActive(False)
    UsdGeom.Cube.Define(stage, "/World/AA")
    reader.update()
    after = ids(delegate)
    assert after["/World/B"] == before["/World/B"] and after["/World/C"] == before["/World/C"]
    fresh = type(delegate)()
    load(stage, fresh)
    assert ids(fresh) == after, (ids(fresh), after)


def test_large_arrays_are_kept_as_digests_and_still_compared(stage, delegate):
    # a mesh whose points and indices exceed the digest size: the reader keeps digests of them,
    # yet an edit of one point is sent, and edits elsewhere send none of the large arrays again
    import numpy as np
    from pxr import Vt
    from tide import usd_reader
    _scene(stage)
    n = 80
    xs, ys = np.meshgrid(np.arange(n, dtype=np.float32), np.arange(n, dtype=np.float32))
    pts = np.stack([xs.ravel(), ys.ravel(), np.full(n * n, -9.0, np.float32)], axis=1)
    quads = [(j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i)
             for j in range(n - 1) for i in range(n - 1)]
    mesh = UsdGeom.Mesh.Define(stage, "/World/Grid")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts))
    mesh.CreateFaceVertexCountsAttr([4] * len(quads))
    mesh.CreateFaceVertexIndicesAttr([k for q in quads for k in q])
    mesh.AddTranslateOp().Set(Gf.Vec3d(0, 0, 0))
    reader, _ = load(stage, delegate)
    kept = reader.sent()["/World/Grid"][1]
    assert pts.nbytes >= usd_reader.DIGEST_BYTES
    assert isinstance(kept["points"][0][1][2], usd_reader._Digest)
    assert usd_reader.rows(kept["points"][0][1]) == n * n
    # the transform moves: only it is sent
    del delegate.calls[:]
    UsdGeom.Xformable(mesh).GetOrderedXformOps()[0].Set(Gf.Vec3d(1, 0, 0))
    reader.update()
    assert [c for c in delegate.calls if c[0] == "set"] == [("set", "/World/Grid", "transform")]
    # one point moves: the points are sent again, with the new point
    del delegate.calls[:]
    pts[123] = (5.0, 6.0, -8.0)
    mesh.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(pts))
    reader.update()
    assert [c for c in delegate.calls if c[0] == "set"] == [("set", "/World/Grid", "points")]
    assert floats(delegate.value("/World/Grid", "points"))[123].tolist() == [5.0, 6.0, -8.0]
    # the same points authored again: nothing is sent
    del delegate.calls[:]
    mesh.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(pts.copy()))
    reader.update()
    assert [c for c in delegate.calls if c[0] == "set"] == []
