"""TideOcean end to end: a small open sea under a sun and a sky, rendered through the real
module. Expectations come from the camera model and the reflection geometry, not from the
renderer: where the sun glint sits, and that the sea reaches the horizon.

Camera: USD's (looks down -Z, Y up), above the mean sea level, pitched down by PITCH. Sun: a
DistantLight straight ahead at elevation E, so its mirror image on the mean sea level is straight
ahead at E below the horizontal."""
import math

import numpy as np
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade

from conftest import bind, camera, converged_images, settings
from tide import usd_reader

F, AP = 50.0, 36.0            # focal length, square aperture: tan(half fov) = 18/50
W = H = 48
E = 40.0                      # sun elevation (degrees)
U = 5.0                       # wind speed (m/s)


def _row_of(elevation_deg, pitch=0.0):
    """Image row (from the top, continuous) of a view direction at this elevation, straight
    ahead, for a camera pitched by `pitch` degrees."""
    ndc_y = math.tan(math.radians(elevation_deg - pitch)) * F / (AP / 2)
    return (1 - ndc_y) / 2 * H


def ocean_prim(stage, path, **attrs):
    """A TideOcean prim with `attrs` (ints as Int, floats as Float)."""
    ocean = stage.DefinePrim(path, "TideOcean")
    for name, v in attrs.items():
        ocean.CreateAttribute(name, Sdf.ValueTypeNames.Int if isinstance(v, int) else Sdf.ValueTypeNames.Float).Set(v)
    return ocean


def sea_material(stage, ocean):
    """Binds to `ocean` a sea: TideWater (the sea surface model) over a blue-green medium."""
    mat = UsdShade.Material.Define(stage, "/Looks/Sea")
    water = UsdShade.Shader.Define(stage, "/Looks/Sea/Water")
    water.CreateIdAttr("TideWater")
    water.CreateInput("surfaceModel", Sdf.ValueTypeNames.Token).Set("sea")
    mat.CreateSurfaceOutput().ConnectToSource(water.ConnectableAPI(), "surface")
    medium = UsdShade.Shader.Define(stage, "/Looks/Sea/Medium")
    medium.CreateIdAttr("TideMedium")
    medium.CreateInput("absorption", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.4, 0.06, 0.02))
    medium.CreateInput("scattering", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.02, 0.03, 0.04))
    mat.CreateVolumeOutput().ConnectToSource(medium.ConnectableAPI(), "volume")
    bind(ocean, mat)


def sun_and_sky(stage, elevation):
    """A sun (100 lx) straight ahead of a camera looking down -Z at `elevation` degrees, and
    its Hosek-Wilkie sky (a TideSkyAPI dome)."""
    sun = UsdLux.DistantLight.Define(stage, "/Sun")
    # a DistantLight shines down its -Z: rotated 180 + E about X it shines towards +Z and down,
    # so the sun stands ahead of the camera at elevation E
    sun.AddRotateXOp().Set(180.0 + elevation)
    sun.CreateIntensityAttr(100.0)
    sun.CreateAngleAttr(0.53)
    sun.CreateNormalizeAttr(True)    # intensity is the illuminance it gives
    dome = UsdLux.DomeLight.Define(stage, "/Sky")
    dome.GetPrim().ApplyAPI("TideSkyAPI")
    dome.GetPrim().GetRelationship("tide:sky:sun").SetTargets(["/Sun"])


def _sea_stage(stage, height, pitch):
    cam = camera(stage, pos=(0, height, 0), focal=F, aperture=(AP, AP))
    if pitch:
        cam.AddRotateXOp().Set(pitch)
    # the wind blows away from the camera (towards -Z): the sea is mirror symmetric about the
    # view plane
    ocean = ocean_prim(stage, "/Ocean", windSpeed=U, windDirection=90.0, patchSize=16.0,
                       resolution=64, extent=200.0)
    sea_material(stage, ocean)
    sun_and_sky(stage, E)
    settings(stage, res=(W, H), samples=32, integrator="path", maxDepth=8,
             vars_=("color", "depth"))


def _render(module, stage):
    d = module.RenderDelegate()
    r = usd_reader.Reader(stage, d, usd_reader.Options())
    problems = list(r.load())
    return converged_images(r, d, r.render_pass(), 120), problems


def _glint_model(pitch):
    """Relative radiance of the sun's glint per pixel on the mean sea level with Cox–Munk
    slopes at U (mesh + BSDF carry them together): Fresnel times the slope density of the
    facet that mirrors the sun into the pixel over 4 cos(view) cos^4(facet tilt). For a distant
    sun it depends on the view direction only, not on the camera's height."""
    s = np.array([0.0, math.sin(math.radians(E)), -math.cos(math.radians(E))])
    var_up, var_cross = 3.16e-3 * U, 0.003 + 1.92e-3 * U
    rows, cols = np.mgrid[0:H, 0:W] + 0.5
    d = np.stack([(cols / W * 2 - 1) * AP / 2 / F, (1 - rows / H * 2) * AP / 2 / F,
                  -np.ones_like(rows)], axis=-1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    c, sn = math.cos(math.radians(pitch)), math.sin(math.radians(pitch))
    d = np.stack([d[..., 0], c * d[..., 1] - sn * d[..., 2], sn * d[..., 1] + c * d[..., 2]], axis=-1)
    below = d[..., 1] < 0
    v = -d                                            # towards the camera
    h = v + s
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    zx, zz = -h[..., 0] / h[..., 1], -h[..., 2] / h[..., 1]
    p = np.exp(-0.5 * (zx ** 2 / var_cross + zz ** 2 / var_up))
    c = np.clip((v * h).sum(-1), 0, 1)
    n = 1.333
    g = np.sqrt(n * n - 1 + c * c)
    fres = 0.5 * ((g - c) / (g + c)) ** 2 * (1 + ((c * (g + c) - 1) / (c * (g - c) + 1)) ** 2)
    model = fres * p / (4 * np.abs(v[..., 1]) * h[..., 1] ** 4)
    return np.where(below, model, 0.0), np.where(below, p, 0.0)


def _centroid(img):
    rows, cols = np.mgrid[0:H, 0:W] + 0.5
    return (img * cols).sum() / img.sum(), (img * rows).sum() / img.sum()


def test_ocean_renders_with_the_glint_where_the_sun_mirrors(renderer, stage):
    # 100 m up, looking down at the sun's mirror point: the view spans many 16 m patches, so the
    # glitter averages over the whole periodic sea rather than one wave's tilt
    _sea_stage(stage, 100.0, -E)
    out, problems = _render(renderer, stage)
    assert problems == [], problems
    rgb = out["color"][..., :3].astype(np.float64)
    assert np.isfinite(rgb).all()
    lum = 0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2]
    # the sun's glint fills the view: the sky's reflection (a few percent of a dome of radiance
    # about 1) and the light scattered up from the water are under 1 % of the image's mean
    assert lum.mean() > 1.0 and lum.max() > 20.0, (lum.mean(), lum.max())
    cx, cy = _centroid(lum)
    model, slope_density = _glint_model(-E)
    mx, my = _centroid(model)
    # the mirror point of the sun is the image centre: the model's glint is centred on it
    # across (the sea is mirror symmetric about the view plane: wind along the view), and the
    # facets there are level, the most frequent (the radiance itself grows towards the horizon
    # with Fresnel and the foreshortening)
    assert _row_of(-E, -E) == H / 2
    assert abs(mx - W / 2) < 1e-9
    peak = np.unravel_index(np.argmax(slope_density), model.shape)
    assert abs(peak[0] + 0.5 - H / 2) <= 1.0 and abs(peak[1] + 0.5 - W / 2) <= 1.0, peak
    # the rendered glint's centroid against the model's: the model's glint spreads over sx, sy
    # pixels (its standard deviations); the rendered one is one random sea whose slopes are
    # resolved up to 64 samples per patch, a sparkle pattern whose centroid scatters about
    # the expected one by a fraction of that spread: a quarter bounds it
    rows, cols = np.mgrid[0:H, 0:W] + 0.5
    sx = math.sqrt((model * (cols - mx) ** 2).sum() / model.sum())
    sy = math.sqrt((model * (rows - my) ** 2).sum() / model.sum())
    assert abs(cx - mx) < 0.25 * sx, (cx, mx, sx)
    assert abs(cy - my) < 0.25 * sy, (cy, my, sy)


def test_ocean_meets_the_horizon(renderer, stage):
    _sea_stage(stage, 2.0, 0.0)
    out, problems = _render(renderer, stage)
    assert problems == [], problems
    depth = out["depth"][..., 0]
    horizon = _row_of(0.0)
    assert horizon == H / 2
    # the depth AOV holds each pixel's first sample, which the pixel filter (a Gaussian
    # truncated at 1.5 px) places up to 1.5 px from the pixel's centre: the first row whose
    # samples all lie below the horizontal line is H/2 + 1 (0 to 3 px below it, down to
    # directions that meet the mean sea level tens of kilometres out: on the horizon skirt,
    # past the 208 m tiled surface); it must be sea all across, as every row below it, and
    # H/2 - 2, the last row wholly above the line, sky all across
    assert np.isfinite(depth[H // 2 + 1:]).all(), depth[H // 2 + 1]
    assert np.isinf(depth[H // 2 - 2]).all(), depth[H // 2 - 2]
    # the rows across the line see both, sea only where a sample fell below it
    assert np.isfinite(depth[H // 2]).any() and np.isinf(depth[H // 2 - 1]).any()
