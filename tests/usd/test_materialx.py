"""MaterialX materials (USD's `mtlx` render context), as Houdini Solaris and Maya write them:
standard_surface read as the surfaces Tide has, its texture nodes inside a NodeGraph, and its
transmission as a clear dielectric."""
import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

from conftest import (RES, bind, camera, near, panel, render, settings, top_camera, white_dome,
                      write_exr)


def _standard_surface(stage, path, **inputs):
    """A Material whose mtlx:surface is a standard_surface with `inputs` (floats, or 3-tuples
    as colours); returns the material and the shader."""
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, path + "/SR")
    sh.CreateIdAttr("ND_standard_surface_surfaceshader")
    for k, v in inputs.items():
        if isinstance(v, tuple):
            sh.CreateInput(k, Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*v))
        else:
            sh.CreateInput(k, Sdf.ValueTypeNames.Float).Set(v)
    out = sh.CreateOutput("out", Sdf.ValueTypeNames.Token)
    mat.CreateSurfaceOutput("mtlx").ConnectToSource(out)
    return mat, sh


def test_a_diffuse_standard_surface_reflects_its_base_colour(renderer, stage):
    """base x base_color with no specular, under a white dome of radiance 1: the albedo. A
    UsdPreviewSurface on the universal output, which the MaterialX one takes precedence over,
    would show red."""
    top_camera(stage)
    white_dome(stage)
    m = panel(stage, "/Panel")
    mat, _ = _standard_surface(stage, "/Looks/Clay", base=0.5, base_color=(0.9, 0.6, 0.3),
                               specular=0.0)
    preview = UsdShade.Shader.Define(stage, "/Looks/Clay/Preview")
    preview.CreateIdAttr("UsdPreviewSurface")
    preview.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(1, 0, 0))
    mat.CreateSurfaceOutput().ConnectToSource(preview.ConnectableAPI(), "surface")
    bind(m.GetPrim(), mat)
    settings(stage, res=(RES, RES), samples=16, integrator="path", maxDepth=1)
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3]
    assert [p for p in problems if p.prim.startswith("/Looks")] == [], problems
    ok, why = near(img, (0.45, 0.3, 0.15))
    assert ok, why


def test_an_image_in_a_node_graph_feeds_the_emission(renderer, stage, tmp_path):
    """emission x emission_color, the colour from an ND_image_color3 inside a NodeGraph (the
    way DCCs package MaterialX): a black surface glowing the image, red left and blue right."""
    tex_file = tmp_path / "halves.exr"
    write_exr(tex_file, [[(1, 0, 0), (1, 0, 0), (0, 0, 1), (0, 0, 1)]])
    top_camera(stage)
    m = panel(stage, "/Panel", columns=1)
    UsdGeom.PrimvarsAPI(m.GetPrim()).CreatePrimvar(
        "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
        [(0, 0), (0, 1), (1, 0), (1, 1)])
    mat, sh = _standard_surface(stage, "/Looks/Sign", base=0.0, specular=0.0, emission=2.0)
    graph = UsdShade.NodeGraph.Define(stage, "/Looks/Sign/Graph")
    img = UsdShade.Shader.Define(stage, "/Looks/Sign/Graph/Image")
    img.CreateIdAttr("ND_image_color3")
    img.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(str(tex_file))
    img.CreateInput("uaddressmode", Sdf.ValueTypeNames.String).Set("clamp")
    uv = UsdShade.Shader.Define(stage, "/Looks/Sign/Graph/Uv")
    uv.CreateIdAttr("ND_texcoord_vector2")
    img.CreateInput("texcoord", Sdf.ValueTypeNames.Float2).ConnectToSource(
        uv.CreateOutput("out", Sdf.ValueTypeNames.Float2))
    graph_out = graph.CreateOutput("glow", Sdf.ValueTypeNames.Color3f)
    graph_out.ConnectToSource(img.CreateOutput("out", Sdf.ValueTypeNames.Color3f))
    sh.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(graph_out)
    bind(m.GetPrim(), mat)
    settings(stage, res=(RES, RES), samples=4, integrator="path")
    out = render(renderer, stage)["color"][..., :3]
    for part, want in ((out[:, :RES // 4], (2, 0, 0)), (out[:, -RES // 4:], (0, 0, 2))):
        ok, why = near(part, want)
        assert ok, why


def _glass_ball(stage, material):
    """A ball of `material` over a grey floor under a white dome, seen from the side."""
    camera(stage, pos=(0, 1, 6), focal=35.0)
    white_dome(stage)
    ball = UsdGeom.Sphere.Define(stage, "/Ball")
    ball.AddTranslateOp().Set(Gf.Vec3d(0, 1, 0))
    bind(ball.GetPrim(), material)
    floor = UsdGeom.Mesh.Define(stage, "/Floor")
    floor.CreatePointsAttr([(-5, 0, -5), (-5, 0, 5), (5, 0, 5), (5, 0, -5)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    floor.CreateDisplayColorPrimvar().Set([(0.5, 0.5, 0.5)])
    settings(stage, res=(RES, RES), samples=16, integrator="path")


def test_transmission_makes_the_same_clear_dielectric_as_tide_water(renderer):
    """A standard_surface with transmission 1, specular_IOR 1.5 and specular_roughness 0.1
    renders, sample for sample, as a TideWater of ior 1.5 and roughness 0.1; a diffuse ball
    looks different, so the comparison can tell."""
    def ball(kind):
        s = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
        if kind == "mtlx":
            mat, _ = _standard_surface(s, "/Looks/Glass", transmission=1.0, specular_IOR=1.5,
                                       specular_roughness=0.1)
        else:
            mat = UsdShade.Material.Define(s, "/Looks/Glass")
            sh = UsdShade.Shader.Define(s, "/Looks/Glass/Water")
            sh.CreateIdAttr("TideWater" if kind == "water" else "UsdPreviewSurface")
            if kind == "water":
                sh.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.5)
                sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.1)
            mat.CreateSurfaceOutput().ConnectToSource(sh.CreateOutput("surface", Sdf.ValueTypeNames.Token))
        _glass_ball(s, mat)
        return render(renderer, s)["color"]

    glass = ball("mtlx")
    assert np.array_equal(glass, ball("water"))
    assert np.abs(glass - ball("diffuse")).mean() > 0.05
