"""UsdLux light linking end to end (contract §2): a light's lightLink collection decides which
prims it illuminates, its shadowLink collection which prims cast its shadows."""
import math

import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from conftest import bind, camera, lambert_material, load, render, settings

F, AP = 50.0, 36.0


def _grey(stage):
    return lambert_material(stage, "/Looks/Grey", (0.5, 0.5, 0.5))


def _wall(stage, path, x0, x1, z, mat):
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreatePointsAttr([(x0, -10, z), (x1, -10, z), (x1, 10, z), (x0, 10, z)])
    m.CreateFaceVertexCountsAttr([4])
    m.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    bind(m.GetPrim(), mat)
    return m


def _sun_and_dome(stage):
    """A sun shining straight down the camera's view (radiance 0.5 off an albedo of 0.5) and
    a dim white dome (0.2: radiance 0.1 off the walls)."""
    sun = UsdLux.DistantLight.Define(stage, "/Sun")
    sun.CreateIntensityAttr(math.pi)
    sun.CreateNormalizeAttr(True)
    dome = UsdLux.DomeLight.Define(stage, "/Dome")
    dome.CreateIntensityAttr(0.2)
    return sun


def _two_walls(stage):
    """Two grey walls facing the camera, left and right of the view's centre, each inside
    a group (/World/Left, /World/Right); a sun shining straight onto them (radiance 0.5 off
    an albedo of 0.5) and a dim white dome (0.2: radiance 0.1 off the walls)."""
    camera(stage, focal=F, aperture=(AP, AP))
    mat = _grey(stage)
    UsdGeom.Xform.Define(stage, "/World/Left")
    UsdGeom.Xform.Define(stage, "/World/Right")
    _wall(stage, "/World/Left/Wall", -10, -0.1, -5, mat)
    _wall(stage, "/World/Right/Wall", 0.1, 10, -5, mat)
    return _sun_and_dome(stage)


def _halves(img):
    left = img[4:28, 2:12, :3].reshape(-1, 3).mean(axis=0)
    right = img[4:28, 20:30, :3].reshape(-1, 3).mean(axis=0)
    return left, right


def test_light_link_collection_is_sent_with_its_expansion_rule(stage, delegate):
    sun = _two_walls(stage)
    coll = UsdLux.LightAPI(sun).GetLightLinkCollectionAPI()
    coll.CreateIncludesRel().AddTarget("/World/Left")
    coll.CreateIncludeRootAttr(False)
    load(stage, delegate)
    assert delegate.value("/Sun", "collection:lightLink:includes") == ("paths", ["/World/Left"])
    assert delegate.value("/Sun", "collection:lightLink:includeRoot") is False
    assert delegate.value("/Sun", "collection:lightLink:expansionRule") in ("expandPrims", ("token", "expandPrims"))
    assert delegate.value("/Dome", "collection:lightLink:includes") is None


def test_a_light_linked_to_one_prim_leaves_the_other_to_the_dome(renderer, stage):
    w = h = 32
    sun = _two_walls(stage)
    coll = UsdLux.LightAPI(sun).GetLightLinkCollectionAPI()
    # the group, not the mesh: its descendants are members (expandPrims)
    coll.CreateIncludesRel().AddTarget("/World/Left")
    coll.CreateIncludeRootAttr(False)
    settings(stage, res=(w, h), samples=32, maxDepth=2)
    left, right = _halves(render(renderer, stage)["color"])
    assert left == pytest.approx([0.6] * 3, rel=0.05), "sun and dome on the linked wall"
    assert right == pytest.approx([0.1] * 3, rel=0.05), "the dome alone on the unlinked wall"


def _link_by(stage, sun, how):
    """The sun's light link by a path expression or by another collection (membership only
    USD's query resolves); the walls it takes by usd-core's own membership query."""
    coll = UsdLux.LightAPI(sun).GetLightLinkCollectionAPI()
    coll.CreateIncludeRootAttr(False)
    if how == "expression":
        coll.CreateMembershipExpressionAttr(Sdf.PathExpression("/World/Left/Wall"))
    else:
        sets = Usd.CollectionAPI.Apply(stage.DefinePrim("/Sets"), "grp")
        sets.CreateIncludesRel().AddTarget("/World/Right")
        coll.CreateIncludesRel().AddTarget(sets.GetCollectionPath())
    query = coll.ComputeMembershipQuery()
    return [query.IsPathIncluded(Sdf.Path(p)) for p in ("/World/Left/Wall", "/World/Right/Wall")]


@pytest.mark.parametrize("how, lit", [("expression", [True, False]), ("collection", [False, True])])
def test_a_light_link_by_expression_or_by_another_collection(renderer, stage, how, lit):
    w = h = 32
    sun = _two_walls(stage)
    assert _link_by(stage, sun, how) == lit, "usd-core's membership query"
    settings(stage, res=(w, h), samples=32, maxDepth=2)
    problems = []
    halves = _halves(render(renderer, stage, problems)["color"])
    assert problems == [], problems
    for on, got in zip(lit, halves):
        assert got == pytest.approx([0.6 if on else 0.1] * 3, rel=0.05), how


def test_an_expression_link_takes_in_prims_added_later(stage, delegate):
    """A light whose expression matches every wall takes in a wall added after the load (the
    light itself unedited), and lets go of one removed."""
    sun = _two_walls(stage)
    coll = UsdLux.LightAPI(sun).GetLightLinkCollectionAPI()
    coll.CreateIncludeRootAttr(False)
    coll.CreateMembershipExpressionAttr(Sdf.PathExpression("/World/*/Wall"))
    reader, problems = load(stage, delegate)
    key = "collection:lightLink:includes"
    assert delegate.value("/Sun", key) == ("paths", ["/World/Left/Wall", "/World/Right/Wall"])
    _wall(stage, "/World/Middle/Wall", -0.1, 0.1, -6, _grey(stage))
    reader.update()
    assert delegate.value("/Sun", key) == ("paths", ["/World/Left/Wall", "/World/Middle/Wall", "/World/Right/Wall"])
    stage.RemovePrim("/World/Left")
    reader.update()
    assert delegate.value("/Sun", key) == ("paths", ["/World/Middle/Wall", "/World/Right/Wall"])


def test_excluding_a_prim_from_the_light_link(renderer, stage):
    w = h = 32
    sun = _two_walls(stage)
    UsdLux.LightAPI(sun).GetLightLinkCollectionAPI().CreateExcludesRel().AddTarget("/World/Left/Wall")
    settings(stage, res=(w, h), samples=32, maxDepth=2)
    left, right = _halves(render(renderer, stage)["color"])
    assert left == pytest.approx([0.1] * 3, rel=0.05)
    assert right == pytest.approx([0.6] * 3, rel=0.05)


def test_a_prim_outside_the_shadow_link_casts_no_shadow(renderer, stage):
    w = h = 32
    sun = _two_walls(stage)
    # the sun alone, from up and behind the camera; a roof above the camera's view shadows
    # both walls
    stage.RemovePrim("/Dome")
    UsdGeom.Xformable(sun).AddRotateXOp().Set(-30.0)
    roof = UsdGeom.Mesh.Define(stage, "/World/Roof")
    roof.CreatePointsAttr([(-20, 4, -20), (20, 4, -20), (20, 4, 20), (-20, 4, 20)])
    roof.CreateFaceVertexCountsAttr([4])
    roof.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    settings(stage, res=(w, h), samples=16, maxDepth=1)
    shadowed = _halves(render(renderer, stage)["color"])
    coll = UsdLux.LightAPI(sun).GetShadowLinkCollectionAPI()
    coll.CreateExcludesRel().AddTarget("/World/Roof")
    lit = _halves(render(renderer, stage)["color"])
    for s, l in zip(shadowed, lit):
        assert l.mean() > 0.3 and s.mean() < 0.1 * l.mean(), (s, l)


def _two_instanced_walls(stage):
    """`_two_walls`' scene with the walls as two native instances of one prototype wall
    (/World/Left and /World/Right, instanceable references to the class /Protos/Wall): the
    renderer gets one mesh drawn twice, so links must resolve instance by instance."""
    camera(stage, focal=F, aperture=(AP, AP))
    mat = _grey(stage)
    proto = stage.CreateClassPrim("/Protos/Wall")
    m = UsdGeom.Mesh.Define(stage, "/Protos/Wall/Mesh")
    m.CreatePointsAttr([(0, -10, -5), (9.9, -10, -5), (9.9, 10, -5), (0, 10, -5)])
    m.CreateFaceVertexCountsAttr([4])
    m.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    for name, x in (("Left", -10.0), ("Right", 0.1)):
        x_form = UsdGeom.Xform.Define(stage, "/World/" + name)
        x_form.AddTranslateOp().Set(Gf.Vec3d(x, 0, 0))
        prim = x_form.GetPrim()
        prim.GetReferences().AddInternalReference(proto.GetPath())
        prim.SetInstanceable(True)
        bind(prim, mat)
    return _sun_and_dome(stage)


@pytest.mark.parametrize("target, lit", [("/World/Left", (True, False)),
                                         ("/World/Right/Mesh", (False, True)),
                                         ("/World", (True, True))])
def test_a_light_links_native_instances_one_by_one(renderer, stage, target, lit):
    w = h = 32
    sun = _two_instanced_walls(stage)
    coll = UsdLux.LightAPI(sun).GetLightLinkCollectionAPI()
    coll.CreateIncludesRel().AddTarget(target)
    coll.CreateIncludeRootAttr(False)
    settings(stage, res=(w, h), samples=32, maxDepth=2)
    halves = _halves(render(renderer, stage)["color"])
    for side, on, got in zip(("left", "right"), lit, halves):
        want = 0.6 if on else 0.1
        assert got == pytest.approx([want] * 3, rel=0.05), "%s instance, sun linked to %s" % (side, target)


def test_a_native_instance_outside_the_shadow_link_casts_no_shadow(renderer, stage):
    """Two instances of one roof prototype over the two walls' halves of the view; the sun's
    shadow link leaves out the right one, so only the left wall is shadowed."""
    w = h = 32
    sun = _two_walls(stage)
    stage.RemovePrim("/Dome")
    UsdGeom.Xformable(sun).AddRotateXOp().Set(-30.0)
    proto = stage.CreateClassPrim("/Protos/Roof")
    roof = UsdGeom.Mesh.Define(stage, "/Protos/Roof/Mesh")
    roof.CreatePointsAttr([(0, 4, -20), (20, 4, -20), (20, 4, 20), (0, 4, 20)])
    roof.CreateFaceVertexCountsAttr([4])
    roof.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    for name, x in (("RoofL", -20.0), ("RoofR", 0.0)):
        x_form = UsdGeom.Xform.Define(stage, "/World/" + name)
        x_form.AddTranslateOp().Set(Gf.Vec3d(x, 0, 0))
        x_form.GetPrim().GetReferences().AddInternalReference(proto.GetPath())
        x_form.GetPrim().SetInstanceable(True)
    UsdLux.LightAPI(sun).GetShadowLinkCollectionAPI().CreateExcludesRel().AddTarget("/World/RoofR")
    settings(stage, res=(w, h), samples=16, maxDepth=1)
    left, right = _halves(render(renderer, stage)["color"])
    assert right.mean() > 0.3 and left.mean() < 0.1 * right.mean(), (left, right)
