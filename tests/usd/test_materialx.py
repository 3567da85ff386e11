"""MaterialX materials (USD's `mtlx` render context), as Houdini Solaris and Maya write them:
standard_surface read as the surfaces Tide has, its texture nodes inside a NodeGraph, and its
transmission as a dielectric: absorbing over a depth, tinted at the surface, or blended with
the opaque stack where it is partial."""
import math

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from conftest import (HALF, RES, bind, camera, near, panel, render, settings, shader_node, top_camera,
                      white_dome, write_exr)


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
    _shows_albedo(renderer, stage, m, mat, (0.45, 0.3, 0.15))


def _shows_albedo(renderer, stage, m, mat, albedo):
    """Panel `m` bound to `mat`, seen from above under the white dome with one bounce, shows
    `albedo`, and the material raises no problem."""
    bind(m.GetPrim(), mat)
    settings(stage, res=(RES, RES), samples=16, integrator="path", maxDepth=1)
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3]
    assert [p for p in problems if p.prim.startswith("/Looks")] == [], problems
    ok, why = near(img, albedo)
    assert ok, why


def test_an_image_in_a_node_graph_feeds_the_emission(renderer, stage, tmp_path):
    """emission x emission_color, the colour from an ND_image_color3 inside a NodeGraph (the
    way DCCs package MaterialX): a black surface glowing the image, red left and blue right."""
    tex_file = tmp_path / "halves.exr"
    write_exr(tex_file, [[(1, 0, 0), (1, 0, 0), (0, 0, 1), (0, 0, 1)]])
    top_camera(stage)
    m = panel(stage, "/Panel", columns=1, st=True)
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


def test_two_textures_multiplied_and_mixed_by_a_primvar_mask(renderer, stage, tmp_path):
    """emission_color = mix(bg 0.1, image A x image B, a per-face primvar mask): arithmetic on
    two varying operands, evaluated at each hit. Left (mask 1): A x B = (1, 0.5, 0.25) x 2;
    right (mask 0.25): 0.25 (0.25, 0.5, 1) x 0.5 + 0.75 x 0.1."""
    a, b = tmp_path / "a.exr", tmp_path / "b.exr"
    write_exr(a, [[(1, 0.5, 0.25)] * 2 + [(0.25, 0.5, 1)] * 2])
    write_exr(b, [[(2, 2, 2)] * 2 + [(0.5, 0.5, 0.5)] * 2])
    top_camera(stage)
    m = panel(stage, "/Panel", columns=2)
    pv = UsdGeom.PrimvarsAPI(m.GetPrim())
    pv.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
        [(0, 0), (0, 1), (0.5, 0), (0.5, 1), (1, 0), (1, 1)])
    pv.CreatePrimvar("mask", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.uniform).Set([1.0, 0.25])
    mat, sh = _standard_surface(stage, "/Looks/Sign", base=0.0, specular=0.0, emission=1.0)
    out = lambda s: s.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
    img_a = shader_node(stage, "/Looks/Sign/A", "ND_image_color3", file=str(a), uaddressmode="clamp")
    img_b = shader_node(stage, "/Looks/Sign/B", "ND_image_color3", file=str(b), uaddressmode="clamp")
    mask = shader_node(stage, "/Looks/Sign/Mask", "ND_geompropvalue_float", geomprop="mask")
    prod = shader_node(stage, "/Looks/Sign/AxB", "ND_multiply_color3", in1=out(img_a), in2=out(img_b))
    mix = shader_node(stage, "/Looks/Sign/Mix", "ND_mix_color3FA", fg=out(prod), bg=(0.1, 0.1, 0.1),
                  mix=mask.CreateOutput("out", Sdf.ValueTypeNames.Float))
    sh.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(out(mix))
    bind(m.GetPrim(), mat)
    settings(stage, res=(RES, RES), samples=4, integrator="path")
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3]
    assert [p for p in problems if p.prim.startswith("/Looks")] == [], problems
    right = 0.25 * np.array([0.25, 0.5, 1.0]) * 0.5 + 0.75 * 0.1
    for part, want in ((img[:, :RES // 4], (2, 1, 0.5)), (img[:, -RES // 4:], right)):
        ok, why = near(part, want)
        assert ok, why


def _open_pbr(stage, path, **inputs):
    """A Material whose mtlx:surface is an open_pbr_surface with `inputs`."""
    mat = UsdShade.Material.Define(stage, path)
    sh = shader_node(stage, path + "/OpenPBR", "ND_open_pbr_surface_surfaceshader", **inputs)
    mat.CreateSurfaceOutput("mtlx").ConnectToSource(sh.CreateOutput("out", Sdf.ValueTypeNames.Token))
    return mat


def test_an_open_pbr_surface_reflects_its_base_colour(renderer, stage):
    """base_weight x base_color with no specular, under a white dome of radiance 1: the albedo."""
    top_camera(stage)
    white_dome(stage)
    m = panel(stage, "/Panel")
    mat = _open_pbr(stage, "/Looks/Clay", base_weight=0.5, base_color=(0.9, 0.6, 0.3),
                    specular_weight=0.0)
    _shows_albedo(renderer, stage, m, mat, (0.45, 0.3, 0.15))


def test_a_tinted_transmission_absorbs_as_beer_lambert(renderer):
    """An OpenPBR glass ball whose transmission_color (0.5, 0.25, 1) is reached at
    transmission_depth 2 renders as a TideWater ball filled with a TideMedium absorbing
    σa = −ln(colour) / 2, sample for sample up to float rounding of σa; a clear ball differs."""
    ln2 = float(np.log(2.0))

    def ball(tint):
        return _ball(renderer, lambda s: _open_pbr(
            s, "/Looks/Glass", transmission_weight=1.0, specular_ior=1.5, specular_roughness=0.1,
            transmission_color=tint, transmission_depth=2.0))

    tinted = ball((0.5, 0.25, 1.0))
    water = _ball(renderer, lambda s: _water_body(s, 1.5, 0.1, (ln2 / 2, ln2, 0), (0, 0, 0)))
    assert np.allclose(tinted, water, rtol=1e-4, atol=1e-6), np.abs(tinted - water).max()
    assert np.abs(tinted - ball((1.0, 1.0, 1.0))).mean() > 0.01


def _slab_seen_from_above(renderer, stage, **inputs):
    """A 0.2-thick slab of a standard_surface with `inputs` filling the view of the top
    camera, under and over the white dome; returns the colour and the problems raised."""
    top_camera(stage)
    white_dome(stage)
    slab = UsdGeom.Cube.Define(stage, "/Slab")
    slab.AddScaleOp().Set(Gf.Vec3f(10, 0.1, 10))
    mat, _ = _standard_surface(stage, "/Looks/Glass", **inputs)
    bind(slab.GetPrim(), mat)
    settings(stage, res=(RES, RES), samples=64, integrator="path")
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3]
    return img, problems


def test_a_transmission_colour_with_no_depth_tints_each_crossing(renderer, stage):
    """A smooth glass slab (R = 0.04 head-on) whose transmission_color c tints each crossing,
    seen head-on against a dome of radiance 1: every path that crosses both faces, however
    often it reflects inside, carries c^2, so the slab shows R + c^2 (1 - R): 0.28 for a grey
    c = 0.5, where a clear slab shows 1."""
    img, problems = _slab_seen_from_above(renderer, stage, transmission=1.0, specular_IOR=1.5,
                                          specular_roughness=0.0, transmission_color=(0.5, 0.5, 0.5))
    assert problems == [], problems
    ok, why = near(img, 0.04 + 0.25 * 0.96)
    assert ok, why


def test_a_partial_transmission_blends_the_glass_with_the_opaque_base(renderer, stage):
    """A smooth slab transmitting 0.6 over a black base: both shares reflect R = 0.04 from
    either side; 0.6 (1 - R) of what meets a face crosses it and the rest is absorbed. The
    paths that cross both faces sum to 0.6^2 (1 - R)^2 / (1 - R), so the slab shows
    R + 0.36 (1 - R) = 0.3856."""
    img, problems = _slab_seen_from_above(renderer, stage, transmission=0.6, specular_IOR=1.5,
                                          specular_roughness=0.0, base=0.0)
    assert problems == [], problems
    ok, why = near(img, 0.04 + 0.36 * 0.96)
    assert ok, why


def test_a_transmitting_metal_is_the_metal(renderer):
    """MaterialX's metal lies over its transmission: at metalness 1 a fully transmitting
    standard_surface renders, sample for sample, as the same opaque metal; at metalness 0.5
    it differs from both."""
    def ball(**inputs):
        return _ball(renderer, lambda s: _standard_surface(
            s, "/Looks/M", base_color=(0.9, 0.6, 0.3), specular_roughness=0.3, **inputs)[0])

    metal = ball(metalness=1.0)
    assert np.array_equal(ball(metalness=1.0, transmission=1.0), metal)
    # the ball fills the middle quarter of the view
    mid = (slice(RES // 2 - 4, RES // 2 + 4), slice(RES // 2 - 4, RES // 2 + 4))
    half = ball(metalness=0.5, transmission=1.0)[mid]
    assert np.abs(half - metal[mid]).mean() > 0.05
    assert np.abs(half - ball(transmission=1.0)[mid]).mean() > 0.05


def test_a_glowing_glass_shows_its_emission(renderer, stage):
    """A fully transmitting slab with emission 0.5 under no light at all: the camera sees the
    top face's glow, and nothing else lights anything (the faces glow outwards only), so every
    pixel shows 0.5."""
    top_camera(stage)
    slab = UsdGeom.Cube.Define(stage, "/Slab")
    slab.AddScaleOp().Set(Gf.Vec3f(10, 0.1, 10))
    mat, _ = _standard_surface(stage, "/Looks/Glow", transmission=1.0, emission=0.5,
                               emission_color=(1.0, 1.0, 1.0))
    bind(slab.GetPrim(), mat)
    settings(stage, res=(RES, RES), samples=4, integrator="path")
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3]
    assert problems == [], problems
    ok, why = near(img, 0.5)
    assert ok, why


def _thin(mat_shader):
    mat_shader.CreateInput("thin_walled", Sdf.ValueTypeNames.Bool).Set(True)


def test_a_thin_pane_passes_light_straight_through(renderer, stage):
    """A single quad of thin-walled smooth glass (transmission 1, colour 0.5) seen head-on
    against a dome of radiance 1: it reflects its specular layer's F0 = 0.04 and passes the
    rest unbent, tinted: 0.04 + 0.96 x 0.5 = 0.52."""
    top_camera(stage)
    white_dome(stage)
    m = panel(stage, "/Pane")
    mat, sh = _standard_surface(stage, "/Looks/Pane", transmission=1.0, specular_roughness=0.0,
                                transmission_color=(0.5, 0.5, 0.5))
    _thin(sh)
    bind(m.GetPrim(), mat)
    settings(stage, res=(RES, RES), samples=64, integrator="path")
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3]
    assert problems == [], problems
    ok, why = near(img, 0.04 + 0.96 * 0.5)
    assert ok, why


def test_a_thin_pane_lets_the_sun_through(renderer):
    """A floor lit by a sun overhead, seen from between it and a thin pane of tinted glass
    above: the pane lets tint x (1 - F0) = 0.5 x 0.96 of the sun through (direct light only);
    a pane that is not thin-walled is a glass body's surface and casts a full shadow."""
    def floor(pane):
        s = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
        cam = camera(s, pos=(0, 0.5, 0), aperture=(4 * HALF, 4 * HALF), projection="orthographic")
        cam.AddRotateXOp().Set(-90.0)
        sun = UsdLux.DistantLight.Define(s, "/Sun")
        sun.CreateIntensityAttr(3.0)
        sun.CreateAngleAttr(0.0)
        sun.AddRotateXOp().Set(-90.0)
        panel(s, "/Floor").CreateDisplayColorPrimvar().Set([(0.5, 0.5, 0.5)])
        if pane is not None:
            glass = panel(s, "/Pane")
            glass.AddTranslateOp().Set(Gf.Vec3d(0, 1, 0))
            mat, sh = _standard_surface(s, "/Looks/Pane", transmission=1.0, specular_roughness=0.0,
                                        transmission_color=(0.5, 0.5, 0.5))
            if pane:
                _thin(sh)
            bind(glass.GetPrim(), mat)
        settings(s, res=(RES, RES), samples=4, integrator="path", maxDepth=1)
        return render(renderer, s)["color"][..., :3]

    lit = floor(None)
    assert lit.mean() > 0.1
    ok, why = near(floor(True), lit.mean(axis=(0, 1)) * 0.5 * 0.96)
    assert ok, why
    assert floor(False).max() == 0.0


def test_a_thin_leaf_is_translucent(renderer, stage):
    """A thin-walled Standard Surface of subsurface 1 (colour c) and no specular, under the
    white dome with one bounce: its translucent lobe carries the dome below it up through it,
    so a top view shows c; an OpenPBR leaf of anisotropy 0.5 splits c into a reflection of
    c (1 - g) / 2 and a translucency of c (1 + g) / 2, which a sun below or above shows in the
    ratio 3."""
    c = (0.3, 0.6, 0.2)
    top_camera(stage)
    white_dome(stage)
    m = panel(stage, "/Leaf")
    mat, sh = _standard_surface(stage, "/Looks/Leaf", subsurface=1.0, subsurface_color=c,
                                specular=0.0)
    _thin(sh)
    _shows_albedo(renderer, stage, m, mat, c)

    def lit(turn):
        s = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
        top_camera(s)
        sun = UsdLux.DistantLight.Define(s, "/Sun")
        sun.CreateAngleAttr(0.0)
        sun.AddRotateXOp().Set(turn)
        leaf = panel(s, "/Leaf")
        mat = _open_pbr(s, "/Looks/Leaf", subsurface_weight=1.0, subsurface_color=c,
                        subsurface_scatter_anisotropy=0.5, specular_weight=0.0)
        sh = UsdShade.Shader(s.GetPrimAtPath("/Looks/Leaf/OpenPBR"))
        sh.CreateInput("geometry_thin_walled", Sdf.ValueTypeNames.Bool).Set(True)
        bind(leaf.GetPrim(), mat)
        settings(s, res=(RES, RES), samples=4, integrator="path", maxDepth=1)
        return render(renderer, s)["color"][..., :3].mean(axis=(0, 1))

    below, above = lit(90.0), lit(-90.0)
    assert above.min() > 0.01
    assert np.allclose(below / above, 3.0, rtol=0.01), below / above


def _ball(renderer, material):
    """The image of `_glass_ball` of the material that `material(stage)` defines; no problem
    raised."""
    s = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
    _glass_ball(s, material(s))
    problems = []
    img = render(renderer, s, problems)["color"]
    assert problems == [], problems
    return img


def _water_body(stage, ior, roughness, absorption, scattering, g=None):
    """A TideWater surface (`ior`, `roughness`) over a TideMedium body."""
    mat = UsdShade.Material.Define(stage, "/Looks/Body")
    sh = UsdShade.Shader.Define(stage, "/Looks/Body/Water")
    sh.CreateIdAttr("TideWater")
    sh.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(ior)
    sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(roughness)
    mat.CreateSurfaceOutput().ConnectToSource(sh.CreateOutput("surface", Sdf.ValueTypeNames.Token))
    med = UsdShade.Shader.Define(stage, "/Looks/Body/Medium")
    med.CreateIdAttr("TideMedium")
    med.CreateInput("absorption", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*absorption))
    med.CreateInput("scattering", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*scattering))
    if g is not None:
        med.CreateInput("phase", Sdf.ValueTypeNames.Token).Set("hg")
        med.CreateInput("g", Sdf.ValueTypeNames.Float).Set(g)
    mat.CreateVolumeOutput().ConnectToSource(med.CreateOutput("volume", Sdf.ValueTypeNames.Token))
    return mat


def test_subsurface_is_a_random_walk_in_the_body(renderer):
    """A standard_surface with subsurface 1 renders as a TideWater of its specular_IOR over a
    TideMedium with σt = 1 / (radius x scale) and the single-scattering albedo whose
    multiple-scattering albedo is subsurface_color (Christensen and Burley's inversion),
    sample for sample up to float rounding; a diffuse ball of that colour differs."""
    color, radius, scale = (0.9, 0.5, 0.2), (1.0, 0.5, 0.25), 0.5

    def single(a):
        r = 4.09712 + 4.20863 * a - np.sqrt(9.59217 + 41.6808 * a + 17.7126 * a * a)
        return 1.0 - r * r

    sigma_t = [1.0 / (r * scale) for r in radius]
    sigma_s = [single(a) * t for a, t in zip(color, sigma_t)]
    sigma_a = [t - ss for t, ss in zip(sigma_t, sigma_s)]
    skin = _ball(renderer, lambda s: _standard_surface(
        s, "/Looks/Skin", subsurface=1.0, subsurface_color=color, subsurface_radius=radius,
        subsurface_scale=scale, subsurface_anisotropy=0.4, specular_IOR=1.4,
        specular_roughness=0.3)[0])
    water = _ball(renderer, lambda s: _water_body(s, 1.4, 0.3, sigma_a, sigma_s, g=0.4))
    assert np.allclose(skin, water, rtol=1e-3, atol=1e-5), np.abs(skin - water).max()
    diffuse = _ball(renderer, lambda s: _standard_surface(s, "/Looks/Clay", base_color=color)[0])
    assert np.abs(skin - diffuse).mean() > 0.01


def test_cell_noise_gives_one_uniform_value_per_cell(renderer, stage):
    """emission_color = cellnoise2d(texture coordinates x N): over the panel's N x N cells
    (RES / N pixels square each) the image is one value per cell, and the cells' values, as
    independent draws uniform on [0, 1], have mean 1/2 and variance 1/12 within 4 of their
    standard errors over N^2 cells: sqrt(1/12) / N for the mean, sqrt((1/80 - 1/144) / N^2)
    for the variance."""
    n = 8
    top_camera(stage)
    m = panel(stage, "/Panel", columns=1, st=True)
    mat, sh = _standard_surface(stage, "/Looks/Cells", base=0.0, specular=0.0, emission=1.0)
    vec2 = lambda s: s.CreateOutput("out", Sdf.ValueTypeNames.Float2)
    uv = shader_node(stage, "/Looks/Cells/Uv", "ND_texcoord_vector2")
    scaled = shader_node(stage, "/Looks/Cells/Scale", "ND_multiply_vector2FA", in1=vec2(uv), in2=float(n))
    cells = shader_node(stage, "/Looks/Cells/Noise", "ND_cellnoise2d_float", texcoord=vec2(scaled))
    sh.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        cells.CreateOutput("out", Sdf.ValueTypeNames.Float))
    bind(m.GetPrim(), mat)
    settings(stage, res=(RES, RES), samples=16, integrator="path")
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3].astype(np.float64)
    assert [p for p in problems if p.prim.startswith("/Looks")] == [], problems
    # rows follow v, columns u: cell (i, j) is the block of rows i and columns j
    k = RES // n
    blocks = img.reshape(n, k, n, k, 3).transpose(0, 2, 1, 3, 4).reshape(n, n, k * k, 3)
    grey = blocks.mean(axis=-1)
    cell = grey.mean(axis=-1)
    # piecewise constant: every pixel within 5 % of its cell's mean (a pixel's hero-wavelength
    # noise at 16 samples is about 1 %), while cells differ by about 0.29
    assert np.all(np.abs(grey - cell[..., None]) <= 0.05 * cell[..., None] + 1e-3), \
        np.abs(grey / cell[..., None] - 1).max()
    assert np.all((cell >= 0) & (cell <= 1.05)), (cell.min(), cell.max())
    se_mean = np.sqrt(1 / 12) / n
    se_var = np.sqrt((1 / 80 - 1 / 144) / n ** 2)
    assert abs(cell.mean() - 0.5) < 4 * se_mean, cell.mean()
    assert abs(cell.var() - 1 / 12) < 4 * se_var, cell.var()


def _glowing_ball(renderer, glow, turn=0.0):
    """A unit sphere turned `turn` degrees about +Y, seen straight down by `top_camera`,
    glowing the colour output `glow(stage, shader_path)` returns; the image, and the world
    normal (x, y, z) each pixel sees."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    top_camera(stage)
    ball = UsdGeom.Sphere.Define(stage, "/Ball")
    ball.CreateRadiusAttr(1.0)
    ball.AddRotateYOp().Set(turn)
    mat, sh = _standard_surface(stage, "/Looks/G", base=0.0, specular=0.0, emission=1.0)
    sh.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(glow(stage, "/Looks/G"))
    bind(ball.GetPrim(), mat)
    settings(stage, res=(RES, RES), samples=16, integrator="path", maxDepth=1)
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3]
    assert [p for p in problems if p.prim.startswith("/Looks")] == [], problems
    c = -HALF + (np.arange(RES) + 0.5) * 2 * HALF / RES
    x, z = np.meshgrid(c, c)  # rows follow z, columns x
    return img, np.stack([x, np.sqrt(np.clip(1 - x ** 2 - z ** 2, 0, 1)), z], axis=-1)


def _quadrants_show(img, normal, want):
    """Each quadrant's mean colour inside the disc (away from its rim) is the mean of `want`
    there."""
    inside = normal[..., 0] ** 2 + normal[..., 2] ** 2 < 0.8 ** 2
    h = RES // 2
    for rows in (slice(0, h), slice(h, RES)):
        for cols in (slice(0, h), slice(h, RES)):
            sel = inside[rows, cols]
            ok, why = near(img[rows, cols][sel], want[rows, cols][sel].mean(axis=0))
            if not ok:
                return False, why
    return True, None


def test_the_normal_node_reads_the_shading_normal_in_either_space(renderer):
    """A sphere turned 90 degrees about +Y glows (n + 1) / 2 of MaterialX's `normal`. In the
    world, the normal where the camera looks down at (x, z) is (x, y, z) on the unit sphere;
    in the object's space it is turned back: (x, y, z) -> (-z, y, x)."""
    vec3 = lambda s: s.CreateOutput("out", Sdf.ValueTypeNames.Float3)

    def glow(space):
        def build(stage, path):
            n = shader_node(stage, path + "/Normal", "ND_normal_vector3", space=space)
            half = shader_node(stage, path + "/Half", "ND_multiply_vector3FA", in1=vec3(n), in2=0.5)
            return vec3(shader_node(stage, path + "/Shift", "ND_add_vector3FA", in1=vec3(half), in2=0.5))
        return build

    for space, turn in (("world", lambda n: n), ("object", lambda n: np.stack([-n[..., 2], n[..., 1], n[..., 0]], axis=-1))):
        img, normal = _glowing_ball(renderer, glow(space), turn=90.0)
        ok, why = _quadrants_show(img, normal, (turn(normal) + 1) / 2)
        assert ok, (space, why)


def test_triplanar_projection_blends_three_images_by_the_normal(renderer, tmp_path):
    """A unit sphere glowing a triplanarprojection of three solid images, red along x, green
    along y, blue along z: where the camera looking down sees the normal n = (x, y, z), the
    colour is the weights |n| / (|n|.1) raised to 1 / blend and renormalised. blend 1 gives
    (|x|, |y|, |z|) / (|x| + |y| + |z|); blend 0.5 squares the weights first."""
    files = []
    for k, name in enumerate("xyz"):
        files.append(str(tmp_path / f"{name}.exr"))
        write_exr(files[-1], [[tuple(float(j == k) for j in range(3))]])

    def glow(blend):
        def build(stage, path):
            tri = shader_node(stage, path + "/Tri", "ND_triplanarprojection_color3", blend=blend)
            for axis, f in zip("xyz", files):
                tri.CreateInput("file" + axis, Sdf.ValueTypeNames.Asset).Set(f)
            return tri.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
        return build

    for blend in (1.0, 0.5):
        img, normal = _glowing_ball(renderer, glow(blend))
        n = np.abs(normal)
        q = (n / n.sum(axis=-1, keepdims=True)) ** (1 / blend)
        ok, why = _quadrants_show(img, normal, q / q.sum(axis=-1, keepdims=True))
        assert ok, (blend, why)


def _stripe_through_a_tilted_slab(renderer, material, n=1.5):
    """A white emissive stripe seen by an orthographic camera through a slab (1 thick, of index
    `n` at the d line) turned 45° about Y, bound to `material(stage)`. A slab shifts a ray
    sideways by t sin(θi − θt) / cos θt (towards +x here), more for a higher index; returns
    the red and blue columns' centroids (pixels; the image is 0.06 wide over 120 columns) of
    the stripe's image."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    t = 1.0
    ti = math.asin(math.sin(math.pi / 4) / n)
    shift = t * math.sin(math.pi / 4 - ti) / math.cos(ti)
    camera(stage, pos=(shift, 0, 5), aperture=(0.6, 0.02), projection="orthographic")
    slab = UsdGeom.Cube.Define(stage, "/Slab")
    slab.AddRotateYOp().Set(45.0)
    slab.AddScaleOp().Set(Gf.Vec3f(2.0, 2.0, t / 2.0))
    bind(slab.GetPrim(), material(stage))
    stripe = UsdGeom.Mesh.Define(stage, "/Stripe")
    w = 0.002
    stripe.CreatePointsAttr([(-w / 2, -1, -3), (w / 2, -1, -3), (w / 2, 1, -3), (-w / 2, 1, -3)])
    stripe.CreateFaceVertexCountsAttr([4])
    stripe.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    glow = UsdShade.Material.Define(stage, "/Looks/Glow")
    sh = UsdShade.Shader.Define(stage, "/Looks/Glow/S")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0, 0, 0))
    sh.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(1, 1, 1))
    glow.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    bind(stripe.GetPrim(), glow)
    settings(stage, res=(120, 4), samples=64, integrator="path")
    problems = []
    img = render(renderer, stage, problems)["color"].astype(np.float64)
    assert not problems, problems
    cols = np.arange(img.shape[1]) + 0.5
    profile = img.sum(axis=0)
    return [float((cols * profile[:, c]).sum() / profile[:, c].sum()) for c in (0, 2)]


def _glass(abbe, n=1.5):
    """A clear standard_surface glass of specular_IOR `n` and, unless None, Abbe number `abbe`."""
    def make(stage):
        inputs = dict(base=0.0, transmission=1.0, specular_IOR=n, specular_roughness=0.0)
        if abbe:
            inputs["transmission_dispersion"] = float(abbe)
        return _standard_surface(stage, "/Looks/Glass", **inputs)[0]
    return make


def _quan_fry(lam, salinity=0.0, temperature=20.0):
    """Quan & Fry's (1995) index of water at wavelength `lam` (nm)."""
    s, t = salinity, temperature
    return (1.31405 + (1.779e-4 - 1.05e-6 * t + 1.6e-8 * t * t) * s - 2.02e-6 * t * t
            + (15.868 + 0.01155 * s - 0.00423 * t) / lam - 4382.0 / lam ** 2 + 1.1455e6 / lam ** 3)


def test_dispersion_splits_colours_as_the_abbe_number_says(renderer):
    """Without dispersion the stripe's red and blue images coincide; with it, blue (the higher
    index) shifts further, by an amount that, to first order in the index's spread, is
    inversely proportional to the Abbe number (Cauchy's B = (n_d − 1) / (V (λF⁻² − λC⁻²)))."""
    red, blue = _stripe_through_a_tilted_slab(renderer, _glass(None))
    assert abs(blue - red) < 0.3, (red, blue)
    seps = {}
    for v in (20, 40):
        red, blue = _stripe_through_a_tilted_slab(renderer, _glass(v))
        seps[v] = blue - red
    assert seps[40] > 1.5, seps
    ratio = seps[20] / seps[40]
    assert 1.85 < ratio < 2.15, seps


def test_dispersive_tide_water_splits_colours_as_quan_fry_says(renderer):
    """TideWater with `dispersion` on splits the stripe's colours as much as a Cauchy glass of
    the same index at the d line and the same Abbe number, which the Quan–Fry formula gives
    (about 55.8 at 20 °C, fresh water): the two curves meet at the d, F and C lines and differ
    by at most 4.7 % of n_F − n_C over 420–700 nm, so the splits agree to that and the noise."""
    f, d, c = 486.13, 587.56, 656.27
    n_d = _quan_fry(d)
    abbe = (n_d - 1.0) / (_quan_fry(f) - _quan_fry(c))

    def water(stage):
        mat = UsdShade.Material.Define(stage, "/Looks/Water")
        sh = UsdShade.Shader.Define(stage, "/Looks/Water/S")
        sh.CreateIdAttr("TideWater")
        sh.CreateInput("dispersion", Sdf.ValueTypeNames.Bool).Set(True)
        sh.CreateInput("temperature", Sdf.ValueTypeNames.Float).Set(20.0)
        mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
        return mat
    red, blue = _stripe_through_a_tilted_slab(renderer, water, n=n_d)
    red_g, blue_g = _stripe_through_a_tilted_slab(renderer, _glass(abbe, n=n_d), n=n_d)
    assert blue - red > 1.0, (red, blue)
    assert abs((blue - red) / (blue_g - red_g) - 1.0) < 0.07, (blue - red, blue_g - red_g, abbe)


def _glow_of(renderer, stage, build, st=None, res=8):
    """The emission a MaterialX graph gives a black standard_surface seen directly: `build`
    makes the graph under /Looks/G and returns the output feeding emission_color."""
    top_camera(stage)
    m = panel(stage, "/Panel", columns=1, st=st is None)
    if st is not None:
        UsdGeom.PrimvarsAPI(m.GetPrim()).CreatePrimvar(
            "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(st)
    mat, sh = _standard_surface(stage, "/Looks/G", base=0.0, specular=0.0, emission=1.0)
    sh.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(build(stage))
    bind(m.GetPrim(), mat)
    settings(stage, res=(RES, RES), samples=res, integrator="path")
    return render(renderer, stage)


def _node(stage, name, node_id, out_type, **inputs):
    sh = UsdShade.Shader.Define(stage, "/Looks/G/" + name)
    sh.CreateIdAttr(node_id)
    for k, (tn, v) in inputs.items():
        inp = sh.CreateInput(k, tn)
        if isinstance(v, UsdShade.Output):
            inp.ConnectToSource(v)
        else:
            inp.Set(v)
    return sh.CreateOutput("out", out_type)


@pytest.mark.parametrize("node_id, in1, in2, index, want", [
    ("ND_combine2_color4CF", (Sdf.ValueTypeNames.Color3f, Gf.Vec3f(0.2, 0.4, 0.6)), (Sdf.ValueTypeNames.Float, 0.25), 3, 0.25),
    ("ND_combine2_color4CF", (Sdf.ValueTypeNames.Color3f, Gf.Vec3f(0.2, 0.4, 0.6)), (Sdf.ValueTypeNames.Float, 0.25), 2, 0.6),
    ("ND_combine2_vector4VV", (Sdf.ValueTypeNames.Float2, Gf.Vec2f(0.2, 0.4)), (Sdf.ValueTypeNames.Float2, Gf.Vec2f(0.6, 0.8)), 1, 0.4),
    ("ND_combine2_vector4VV", (Sdf.ValueTypeNames.Float2, Gf.Vec2f(0.2, 0.4)), (Sdf.ValueTypeNames.Float2, Gf.Vec2f(0.6, 0.8)), 2, 0.6),
])
def test_combine2_lays_out_its_inputs_by_their_types(renderer, stage, node_id, in1, in2, index, want):
    """combine2 to four components: color4CF is (in1.rgb, in2), vector4VV (in1.xy, in2.xy)
    (MaterialX's stdlib); one component, extracted, glows grey."""
    def build(s):
        four = _node(s, "C", node_id, Sdf.ValueTypeNames.Float4, in1=in1, in2=in2)
        one = _node(s, "E", "ND_extract_vector4", Sdf.ValueTypeNames.Float,
                    **{"in": (Sdf.ValueTypeNames.Float4, four), "index": (Sdf.ValueTypeNames.Int, index)})
        return _node(s, "G", "ND_convert_float_color3", Sdf.ValueTypeNames.Color3f,
                     **{"in": (Sdf.ValueTypeNames.Float, one)})
    ok, why = near(_glow_of(renderer, stage, build)["color"][..., :3], (want,) * 3)
    assert ok, why


def test_the_constant_address_mode_gives_the_images_default(renderer, stage, tmp_path):
    """An image read with uaddressmode = constant returns its `default` where u leaves [0, 1]
    (MaterialX: "texture coordinates outside the 0-1 range return the value of the node's
    default input"), not black: s runs 0..2 across the panel."""
    tex_file = tmp_path / "green.exr"
    write_exr(tex_file, [[(0, 1, 0)] * 4] * 4)

    def build(s):
        return _node(s, "I", "ND_image_color3", Sdf.ValueTypeNames.Color3f,
                     file=(Sdf.ValueTypeNames.Asset, str(tex_file)),
                     uaddressmode=(Sdf.ValueTypeNames.String, "constant"),
                     vaddressmode=(Sdf.ValueTypeNames.String, "clamp"),
                     default=(Sdf.ValueTypeNames.Color3f, Gf.Vec3f(0.3, 0.6, 0.3)))
    img = _glow_of(renderer, stage, build, st=[(0, 0), (0, 1), (2, 0), (2, 1)])["color"][..., :3]
    for part, want in ((img[:, RES // 8 + 1:3 * RES // 8 - 1], (0, 1, 0)),
                       (img[:, 5 * RES // 8 + 1:7 * RES // 8 - 1], (0.3, 0.6, 0.3))):
        ok, why = near(part, want)
        assert ok, why


def test_a_node_used_twice_is_read_once(renderer, stage):
    """Fourteen add(x, x) chained from 0.0001: 0.0001 x 2^14 = 1.6384. Read anew at each use,
    the graph grew past the node budget and fell back to the default."""
    def build(s):
        x = _node(s, "N0", "ND_constant_color3", Sdf.ValueTypeNames.Color3f,
                  value=(Sdf.ValueTypeNames.Color3f, Gf.Vec3f(1e-4, 1e-4, 1e-4)))
        for k in range(1, 15):
            x = _node(s, "N%d" % k, "ND_add_color3", Sdf.ValueTypeNames.Color3f,
                      in1=(Sdf.ValueTypeNames.Color3f, x), in2=(Sdf.ValueTypeNames.Color3f, x))
        return x
    ok, why = near(_glow_of(renderer, stage, build)["color"][..., :3], (1.6384,) * 3)
    assert ok, why


def test_a_standard_surface_opacity_colour_covers_alike_however_given(renderer, stage, tmp_path):
    """opacity (0.2, 0.6, 1.0) as a constant and from an image of that texel: the same
    coverage (the channels' mean) either way."""
    tex_file = tmp_path / "op.exr"
    write_exr(tex_file, [[(0.2, 0.6, 1.0)]])
    alphas = []
    for textured in (False, True):
        s = Usd.Stage.CreateInMemory()
        top_camera(s)
        m = panel(s, "/Panel", columns=1, st=True)
        mat, sh = _standard_surface(s, "/Looks/O", base=0.0, specular=0.0, emission=1.0,
                                    emission_color=(1.0, 1.0, 1.0))
        if textured:
            img = UsdShade.Shader.Define(s, "/Looks/O/I")
            img.CreateIdAttr("ND_image_color3")
            img.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(str(tex_file))
            sh.CreateInput("opacity", Sdf.ValueTypeNames.Color3f).ConnectToSource(
                img.CreateOutput("out", Sdf.ValueTypeNames.Color3f))
        else:
            sh.CreateInput("opacity", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.2, 0.6, 1.0))
        bind(m.GetPrim(), mat)
        settings(s, res=(RES, RES), samples=64, integrator="path")
        alphas.append(render(renderer, s)["color"][4:-4, 4:-4, 3].mean())
    assert alphas[0] == pytest.approx(0.6, abs=0.03) and alphas[1] == pytest.approx(alphas[0], abs=0.03), alphas


@pytest.mark.parametrize("kind, space", [("png", "lin_rec709"), ("png", None), ("exr", "srgb_texture"), ("exr", None)])
def test_an_image_files_colour_space_metadata_decides_its_decoding(renderer, stage, tmp_path, kind, space):
    """The colorSpace metadata of an image node's file input: an 8-bit PNG marked lin_rec709
    is read as stored, a float EXR marked srgb_texture is decoded from sRGB; unmarked, the
    file's own encoding decides (an 8-bit PNG is sRGB, a float EXR linear)."""
    from images import write_png
    stored = np.array([128, 64, 200]) / 255.0
    path = str(tmp_path / ("t." + kind))
    if kind == "png":
        write_png(path, 1, 1, [[(128, 64, 200)]])
    else:
        write_exr(path, [[tuple(stored)]])
    srgb = kind == "png" if space is None else space == "srgb_texture"
    want = np.where(stored <= 0.04045, stored / 12.92, ((stored + 0.055) / 1.055) ** 2.4) if srgb else stored

    def build(s):
        out = _node(s, "I", "ND_image_color3", Sdf.ValueTypeNames.Color3f,
                    file=(Sdf.ValueTypeNames.Asset, path))
        if space:
            UsdShade.Shader(s.GetPrimAtPath("/Looks/G/I")).GetInput("file").GetAttr().SetColorSpace(space)
        return out
    ok, why = near(_glow_of(renderer, stage, build)["color"][..., :3], want)
    assert ok, (kind, space, why)


def _primary_matrix(primaries, white):
    """Linear RGB -> XYZ of a colour space from the (x, y) of its primaries and white (the
    textbook normalised primary matrix)."""
    xyz = lambda c: np.array([c[0] / c[1], 1.0, (1.0 - c[0] - c[1]) / c[1]])
    p = np.stack([xyz(c) for c in primaries], axis=1)
    return p * np.linalg.solve(p, xyz(white))


def _to_linear_rec709(stored, curve, primaries, white):
    """A file's stored values in a colour space as linear Rec.709: the curve undone, then XYZ,
    a Bradford adaptation to D65 for another white, and Rec.709's inverse matrix."""
    decode = {"lin": lambda v: v, "g22": lambda v: v ** 2.2,
              "srgb": lambda v: np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)}[curve]
    d65 = (0.3127, 0.3290)
    bradford = np.array([[0.8951, 0.2664, -0.1614], [-0.7502, 1.7135, 0.0367], [0.0389, -0.0685, 1.0296]])
    xyz = lambda c: np.array([c[0] / c[1], 1.0, (1.0 - c[0] - c[1]) / c[1]])
    adapt = np.linalg.inv(bradford) @ np.diag((bradford @ xyz(d65)) / (bradford @ xyz(white))) @ bradford
    rec709 = _primary_matrix([(0.64, 0.33), (0.30, 0.60), (0.15, 0.06)], d65)
    return np.linalg.inv(rec709) @ adapt @ _primary_matrix(primaries, white) @ decode(np.asarray(stored))


AP1 = ([(0.713, 0.293), (0.165, 0.830), (0.128, 0.044)], (0.32168, 0.33767))
P3 = ([(0.680, 0.320), (0.265, 0.690), (0.150, 0.060)], (0.3127, 0.3290))
REC709 = ([(0.64, 0.33), (0.30, 0.60), (0.15, 0.06)], (0.3127, 0.3290))


@pytest.mark.parametrize("space, curve, gamut", [
    ("acescg", "lin", AP1), ("lin_ap1_scene", "lin", AP1), ("srgb_ap1_scene", "srgb", AP1),
    ("lin_p3d65_scene", "lin", P3), ("srgb_displayp3", "srgb", P3), ("g22_rec709", "g22", REC709),
])
def test_an_image_file_in_another_colour_space_is_converted_to_linear_rec709(
        renderer, stage, tmp_path, space, curve, gamut):
    """A float EXR whose file input is marked with a colour space of other primaries (ACEScg,
    Display P3) or another curve glows as its values converted to linear Rec.709, the
    authored colours' space (the textbook conversion, computed here); before, they were
    taken as linear Rec.709 as stored."""
    stored = (0.5, 0.25, 0.78)
    path = str(tmp_path / "t.exr")
    write_exr(path, [[stored]])
    want = _to_linear_rec709(stored, curve, *gamut)

    def build(s):
        out = _node(s, "I", "ND_image_color3", Sdf.ValueTypeNames.Color3f,
                    file=(Sdf.ValueTypeNames.Asset, path))
        UsdShade.Shader(s.GetPrimAtPath("/Looks/G/I")).GetInput("file").GetAttr().SetColorSpace(space)
        return out
    got = _glow_of(renderer, stage, build)["color"][..., :3]
    ok, why = near(got, want)
    assert ok, (space, why)
    assert np.abs(got.reshape(-1, 3).mean(axis=0) - stored).max() > 0.02, "the conversion shows"


def test_an_unknown_colour_space_is_named_and_the_file_decides(renderer, stage, tmp_path):
    path = str(tmp_path / "t.exr")
    write_exr(path, [[(0.5, 0.25, 0.78)]])
    top_camera(stage)
    m = panel(stage, "/Panel", columns=1, st=True)
    mat, sh = _standard_surface(stage, "/Looks/G", base=0.0, specular=0.0, emission=1.0)
    img = _node(stage, "I", "ND_image_color3", Sdf.ValueTypeNames.Color3f,
                file=(Sdf.ValueTypeNames.Asset, path))
    UsdShade.Shader(stage.GetPrimAtPath("/Looks/G/I")).GetInput("file").GetAttr().SetColorSpace("my_log_space")
    sh.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(img)
    bind(m.GetPrim(), mat)
    settings(stage, res=(RES, RES), samples=8, integrator="path")
    problems = []
    got = render(renderer, stage, problems)["color"][..., :3]
    named = [p for p in problems if p.prim == "/Looks/G/I" and p.attribute == "inputs:file"]
    assert len(named) == 1 and "my_log_space" in named[0].message, problems
    ok, why = near(got, (0.5, 0.25, 0.78))
    assert ok, why


def _bspline(t):
    """The uniform cubic B-spline kernel."""
    t = np.abs(t)
    return np.where(t < 1, (4 - 6 * t ** 2 + 3 * t ** 3) / 6, np.where(t < 2, (2 - t) ** 3 / 6, 0.0))


@pytest.mark.parametrize("filtertype", ["linear", "closest", "cubic"])
def test_an_image_with_closest_filtering_shows_its_texels_unblended(renderer, stage, tmp_path, filtertype):
    """A 2 x 1 image, red | green, across the panel: `closest` gives the left half pure red and
    the right half pure green (a texel per half, the edge at the middle); `linear` blends them
    linearly between the texel centres (u = 1/4 and 3/4); `cubic` by the cubic B-spline over
    the texels (clamped: red to the left, green to the right), a smooth step that still
    blends at the texel centres."""
    path = str(tmp_path / "rg.exr")
    write_exr(path, [[(1.0, 0.0, 0.0), (0.0, 1.0, 0.0)]])

    def build(s):
        return _node(s, "I", "ND_image_color3", Sdf.ValueTypeNames.Color3f,
                     file=(Sdf.ValueTypeNames.Asset, path), filtertype=(Sdf.ValueTypeNames.String, filtertype),
                     uaddressmode=(Sdf.ValueTypeNames.String, "clamp"))
    img = _glow_of(renderer, stage, build, res=32)["color"][..., :3].astype(np.float64)
    # the red of each column (the panel spans the image: column i is at u = (i + 0.5) / RES),
    # averaged down the column; the pixels next to the middle see both halves through the
    # pixel filter
    red = img[:, :, 0].mean(axis=0)
    u = (np.arange(RES) + 0.5) / RES
    want = {"closest": (u < 0.5).astype(float), "linear": np.clip(1.5 - 2 * u, 0, 1),
            # texel i (centre at x = i, x = 2u - 1/2) is red for i <= 0
            "cubic": sum(_bspline(2 * u - 0.5 - i) for i in range(-3, 1))}[filtertype]
    away = np.abs(u - 0.5) > 1.5 / RES
    assert np.abs(red - want)[away].max() < 0.05, (red, want)


def _doubling_chain(stage, n):
    """Glow G_n where G_0 = 0.5 + 0 x (the texture coordinates' u) and G_k = G_(k-1) x G_(k-1):
    0.5^(2^n), each node read twice by the next: its expression spells out 2^n copies of the
    first."""
    node = lambda name, node_id, **inputs: shader_node(stage, "/Looks/G/" + name, node_id, **inputs)
    uv = node("UV", "ND_texcoord_vector2").CreateOutput("out", Sdf.ValueTypeNames.Float2)
    u = node("U", "ND_extract_vector2", **{"in": uv}).CreateOutput("out", Sdf.ValueTypeNames.Float)
    zero = node("Z", "ND_multiply_float", in1=u, in2=0.0).CreateOutput("out", Sdf.ValueTypeNames.Float)
    g = node("G0", "ND_add_float", in1=zero, in2=0.5).CreateOutput("out", Sdf.ValueTypeNames.Float)
    for k in range(1, n + 1):
        g = node("G%d" % k, "ND_multiply_float", in1=g, in2=g).CreateOutput("out", Sdf.ValueTypeNames.Float)
    return node("C", "ND_convert_float_color3", **{"in": g}).CreateOutput("out", Sdf.ValueTypeNames.Color3f)


@pytest.mark.parametrize("n", [2, 24])
def test_a_node_reused_along_many_paths_is_bounded(renderer, stage, n):
    """A chain of n nodes each multiplying the one before by itself: two steps glow
    0.5^4 = 0.0625; 24 steps would spell out 2^24 copies of the first node (some 24 GB, the
    process was killed), and are named once instead, on the input whose graph passes the
    bound, with the rest rendering."""
    top_camera(stage)
    m = panel(stage, "/Panel", columns=1)
    mat, sh = _standard_surface(stage, "/Looks/G", base=0.0, specular=0.0, emission=1.0)
    sh.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(_doubling_chain(stage, n))
    bind(m.GetPrim(), mat)
    settings(stage, res=(RES, RES), samples=8, integrator="path")
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3]
    if n == 2:
        assert problems == [], problems
        ok, why = near(img, (0.0625,) * 3)
        assert ok, why
    else:
        assert len(problems) == 1 and "operations" in problems[0].message, problems
        assert img.max() < 1.01 and np.isfinite(img).all()


def test_a_cycle_in_a_node_graph_is_cut_and_named_once(renderer, stage):
    """A = B x B, B = A + 0.2: the cycle is named once, on the input that closes it (B.in1,
    listing A -> B -> A), which reads its default (add's 0); the rest of the graph renders:
    B = 0 + 0.2, the glow A = 0.04. It was named at every node as a chain of more than 64."""
    def build(s):
        a = UsdShade.Shader.Define(s, "/Looks/G/A")
        a.CreateIdAttr("ND_multiply_color3")
        b = UsdShade.Shader.Define(s, "/Looks/G/B")
        b.CreateIdAttr("ND_add_color3")
        a_out = a.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
        b_out = b.CreateOutput("out", Sdf.ValueTypeNames.Color3f)
        for k in ("in1", "in2"):
            a.CreateInput(k, Sdf.ValueTypeNames.Color3f).ConnectToSource(b_out)
        b.CreateInput("in1", Sdf.ValueTypeNames.Color3f).ConnectToSource(a_out)
        b.CreateInput("in2", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.2, 0.2, 0.2))
        return a_out
    top_camera(stage)
    m = panel(stage, "/Panel", columns=1)
    mat, sh = _standard_surface(stage, "/Looks/G", base=0.0, specular=0.0, emission=1.0)
    sh.CreateInput("emission_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(build(stage))
    bind(m.GetPrim(), mat)
    settings(stage, res=(RES, RES), samples=8, integrator="path")
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3]
    assert [(p.prim, p.attribute) for p in problems] == [("/Looks/G/B", "inputs:in1")], problems
    assert "/Looks/G/A → /Looks/G/B → /Looks/G/A" in problems[0].message, problems[0].message
    ok, why = near(img, (0.04, 0.04, 0.04))
    assert ok, why
