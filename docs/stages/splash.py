"""Writes docs/stages/splash.usda (and the point clouds it sublayers, splash_points.usdc): water's
FX primitives and wetness together. A wet rock (its material with TideWetAPI) stands in the
sea beside a dry one of the same stone; a splash leaves it as a sheet of merging
blobbies thinning into loose droplets, and a cloud of fine spray (TideDropletsAPI, rendered as a
medium inside, spheres in its shell) hangs above; air bubbles (TideBubbleAPI) float on the
water around the rock's foot. A Hošek–Wilkie sky and a low sun light it.

Run from the repository root: PYTHONPATH=cpp-bridge/python .venv/bin/python docs/stages/splash.py
"""
import math
import os

import numpy as np

from tide import env

env.prepare()  # Tide's schemas, before pxr loads its plugins
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade, Vt  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def preview(stage, path, color, roughness, wet=None):
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, path + "/Surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
    sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(roughness)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    if wet is not None:
        mat.GetPrim().ApplyAPI("TideWetAPI")
        mat.GetPrim().CreateAttribute("tide:wet:amount", Sdf.ValueTypeNames.Float).Set(wet)
    return mat


def water(stage, path):
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, path + "/Surface")
    sh.CreateIdAttr("TideWater")
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    med = UsdShade.Shader.Define(stage, path + "/Medium")
    med.CreateIdAttr("TideMedium")
    med.CreateInput("jerlovType", Sdf.ValueTypeNames.Token).Set("II")
    med.CreateOutput("volume", Sdf.ValueTypeNames.Token)
    mat.CreateVolumeOutput().ConnectToSource(med.ConnectableAPI(), "volume")
    return mat


def bind(prim, mat):
    UsdShade.MaterialBindingAPI.Apply(prim).Bind(mat)


def points(stage, path, pts, widths, mat, api=None):
    """Points bound to the material at path `mat` (defined in the main layer)."""
    p = UsdGeom.Points.Define(stage, path)
    p.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(pts, dtype=np.float32)))
    p.CreateWidthsAttr(Vt.FloatArray.FromNumpy(np.asarray(widths, dtype=np.float32)))
    if api:
        p.GetPrim().ApplyAPI(api)
    UsdShade.MaterialBindingAPI.Apply(p.GetPrim())
    p.GetPrim().CreateRelationship("material:binding").SetTargets([Sdf.Path(mat)])
    return p


def main():
    rng = np.random.default_rng(11)
    # the point clouds in a binary layer of their own
    clouds = Usd.Stage.CreateNew(os.path.join(HERE, "splash_points.usdc"))
    stage = Usd.Stage.CreateNew(os.path.join(HERE, "splash.usda"))
    stage.GetRootLayer().subLayerPaths.append("./splash_points.usdc")
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    rock_mat = preview(stage, "/World/Looks/WetRock", (0.32, 0.27, 0.22), 0.7, wet=1.0)
    dry_mat = preview(stage, "/World/Looks/DryRock", (0.32, 0.27, 0.22), 0.7)
    sand = preview(stage, "/World/Looks/Sand", (0.6, 0.52, 0.4), 0.9)
    sea = water(stage, "/World/Looks/Water")
    # the sea: a 0.6 m deep box of water over sand, reaching the horizon
    pool = UsdGeom.Cube.Define(stage, "/World/Pool")
    pool.CreateSizeAttr(1.0)
    pool.AddTranslateOp().Set(Gf.Vec3d(0, -0.3, 0))
    pool.AddScaleOp().Set(Gf.Vec3f(4000, 0.6, 4000))
    bind(pool.GetPrim(), sea)
    floor = UsdGeom.Cube.Define(stage, "/World/Floor")
    floor.CreateSizeAttr(1.0)
    floor.AddTranslateOp().Set(Gf.Vec3d(0, -0.65, 0))
    floor.AddScaleOp().Set(Gf.Vec3f(4000.2, 0.1, 4000.2))
    bind(floor.GetPrim(), sand)
    rock = UsdGeom.Sphere.Define(stage, "/World/Rock")
    rock.CreateRadiusAttr(1.0)
    rock.AddTranslateOp().Set(Gf.Vec3d(0, 0.1, 0))
    rock.AddScaleOp().Set(Gf.Vec3f(0.9, 0.8, 0.7))
    bind(rock.GetPrim(), rock_mat)
    # the same stone, dry, for comparison
    dry = UsdGeom.Sphere.Define(stage, "/World/DryRock")
    dry.CreateRadiusAttr(1.0)
    dry.AddTranslateOp().Set(Gf.Vec3d(-1.5, 0.05, 0.3))
    dry.AddScaleOp().Set(Gf.Vec3f(0.6, 0.55, 0.5))
    bind(dry.GetPrim(), dry_mat)
    water(stage, "/World/Looks/Drop")
    drop = "/World/Looks/Drop"
    # the splash: a sheet of blobbies arcing off the rock's right side, thinning as it rises
    s = rng.uniform(0, 1, 900)
    a = rng.uniform(-0.35, 0.35, 900)
    x = 0.7 + 1.3 * s
    y = 0.2 + 1.6 * s - 1.1 * s * s
    z = a * (0.4 + 0.8 * s)
    sheet = np.stack([x, y, z], axis=1) + rng.normal(0, 0.02, (900, 3))
    points(clouds, "/World/Splash", sheet, 0.07 * (1.0 - 0.6 * s), drop, "TideBlobbyAPI")
    # loose droplets at the sheet's end
    s = rng.uniform(0.8, 1.3, 300)
    tips = np.stack([0.7 + 1.3 * s, 0.2 + 1.6 * s - 1.1 * s * s, rng.uniform(-0.6, 0.6, 300)], axis=1)
    tips += rng.normal(0, 0.08, (300, 3))
    points(clouds, "/World/Droplets", tips, rng.uniform(0.01, 0.03, 300), drop)
    # spray above the rock: 20000 droplets of 3-6 mm, a medium inside a 5 cm shell
    n = 20000
    c = rng.normal(0, 1, (n, 3)) * np.array([0.7, 0.35, 0.5]) + np.array([0.5, 1.5, 0.0])
    spray = points(clouds, "/World/Spray", c, rng.uniform(0.006, 0.012, n), drop, "TideDropletsAPI")
    spray.GetPrim().CreateAttribute("tide:droplets:asVolume", Sdf.ValueTypeNames.Bool).Set(True)
    spray.GetPrim().CreateAttribute("tide:droplets:voxelSize", Sdf.ValueTypeNames.Float).Set(0.05)
    spray.GetPrim().CreateAttribute("tide:droplets:shell", Sdf.ValueTypeNames.Float).Set(0.05)
    # bubbles floating around the rock's foot: half above the water, flat below
    k = 40
    ang = rng.uniform(0, 2 * math.pi, k)
    rad = rng.uniform(1.0, 1.8, k)
    r = rng.uniform(0.04, 0.1, k)
    bub = np.stack([rad * np.cos(ang) * 0.9, np.zeros(k), rad * np.sin(ang) * 0.7 + 0.4], axis=1)
    preview(stage, "/World/Looks/Film", (0.0, 0.0, 0.0), 0.0)
    film = UsdShade.Shader(stage.GetPrimAtPath("/World/Looks/Film/Surface"))
    film.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(0.15)
    b = points(clouds, "/World/Bubbles", bub, 2 * r, "/World/Looks/Film", "TideBubbleAPI")
    pv = UsdGeom.PrimvarsAPI(b)
    pv.CreatePrimvar("tide:bubble:top", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex).Set(
        Vt.FloatArray.FromNumpy((0.9 * r).astype(np.float32)))
    pv.CreatePrimvar("tide:bubble:bottom", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex).Set(
        Vt.FloatArray.FromNumpy((0.35 * r).astype(np.float32)))
    # light: a sun 25° up behind the camera, so that both stones are lit alike, and its sky
    sun = UsdLux.DistantLight.Define(stage, "/World/Sun")
    sun.CreateAngleAttr(0.53)
    sun.CreateIntensityAttr(30000.0)
    sun.AddRotateXYZOp().Set(Gf.Vec3f(-25, 15, 0))
    sky = UsdLux.DomeLight.Define(stage, "/World/Sky")
    sky.GetPrim().ApplyAPI("TideSkyAPI")
    sky.GetPrim().CreateAttribute("tide:sky:model", Sdf.ValueTypeNames.Token).Set("hosekWilkie")
    sky.GetPrim().CreateAttribute("tide:sky:turbidity", Sdf.ValueTypeNames.Float).Set(3.0)
    sky.GetPrim().CreateAttribute("tide:sky:physicalSun", Sdf.ValueTypeNames.Bool).Set(True)
    sky.GetPrim().CreateRelationship("tide:sky:sun").SetTargets([sun.GetPath()])
    cam = UsdGeom.Camera.Define(stage, "/World/Cam")
    cam.CreateFocalLengthAttr(35)
    cam.CreateHorizontalApertureAttr(36)
    cam.CreateVerticalApertureAttr(24)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.05, 1000))
    cam.AddTranslateOp().Set(Gf.Vec3d(0.8, 0.9, 5.0))
    cam.AddRotateXYZOp().Set(Gf.Vec3f(-3, 0, 0))
    # the sunny-16 rule: f/16 at 1/ISO s
    for name, value in (("exposure:fStop", 16.0), ("exposure:time", 0.01), ("exposure:iso", 100.0),
                        ("exposure:responsivity", 1.0053096)):
        cam.GetPrim().CreateAttribute(name, Sdf.ValueTypeNames.Float).Set(value)
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets([cam.GetPath()])
    settings.CreateResolutionAttr(Gf.Vec2i(600, 400))
    settings.GetPrim().ApplyAPI("TideRenderSettingsAPI")
    settings.GetPrim().CreateAttribute("tide:integrator", Sdf.ValueTypeNames.Token).Set("path")
    settings.GetPrim().CreateAttribute("tide:samples", Sdf.ValueTypeNames.Int).Set(32)
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    clouds.GetRootLayer().Save()
    stage.GetRootLayer().Save()


if __name__ == "__main__":
    main()
