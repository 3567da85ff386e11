"""UsdLux light linking end to end (contract §2): a light's lightLink collection decides which
prims it illuminates, its shadowLink collection which prims cast its shadows."""
import math

import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade

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
    sun = UsdLux.DistantLight.Define(stage, "/Sun")
    sun.CreateIntensityAttr(math.pi)
    sun.CreateNormalizeAttr(True)
    dome = UsdLux.DomeLight.Define(stage, "/Dome")
    dome.CreateIntensityAttr(0.2)
    return sun


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
