"""Primvars into materials: UsdPrimvarReader outputs connected to UsdPreviewSurface inputs
(per face, per vertex, per point, constant), texture coordinates from a primvar other than st,
an unbound gprim's varying displayColor, and a wetness mask (`tide:wet:amount` connected to a
texture or a primvar reader). Emission seen directly and diffuse surfaces under a white dome
read their values back."""
import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

from conftest import (HALF, RES, bind, camera, lambert_material, near, panel, render, settings,
                      shader_node, top_camera, white_dome, write_exr)


def _black(stage, path):
    """A black Lambertian UsdPreviewSurface material and its shader, to glow through its
    emissiveColor."""
    mat = lambert_material(stage, path, (0, 0, 0))
    return mat, UsdShade.Shader(stage.GetPrimAtPath(path + "/S"))


def _glow(stage, reader_id, varname, out_type, fallback=None):
    """A black surface whose emissiveColor is a primvar reader's result."""
    mat, sh = _black(stage, "/Looks/Glow")
    rd = UsdShade.Shader.Define(stage, "/Looks/Glow/Reader")
    rd.CreateIdAttr(reader_id)
    rd.CreateInput("varname", Sdf.ValueTypeNames.Token).Set(varname)
    if fallback is not None:
        rd.CreateInput("fallback", out_type).Set(fallback)
    rd.CreateOutput("result", out_type)
    sh.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(rd.ConnectableAPI(), "result")
    return mat


def _glowing_texture(stage, path, file, source=None, file_space=None):
    """A black material glowing with a clamped UsdUVTexture of `file` (its `sourceColorSpace`
    and the file attribute's colour space metadata where given)."""
    mat, sh = _black(stage, path)
    tex = UsdShade.Shader.Define(stage, path + "/Tex")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(file)
    if file_space:
        tex.GetInput("file").GetAttr().SetColorSpace(file_space)
    if source:
        tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set(source)
    for wrap in ("wrapS", "wrapT"):
        tex.CreateInput(wrap, Sdf.ValueTypeNames.Token).Set("clamp")
    tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    sh.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
    return mat


def _seen(stage, samples=16):
    """Settings for emission seen directly."""
    settings(stage, res=(RES, RES), samples=samples, integrator="path")


def test_a_per_face_primvar_colours_each_face(renderer, stage):
    top_camera(stage)
    m = panel(stage, "/Panel")
    glow = [(0.8, 0.2, 0.1), (0.1, 0.3, 0.9)]
    UsdGeom.PrimvarsAPI(m.GetPrim()).CreatePrimvar("glow", Sdf.ValueTypeNames.Color3fArray,
                                                   UsdGeom.Tokens.uniform).Set(glow)
    bind(m.GetPrim(), _glow(stage, "UsdPrimvarReader_float3", "glow", Sdf.ValueTypeNames.Float3))
    _seen(stage)
    img = render(renderer, stage)["color"][..., :3].astype(np.float64)
    # emission seen directly, through the spectral round trip: 1 %
    left, right = img[:, 2:RES // 2 - 2], img[:, RES // 2 + 2:-2]
    ok, why = near(left, glow[0])
    assert ok, why
    ok, why = near(right, glow[1])
    assert ok, why


@pytest.mark.parametrize("on_parent", [False, True])
def test_a_primvar_of_one_vector_value_is_that_vector(renderer, stage, on_parent):
    """A constant primvar authored as one color3f (not an array), on the gprim or inherited
    from its parent, reads as that colour through UsdPrimvarReader_float3."""
    top_camera(stage)
    UsdGeom.Xform.Define(stage, "/G")
    m = panel(stage, "/G/Panel")
    owner = stage.GetPrimAtPath("/G") if on_parent else m.GetPrim()
    glow = (0.2, 0.9, 0.3)
    UsdGeom.PrimvarsAPI(owner).CreatePrimvar("glow", Sdf.ValueTypeNames.Color3f,
                                             UsdGeom.Tokens.constant).Set(Gf.Vec3f(*glow))
    bind(m.GetPrim(), _glow(stage, "UsdPrimvarReader_float3", "glow", Sdf.ValueTypeNames.Float3))
    _seen(stage)
    ok, why = near(render(renderer, stage)["color"][..., :3], glow)
    assert ok, why


def test_a_per_vertex_primvar_is_interpolated_across_the_face(renderer, stage):
    """A scalar 0 at x = -HALF and 1 at x = HALF, read by UsdPrimvarReader_float into a colour
    input (a scalar fills the three components): each column glows (x + HALF) / (2 HALF)."""
    top_camera(stage)
    m = panel(stage, "/Panel", columns=1)
    heat = [0.0, 0.0, 1.0, 1.0]  # points (-H,-H) (-H,H) (H,-H) (H,H)
    UsdGeom.PrimvarsAPI(m.GetPrim()).CreatePrimvar("heat", Sdf.ValueTypeNames.FloatArray,
                                                   UsdGeom.Tokens.vertex).Set(heat)
    bind(m.GetPrim(), _glow(stage, "UsdPrimvarReader_float", "heat", Sdf.ValueTypeNames.Float))
    _seen(stage)
    img = render(renderer, stage)["color"][..., :3].astype(np.float64)
    for i in range(RES):
        ok, why = near(img[:, i], (i + 0.5) / RES)
        assert ok, (i, why)


def test_an_absent_primvar_gives_the_readers_fallback(renderer, stage):
    top_camera(stage)
    m = panel(stage, "/Panel")
    bind(m.GetPrim(), _glow(stage, "UsdPrimvarReader_float3", "nowhere",
                            Sdf.ValueTypeNames.Float3, Gf.Vec3f(0.2, 0.4, 0.6)))
    _seen(stage, samples=4)
    ok, why = near(render(renderer, stage)["color"][..., :3], (0.2, 0.4, 0.6))
    assert ok, why


def test_varying_display_colors_of_an_unbound_mesh(renderer, stage):
    """Under a white dome of radiance 1 a Lambertian surface that sees the whole sky reflects
    its albedo: each face of an unbound mesh its own displayColor."""
    top_camera(stage)
    white_dome(stage)
    m = panel(stage, "/Panel")
    faces = [(0.7, 0.3, 0.2), (0.2, 0.5, 0.6)]
    UsdGeom.PrimvarsAPI(m.GetPrim()).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                   UsdGeom.Tokens.uniform).Set(faces)
    settings(stage, res=(RES, RES), samples=16, integrator="path", maxDepth=1)
    img = render(renderer, stage)["color"][..., :3]
    for part, want in ((img[:, 1:RES // 2 - 1], faces[0]), (img[:, RES // 2 + 1:-1], faces[1])):
        ok, why = near(part, want)
        assert ok, why


def test_varying_display_colors_of_unbound_points(renderer, stage):
    """The same for the spheres of a Points prim with a displayColor per point, seen at their
    tops (which see the whole sky: the other ball lies below their horizon)."""
    top_camera(stage)
    white_dome(stage)
    pts = UsdGeom.Points.Define(stage, "/Balls")
    pts.CreatePointsAttr([(-1, 0, 0), (1, 0, 0)])
    pts.CreateWidthsAttr([0.8, 0.8])
    balls = [(0.9, 0.9, 0.1), (0.1, 0.8, 0.3)]
    pts.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex).Set(balls)
    settings(stage, res=(RES, RES), samples=64, integrator="path", maxDepth=1)
    img = render(renderer, stage)["color"][..., :3]
    # x = -1 and 1 are the columns around RES/4 and 3 RES/4; z = 0 the middle rows
    for col, want in ((RES // 4, balls[0]), (3 * RES // 4, balls[1])):
        ok, why = near(img[RES // 2 - 1:RES // 2 + 1, col - 1:col + 1], want)
        assert ok, why


def test_texture_coordinates_from_another_primvar(renderer, stage, tmp_path):
    """A texture red on its left half and blue on its right, read through st1 (the panel's st
    is all zero): the panel shows it mirrored, as st1 runs from 1 at x = -HALF to 0."""
    tex_file = tmp_path / "halves.exr"
    write_exr(tex_file, [[(1, 0, 0), (1, 0, 0), (0, 0, 1), (0, 0, 1)]])
    top_camera(stage)
    m = panel(stage, "/Panel", columns=1)
    pv = UsdGeom.PrimvarsAPI(m.GetPrim())
    pv.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set([(0, 0)] * 4)
    pv.CreatePrimvar("st1", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
        [(1, 0), (1, 1), (0, 0), (0, 1)])
    mat, sh = _black(stage, "/Looks/T")
    tex = UsdShade.Shader.Define(stage, "/Looks/T/Tex")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(str(tex_file))
    tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set("clamp")
    tex.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set("clamp")
    tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    uv = UsdShade.Shader.Define(stage, "/Looks/T/Uv")
    uv.CreateIdAttr("UsdPrimvarReader_float2")
    uv.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st1")
    uv.CreateOutput("result", Sdf.ValueTypeNames.Float2)
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(uv.ConnectableAPI(), "result")
    sh.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
    bind(m.GetPrim(), mat)
    _seen(stage, samples=4)
    img = render(renderer, stage)["color"][..., :3].astype(np.float64)
    for part, want in ((img[:, :RES // 4], (0, 0, 1)), (img[:, -RES // 4:], (1, 0, 0))):
        ok, why = near(part, want)
        assert ok, why


@pytest.mark.parametrize("wrap_s, metadata, beyond", [
    (None, None, 0.0),                  # useMetadata, a file without wrap metadata: black
    (None, "periodic,periodic", 1.0),   # the file's own wrap mode (what maketx writes)
    (None, "black,periodic", 0.0),
    ("repeat", "black,black", 1.0),     # an authored wrap overrides the file's
])
def test_use_metadata_wrap_is_the_files_own_else_black(renderer, stage, tmp_path, wrap_s, metadata, beyond):
    """UsdUVTexture's default wrap, useMetadata, takes the file's wrap metadata, and is black
    where the file names none. A green texture glows through a quad whose s runs from 0 to 2:
    the half within [0, 1] is green; the half beyond shows the wrap."""
    tex_file = tmp_path / "green.exr"
    write_exr(tex_file, [[(0, 1, 0)] * 4] * 4, **({"wrapmodes": metadata} if metadata else {}))
    top_camera(stage)
    m = panel(stage, "/Panel", columns=1)
    UsdGeom.PrimvarsAPI(m.GetPrim()).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
        [(0, 0), (0, 1), (2, 0), (2, 1)])
    mat, sh = _black(stage, "/Looks/T")
    tex = UsdShade.Shader.Define(stage, "/Looks/T/Tex")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(str(tex_file))
    if wrap_s:
        tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set(wrap_s)
    tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    sh.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
    bind(m.GetPrim(), mat)
    _seen(stage, samples=4)
    img = render(renderer, stage)["color"][..., :3].astype(np.float64)
    # columns RES/8 .. 3 RES/8 see s in [0.25, 0.75]; 5 RES/8 .. 7 RES/8 see s in [1.25, 1.75];
    # rows within t in [0.125, 0.875] are clear of the black border t's wrap blends in
    rows = img[RES // 8 + 1:7 * RES // 8 - 1]
    inside, outside = rows[:, RES // 8 + 1:3 * RES // 8 - 1], rows[:, 5 * RES // 8 + 1:7 * RES // 8 - 1]
    for part, want in ((inside, (0, 1, 0)), (outside, (0, beyond, 0))):
        ok, why = near(part, want)
        assert ok, why


def test_an_8_bit_texture_is_decoded_once_by_each_materials_colour_space(renderer, stage, tmp_path):
    """One 8-bit RGB PNG glows through three quads whose UsdUVTextures read it as `raw`, `auto`
    and `sRGB`: raw shows the stored values, the other two their sRGB decoding (an 8-bit RGB
    file without other tags is sRGB to `auto`, as UsdImaging reads it), each decoded once
    whatever the order the materials load it in."""
    from images import write_png
    texel = (90, 40, 200)
    png = str(tmp_path / "swatch.png")
    write_png(png, 1, 1, [[texel]])
    stored = np.array(texel) / 255.0
    decoded = np.where(stored <= 0.04045, stored / 12.92, ((stored + 0.055) / 1.055) ** 2.4)
    top_camera(stage)
    third = 2 * HALF / 3
    for k, space in enumerate(("raw", "auto", "sRGB")):
        m = UsdGeom.Mesh.Define(stage, "/Q%d" % k)
        x0 = -HALF + k * third
        m.CreatePointsAttr([(x0, 0, -HALF), (x0, 0, HALF), (x0 + third, 0, HALF), (x0 + third, 0, -HALF)])
        m.CreateFaceVertexCountsAttr([4])
        m.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
        bind(m.GetPrim(), _glowing_texture(stage, "/Looks/M%d" % k, png, space))
    _seen(stage, samples=4)
    img = render(renderer, stage)["color"][..., :3].astype(np.float64)
    cols = RES // 3
    for k, want in enumerate((stored, decoded, decoded)):
        part = img[:, k * cols + 2:(k + 1) * cols - 2]
        ok, why = near(part, want)
        assert ok, (("raw", "auto", "sRGB")[k], why)


@pytest.mark.parametrize("kind, source, space", [
    ("png", None, "lin_rec709"), ("png", "sRGB", "lin_rec709"), ("exr", None, "acescg"),
    ("exr", "raw", "acescg"), ("exr", None, "srgb_texture")])
def test_a_uv_textures_file_colour_space_decides_where_its_source_colour_space_is_auto(
        renderer, stage, tmp_path, kind, source, space):
    """The colour space metadata of a UsdUVTexture's file (USD's per-attribute colour space)
    decides the decoding where `sourceColorSpace` leaves it to `auto` (unauthored): an 8-bit
    PNG marked lin_rec709 shows its stored values, not its sRGB decoding; an EXR marked acescg
    its values converted to linear Rec.709 (ACEScg's published matrix). An explicit `raw` or
    `sRGB` says how the file is encoded and wins."""
    from images import write_png
    texel = (90, 40, 200)
    stored = np.array(texel) / 255.0
    path = str(tmp_path / ("t." + kind))
    if kind == "png":
        write_png(path, 1, 1, [[texel]])
    else:
        write_exr(path, [[tuple(stored)]])
    srgb = lambda v: np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)
    acescg_to_rec709 = np.array([[1.70505, -0.62179, -0.08326], [-0.13026, 1.14080, -0.01055],
                                 [-0.02400, -0.12897, 1.15297]])
    want = {("png", None): stored, ("png", "sRGB"): srgb(stored),
            ("exr", None): acescg_to_rec709 @ stored if space == "acescg" else srgb(stored),
            ("exr", "raw"): stored}[(kind, source)]
    top_camera(stage)
    m = panel(stage, "/Panel", columns=1, st=True)
    bind(m.GetPrim(), _glowing_texture(stage, "/Looks/M", path, source, file_space=space))
    _seen(stage, samples=8)
    ok, why = near(render(renderer, stage)["color"][..., :3], want)
    assert ok, (kind, source, space, why)


@pytest.mark.parametrize("source", ["texture", "constant", "primvar"])
@pytest.mark.parametrize("tilt,n_dot_l", [((1, 0), 0.25), ((0, 1), 1.0), ((0, -1), 0.0)])
def test_a_normal_map_shades_as_the_surface_turned_to_its_normal(renderer, tmp_path, tilt, n_dot_l, source):
    """A white UsdPreviewSurface panel facing +Y (u along +x, v along +z), seen from above under
    a sun from (0, cos 60, sin 60), with a tangent-space normal tilting its normal 60 degrees
    towards +u, +v or -v, shades as the same panel turned by 60 degrees that way without one:
    same normal, light and view, so the same radiance. The normal comes from a texture (holding
    (n + 1) / 2, turned back by UsdUVTexture's scale and bias as UsdPreviewSurface's `normal`
    expects), is authored as a constant, or is read from a constant primvar by a
    UsdPrimvarReader. Towards -v the normal faces away from the sun: black."""
    import math
    from pxr import Usd, UsdLux

    def scene(mapped):
        stage = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
        top_camera(stage)
        m = panel(stage, "/Panel", columns=1, st=True)
        mat, sh = _white_specless(stage)
        s60, c60 = math.sin(math.radians(60)), math.cos(math.radians(60))
        n = (tilt[0] * s60, tilt[1] * s60, c60)
        if mapped and source == "constant":
            sh.CreateInput("normal", Sdf.ValueTypeNames.Normal3f).Set(Gf.Vec3f(*n))
        elif mapped and source == "primvar":
            pv = UsdGeom.PrimvarsAPI(m.GetPrim()).CreatePrimvar("tilted", Sdf.ValueTypeNames.Normal3f, UsdGeom.Tokens.constant)
            pv.Set(Gf.Vec3f(*n))
            reader = UsdShade.Shader.Define(stage, "/Looks/W/Tilt")
            reader.CreateIdAttr("UsdPrimvarReader_normal")
            reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("tilted")
            out = reader.CreateOutput("result", Sdf.ValueTypeNames.Normal3f)
            sh.CreateInput("normal", Sdf.ValueTypeNames.Normal3f).ConnectToSource(out)
        elif mapped:
            f = tmp_path / "normal.exr"
            write_exr(f, [[tuple((c + 1) / 2 for c in n)]])
            tex = UsdShade.Shader.Define(stage, "/Looks/W/N")
            tex.CreateIdAttr("UsdUVTexture")
            tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(str(f))
            tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
            tex.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(2, 2, 2, 1))
            for wrap in ("wrapS", "wrapT"):
                tex.CreateInput(wrap, Sdf.ValueTypeNames.Token).Set("clamp")
            tex.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(-1, -1, -1, 0))
            out = tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
            sh.CreateInput("normal", Sdf.ValueTypeNames.Normal3f).ConnectToSource(out)
        elif tilt[0]:
            m.AddRotateZOp().Set(-60.0 * tilt[0])        # +Y turned towards +x
        else:
            m.AddRotateXOp().Set(60.0 * tilt[1])         # +Y turned towards +z
        bind(m.GetPrim(), mat)
        sun = UsdLux.DistantLight.Define(stage, "/Sun")
        sun.CreateIntensityAttr(math.pi)
        sun.CreateAngleAttr(0.0)
        sun.AddRotateXOp().Set(-30.0)                   # arriving from (0, cos 60, sin 60)
        settings(stage, res=(RES, RES), samples=64, integrator="path", maxDepth=1)
        img = render(renderer, stage)["color"][..., :3].astype(np.float64)
        # the middle, which the turned panel (half as wide seen from above) covers too
        return img[3 * RES // 8:5 * RES // 8, 3 * RES // 8:5 * RES // 8]

    mapped, turned = scene(True), scene(False)
    assert abs(mapped.mean() - turned.mean()) <= 0.02 * turned.mean() + 1e-3, (mapped.mean(), turned.mean())
    # the turned panel itself: black where it faces away from the sun, lit otherwise
    assert (turned.mean() > 0.1) == (n_dot_l > 0), turned.mean()


def _white_specless(stage):
    mat = lambert_material(stage, "/Looks/W", (1, 1, 1))
    return mat, UsdShade.Shader(stage.GetPrimAtPath("/Looks/W/S"))


def _wet_stage(amount, connect=None):
    """A grey Lambertian panel under the white dome wearing TideWetAPI with `amount` (the
    authored value) and, with `connect`, a function that authors its mask and connects it."""
    s = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
    top_camera(s)
    white_dome(s)
    m = panel(s, "/Panel")
    mat = lambert_material(s, "/Looks/Grey", (0.5, 0.5, 0.5))
    mat.GetPrim().ApplyAPI("TideWetAPI")
    attr = mat.GetPrim().GetAttribute("tide:wet:amount")
    attr.Set(amount)
    if connect is not None:
        connect(s, m, mat, attr)
    bind(m.GetPrim(), mat)
    settings(s, res=(RES, RES), samples=16, integrator="path", maxDepth=2)
    return s


@pytest.mark.parametrize("mask", ["texture", "primvar", "position"])
def test_a_wetness_mask_wets_where_it_says(renderer, tmp_path, mask):
    """The left half wet (mask 1) and the right half dry (mask 0) match, pixel for pixel, the
    panel wet all over and dry all over; the authored amount (0.5) is not used. The mask is a
    texture, a per-face primvar, or MaterialX nodes on the position (wet where x < 0: the
    way wet sand below a waterline is made)."""
    def by_texture(s, m, mat, attr):
        f = tmp_path / "mask.exr"
        write_exr(f, [[(1, 1, 1), (1, 1, 1), (0, 0, 0), (0, 0, 0)]])
        tex = UsdShade.Shader.Define(s, "/Looks/Grey/Mask")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(str(f))
        tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set("clamp")
        tex.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set("clamp")
        out = tex.CreateOutput("r", Sdf.ValueTypeNames.Float)
        UsdGeom.PrimvarsAPI(m.GetPrim()).CreatePrimvar(
            "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
            [(0, 0), (0, 1), (0.5, 0), (0.5, 1), (1, 0), (1, 1)])
        attr.AddConnection(out.GetAttr().GetPath())

    def by_primvar(s, m, mat, attr):
        UsdGeom.PrimvarsAPI(m.GetPrim()).CreatePrimvar(
            "wetness", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.uniform).Set([1.0, 0.0])
        rd = UsdShade.Shader.Define(s, "/Looks/Grey/Wet")
        rd.CreateIdAttr("UsdPrimvarReader_float")
        rd.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("wetness")
        out = rd.CreateOutput("result", Sdf.ValueTypeNames.Float)
        attr.AddConnection(out.GetAttr().GetPath())

    def by_position(s, m, mat, attr):
        node = lambda name, node_id, **inputs: shader_node(s, "/Looks/Grey/" + name, node_id, **inputs)
        p = node("P", "ND_position_vector3").CreateOutput("out", Sdf.ValueTypeNames.Float3)
        x = node("X", "ND_extract_vector3", **{"in": p}).CreateOutput("out", Sdf.ValueTypeNames.Float)
        below = node("Below", "ND_ifgreater_float", value1=0.0, value2=x, in1=1.0, in2=0.0)
        attr.AddConnection(below.CreateOutput("out", Sdf.ValueTypeNames.Float).GetAttr().GetPath())

    connect = {"texture": by_texture, "primvar": by_primvar, "position": by_position}[mask]
    masked = render(renderer, _wet_stage(0.5, connect))
    wet = render(renderer, _wet_stage(1.0))["color"][..., :3].astype(np.float64)
    dry = render(renderer, _wet_stage(0.0))["color"][..., :3].astype(np.float64)
    half = render(renderer, _wet_stage(0.5))["color"][..., :3].astype(np.float64)
    got = masked["color"][..., :3].astype(np.float64)
    # a texel's bilinear blend reaches a quarter of the panel from the middle: compare the
    # outer quarters, where the mask is 1 and 0
    q = RES // 4
    if mask != "texture":
        q = RES // 2 - 1
    assert np.allclose(got[:, :q], wet[:, :q], rtol=1e-4, atol=1e-5)
    assert np.allclose(got[:, -q:], dry[:, -q:], rtol=1e-4, atol=1e-5)
    # the film darkens, so the test can tell wet from dry and from the authored half amount
    assert wet.mean() < 0.9 * half.mean() < 0.9 * dry.mean(), (wet.mean(), half.mean(), dry.mean())


def tops(img, xs):
    """The 2 x 2 pixels around the top of an object centred at x (and z = 0) in the top view."""
    cols = [int(round((x + HALF) / (2 * HALF) * RES)) for x in xs]
    return [img[RES // 2 - 1:RES // 2 + 1, c - 1:c + 1] for c in cols]


def test_a_point_instancers_per_instance_colours(renderer, stage):
    """A PointInstancer's displayColor with one value per instance colours each instance,
    whichever prototype it places; a masked instance takes its colour along."""
    top_camera(stage)
    white_dome(stage)
    inst = UsdGeom.PointInstancer.Define(stage, "/Inst")
    protos = stage.DefinePrim("/Inst/Protos", "Scope")
    UsdGeom.Sphere.Define(stage, "/Inst/Protos/Ball").CreateRadiusAttr(0.4)
    UsdGeom.Cube.Define(stage, "/Inst/Protos/Box").CreateSizeAttr(0.8)
    inst.CreatePrototypesRel().SetTargets([protos.GetPath().AppendChild("Ball"),
                                           protos.GetPath().AppendChild("Box")])
    xs = [-1.5, -0.5, 0.5, 1.5, 1.9]
    inst.CreateProtoIndicesAttr([0, 1, 0, 1, 0])
    inst.CreatePositionsAttr([(x, 0, 0) for x in xs])
    colours = [(0.8, 0.2, 0.2), (0.2, 0.7, 0.2), (0.2, 0.3, 0.9), (0.9, 0.8, 0.1), (0, 0, 0)]
    UsdGeom.PrimvarsAPI(inst.GetPrim()).CreatePrimvar(
        "displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.vertex).Set(colours)
    inst.DeactivateId(4)
    settings(stage, res=(RES, RES), samples=64, integrator="path", maxDepth=1)
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3]
    assert problems == [], problems
    for part, want in zip(tops(img, xs[:4]), colours):
        ok, why = near(part, want)
        assert ok, why


@pytest.mark.parametrize("missing", [None, 0, 1])
def test_native_instances_inherit_their_own_colours(renderer, stage, missing):
    """Instanceable prims sharing one prototype, each with its own displayColor: every
    instance shows the colour its instance prim gives (the prototype authors none). An
    instance whose prim gives none (`missing`) is an unbound gprim without displayColor
    (grey 0.18) and changes no other's colour."""
    top_camera(stage)
    white_dome(stage)
    proto = stage.DefinePrim("/Proto", "Xform")
    UsdGeom.Sphere.Define(stage, "/Proto/Ball").CreateRadiusAttr(0.4)
    xs = [-1.5, 0.0, 1.5]
    colours = [(0.8, 0.3, 0.2), (0.2, 0.6, 0.3), (0.3, 0.2, 0.8)]
    for i, (x, c) in enumerate(zip(xs, colours)):
        x_ = UsdGeom.Xform.Define(stage, "/World/I%d" % i)
        x_.AddTranslateOp().Set(Gf.Vec3d(x, 0, 0))
        p = x_.GetPrim()
        p.GetReferences().AddInternalReference(proto.GetPath())
        p.SetInstanceable(True)
        if i != missing:
            UsdGeom.PrimvarsAPI(p).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                 UsdGeom.Tokens.constant).Set([c])
    if missing is not None:
        colours[missing] = (0.18, 0.18, 0.18)
    proto.SetSpecifier(Sdf.SpecifierClass)
    settings(stage, res=(RES, RES), samples=64, integrator="path", maxDepth=1)
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3]
    assert problems == [], problems
    for part, want in zip(tops(img, xs), colours):
        ok, why = near(part, want)
        assert ok, why


def test_display_opacity_of_unbound_gprims(renderer, stage):
    """displayOpacity makes an unbound gprim thin-transparent, per face where it varies: black
    surfaces against a white dome show 1 - opacity of the sky through each crossing (a ball's
    front and back both)."""
    top_camera(stage)
    white_dome(stage)
    m = panel(stage, "/Panel")
    m.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([(0, 0, 0)])
    m.CreateDisplayOpacityPrimvar(UsdGeom.Tokens.uniform).Set([1.0, 0.25])
    pts = UsdGeom.Points.Define(stage, "/Ball")
    pts.CreatePointsAttr([(1, 1, 0)])
    pts.CreateWidthsAttr([1.0])
    pts.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([(0, 0, 0)])
    pts.CreateDisplayOpacityPrimvar(UsdGeom.Tokens.constant).Set([0.5])
    settings(stage, res=(RES, RES), samples=64, integrator="path")
    img = render(renderer, stage)["color"][..., :3]
    # the left face is opaque black; the right face lets 0.75 through where no ball covers it
    for part, want in ((img[:, 1:RES // 2 - 1], 0.0), (img[-6:, RES // 2 + 1:-1], 0.75)):
        ok, why = near(part, want)
        assert ok, why
    # the ball's top over the panel: 0.5 through each of its two crossings, then the face
    ok, why = near(tops(img, [1.0]), 0.75 * 0.25)
    assert ok, why


def test_emission_varying_over_a_mesh_lights_as_it_glows(renderer, stage):
    """A large panel whose glow (a per-vertex primvar) rises linearly from 0 at x = -20 to 1 at
    x = 20, 1 above a grey floor (albedo 0.5): under a plane of linearly varying radiance the
    floor's irradiance is pi L(x) (the odd part cancels), so it shows 0.5 L(x); the panel is
    sampled as a light with that radiance, and a light of the panel's mean radiance would show
    0.25 everywhere."""
    cam = camera(stage, pos=(0, 0.5, 0), aperture=(20 * HALF, 20 * HALF), projection="orthographic")
    cam.AddRotateXOp().Set(-90.0)
    m = UsdGeom.Mesh.Define(stage, "/Glow")
    m.CreatePointsAttr([(-20, 1, -20), (20, 1, -20), (20, 1, 20), (-20, 1, 20)])
    m.CreateFaceVertexCountsAttr([4])
    m.CreateFaceVertexIndicesAttr([0, 1, 2, 3])  # facing down (-Y)
    UsdGeom.PrimvarsAPI(m.GetPrim()).CreatePrimvar(
        "glow", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.vertex).Set(
        [(0, 0, 0), (1, 1, 1), (1, 1, 1), (0, 0, 0)])
    bind(m.GetPrim(), _glow(stage, "UsdPrimvarReader_float3", "glow", Sdf.ValueTypeNames.Float3))
    floor = panel(stage, "/Floor", columns=1)
    floor.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([(0.5, 0.5, 0.5)])
    settings(stage, res=(RES, RES), samples=64, integrator="path", maxDepth=1)
    img = render(renderer, stage)["color"][..., :3]
    for i in (2, RES // 2, RES - 3):
        x = -HALF + (i + 0.5) * 2 * HALF / RES
        ok, why = near(img[:, i], 0.5 * (0.5 + x / 40))
        assert ok, (i, why)


def test_a_primvar_reader_reads_the_texture_coordinates_it_names(renderer, stage, tmp_path):
    """UsdPrimvarReader: varname names the primvar read. The panel's st runs over the square
    (left texel red, right blue) and a constant `uv` sits on the right texel: a reader of `st`
    shows both halves, one of `uv` the blue texel everywhere, one of `st0` (which the panel
    lacks) its fallback (0.25, 0.5): the red texel."""
    tex_file = tmp_path / "halves.exr"
    write_exr(tex_file, [[(1, 0, 0), (0, 0, 1)]])
    top_camera(stage)
    panels = {}
    for k, name in enumerate(("st", "uv", "st0")):
        m = panel(stage, "/P_" + name, columns=1, st=True)
        UsdGeom.Xformable(m).AddTranslateOp().Set(Gf.Vec3d(0, -10 * k, 0))
        UsdGeom.PrimvarsAPI(m.GetPrim()).CreatePrimvar(
            "uv", Sdf.ValueTypeNames.TexCoord2f, UsdGeom.Tokens.constant).Set((0.75, 0.5))
        mat, sh = _black(stage, "/Looks/" + name)
        tex = UsdShade.Shader.Define(stage, "/Looks/%s/Tex" % name)
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(str(tex_file))
        tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set("clamp")
        tex.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set("clamp")
        tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
        rd = UsdShade.Shader.Define(stage, "/Looks/%s/Uv" % name)
        rd.CreateIdAttr("UsdPrimvarReader_float2")
        rd.CreateInput("varname", Sdf.ValueTypeNames.Token).Set(name)
        rd.CreateInput("fallback", Sdf.ValueTypeNames.Float2).Set((0.25, 0.5))
        rd.CreateOutput("result", Sdf.ValueTypeNames.Float2)
        tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(rd.ConnectableAPI(), "result")
        sh.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
        bind(m.GetPrim(), mat)
        panels[name] = m
    _seen(stage, samples=4)
    images = {}
    for k, name in enumerate(("st", "uv", "st0")):
        # only one panel in view at a time: the others below it are hidden
        for other, m in panels.items():
            UsdGeom.Imageable(m).GetVisibilityAttr().Set("inherited" if other == name else "invisible")
        images[name] = render(renderer, stage)["color"][..., :3].astype(np.float64)
    quarter = RES // 4
    for name, left, right in (("st", (1, 0, 0), (0, 0, 1)), ("uv", (0, 0, 1), (0, 0, 1)),
                              ("st0", (1, 0, 0), (1, 0, 0))):
        img = images[name]
        for part, want in ((img[:, :quarter], left), (img[:, -quarter:], right)):
            ok, why = near(part, want)
            assert ok, (name, why)
