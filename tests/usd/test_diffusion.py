"""TideMedium `method` end to end: a thick milky body authored in USD renders in diffusion mode
through the real module and agrees with volumetric path tracing within the model's documented
error (docs/diffusion.md), and a bad token is a problem naming the input while the rest renders."""
import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade

from conftest import bind, camera, render, settings
from tide import usd_reader


def _milky(stage, method, x=0.0, view=0.4):
    # straight down onto the top of a 4 x 2 x 4 m body at (x, 0, 0); a `view` m wide view
    ap = 50.0 * view / 4.0
    cam = camera(stage, pos=(x, 4, 0), focal=50.0, aperture=(ap, ap))
    cam.AddRotateXOp().Set(-90.0)
    body = UsdGeom.Cube.Define(stage, "/Body")
    body.CreateSizeAttr(1.0)
    body.AddTranslateOp().Set(Gf.Vec3d(0, -1, 0))
    body.AddScaleOp().Set(Gf.Vec3f(4, 2, 4))
    mat = UsdShade.Material.Define(stage, "/Looks/Milk")
    water = UsdShade.Shader.Define(stage, "/Looks/Milk/W")
    water.CreateIdAttr("TideWater")
    mat.CreateSurfaceOutput().ConnectToSource(water.ConnectableAPI(), "surface")
    med = UsdShade.Shader.Define(stage, "/Looks/Milk/V")
    med.CreateIdAttr("TideMedium")
    med.CreateInput("absorption", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.5, 0.5, 0.5))
    med.CreateInput("scattering", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(10, 10, 10))
    med.CreateInput("method", Sdf.ValueTypeNames.Token).Set(method)
    mat.CreateVolumeOutput().ConnectToSource(med.ConnectableAPI(), "volume")
    bind(body.GetPrim(), mat)
    dome = UsdLux.DomeLight.Define(stage, "/Sky")
    dome.GetPrim().CreateAttribute("visibleToCamera", Sdf.ValueTypeNames.Bool).Set(False)


def _problems(stage, delegate):
    return list(usd_reader.Reader(stage, delegate, usd_reader.Options()).load())


def test_diffusion_token_is_read_without_problems(stage, delegate):
    _milky(stage, "diffusion")
    assert _problems(stage, delegate) == []


def test_bad_method_names_the_input_and_falls_back_to_volumetric(stage, renderer):
    _milky(stage, "dipole")
    settings(stage, res=(4, 4), samples=4, integrator="path")
    d = renderer.RenderDelegate()
    problems = list(usd_reader.Reader(stage, d, usd_reader.Options()).load())
    assert any((p.prim, p.attribute) == ("/Looks/Milk/V", "inputs:method") and "volumetric" in str(p)
               for p in problems), problems


def test_diffusion_agrees_with_volumetric_on_the_flat_centre(renderer):
    from pxr import Usd
    means, errs = {}, {}
    for method, spp, depth in (("diffusion", 16, 64), ("volumetric", 256, 4096)):
        stage = Usd.Stage.CreateInMemory()
        _milky(stage, method)
        settings(stage, res=(8, 8), samples=spp, integrator="path", maxDepth=depth)
        px = render(renderer, stage)["color"]
        assert np.isfinite(px).all()
        g = px[..., 1].ravel()
        means[method] = float(g.mean())
        errs[method] = float(g.std(ddof=1) / np.sqrt(g.size))
    # the model's error here: the rendered profile's total diffuse reflectance is the
    # classical dipole's, within 3.5% of a random walk, and the point placement moves the
    # result by up to 3% (docs/diffusion.md, the Rust tests): 6%, plus 3 standard errors of
    # the two means (pixel to pixel). The published directional dipole (+40%) fails it.
    ratio = means["diffusion"] / means["volumetric"]
    rel = np.hypot(errs["diffusion"] / means["diffusion"], errs["volumetric"] / means["volumetric"])
    assert abs(ratio - 1.0) < 0.06 + 3.0 * rel, (means, errs)


def test_diffusion_follows_volumetric_along_an_edge(renderer):
    # the band 0-0.25 m from the edge at x = 2: light entering the side face leaves through
    # the top. The rendered profile reads -10% against volumetric path tracing on this band
    # (core/tests/diffusion.rs), the classical dipole -22%: 15%, plus 3 standard errors of
    # the mean per-pixel difference (the band's brightness gradient cancels in it)
    from pxr import Usd
    px = {}
    for method, spp, depth in (("diffusion", 16, 64), ("volumetric", 256, 4096)):
        stage = Usd.Stage.CreateInMemory()
        _milky(stage, method, x=1.875, view=0.25)
        settings(stage, res=(8, 8), samples=spp, integrator="path", maxDepth=depth)
        img = render(renderer, stage)["color"]
        assert np.isfinite(img).all()
        px[method] = img[..., 1].ravel().astype(np.float64)
    d, v = px["diffusion"], px["volumetric"]
    diff = d - v
    se = diff.std(ddof=1) / np.sqrt(diff.size)
    ratio = d.mean() / v.mean()
    assert abs(ratio - 1.0) < 0.15 + 3.0 * se / v.mean(), (d.mean(), v.mean(), se)
