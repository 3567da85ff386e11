"""Water FX primitives on points (contract §5), rendered through the real module and checked
against the primitives' geometry computed here: black shapes against a white dome, so a pixel's
darkness is the fraction of it the shape covers.

Camera: USD's, looking down -Z from +Z; a point (x, y, z) projects to NDC x = (f x / -z)/(ha/2).
"""
import math

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux

from conftest import bind, camera, darkness, lambert_material, render, settings

F, AP, DIST = 100.0, 36.0, 20.0     # focal length, square aperture, camera distance
W = 96                             # image side in pixels


def _px_per_unit():
    return F / DIST / (AP / 2) * W / 2


def _scene(stage):
    camera(stage, pos=(0, 0, DIST), focal=F, aperture=(AP, AP))
    dome = UsdLux.DomeLight.Define(stage, "/Dome")
    dome.CreateIntensityAttr(1.0)
    settings(stage, res=(W, W), samples=16)
    return lambert_material(stage, "/Looks/Black", (0, 0, 0))


def _points(stage, path, pts, widths, api=None):
    p = UsdGeom.Points.Define(stage, path)
    p.CreatePointsAttr([Gf.Vec3f(*x) for x in pts])
    p.CreateWidthsAttr(widths)
    if api:
        p.GetPrim().ApplyAPI(api)
    return p


def _pair(stage, api):
    mat = _scene(stage)
    p = _points(stage, "/Pair", [(-0.6, 0, 0), (0.6, 0, 0)], [1.0, 1.0], api)
    bind(p.GetPrim(), mat)
    return darkness(render(pytest.renderer_module, stage)["color"])


@pytest.fixture
def module(renderer):
    pytest.renderer_module = renderer
    return renderer


def test_two_blobbies_bridge_the_gap_two_spheres_leave(module, stage):
    """Two points of width 1 (inner radius r = 0.5) 1.2 apart: as spheres they leave a gap of
    0.2; as blobbies (T = 0.5, bounding radius R = r / sqrt(1 - T^(1/3))) their fields add up
    to more than T between them, so a bridge joins them whose half-thickness y at the midpoint
    solves 2 (1 - (0.6^2 + y^2)/R^2)^3 = T."""
    from pxr import Usd
    spheres = _pair(stage, None)
    blob_stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(blob_stage, UsdGeom.Tokens.y)
    blobs = _pair(blob_stage, "TideBlobbyAPI")
    mid = W // 2
    # the centre column (pixels W/2 - 1 and W/2 straddle x = 0)
    col_s = spheres[:, mid - 1:mid + 1].mean(axis=1)
    col_b = blobs[:, mid - 1:mid + 1].mean(axis=1)
    assert col_s.max() < 0.05, col_s.max()
    T, r = 0.5, 0.5
    R = r / math.sqrt(1 - T ** (1 / 3))
    y = math.sqrt(R * R * (1 - (T / 2) ** (1 / 3)) - 0.36)
    expect_px = 2 * y * _px_per_unit()
    # covered height of the centre column: its summed darkness (anti-aliased edges included),
    # within a pixel and a half
    assert abs(col_b.sum() - expect_px) < 1.5, (col_b.sum(), expect_px)
    # away from the bridge an isolated-looking blob's outer edge is the sphere's: the row
    # through the centres is covered from -0.6 - r to 0.6 + r in both
    row_s = spheres[mid - 1:mid + 1].mean(axis=0).sum()
    row_b = blobs[mid - 1:mid + 1].mean(axis=0).sum()
    assert abs(row_b - 2.2 * _px_per_unit()) < 1.5 and abs(row_s - 2.0 * _px_per_unit()) < 1.5, (row_b, row_s)


def test_an_isolated_blobby_covers_its_inner_sphere(module, stage):
    """A lone blobby is the sphere of its inner radius, whatever its threshold."""
    mat = _scene(stage)
    p = _points(stage, "/Blob", [(0, 0, 0)], [2.0], "TideBlobbyAPI")
    p.GetPrim().GetAttribute("tide:blobby:threshold").Set(0.3)
    bind(p.GetPrim(), mat)
    d = darkness(render(module, stage)["color"])
    r_px = 1.0 * _px_per_unit()
    # perspective makes the silhouette 1/(1 - r^2/z^2) larger: 0.25 %; noise ~1 %
    assert d.sum() == pytest.approx(math.pi * r_px ** 2, rel=0.03)


def test_a_bubble_has_its_radius_and_heights(module, stage):
    """Seen from the side, a bubble of radius r, height h1 above its equator and depth h2 below
    covers pi r h1 / 2 + 2 r h2 * int_0^1 sqrt(1 - s^4) ds and reaches from -h2 to h1."""
    mat = _scene(stage)
    r, h1, h2 = 1.5, 1.2, 0.6
    p = _points(stage, "/Bubble", [(0, 0, 0)], [2 * r], "TideBubbleAPI")
    UsdGeom.PrimvarsAPI(p).CreatePrimvar("tide:bubble:top", Sdf.ValueTypeNames.FloatArray,
                                         UsdGeom.Tokens.vertex).Set([h1])
    UsdGeom.PrimvarsAPI(p).CreatePrimvar("tide:bubble:bottom", Sdf.ValueTypeNames.FloatArray,
                                         UsdGeom.Tokens.vertex).Set([h2])
    bind(p.GetPrim(), mat)
    d = darkness(render(module, stage)["color"])
    n = 20000
    quartic = sum(math.sqrt(1 - ((k + 0.5) / n) ** 4) for k in range(n)) / n
    area = math.pi * r * h1 / 2 + 2 * r * h2 * quartic
    # the silhouette of a body seen from 20 units is that of its profile within ~0.5 %
    assert d.sum() == pytest.approx(area * _px_per_unit() ** 2, rel=0.03)
    # vertical extent of the centre column, and the horizontal one of the equator's row
    mid = W // 2
    col = d[:, mid - 1:mid + 1].mean(axis=1).sum()
    assert abs(col - (h1 + h2) * _px_per_unit()) < 1.5, (col, (h1 + h2) * _px_per_unit())
    # the bubble sits higher than a sphere would: more of it lies above the centre row
    above, below = d[:mid].sum(), d[mid:].sum()
    assert above > below * 1.3, (above, below)


def test_a_bubble_turns_with_its_orientation(module, stage):
    """A quarter turn about Z lays the bubble on its side: the extents swap."""
    mat = _scene(stage)
    r, h1, h2 = 1.5, 1.2, 0.6
    p = _points(stage, "/Bubble", [(0, 0, 0)], [2 * r], "TideBubbleAPI")
    pv = UsdGeom.PrimvarsAPI(p)
    pv.CreatePrimvar("tide:bubble:top", Sdf.ValueTypeNames.FloatArray).Set([h1])
    pv.CreatePrimvar("tide:bubble:bottom", Sdf.ValueTypeNames.FloatArray).Set([h2])
    q = Gf.Rotation(Gf.Vec3d(0, 0, 1), 90).GetQuat()
    pv.CreatePrimvar("tide:bubble:orientation", Sdf.ValueTypeNames.QuatfArray).Set(
        [Gf.Quatf(q.GetReal(), Gf.Vec3f(q.GetImaginary()))])
    bind(p.GetPrim(), mat)
    d = darkness(render(module, stage)["color"])
    mid = W // 2
    row = d[mid - 1:mid + 1].mean(axis=0).sum()
    col = d[:, mid - 1:mid + 1].mean(axis=1).sum()
    assert abs(row - (h1 + h2) * _px_per_unit()) < 1.5, (row, (h1 + h2) * _px_per_unit())
    assert abs(col - 2 * r * _px_per_unit()) < 1.5, (col, 2 * r * _px_per_unit())
    # +Y of the bubble now points to -X: more of it lies left of the centre
    assert d[:, :mid].sum() > d[:, mid:].sum() * 1.3


def _droplet_cloud(stage, as_volume):
    """20000 droplets of radius 5 mm at random in a 1 m cube (optical depth about 1.6 across),
    in front of a black backdrop that hides the dome within about 45 degrees of the view
    direction behind the cloud: the cloud shows by the dome light it scatters towards the camera
    through larger angles, which depends on both its scattering coefficient and its phase
    function."""
    camera(stage, pos=(0, 0, 4), focal=50.0, aperture=(AP, AP))
    dome = UsdLux.DomeLight.Define(stage, "/Dome")
    dome.CreateIntensityAttr(1.0)
    settings(stage, res=(32, 32), samples=256, integrator="path")
    black = lambert_material(stage, "/Looks/Black", (0, 0, 0))
    back = UsdGeom.Mesh.Define(stage, "/Backdrop")
    back.CreatePointsAttr([(-3, -3, -3), (3, -3, -3), (3, 3, -3), (-3, 3, -3)])
    back.CreateFaceVertexCountsAttr([4])
    back.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    bind(back.GetPrim(), black)
    from pxr import UsdShade
    water = UsdShade.Material.Define(stage, "/Looks/Water")
    sh = UsdShade.Shader.Define(stage, "/Looks/Water/Surface")
    sh.CreateIdAttr("TideWater")
    water.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    rng = np.random.default_rng(7)
    pts = rng.uniform(-0.5, 0.5, size=(20000, 3))
    p = _points(stage, "/Spray", [tuple(map(float, x)) for x in pts], [0.01] * len(pts))
    bind(p.GetPrim(), water)
    if as_volume:
        p.GetPrim().ApplyAPI("TideDropletsAPI")
        p.GetPrim().GetAttribute("tide:droplets:asVolume").Set(True)
        p.GetPrim().GetAttribute("tide:droplets:voxelSize").Set(0.1)
    return stage


def test_droplets_as_a_medium_match_the_droplets(module, stage):
    """TideDropletsAPI: the same cloud traced as 20000 water spheres (the reference) and as the
    medium its droplets become (sigma_s from their cross-section, the phase function of a
    water sphere) scatters the same dome light towards the camera."""
    from pxr import Usd
    spheres = render(module, _droplet_cloud(stage, False))["color"][..., :3].astype(np.float64)
    vol_stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(vol_stage, UsdGeom.Tokens.y)
    medium = render(module, _droplet_cloud(vol_stage, True))["color"][..., :3].astype(np.float64)
    # the cloud's square: +-0.5 at distance 3.5..4.5 projects to about +-12 px of 32; take the
    # middle 16 x 16
    a, b = spheres[8:24, 8:24].mean(axis=2), medium[8:24, 8:24].mean(axis=2)
    # the standard error of the mean difference (the cloud's shading, common to both, cancels)
    se = (a - b).std(ddof=1) / math.sqrt(a.size)
    print("spheres %.4f, medium %.4f, se %.4f" % (a.mean(), b.mean(), se))
    assert a.mean() > 0.05, a.mean()      # the cloud is seen at all
    # independent scattering by dilute droplets (volume fraction 1 %): 8 % model tolerance
    assert abs(a.mean() - b.mean()) < 0.08 * a.mean() + 4 * se, (a.mean(), b.mean(), se)
    # and outside the cloud both see the black backdrop
    assert spheres[:3].mean() < 0.02 and medium[:3].mean() < 0.02
