"""UsdLuxShapingAPI: a spot light's cone, soft edge, focus and focus tint, rendered on a
Lambertian floor and compared with the schema's formulas evaluated here; what the reader sends;
and the problems bad shaping values give."""
import math

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux

from conftest import (bind, camera, exact_lambert_material, fwhm, lambert_material, load, near,
                      preview_material, render, settings, write_exr)

HEIGHT = 2.0          # the light above the floor
WIDTH = 4.0           # the floor seen by the orthographic camera (metres across the image)
RES = 64


def _spot_scene(stage, cone=35.0, softness=0.4, focus=2.0, tint=None, albedo=0.5,
                intensity=40.0):
    """A point spot light HEIGHT above a Lambertian floor, pointing straight down, seen from
    above by an orthographic camera WIDTH across."""
    cam = camera(stage, pos=(0, 5, 0), aperture=(WIDTH * 10, WIDTH * 10),
                 projection="orthographic")
    cam.AddRotateXOp().Set(-90.0)
    floor = UsdGeom.Mesh.Define(stage, "/Floor")
    s = 10.0
    floor.CreatePointsAttr([(-s, 0, -s), (s, 0, -s), (s, 0, s), (-s, 0, s)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 3, 2, 1])      # facing +Y
    bind(floor.GetPrim(), lambert_material(stage, "/Looks/Floor", (albedo,) * 3))
    light = UsdLux.SphereLight.Define(stage, "/Spot")
    light.CreateTreatAsPointAttr(True)
    light.CreateNormalizeAttr(True)
    light.CreateIntensityAttr(intensity)
    light.AddTranslateOp().Set(Gf.Vec3d(0, HEIGHT, 0))
    light.AddRotateXOp().Set(-90.0)                      # its -Z points down
    shaping = UsdLux.ShapingAPI.Apply(light.GetPrim())
    shaping.CreateShapingConeAngleAttr(cone)
    shaping.CreateShapingConeSoftnessAttr(softness)
    shaping.CreateShapingFocusAttr(focus)
    if tint is not None:
        shaping.CreateShapingFocusTintAttr(Gf.Vec3f(*tint))
    settings(stage, res=(RES, RES), samples=16, integrator="path")
    return light


def _profile(r, cone, softness, focus, tint_c, albedo, intensity):
    """Radiance of the floor at distance r from the light's foot, per the UsdLux schema:
    (ρ/π) I k(θ) (t + f(1 − t)) cos θ / d², θ the angle off the axis, I = intensity / 4 (a
    normalised point light, Tide's treatAsPoint limit of a sphere light)."""
    th = np.arctan2(r, HEIGHT)
    tc = math.radians(cone)
    ts = (1.0 - softness) * tc
    t = np.clip((th - ts) / max(tc - ts, 1e-12), 0.0, 1.0)
    k = np.where(th <= ts, 1.0, np.where(th >= tc, 0.0, 1.0 - t * t * (3.0 - 2.0 * t)))
    f = np.abs(np.cos(th)) ** focus
    d2 = HEIGHT ** 2 + r ** 2
    return albedo / math.pi * intensity / 4.0 * k * (tint_c + f * (1.0 - tint_c)) * np.cos(th) / d2


def _expected_image(tint_c, **kw):
    """The profile averaged over each pixel (box filter) on an 8 x 8 sub-grid."""
    sub = 8
    px = WIDTH / RES
    c = (np.arange(RES * sub) + 0.5) / (RES * sub) * WIDTH - WIDTH / 2
    x, z = np.meshgrid(c, c)
    v = _profile(np.hypot(x, z), tint_c=tint_c, **kw)
    return v.reshape(RES, sub, RES, sub).mean(axis=(1, 3)), px


def _floor_scale(renderer, stage_factory):
    """The floor's radiance under a straight-down sun of unit irradiance, over ρ/π: the
    UsdPreviewSurface's diffuse base seen and lit head-on (its grazing Schlick specular
    renormalises the base by a couple of percent), measured so the spot tests compare the
    emission profile alone. It changes by under 0.3% for incidence within 35° of the normal."""
    stage = stage_factory()
    _spot_scene(stage, cone=0.0)
    sun = UsdLux.DistantLight.Define(stage, "/Sun")
    sun.CreateIntensityAttr(1.0)
    sun.CreateNormalizeAttr(True)                        # intensity = irradiance
    sun.AddRotateXOp().Set(-90.0)                        # straight down
    img = render(renderer, stage)["color"][..., :3]
    scale = img.mean(axis=(0, 1)) / (0.5 / math.pi)
    assert np.all(np.abs(scale - 1.0) < 0.03), scale
    return scale


def _rings(img, px, width=2):
    c = (np.arange(RES) + 0.5) * px - WIDTH / 2
    x, z = np.meshgrid(c, c)
    ring = (np.hypot(x, z) / (width * px)).astype(int)
    n = ring.max() + 1
    return np.array([img[ring == i].mean() for i in range(n)])


def _new_stage():
    s = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
    return s


def test_spot_light_profile_follows_the_shaping_formulas(renderer, stage):
    kw = dict(cone=35.0, softness=0.4, focus=2.0, albedo=0.5, intensity=40.0)
    scale = _floor_scale(renderer, _new_stage)[0]
    _spot_scene(stage, **kw)
    img = render(renderer, stage)["color"][..., 0]
    want, px = _expected_image(0.0, **kw)
    want = want * scale
    got_r, want_r = _rings(img, px), _rings(want, px)
    peak = want_r.max()
    # ring means (each ring holds many pixels; the only noise is sub-pixel jitter)
    assert np.all(np.abs(got_r - want_r) <= 0.01 * want_r + 2e-3 * peak), \
        np.round(np.stack([got_r, want_r]), 4).tolist()
    # beyond the cone nothing is lit
    assert got_r[-3:].max() == 0.0
    # the same light unshaped would read cos θ / d² with no focus and no cone: far off the test
    th = np.arctan2((np.arange(len(want_r)) + 0.5) * 2 * px, HEIGHT)
    unshaped = 0.5 / math.pi * 10.0 * np.cos(th) / (HEIGHT ** 2 + ((np.arange(len(want_r)) + 0.5) * 2 * px) ** 2)
    assert np.abs(got_r - unshaped).max() > 0.2 * peak


def test_focus_tint_colours_the_falloff(renderer, stage):
    tint = (0.8, 0.4, 0.2)
    kw = dict(cone=60.0, softness=0.0, focus=6.0, albedo=0.5, intensity=40.0)
    scale = _floor_scale(renderer, _new_stage)
    _spot_scene(stage, tint=tint, **kw)
    img = render(renderer, stage)["color"]
    for ch in range(3):
        want, px = _expected_image(tint[ch], **kw)
        want = want * scale[ch]
        got_r, want_r = _rings(img[..., ch], px), _rings(want, px)
        inside = want_r > 0.05 * want_r.max()
        # the tint goes through the spectral uplift and back: 2% (plus the pixel-noise floor)
        err = np.abs(got_r - want_r)[inside] / want_r[inside]
        assert err.max() < 0.02, (ch, np.round(got_r, 4).tolist(), np.round(want_r, 4).tolist())
    # off-axis the tint shows: red over blue grows from 1 on the axis towards 4 (0.8 / 0.2)
    b = _rings(img[..., 2], WIDTH / RES)
    r = _rings(img[..., 0], WIDTH / RES)
    assert abs(r[0] / b[0] - 1.0) < 0.05 and r[12] / b[12] > 1.5


def test_reader_sends_shaping_only_where_it_is(stage, delegate):
    camera(stage)
    spot = UsdLux.SphereLight.Define(stage, "/Spot")
    UsdLux.ShapingAPI.Apply(spot.GetPrim()).CreateShapingFocusAttr(3.0)
    UsdLux.SphereLight.Define(stage, "/Plain")
    load(stage, delegate)
    # the applied API's fallbacks come along (a 90° cone)
    assert delegate.value("/Spot", "inputs:shaping:cone:angle") == 90.0
    assert delegate.value("/Spot", "inputs:shaping:focus") == 3.0
    assert delegate.value("/Spot", "inputs:shaping:cone:softness") == 0.0
    assert delegate.value("/Plain", "inputs:shaping:cone:angle") is None


def test_bad_shaping_values_are_reported_and_the_rest_renders(renderer, stage):
    _spot_scene(stage)
    spot = stage.GetPrimAtPath("/Spot")
    spot.GetAttribute("inputs:shaping:cone:angle").Set(-10.0)
    sun = UsdLux.DistantLight.Define(stage, "/Sun")
    UsdLux.ShapingAPI.Apply(sun.GetPrim()).CreateShapingFocusAttr(4.0)
    sun.CreateIntensityAttr(1.0)
    sun.CreateNormalizeAttr(True)                        # intensity = irradiance
    sun.AddRotateXOp().Set(-90.0)                        # straight down
    d = renderer.RenderDelegate()
    _, problems = load(stage, d)
    keys = {(p.prim, p.attribute) for p in problems}
    assert ("/Spot", "shaping:cone:angle") in keys or ("/Spot", "inputs:shaping:cone:angle") in keys, problems
    assert any(p.prim == "/Sun" and "shaping" in p.attribute for p in problems), problems
    # the spot emits nothing (cone 0); the sun, unshaped, lights the floor as it does alone
    img = render(renderer, stage)["color"][..., 0]
    alone = _floor_scale(renderer, _new_stage)[0] * 0.5 / math.pi
    assert abs(img.mean() - alone) < 0.005 * alone


# -- IES profiles ----------------------------------------------------------------------------
V_ANGLES = [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0]
H_ANGLES = [0.0, 45.0, 90.0]
CANDELA = [[200.0, 190.0, 160.0, 120.0, 70.0, 30.0, 0.0],     # along the light's X
           [200.0, 170.0, 120.0, 75.0, 37.5, 15.0, 0.0],
           [200.0, 150.0, 80.0, 30.0, 5.0, 0.0, 0.0]]         # along its Y


def _write_ies(path):
    """A quadrant-symmetric downlight (LM-63-2002, type C), twice as wide along X as along Y."""
    lines = ["IESNA:LM-63-2002", "[TEST] quadrant downlight", "TILT=NONE",
             "1 -1 1.0 %d %d 1 2 0.1 0.1 0" % (len(V_ANGLES), len(H_ANGLES)), "1.0 1.0 20",
             " ".join(map(str, V_ANGLES)), " ".join(map(str, H_ANGLES))]
    lines += [" ".join(map(str, row)) for row in CANDELA]
    path.write_text("\n".join(lines) + "\n")


def _candela(v_deg, h_deg):
    """The profile's bilinear interpolant, its quadrant symmetry unfolded (numpy arrays)."""
    a = np.mod(h_deg, 180.0)
    a = np.where(a > 90.0, 180.0 - a, a)
    table = np.array(CANDELA)
    out = np.zeros_like(v_deg)
    rows = [np.interp(v_deg, V_ANGLES, table[j], right=0.0) for j in range(len(H_ANGLES))]
    for j in range(len(H_ANGLES) - 1):
        t = np.clip((a - H_ANGLES[j]) / (H_ANGLES[j + 1] - H_ANGLES[j]), 0.0, 1.0)
        inside = (a >= H_ANGLES[j]) & (a <= H_ANGLES[j + 1])
        out = np.where(inside, rows[j] * (1 - t) + rows[j + 1] * t, out)
    return out


def test_ies_profile_shapes_the_light_along_its_own_axes(renderer, stage, tmp_path):
    ies = tmp_path / "quadrant.ies"
    _write_ies(ies)
    scale = _floor_scale(renderer, _new_stage)[0]
    intensity = 0.4
    _spot_scene(stage, cone=90.0, softness=0.0, focus=0.0, intensity=intensity)
    stage.GetPrimAtPath("/Spot").GetAttribute("inputs:shaping:ies:file").Set(Sdf.AssetPath(str(ies)))
    img = render(renderer, stage)["color"][..., 0]
    # the floor under the light: the light's X is the world's X (image right), its Y the
    # world's -Z (image up); radiance (ρ/π) (intensity/4) I(v, h) cos v / d²
    sub = 8
    c = (np.arange(RES * sub) + 0.5) / (RES * sub) * WIDTH - WIDTH / 2
    x, z = np.meshgrid(c, c)            # image rows run along +Z (top row at -Z)
    r = np.hypot(x, z)
    v = np.degrees(np.arctan2(r, HEIGHT))
    h = np.degrees(np.arctan2(-z, x))
    e = intensity / 4.0 * _candela(v, h) * np.cos(np.radians(v)) / (HEIGHT ** 2 + r ** 2)
    want = (0.5 / math.pi * scale * e).reshape(RES, sub, RES, sub).mean(axis=(1, 3))
    lit = want > 0.05 * want.max()
    # 8 x 8-pixel blocks: a pixel carries a few % of spectral noise at 16 samples (the white
    # illuminant seen through 4 wavelengths per sample), a block well under 1%
    b = RES // 8
    block = lambda a: a.reshape(b, 8, b, 8).sum(axis=(1, 3))  # noqa: E731
    bi, bw = block(img), block(want)
    full = block(lit.astype(float)) == 64
    rel = np.abs(bi[full] - bw[full]) / bw[full]
    assert full.sum() >= 16 and rel.max() < 0.025, (full.sum(), np.round(rel, 4).tolist())
    # the beam is wider along X (image rows) than along Y (image columns): 2.5 times brighter
    # 37° off the axis
    mid = RES // 2
    assert img[mid, RES - 8] > 1.8 * img[8, mid]
    # normalised, the profile keeps the light's power: the image scales by 1 / mean candela
    stage.GetPrimAtPath("/Spot").GetAttribute("inputs:shaping:ies:normalize").Set(True)
    norm = render(renderer, stage)["color"][..., 0]
    v_mid = np.radians(np.arange(0.0, 90.0, 0.01) + 0.005)
    hh = np.arange(0.0, 90.0, 0.5) + 0.25
    mean = np.mean([np.sum(_candela(np.degrees(v_mid), np.full_like(v_mid, hv)) * np.sin(v_mid))
                    * np.radians(0.01) for hv in hh])
    ratio = norm[lit].sum() / img[lit].sum()
    assert abs(ratio * mean - 1.0) < 0.01, (ratio, 1.0 / mean)


def test_unreadable_ies_file_is_reported_and_the_light_still_shines(renderer, stage, tmp_path):
    _spot_scene(stage, cone=40.0, softness=0.0, focus=0.0)
    stage.GetPrimAtPath("/Spot").GetAttribute("inputs:shaping:ies:file").Set(
        Sdf.AssetPath(str(tmp_path / "missing.ies")))
    d = renderer.RenderDelegate()
    _, problems = load(stage, d)
    assert any(p.prim == "/Spot" and "ies:file" in p.attribute for p in problems), problems
    img = render(renderer, stage)["color"][..., 0]
    assert img[RES // 2, RES // 2] > 0.0


def test_shadow_api_turns_a_lights_shadows_off(renderer, stage):
    """A ball 1 m above the floor under a sun 30° off the vertical: the part of its shadow the
    camera (looking straight down) sees past the ball is dark; with the sun's shadow:enable off
    it is lit like the open floor."""
    _spot_scene(stage, cone=0.0)
    sun = UsdLux.DistantLight.Define(stage, "/Sun")
    sun.CreateIntensityAttr(1.0)
    sun.CreateNormalizeAttr(True)
    sun.AddRotateXOp().Set(-60.0)          # shining down and towards -Z
    ball = UsdGeom.Sphere.Define(stage, "/Ball")
    ball.CreateRadiusAttr(0.6)
    ball.AddTranslateOp().Set(Gf.Vec3d(0, 1.0, 0))
    # the shadow's far end, z from -1.27 to -0.6 m beside x = 0: rows 15 to 19 (row 0 at
    # z = -2), columns around the middle
    shadow = np.s_[15:19, RES // 2 - 3:RES // 2 + 3]
    open_floor = np.s_[2:10, 2:10]
    img = render(renderer, stage)["color"][..., 0]
    assert img[shadow].mean() < 0.2 * img[open_floor].mean(), (img[shadow].mean(), img[open_floor].mean())
    UsdLux.ShadowAPI.Apply(sun.GetPrim()).CreateShadowEnableAttr(False)
    img = render(renderer, stage)["color"][..., 0]
    assert img[shadow].mean() > 0.9 * img[open_floor].mean(), (img[shadow].mean(), img[open_floor].mean())


def _half_shadowed_floor(renderer, **shadow):
    """A grey floor under a sun straight overhead, seen straight down from below an opaque
    board 1 m up that covers the half x < 0, with direct light only; the sun's ShadowAPI
    attributes as `shadow` gives them. Returns (mean colour of the shadowed half's pixels,
    their standard errors, mean colour of the open half)."""
    s = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
    cam = camera(s, pos=(0, 0.5, 0), aperture=(40.0, 40.0), projection="orthographic")
    cam.AddRotateXOp().Set(-90.0)
    floor = UsdGeom.Mesh.Define(s, "/Floor")
    floor.CreatePointsAttr([(-3, 0, -3), (-3, 0, 3), (3, 0, 3), (3, 0, -3)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    floor.CreateDisplayColorPrimvar().Set([(0.5, 0.5, 0.5)])
    board = UsdGeom.Mesh.Define(s, "/Board")
    board.CreatePointsAttr([(-3, 1, -3), (-3, 1, 3), (0, 1, 3), (0, 1, -3)])
    board.CreateFaceVertexCountsAttr([4])
    board.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    sun = UsdLux.DistantLight.Define(s, "/Sun")
    sun.CreateAngleAttr(0.0)
    sun.AddRotateXOp().Set(-90.0)
    api = UsdLux.ShadowAPI.Apply(sun.GetPrim())
    for name, value in shadow.items():
        if name == "color":
            api.CreateShadowColorAttr(Gf.Vec3f(*value))
        else:
            getattr(api, "CreateShadow%sAttr" % (name[0].upper() + name[1:]))(value)
    settings(s, res=(RES, RES), samples=64, integrator="path", maxDepth=1)
    problems = []
    img = render(renderer, s, problems)["color"][..., :3].astype(np.float64)
    assert problems == [], problems
    # the view spans x in [-2, 2]: columns below RES / 2 look at x < 0
    dark = img[:, 1:RES // 2 - 1].reshape(-1, 3)
    lit = img[:, RES // 2 + 1:-1].reshape(-1, 3)
    return dark.mean(axis=0), dark.std(axis=0, ddof=1) / np.sqrt(len(dark)), lit.mean(axis=0)


def test_shadow_api_colours_limits_and_fades_shadows(renderer):
    """UsdLuxShadowAPI's non-physical controls, on a board 1 m above the lit point: the shadow
    keeps shadow:color of the light; occluders beyond shadow:distance cast none; within the
    falloff zone (the last shadow:falloff of the distance) an occluder a fraction x in shadows
    by (1 - x)^falloffGamma: a board at x = 1/2 takes 1/2 of the light, and 1/4 at gamma 2."""
    def check(want, **shadow):
        dark, se, lit = _half_shadowed_floor(renderer, **shadow)
        assert np.all(lit > 0.05), lit
        assert np.all(np.abs(dark - want * lit) < 4 * se + 0.005 * lit + 1e-4), (shadow, dark, want * lit, se)

    check(np.zeros(3))
    check(np.array([0.5, 0.25, 0.0]), color=(0.5, 0.25, 0.0))
    check(np.ones(3), distance=0.5)
    check(np.zeros(3), distance=1.5)
    check(np.full(3, 0.5), distance=2.0, falloff=1.0)
    check(np.full(3, 0.75), distance=2.0, falloff=1.0, falloffGamma=2.0)


def test_light_diffuse_and_specular_multipliers(renderer, stage):
    """A straight-down sun over the Lambertian floor: inputs:diffuse = 0.5 halves the image.
    Over a polished metal floor (all specular): inputs:specular = 0 leaves it black, while
    inputs:diffuse does nothing."""
    _spot_scene(stage, cone=0.0)
    sun = UsdLux.DistantLight.Define(stage, "/Sun")
    sun.CreateIntensityAttr(1.0)
    sun.CreateNormalizeAttr(True)
    sun.CreateAngleAttr(20.0)                              # wide enough to be seen in the metal
    sun.AddRotateXOp().Set(-90.0)
    base = render(renderer, stage)["color"][..., 0].mean()
    sun.GetPrim().GetAttribute("inputs:diffuse").Set(0.5)
    half = render(renderer, stage)["color"][..., 0].mean()
    assert abs(half / base - 0.5) < 0.005, half / base
    sun.GetPrim().GetAttribute("inputs:diffuse").Set(1.0)
    metal = preview_material(stage, "/Looks/Metal", (0.9, 0.9, 0.9), metallic=1.0, roughness=0.3)
    bind(stage.GetPrimAtPath("/Floor"), metal)
    shiny = render(renderer, stage)["color"][..., 0].mean()
    sun.GetPrim().GetAttribute("inputs:diffuse").Set(0.0)
    assert abs(render(renderer, stage)["color"][..., 0].mean() - shiny) <= 1e-6 * shiny
    sun.GetPrim().GetAttribute("inputs:specular").Set(0.0)
    assert shiny > 0.01 and render(renderer, stage)["color"][..., 0].mean() < 1e-3 * shiny


# -- dome images in UsdLux's other layouts --------------------------------------------------
def _sky(d):
    """The test environment's grey radiance along unit direction(s) d (..., 3): linear, so
    that a narrow view's mean is its centre's value, and different along every axis."""
    return 0.5 + 0.25 * d[..., 1] + 0.12 * d[..., 0] + 0.08 * d[..., 2]


def _paint(fmt, w, h):
    """An image of _sky in a dome layout, through each layout's pixel -> direction mapping as
    docs/usd-contract.md describes it (written here apart from the renderer's lookups)."""
    u = (np.arange(w) + 0.5) / w
    v = (np.arange(h) + 0.5) / h
    uu, vv = np.meshgrid(u, v)
    if fmt in ("mirroredBall", "angular"):
        x, y = 2 * uu - 1, 1 - 2 * vv
        r2 = x * x + y * y
        inside = r2 <= 1.0
        if fmt == "mirroredBall":
            nz = np.sqrt(np.clip(1 - r2, 0, 1))
            d = np.stack([2 * nz * x, 2 * nz * y, 2 * nz * nz - 1], axis=-1)
        else:
            th = np.sqrt(r2) * math.pi
            ph = np.arctan2(y, x)
            d = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), -np.cos(th)], axis=-1)
        img = np.where(inside, _sky(d), 0.0)
    else:
        img = np.zeros((h, w))
        col, row = (uu * 3).astype(int), (vv * 4).astype(int)
        s, t = (uu * 3) % 1 * 2 - 1, 1 - (vv * 4) % 1 * 2
        one = np.ones_like(s)
        faces = {(1, 0): (s, one, t), (0, 1): (-one, t, -s), (1, 1): (s, t, -one),
                 (2, 1): (one, t, s), (1, 2): (s, -one, -t), (1, 3): (s, -t, one)}
        for (c, r), (dx, dy, dz) in faces.items():
            d = np.stack([dx, dy, dz], axis=-1)
            d = d / np.linalg.norm(d, axis=-1, keepdims=True)
            m = (col == c) & (row == r)
            img[m] = _sky(d)[m]
    return img.astype(np.float32)


@pytest.mark.parametrize("fmt,size", [("mirroredBall", (256, 256)), ("angular", (256, 256)),
                                      ("cubeMapVerticalCross", (192, 256))])
def test_dome_texture_formats(renderer, stage, tmp_path, fmt, size):
    import OpenEXR
    w, h = size
    img = _paint(fmt, w, h)
    path = str(tmp_path / ("probe_%s.exr" % fmt))
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                      {"R": img, "G": img, "B": img}) as f:
        f.write(path)
    dome = UsdLux.DomeLight.Define(stage, "/Dome")
    dome.CreateTextureFileAttr(Sdf.AssetPath(path))
    dome.CreateTextureFormatAttr(fmt)
    cam = camera(stage, focal=200.0, aperture=(10.0, 10.0))
    op = cam.AddRotateXYZOp()
    settings(stage, res=(8, 8), samples=16, integrator="path")
    # looking up (+Y), to +X, and back (+Z) through a narrow view: the sky there
    for rot, d in [((90, 0, 0), (0, 1, 0)), ((0, -90, 0), (1, 0, 0)), ((0, 180, 0), (0, 0, 1))]:
        op.Set(Gf.Vec3f(*rot))
        got = render(renderer, stage)["color"][..., :3].mean()
        want = float(_sky(np.array(d, dtype=float)))
        # 2%: the grey's spectral round trip and 16 samples; the axes differ by 8% or more
        assert abs(got - want) < 0.02 * want, (fmt, d, got, want)


def test_rect_light_texture(renderer, stage, tmp_path):
    """A rect light's image, seen from the side it lights, reads upright: UsdLux puts the
    image's min coordinates at the light's (+X, +Y) corner, and turned to face the camera the
    light's +X is on the camera's left, so the image's left half shows on the left."""
    import OpenEXR
    img = np.array([[0.2, 0.2, 1.0, 1.0], [0.2, 0.2, 1.0, 1.0]], dtype=np.float32)
    path = str(tmp_path / "panel.exr")
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                      {"R": img, "G": img, "B": img}) as f:
        f.write(path)
    camera(stage, focal=30.0, aperture=(20.0, 10.0))
    rect = UsdLux.RectLight.Define(stage, "/Panel")
    rect.CreateWidthAttr(2.0)
    rect.CreateHeightAttr(1.0)
    rect.CreateIntensityAttr(0.5)
    rect.CreateTextureFileAttr(Sdf.AssetPath(path))
    rect.AddTranslateOp().Set(Gf.Vec3d(0, 0, -3))
    rect.AddRotateYOp().Set(180.0)                          # lighting the camera
    settings(stage, res=(16, 8), samples=8, integrator="path")
    px = render(renderer, stage)["color"][..., 0]
    left, right = px[:, 1:7].mean(), px[:, 9:15].mean()
    assert abs(left - 0.1) < 0.003 and abs(right - 0.5) < 0.015, (left, right)


# -- lights that move over the shutter ------------------------------------------------------
def _light_streak(renderer, stage, disable_motion=False):
    """A sphere light of radius 0.25 crossing the view 10 units away during a one-frame shutter
    (x from -1 to 1), seen directly against black: the full width at half maximum of its
    streak along the middle rows, in pixels, and the pixels per unit at its distance."""
    w, h, focal, ap = 128, 16, 50.0, 36.0
    camera(stage, focal=focal, aperture=(ap, ap * h / w), **{"shutter__open": 0.0, "shutter__close": 1.0})
    light = UsdLux.SphereLight.Define(stage, "/Lamp")
    light.CreateRadiusAttr(0.25)
    light.CreateIntensityAttr(4.0)
    op = light.AddTranslateOp()
    op.Set(Gf.Vec3d(-1, 0, -10), 0)
    op.Set(Gf.Vec3d(1, 0, -10), 1)
    st = settings(stage, res=(w, h), samples=256, integrator="path")
    if disable_motion:
        st.GetPrim().CreateAttribute("disableMotionBlur", Sdf.ValueTypeNames.Bool).Set(True)
    img = render(renderer, stage, frame=0)["color"][..., 1]
    return fwhm(img[h // 2 - 1:h // 2 + 1].mean(axis=0)), focal / 10.0 / (ap / 2) * w / 2


def test_a_moving_light_streaks_over_the_shutter(renderer, stage):
    length, per_unit = _light_streak(renderer, stage)
    # a disk of diameter D swept over L >= D: a trapezoid whose full width at half maximum is L
    assert length == pytest.approx(2.0 * per_unit, abs=1.5)


def test_a_moving_light_stands_still_without_motion_blur(renderer, stage):
    length, per_unit = _light_streak(renderer, stage, disable_motion=True)
    assert length == pytest.approx(0.5 * per_unit, abs=1.5)


def _dome_lit_panel(renderer, tmp_path, normal, texture, pole=None, dome_1=True):
    """A Lambertian panel (albedo 0.5, standard_surface with no specular) facing `normal` on a
    Z-up stage, lit only by a dome of lat-long `texture` (a DomeLight_1 with `pole` when
    given), seen head-on by an orthographic camera with one bounce; returns its mean colour."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    path = tmp_path / "dome.exr"
    write_exr(path, texture)
    dome = (UsdLux.DomeLight_1 if dome_1 else UsdLux.DomeLight).Define(stage, "/Dome")
    dome.CreateTextureFileAttr(str(path))
    if pole:
        dome.CreatePoleAxisAttr(pole)
    n = np.asarray(normal, dtype=float)
    u = np.cross(n, (1.0, 0.0, 0.0)) if abs(n[0]) < 0.9 else np.cross(n, (0.0, 1.0, 0.0))
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    corners = [tuple(a * u + b * v) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    panel = UsdGeom.Mesh.Define(stage, "/Panel")
    panel.CreatePointsAttr(corners)
    panel.CreateFaceVertexCountsAttr([4])
    panel.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    panel.CreateDoubleSidedAttr(True)
    bind(panel.GetPrim(), exact_lambert_material(stage, "/Looks/Grey", 0.5))
    cam = camera(stage, pos=tuple(5.0 * n), aperture=(10.0, 10.0), projection="orthographic")
    # the camera looks along its -Z: turn it to look along -normal
    turn = {(0, 0, 1): 0.0, (0, -1, 0): 90.0, (0, 1, 0): -90.0}[tuple(int(x) for x in n)]
    if turn:
        cam.AddRotateXOp().Set(turn)
    settings(stage, res=(8, 8), samples=64, integrator="path", maxDepth=1)
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3]
    assert not problems, problems
    return img


def _half_bright(rows):
    """A 64 x 32 lat-long map, 1 in `rows` (a slice of rows) or where rows(y, x) says, else 0."""
    tex = np.zeros((32, 64, 3))
    for y in range(32):
        for x in range(64):
            if rows(y, x):
                tex[y, x] = 1.0
    return tex


def test_dome_light_1_pole_axis_turns_the_dome(renderer, tmp_path):
    """DomeLight_1's poleAxis: on a Z-up stage its fallback `scene` (and `Z`) puts the image's
    top pole at +Z and its centre (longitude 0) at -Y; `Y` keeps OpenEXR's layout, as a plain
    DomeLight does. A panel under radiance 1 over a hemisphere centred on its normal shows
    albedo × 1 = 0.5; over half of that hemisphere, 0.25; over none, 0."""
    upper = _half_bright(lambda y, x: y < 16)
    for pole, want in ((None, 0.5), ("Z", 0.5), ("Y", 0.25)):
        ok, why = near(_dome_lit_panel(renderer, tmp_path, (0, 0, 1), upper, pole), (want,) * 3)
        assert ok, (pole, why)
    ok, why = near(_dome_lit_panel(renderer, tmp_path, (0, 0, 1), upper, dome_1=False), (0.25,) * 3)
    assert ok, ("DomeLight", why)
    # the longitudes within 90° of 0 (columns 16 to 47): the hemisphere about -Y
    front = _half_bright(lambda y, x: 16 <= x < 48)
    for normal, want in (((0, -1, 0), 0.5), ((0, 1, 0), 0.0)):
        ok, why = near(_dome_lit_panel(renderer, tmp_path, normal, front, "Z"), (want,) * 3)
        assert ok, (normal, why)


def test_a_sphere_light_over_a_surface_far_out_in_its_own_space_has_no_fireflies(renderer):
    """A Lambertian floor under a small SphereLight, its points authored 10^4 units out and
    brought back by its transform (the same world): the same image as the floor authored in
    place. A BSDF-sampled ray starts stepped off the floor (by more, the larger the floor's
    own coordinates); weighed by the light-sampling density from the floor point itself, a
    hit grazing the sphere had no density and counted in full: fireflies of ~100 times a
    pixel and a mean 1.5 % bright."""
    def image(t):
        s = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
        cam = camera(s, pos=(0, 3.5, 5.0), focal=30.0)
        cam.AddRotateXOp().Set(-35.0)
        off = np.array([t, t / 2, -t])
        UsdGeom.Xform.Define(s, "/P").AddTranslateOp().Set(Gf.Vec3d(*off))
        m = UsdGeom.Mesh.Define(s, "/P/Floor")
        m.CreatePointsAttr([Gf.Vec3f(*(np.array(p, float) - off))
                            for p in [(-4, 0, -4), (4, 0, -4), (4, 0, 4), (-4, 0, 4)]])
        m.CreateFaceVertexCountsAttr([4])
        m.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
        bind(m.GetPrim(), exact_lambert_material(s, "/Looks/Grey", 0.5))
        light = UsdLux.SphereLight.Define(s, "/Light")
        light.CreateRadiusAttr(0.25)
        light.CreateIntensityAttr(200.0)
        light.AddTranslateOp().Set(Gf.Vec3d(1.5, 4.0, 3.0))
        settings(s, res=(48, 48), samples=32, integrator="path", maxDepth=1)
        return render(renderer, s)["color"][..., :3].astype(np.float64).mean(axis=2)
    near_img, far_img = image(0.0), image(1e4)
    assert far_img.max() < 1.5 * near_img.max(), (far_img.max(), near_img.max())
    assert far_img.mean() == pytest.approx(near_img.mean(), rel=5e-3)


@pytest.mark.parametrize("space", [None, "acescg"])
def test_a_dome_images_colour_space_metadata_decodes_it(renderer, stage, tmp_path, space):
    """A dome of one texel (0.5, 0.25, 0.78) seen directly: unmarked (a float EXR) it shows
    those values; its `texture:file` marked acescg, their conversion to linear Rec.709
    (ACEScg's published matrix). The metadata was not read for lights."""
    path = str(tmp_path / "sky.exr")
    write_exr(path, [[(0.5, 0.25, 0.78)]])
    camera(stage)
    dome = UsdLux.DomeLight.Define(stage, "/Dome")
    dome.CreateTextureFileAttr(path)
    if space:
        dome.GetTextureFileAttr().SetColorSpace(space)
    settings(stage, res=(8, 8), samples=8, integrator="path")
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3]
    assert problems == [], problems
    stored = np.array([0.5, 0.25, 0.78])
    acescg_to_rec709 = np.array([[1.70505, -0.62179, -0.08326], [-0.13026, 1.14080, -0.01055],
                                 [-0.02400, -0.12897, 1.15297]])
    ok, why = near(img, acescg_to_rec709 @ stored if space else stored)
    assert ok, (space, why)
