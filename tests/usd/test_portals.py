"""UsdLuxPortalLight: a room lit by a white dome through one window, its walls black, so the
floor receives only the dome's direct light through the window: Lambert's formula for a
polygon of constant radiance gives the floor's irradiance exactly. With a portal in the
window the render keeps that image and its noise falls; without one it has the same
expectation. Also what the reader sends for portals and domes."""
import math

import numpy as np
import pytest
from pxr import Gf, UsdGeom, UsdLux

from conftest import bind, camera, exact_lambert_material, lambert_material, load, matrix, render, settings

ALBEDO = 0.5
HALF = 2.0                       # the room spans x, z in [-2, 2], y in [0, 3]
TOP = 3.0
WINDOW = ((1.0, 2.0), (-0.75, 0.75))      # y and z ranges of the window in the wall x = 2
SEEN = 3.0                       # metres of floor across the image
RES = 24


def _quad(stage, path, pts, material):
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreatePointsAttr(pts)
    m.CreateFaceVertexCountsAttr([4])
    m.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    m.CreateDoubleSidedAttr(True)
    bind(m.GetPrim(), material)


def _room(stage, portal):
    """The room, its floor seen from above by an orthographic camera inside it; `portal`:
    None, or the portal's path (a PortalLight in the window)."""
    black = lambert_material(stage, "/Looks/Black", (0, 0, 0))
    grey = exact_lambert_material(stage, "/Looks/Floor", ALBEDO)
    h, t = HALF, TOP
    (y0, y1), (z0, z1) = WINDOW
    _quad(stage, "/Room/Floor", [(-h, 0, -h), (-h, 0, h), (h, 0, h), (h, 0, -h)], grey)
    _quad(stage, "/Room/Ceiling", [(-h, t, -h), (h, t, -h), (h, t, h), (-h, t, h)], black)
    _quad(stage, "/Room/West", [(-h, 0, -h), (-h, t, -h), (-h, t, h), (-h, 0, h)], black)
    _quad(stage, "/Room/North", [(-h, 0, -h), (h, 0, -h), (h, t, -h), (-h, t, -h)], black)
    _quad(stage, "/Room/South", [(-h, 0, h), (-h, t, h), (h, t, h), (h, 0, h)], black)
    # the east wall x = h around its window
    for i, (ya, yb, za, zb) in enumerate([(0, y0, -h, h), (y1, t, -h, h), (y0, y1, -h, z0), (y0, y1, z1, h)]):
        _quad(stage, "/Room/East%d" % i, [(h, ya, za), (h, yb, za), (h, yb, zb), (h, ya, zb)], black)
    UsdLux.DomeLight.Define(stage, "/Dome").CreateColorAttr(Gf.Vec3f(1, 1, 1))
    if portal:
        p = UsdLux.PortalLight.Define(stage, portal)
        p.CreateWidthAttr(WINDOW[1][1] - WINDOW[1][0])
        p.CreateHeightAttr(WINDOW[0][1] - WINDOW[0][0])
        p.AddTranslateOp().Set(Gf.Vec3d(h, 0.5 * (y0 + y1), 0.5 * (z0 + z1)))
        # local X along world -Z, local Y along +Y, local +Z along +X: light crosses to -X
        p.AddRotateYOp().Set(90.0)
    cam = camera(stage, pos=(0, 2.5, 0), aperture=(SEEN * 10, SEEN * 10), projection="orthographic")
    cam.AddRotateXOp().Set(-90.0)


def _irradiance(x, z):
    """Irradiance at floor point (x, 0, z) from radiance 1 through the window (Lambert's
    formula: E = ½ Σ θ_i n·(v_i × v_i+1)/|v_i × v_i+1| over the polygon's edges)."""
    (y0, y1), (z0, z1) = WINDOW
    corners = [(HALF, y0, z0), (HALF, y1, z0), (HALF, y1, z1), (HALF, y0, z1)]
    p = np.array([x, 0.0, z])
    v = [np.array(c) - p for c in corners]
    v = [a / np.linalg.norm(a) for a in v]
    e = 0.0
    for i in range(4):
        a, b = v[i], v[(i + 1) % 4]
        c = np.cross(a, b)
        e += math.acos(np.clip(np.dot(a, b), -1.0, 1.0)) * c[1] / np.linalg.norm(c)
    return 0.5 * abs(e)


def _expected():
    """The floor's radiance ρE/π averaged over each pixel on a 4 x 4 sub-grid. Image rows run
    from -z (top) to +z, columns from -x to +x (the camera looks down, its up along -z)."""
    sub = 4
    c = (np.arange(RES * sub) + 0.5) / (RES * sub) * SEEN - SEEN / 2
    e = np.array([[_irradiance(x, z) for x in c] for z in c])
    return ALBEDO / math.pi * e.reshape(RES, sub, RES, sub).mean(axis=(1, 3))


def _renders(renderer, stage_factory, portal, spp=16):
    """Two renders of different seeds: their mean image and its per-pixel standard error."""
    imgs = []
    for seed in (1, 2):
        stage = stage_factory()
        _room(stage, portal)
        settings(stage, res=(RES, RES), samples=spp, integrator="path", seed=seed)
        problems = []
        imgs.append(render(renderer, stage, problems)["color"][..., 0].astype(np.float64))
        assert not problems, problems
    a, b = imgs
    # each render's pixel variance from the two renders' difference; the mean's is half
    var = np.mean((a - b) ** 2) / 2.0
    return 0.5 * (a + b), math.sqrt(var / 2.0)


@pytest.fixture
def stage_factory():
    from pxr import Usd

    def make():
        s = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
        return s
    return make


def test_a_portal_keeps_the_image_and_lowers_its_noise(renderer, stage_factory):
    want = _expected()
    assert want.max() > 5 * want.min() > 0, "the window lights the floor unevenly"
    guided, se_guided = _renders(renderer, stage_factory, "/Room/Window")
    plain, se_plain = _renders(renderer, stage_factory, None)
    for name, img, se in (("guided", guided, se_guided), ("unguided", plain, se_plain)):
        # the image's mean, and each quadrant's, within 4 standard errors of Lambert's formula
        n = RES // 2
        for r0 in (0, n):
            for c0 in (0, n):
                got = img[r0:r0 + n, c0:c0 + n].mean()
                exp = want[r0:r0 + n, c0:c0 + n].mean()
                tol = 4.0 * se / n + 2e-3 * exp
                assert abs(got - exp) <= tol, "%s quadrant (%d, %d): %.5f vs %.5f ± %.5f" % (name, r0, c0, got, exp, tol)
        # no pixel strays beyond what its noise allows (5 σ over 576 pixels)
        assert np.abs(img - want).max() <= 5.0 * se + 2e-3 * want.max(), name
    # the same samples find the window far more often through the portal
    assert se_guided < 0.4 * se_plain, "noise %.5f guided vs %.5f unguided" % (se_guided, se_plain)


def test_the_reader_sends_portals_and_the_domes_that_name_them(stage, delegate):
    UsdLux.DomeLight.Define(stage, "/Sky")
    named = UsdLux.DomeLight.Define(stage, "/Named")
    p = UsdLux.PortalLight.Define(stage, "/Window")
    p.CreateWidthAttr(2.0)
    p.AddTranslateOp().Set(Gf.Vec3d(1, 2, 3))
    UsdLux.PortalLight.Define(stage, "/Door")
    named.CreatePortalsRel().SetTargets(["/Door"])
    camera(stage)
    _, problems = load(stage, delegate)
    assert not problems, problems
    assert delegate.prims["/Window"] == "portalLight" and delegate.prims["/Door"] == "portalLight"
    assert (delegate.value("/Window", "inputs:width"), delegate.value("/Window", "inputs:height")) == (2.0, 1.0)
    assert tuple(matrix(delegate.value("/Window", "transform"))[3, :3]) == (1.0, 2.0, 3.0)
    assert delegate.value("/Named", "portals") == ("paths", ["/Door"])
    assert delegate.value("/Sky", "portals") is None
