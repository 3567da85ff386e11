"""UsdLuxMeshLightAPI: a mesh that is a light. Its emission seen directly (color x intensity x
2^exposure, divided by the world area when normalized, tinted or replaced by the material's glow
as `light:materialSyncMode` says), and the light it casts, against a RectLight of the same size
and radiance lighting the same floor."""
import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade

from conftest import bind, camera, lambert_material, load, render, settings

RES = 32
WIDTH = 4.0


def _top_camera(stage):
    cam = camera(stage, pos=(0, 5, 0), aperture=(WIDTH * 10, WIDTH * 10),
                 projection="orthographic")
    cam.AddRotateXOp().Set(-90.0)


def _panel(stage, path, size, y, facing_up, scale=1.0):
    h = size / 2
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreatePointsAttr([(-h, 0, -h), (h, 0, -h), (h, 0, h), (-h, 0, h)])
    m.CreateFaceVertexCountsAttr([4])
    m.CreateFaceVertexIndicesAttr([0, 3, 2, 1] if facing_up else [0, 1, 2, 3])
    m.AddTranslateOp().Set(Gf.Vec3d(0, y, 0))
    if scale != 1.0:
        m.AddScaleOp().Set(Gf.Vec3f(scale, 1, scale))
    return m


def _glow_material(stage, glow):
    mat = lambert_material(stage, "/Looks/Glow", (0, 0, 0))
    sh = UsdShade.Shader(stage.GetPrimAtPath("/Looks/Glow/S"))
    sh.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*glow))
    return mat


def _direct(renderer, stage, mode, normalize=False, scale=1.0, color=(1, 1, 1),
            glow=(0.5, 0.25, 1.0)):
    """The centre of a panel (2 x 2 before `scale`) facing the camera: a mesh light of
    `color` x intensity 3 x 2^1 over a black UsdPreviewSurface glowing `glow`."""
    _top_camera(stage)
    m = _panel(stage, "/Panel", 2.0, 1.0, True, scale)
    bind(m.GetPrim(), _glow_material(stage, glow))
    UsdLux.MeshLightAPI.Apply(m.GetPrim())
    la = UsdLux.LightAPI(m.GetPrim())
    la.CreateColorAttr(Gf.Vec3f(*color))
    la.CreateIntensityAttr(3.0)
    la.CreateExposureAttr(1.0)
    la.CreateNormalizeAttr(normalize)
    m.GetPrim().CreateAttribute("light:materialSyncMode", Sdf.ValueTypeNames.Token).Set(mode)
    settings(stage, res=(RES, RES), samples=64, integrator="path")
    img = render(renderer, stage)["color"]
    # the panel's middle (6 x 6 px; the wavelengths each pixel samples average out over them)
    return img[RES // 2 - 3:RES // 2 + 3, RES // 2 - 3:RES // 2 + 3, :3].mean(axis=(0, 1))


@pytest.mark.parametrize("mode,normalize,scale,expect", [
    ("noMaterialResponse", False, 1.0, 6.0),
    ("independent", False, 1.0, 6.0),                # the material's glow replaced
    ("noMaterialResponse", True, 2.0, 6.0 / 16.0),   # / its world area (2 x 2, scaled by 2 x 2)
])
def test_a_mesh_light_seen_directly(renderer, stage, mode, normalize, scale, expect):
    # white light: intensity 3 x 2^exposure 1, in every channel (a white spectrum round-trips)
    centre = _direct(renderer, stage, mode, normalize, scale)
    assert np.allclose(centre, expect, rtol=2e-3), (centre, expect)


def test_the_materials_glow_tints_a_mesh_light(renderer, stage):
    # materialGlowTintsLight (the fallback): white light x glow is what a light of the glow's
    # colour emits with the material's glow replaced
    from pxr import Usd
    tinted = _direct(renderer, stage, "materialGlowTintsLight")
    other = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(other, UsdGeom.Tokens.y)
    coloured = _direct(renderer, other, "independent", color=(0.5, 0.25, 1.0), glow=(0, 0, 0))
    assert np.allclose(tinted, coloured, rtol=1e-5), (tinted, coloured)
    assert tinted[2] > 2 * tinted[1]


def _floor_lit_by(stage, make_light):
    _top_camera(stage)
    floor = _panel(stage, "/Floor", 20.0, 0.0, True)
    bind(floor.GetPrim(), lambert_material(stage, "/Looks/Floor", (0.5, 0.5, 0.5)))
    make_light(stage)
    settings(stage, res=(RES, RES), samples=64, integrator="path", seed=3)


def test_a_mesh_light_lights_the_floor_as_a_rect_light_does(renderer, stage):
    # a 1 x 1 panel 1 unit above the floor, facing down, radiance 2: as a mesh light and as a
    # RectLight (which faces its -Z); the floor around the panel's footprint must agree
    def mesh_light(s):
        m = _panel(s, "/Panel", 1.0, 1.0, False)
        UsdLux.MeshLightAPI.Apply(m.GetPrim())
        UsdLux.LightAPI(m.GetPrim()).CreateIntensityAttr(2.0)
        m.GetPrim().CreateAttribute("light:materialSyncMode", Sdf.ValueTypeNames.Token).Set(
            "noMaterialResponse")

    def rect_light(s):
        r = UsdLux.RectLight.Define(s, "/Panel")
        r.CreateWidthAttr(1.0)
        r.CreateHeightAttr(1.0)
        r.CreateIntensityAttr(2.0)
        r.AddTranslateOp().Set(Gf.Vec3d(0, 1.0, 0))
        r.AddRotateXOp().Set(-90.0)

    from pxr import Usd
    images = []
    for make in (mesh_light, rect_light):
        s = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
        _floor_lit_by(s, make)
        images.append(render(renderer, s)["color"][..., 0].astype(np.float64))
    # the annulus 0.75 to 1.75 units from the panel's foot (outside its footprint seen from
    # above); px -> units: WIDTH / RES
    ys, xs = np.mgrid[0:RES, 0:RES]
    r = np.hypot(xs + 0.5 - RES / 2, ys + 0.5 - RES / 2) * WIDTH / RES
    ring = (r > 0.75) & (r < 1.75)
    a, b = images[0][ring].mean(), images[1][ring].mean()
    assert a > 0.02 and a == pytest.approx(b, rel=0.03), (a, b)


def test_reader_sends_the_mesh_light(stage, delegate):
    camera(stage)
    m = _panel(stage, "/Panel", 1.0, 1.0, False)
    UsdLux.MeshLightAPI.Apply(m.GetPrim())
    UsdLux.LightAPI(m.GetPrim()).CreateIntensityAttr(5.0)
    plain = _panel(stage, "/Plain", 1.0, 2.0, False)
    _, problems = load(stage, delegate)
    assert problems == []
    assert delegate.value("/Panel", "meshLight") is True
    assert delegate.value("/Panel", "inputs:intensity") == 5.0
    assert delegate.value("/Panel", "light:materialSyncMode") == ("token", "materialGlowTintsLight")
    assert delegate.value(str(plain.GetPath()), "meshLight") is None


def test_a_mesh_lights_light_link_collection_leaves_out_what_it_excludes(renderer):
    """A mesh light over a floor made of two halves whose lightLink includes only the left
    half: the left half is lit as without the collection (same samples, to float rounding),
    the right half not at all (nothing else lights it)."""
    from pxr import Usd

    def floor(link):
        s = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
        _top_camera(s)
        grey = lambert_material(s, "/Looks/Floor", (0.5, 0.5, 0.5))
        for name, x in (("Left", -WIDTH / 4), ("Right", WIDTH / 4)):
            half = UsdGeom.Mesh.Define(s, "/" + name)
            h, d = WIDTH / 4, WIDTH / 2
            half.CreatePointsAttr([(x - h, 0, -d), (x + h, 0, -d), (x + h, 0, d), (x - h, 0, d)])
            half.CreateFaceVertexCountsAttr([4])
            half.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
            bind(half.GetPrim(), grey)
        m = _panel(s, "/Panel", 1.0, 1.0, False)
        UsdLux.MeshLightAPI.Apply(m.GetPrim())
        light = UsdLux.LightAPI(m.GetPrim())
        light.CreateIntensityAttr(2.0)
        m.GetPrim().CreateAttribute("light:materialSyncMode", Sdf.ValueTypeNames.Token).Set(
            "noMaterialResponse")
        if link:
            coll = light.GetLightLinkCollectionAPI()
            coll.CreateIncludeRootAttr(False)
            coll.CreateIncludesRel().SetTargets(["/Left"])
        settings(s, res=(RES, RES), samples=32, integrator="path", seed=3)
        problems = []
        img = render(renderer, s, problems)["color"][..., 0].astype(np.float64)
        assert problems == [], problems
        return img

    linked, free = floor(True), floor(False)
    # columns left of the panel's footprint, and right of it (the panel hides the middle)
    left, right = slice(0, RES // 2 - 5), slice(RES // 2 + 5, RES)
    assert free[:, right].mean() > 0.02
    assert np.allclose(linked[:, left], free[:, left], rtol=1e-4, atol=1e-6)
    assert np.all(linked[:, right] == 0.0)


def test_a_normalized_mesh_light_divides_each_instance_by_its_own_area(renderer):
    """A PointInstancer placing a 1 x 1 mesh light (intensity 1, normalize) at x = -1 as it is
    and at x = 1 scaled to half its width and depth: seen from above, the first glows 1 / 1,
    the second 1 / 0.25."""
    from pxr import Usd
    s = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
    _top_camera(s)
    pi = UsdGeom.PointInstancer.Define(s, "/Lights")
    m = _panel(s, "/Lights/Protos/Panel", 1.0, 0.0, True)
    UsdLux.MeshLightAPI.Apply(m.GetPrim())
    light = UsdLux.LightAPI(m.GetPrim())
    light.CreateIntensityAttr(1.0)
    light.CreateNormalizeAttr(True)
    m.GetPrim().CreateAttribute("light:materialSyncMode", Sdf.ValueTypeNames.Token).Set(
        "noMaterialResponse")
    pi.CreatePrototypesRel().SetTargets([m.GetPath()])
    pi.CreateProtoIndicesAttr([0, 0])
    pi.CreatePositionsAttr([(-1, 1, 0), (1, 1, 0)])
    pi.CreateScalesAttr([(1, 1, 1), (0.5, 1, 0.5)])
    # many samples: a white light's wavelengths average out over few pixels
    settings(s, res=(RES, RES), samples=256, integrator="path")
    problems = []
    img = render(renderer, s, problems)["color"][..., 0].astype(np.float64)
    assert problems == [], problems
    # the middle 2 x 2 pixels of each panel (x = -1 and x = 1: columns RES / 4 and 3 RES / 4)
    mid = lambda col: img[RES // 2 - 1:RES // 2 + 1, col - 1:col + 1].mean()
    assert mid(RES // 4) == pytest.approx(1.0, rel=0.01)
    assert mid(3 * RES // 4) == pytest.approx(4.0, rel=0.01)


@pytest.mark.parametrize("apart", [False, True])
def test_a_mesh_light_close_to_a_floor_gives_the_irradiance_of_its_area(renderer, stage, apart):
    """A 1 x 1 mesh light of radiance 2 facing down 0.1 above an exactly Lambertian floor
    (albedo 0.5): around its footprint the floor shows rho/pi x the irradiance the panel's
    area gives, integrated here (E = L h^2 / r^4 over the panel). `apart`: the same world
    positions with each prim's transform moved +100 and its points -100, which makes the
    shadow rays' offsets larger; the shadow ray towards a point on the panel met the panel
    itself a rounding short of it, darkening the floor by a third, and two thirds apart."""
    from conftest import exact_lambert_material
    shift = 100.0 if apart else 0.0
    _top_camera(stage)
    floor = UsdGeom.Mesh.Define(stage, "/Floor")
    floor.CreatePointsAttr([(x, -shift, z) for x, z in ((-10, -10), (-10, 10), (10, 10), (10, -10))])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    floor.AddTranslateOp().Set(Gf.Vec3d(0, shift, 0))
    bind(floor.GetPrim(), exact_lambert_material(stage, "/Looks/Floor", 0.5))
    h = 0.1
    m = _panel(stage, "/Panel", 1.0, h + shift, False)
    m.GetPointsAttr().Set([Gf.Vec3f(p[0], p[1] - shift, p[2]) for p in m.GetPointsAttr().Get()])
    UsdLux.MeshLightAPI.Apply(m.GetPrim())
    UsdLux.LightAPI(m.GetPrim()).CreateIntensityAttr(2.0)
    m.GetPrim().CreateAttribute("light:materialSyncMode", Sdf.ValueTypeNames.Token).Set("noMaterialResponse")
    settings(stage, res=(RES, RES), samples=64, integrator="path", maxDepth=1)
    img = render(renderer, stage)["color"][..., :3].astype(np.float64).mean(axis=2)
    # pixel centres (the view is symmetric about x = 0 and z = 0, as the panel is)
    c = -WIDTH / 2 + (np.arange(RES) + 0.5) * WIDTH / RES
    zs, xs = np.meshgrid(c, c, indexing="ij")
    seen = (np.maximum(np.abs(xs), np.abs(zs)) > 0.5 + WIDTH / RES) & (np.hypot(xs, zs) < 1.3)
    # the panel on a 200 x 200 midpoint grid; each pixel averaged over 4 x 4 points (the
    # default box pixel filter)
    k = (np.arange(200) + 0.5) / 200 - 0.5
    panel = np.stack(np.meshgrid(k, k), axis=-1).reshape(-1, 2)
    sub = ((np.arange(4) + 0.5) / 4 - 0.5) * WIDTH / RES
    offsets = np.stack(np.meshgrid(sub, sub), axis=-1).reshape(-1, 2)

    def radiance(x, z):
        q = np.array([x, z]) + offsets
        r2 = ((panel[None, :, :] - q[:, None, :]) ** 2).sum(axis=2) + h * h
        return 0.5 / np.pi * 2.0 * (h * h / r2 ** 2).mean(axis=1).mean()
    want = np.array([radiance(x, z) for x, z in zip(xs[seen], zs[seen])])
    got = img[seen]
    assert want.mean() > 0.01
    assert got.mean() == pytest.approx(want.mean(), rel=0.03), (got.mean(), want.mean())
