"""Edit and resync: after an edit through usd-core, Reader.update() re-sets only the affected
prims, the delegate syncs only those, and a running pass restarts."""
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade

from conftest import bind, camera, load, matrix, preview_material


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
