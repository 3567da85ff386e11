"""The caustics integrator through USD (contract §4 and §6): `tide:integrator`, the
`TideCausticsAPI` tags with their one-click defaults, and the `tide:caustics` AOV, which holds
the light carried by photons and is part of the split that sums to `color`."""
import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade

from conftest import bind, camera, lambert_material, render, settings

SPLIT = ("tide:diffuse", "tide:specular", "tide:transmission", "tide:volume", "tide:emission",
         "tide:caustics")


def _glass(stage):
    mat = UsdShade.Material.Define(stage, "/Looks/Glass")
    sh = UsdShade.Shader.Define(stage, "/Looks/Glass/Water")
    sh.CreateIdAttr("TideWater")
    sh.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.5)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def _scene(stage, integrator="caustics", ball_tags=None, light_tags=None):
    """A glass ball over a grey floor under a small sphere light straight above it, seen from
    above at an angle: the ball focuses the light into a caustic on the floor beneath it."""
    camera(stage, pos=(0, 0, 0), focal=50.0, aperture=(36.0, 36.0))
    cam = UsdGeom.Xformable(stage.GetPrimAtPath("/Cam"))
    cam.ClearXformOpOrder()
    # 3 m above the floor looking straight down
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 3, 0))
    cam.AddRotateXOp().Set(-90.0)
    floor = UsdGeom.Mesh.Define(stage, "/World/Floor")
    floor.CreatePointsAttr([(-3, 0, -3), (3, 0, -3), (3, 0, 3), (-3, 0, 3)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    bind(floor.GetPrim(), lambert_material(stage, "/Looks/Grey", (0.6, 0.6, 0.6)))
    ball = UsdGeom.Sphere.Define(stage, "/World/Ball")
    ball.CreateRadiusAttr(0.3)
    ball.AddTranslateOp().Set(Gf.Vec3d(0.6, 0.5, 0))
    bind(ball.GetPrim(), _glass(stage))
    for k, v in (ball_tags or {}).items():
        tn = Sdf.ValueTypeNames.Bool if isinstance(v, bool) else Sdf.ValueTypeNames.Token
        ball.GetPrim().CreateAttribute("tide:caustics:" + k, tn).Set(v)
    bulb = UsdLux.SphereLight.Define(stage, "/World/Bulb")
    bulb.CreateRadiusAttr(0.02)
    bulb.CreateIntensityAttr(3000.0)
    bulb.AddTranslateOp().Set(Gf.Vec3d(0.6, 2.0, 0))
    for k, v in (light_tags or {}).items():
        bulb.GetPrim().CreateAttribute("tide:caustics:" + k, Sdf.ValueTypeNames.Bool).Set(v)
    settings(stage, res=(32, 32), vars_=("color",) + SPLIT, samples=16, maxDepth=8,
             integrator=integrator)


def _caustic_energy(out):
    return float(out["tide:caustics"][..., :3].sum())


def test_the_default_integrator_puts_the_glass_caustic_in_its_aov(renderer, stage):
    _scene(stage, integrator="caustics")
    out = render(renderer, stage)
    c = out["tide:caustics"][..., :3].sum(axis=2)
    assert c.sum() > 0, "no photon light"
    # the caustic lies under the ball (image right of centre: +x), not in the far corner
    ys, xs = np.nonzero(c > 0.5 * c.max())
    assert xs.mean() > 16 and abs(ys.mean() - 16) < 6, (xs.mean(), ys.mean())
    total = sum(out[a][..., :3] for a in SPLIT)
    np.testing.assert_allclose(total, out["color"][..., :3], rtol=1e-4, atol=1e-5)


def test_path_integrator_and_untagged_objects_carry_no_photons(renderer, stage):
    _scene(stage, integrator="path")
    assert _caustic_energy(render(renderer, stage)) == 0.0


@pytest.mark.parametrize("ball,light", [({"caster": False}, None), (None, {"emitter": False}),
                                        ({"transparency": "afterDiffuse"}, None)])
def test_tags_switch_photons_off(renderer, stage, ball, light):
    _scene(stage, integrator="caustics", ball_tags=ball, light_tags=light)
    assert _caustic_energy(render(renderer, stage)) == 0.0


def test_explicit_tags_replace_the_one_click_default(renderer, stage):
    # tagging the light as an emitter and the ball as a caster gives the same photons as the
    # default (the light is a sphere light and the ball is TideWater)
    _scene(stage, integrator="caustics", ball_tags={"caster": True}, light_tags={"emitter": True})
    assert _caustic_energy(render(renderer, stage)) > 0.0
