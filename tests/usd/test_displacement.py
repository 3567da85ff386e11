"""Displacement (UsdPreviewSurface's input, or MaterialX's displacement node): a mesh bound to a
displacing material moves along its normals.
The expectation comes from the camera model: a black 2 x 2 square facing the camera at distance
D, seen against a white dome, covers 2 F / D / (AP / 2) of the image's width; displaced by d
towards the camera it covers 2 F / (D - d) / (AP / 2)."""
import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

from conftest import bind, camera, darkness, render, settings, shader_node, write_exr
from test_render import _white_dome

F, AP, D, W = 50.0, 36.0, 8.0, 96


def _square(stage):
    """A 4 x 4 grid of quads over [-1, 1]², facing the camera (+Z), at distance D."""
    m = UsdGeom.Mesh.Define(stage, "/Square")
    xs = np.linspace(-1, 1, 5)
    m.CreatePointsAttr([(x, y, 0) for y in xs for x in xs])
    m.CreateFaceVertexCountsAttr([4] * 16)
    corners = lambda v: (v, v + 1, v + 6, v + 5)      # the quad whose first corner is point v
    m.CreateFaceVertexIndicesAttr([k for j in range(4) for i in range(4)
                                   for k in corners(5 * j + i)])
    m.CreateSubdivisionSchemeAttr("none")
    m.AddTranslateOp().Set(Gf.Vec3d(0, 0, -D))
    return m


def _black_displacing(stage, displacement=None, tex_file=None):
    """A black UsdPreviewSurface displacing by a constant, or by a 1 x 1 texture of 0.5
    scaled by 4."""
    mat = UsdShade.Material.Define(stage, "/Looks/Black")
    sh = UsdShade.Shader.Define(stage, "/Looks/Black/S")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0, 0, 0))
    sh.CreateInput("useSpecularWorkflow", Sdf.ValueTypeNames.Int).Set(1)
    sh.CreateInput("specularColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0, 0, 0))
    if displacement is not None:
        sh.CreateInput("displacement", Sdf.ValueTypeNames.Float).Set(displacement)
    if tex_file is not None:
        tex = UsdShade.Shader.Define(stage, "/Looks/Black/Height")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(str(tex_file))
        tex.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(4, 4, 4, 1))
        # repeating: the texel everywhere (the default, useMetadata, blends a black border in)
        for wrap in ("wrapS", "wrapT"):
            tex.CreateInput(wrap, Sdf.ValueTypeNames.Token).Set("repeat")
        sh.CreateInput("displacement", Sdf.ValueTypeNames.Float).ConnectToSource(
            tex.CreateOutput("r", Sdf.ValueTypeNames.Float))
    mat.CreateSurfaceOutput().ConnectToSource(sh.CreateOutput("surface", Sdf.ValueTypeNames.Token))
    return mat


def _width(renderer, **material):
    s = Usd.Stage.CreateInMemory()
    camera(s, focal=F, aperture=(AP, AP))
    _white_dome(s)
    bind(_square(s).GetPrim(), _black_displacing(s, **material))
    settings(s, res=(W, W), samples=16)
    problems = []
    d = darkness(render(renderer, s, problems)["color"])
    assert problems == [], problems
    return d[W // 2 - 1:W // 2 + 1].mean(axis=0).sum()


@pytest.mark.parametrize("lift", [0.0, 2.0])
def test_a_displaced_square_comes_closer(renderer, tmp_path, lift):
    """Displaced by `lift` (a constant, or a texture read through UsdUVTexture's scale), the
    square covers the width its new distance gives it."""
    px_per_unit = lambda dist: F / dist / (AP / 2) * W / 2
    want = 2 * px_per_unit(D - lift)
    assert _width(renderer, displacement=lift) == pytest.approx(want, abs=0.5)
    if lift:
        tex = tmp_path / "half.exr"
        write_exr(tex, [[(0.5, 0.5, 0.5)]])
        assert _width(renderer, tex_file=tex) == pytest.approx(want, abs=0.5)


def test_a_materialx_displacement_node_displaces(renderer):
    """A material whose mtlx displacement terminal is MaterialX's displacement node (0.5 x
    scale 4) displaces by 2, not by its UsdPreviewSurface's own input (1), which the
    universal displacement terminal would use; a vector displacement is reported and moves
    nothing."""
    px_per_unit = lambda dist: F / dist / (AP / 2) * W / 2

    def width(node_id):
        s = Usd.Stage.CreateInMemory()
        camera(s, focal=F, aperture=(AP, AP))
        _white_dome(s)
        mat = _black_displacing(s, displacement=1.0)
        bind(_square(s).GetPrim(), mat)
        d = shader_node(s, "/Looks/Black/D", node_id, displacement=0.5, scale=4.0)
        mat.CreateDisplacementOutput("mtlx").ConnectToSource(d.CreateOutput("out", Sdf.ValueTypeNames.Token))
        settings(s, res=(W, W), samples=16)
        problems = []
        dark = darkness(render(renderer, s, problems)["color"])
        return dark[W // 2 - 1:W // 2 + 1].mean(axis=0).sum(), [(p.prim, p.attribute) for p in problems]

    assert width("ND_displacement_float") == (pytest.approx(2 * px_per_unit(D - 2.0), abs=0.5), [])
    flat, problems = width("ND_displacement_vector3")
    assert flat == pytest.approx(2 * px_per_unit(D), abs=0.5)
    assert problems == [("/Looks/Black/D", "info:id")]
