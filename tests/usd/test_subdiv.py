"""Subdivision surfaces through USD: `tide:subdivision:level` refines a Catmull-Clark cage to its
limit surface (the cage stays as it is without it). The expectation is Catmull-Clark's exact
limit of a cube's face centre, 68/81 of the half-size (the face-point mask on a regular cube:
every level keeps the six face centres on the axes and their limit follows from the valence-4
vertex rule), not a value from the renderer."""
import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom

from conftest import bind, camera, darkness, render, settings
from test_render import _black, _white_dome

F, AP = 50.0, 36.0
D = 8.0                       # the cube's distance from the camera
CUBE_POINTS = [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1),
               (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)]
CUBE_FACES = [0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7]


def _cube(stage, level):
    m = UsdGeom.Mesh.Define(stage, "/Cube")
    m.CreatePointsAttr(CUBE_POINTS)
    m.CreateFaceVertexCountsAttr([4] * 6)
    m.CreateFaceVertexIndicesAttr(CUBE_FACES)
    m.AddTranslateOp().Set(Gf.Vec3d(0, 0, -D))
    if level is not None:
        m.GetPrim().CreateAttribute("tide:subdivision:level", Sdf.ValueTypeNames.Int).Set(level)
    bind(m.GetPrim(), _black(stage))


@pytest.mark.parametrize("level,half", [(None, D / (D - 1)), (4, 68.0 / 81.0)])
def test_a_subdivided_cube_reaches_its_limit_surface(renderer, stage, level, half):
    # seen face-on, the middle rows' dark run spans 2 * half units at the cube's distance: the
    # cage's front face (its edges at z = +1 project to D / (D - 1)), or the limit surface's
    # side face centres (the run's widest points; the nearer, bulging surface around them adds
    # < 0.1 px)
    w = 96
    camera(stage, focal=F, aperture=(AP, AP))
    _white_dome(stage)
    _cube(stage, level)
    settings(stage, res=(w, w), samples=16)
    d = darkness(render(renderer, stage)["color"])
    k = F / D / (AP / 2) * w / 2             # pixels per unit at the cube's distance
    width = d[w // 2 - 1:w // 2 + 1].mean(axis=0).sum()
    assert width == pytest.approx(2 * half * k, abs=0.5), (width, 2 * half * k)


def _cube_stage(level, refine_level=0):
    from pxr import Usd
    s = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
    camera(s, focal=F, aperture=(AP, AP))
    _white_dome(s)
    _cube(s, level)
    settings(s, res=(32, 32), samples=4)
    return s


def test_the_complexity_subdivides_meshes_that_author_no_level(renderer):
    """usdrecord's complexity (`tide render --complexity`, the reader's refine_level; Hydra's
    display style refineLevel): `high` refines a cube that authors no level twice, pixel for
    pixel as an authored level 2; an authored level wins over it, 0 (the cage) included."""
    def img(level, refine=0):
        return render(renderer, _cube_stage(level), refine_level=refine)["color"]

    level2, cage = img(2), img(None)
    assert np.array_equal(img(None, refine=2), level2)
    assert np.array_equal(img(0, refine=2), cage)
    assert np.array_equal(img(2, refine=1), level2)
    assert not np.array_equal(level2, cage)


def test_face_varying_primvars_are_smooth_by_default(renderer):
    """A flat 2 x 2 grid refined 4 times glows the red of an indexed faceVarying primvar that
    runs as u = x-index / 2 but for 0.6 at the centre. USD's fallback rule (cornersPlus1; no
    seams here) refines it as Catmull-Clark refines points: the centre reaches its limit
    (16·0.6 + 4·(0.5 + 0 + 1 + 0.5) + (0 + 1 + 1 + 0)) / 36 = 0.5444; under `all` it stays
    bilinear within each face (0.6 at the centre, 0.598 over the pixel around it, where it
    falls away on every side)."""
    from pxr import Usd, UsdShade
    from conftest import lambert_material, top_camera

    def centre(rule):
        s = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
        top_camera(s)
        m = UsdGeom.Mesh.Define(s, "/Grid")
        m.CreatePointsAttr([(-2 + 2 * i, 0, -2 + 2 * j) for i in range(3) for j in range(3)])
        m.CreateFaceVertexCountsAttr([4] * 4)
        m.CreateFaceVertexIndicesAttr([k for i in range(2) for j in range(2)
                                       for k in (3 * i + j, 3 * i + j + 1, 3 * i + j + 4, 3 * i + j + 3)])
        m.GetPrim().CreateAttribute("tide:subdivision:level", Sdf.ValueTypeNames.Int).Set(4)
        if rule:
            m.CreateFaceVaryingLinearInterpolationAttr(rule)
        glow = [(0.6 if p == 4 else (p // 3) / 2.0,) * 3 for p in range(9)]
        pv = UsdGeom.PrimvarsAPI(m.GetPrim()).CreatePrimvar(
            "glow", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.faceVarying)
        pv.Set(glow)
        pv.SetIndices(m.GetFaceVertexIndicesAttr().Get())
        mat = lambert_material(s, "/Looks/Glow", (0, 0, 0))
        sh = UsdShade.Shader(s.GetPrimAtPath("/Looks/Glow/S"))
        rd = UsdShade.Shader.Define(s, "/Looks/Glow/Reader")
        rd.CreateIdAttr("UsdPrimvarReader_float3")
        rd.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("glow")
        rd.CreateOutput("result", Sdf.ValueTypeNames.Float3)
        sh.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
            rd.ConnectableAPI(), "result")
        bind(m.GetPrim(), mat)
        # a box filter, many samples: the centre pixel is the mean over a square around the
        # centre, where the glow is smooth (linear to first order)
        settings(s, res=(33, 33), samples=256, integrator="path", pixelFilter="box")
        problems = []
        img = render(renderer, s, problems)["color"]
        assert problems == [], problems
        return float(img[16, 16, 0])

    assert centre(None) == pytest.approx(19.6 / 36, abs=0.002)
    assert centre("cornersPlus1") == centre(None)
    assert 0.59 < centre("all") <= 0.6


def test_the_triangle_rule_reaches_the_delegate(stage, delegate):
    # triangleSubdivisionRule is sent as authored (the delegate's refinement applies it); an
    # unknown token is named and read as catmullClark
    from conftest import load
    camera(stage)
    _cube(stage, 2)
    rule = UsdGeom.Mesh(stage.GetPrimAtPath("/Cube")).CreateTriangleSubdivisionRuleAttr("smooth")
    _, problems = load(stage, delegate)
    assert problems == []
    assert delegate.value("/Cube", "triangleSubdivisionRule") == ("token", "smooth")
    rule.Set("loopy")
    _, problems = load(stage, delegate)
    assert [(p.prim, p.attribute) for p in problems] == [("/Cube", "triangleSubdivisionRule")]
    assert delegate.value("/Cube", "triangleSubdivisionRule") == ("token", "catmullClark")
